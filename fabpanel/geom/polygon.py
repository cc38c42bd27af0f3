"""Planar polygon helpers on (n, 2) arrays (first point not repeated)."""

from __future__ import annotations

import numpy as np


def polygon_area(points: np.ndarray) -> float:
    """Signed area (shoelace), positive for counter-clockwise polygons."""
    x, y = np.asarray(points, dtype=float).T
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))


def polyline_length(points: np.ndarray, closed: bool = False) -> float:
    """Length of a polyline in any dimension."""
    points = np.asarray(points, dtype=float)
    if closed:
        points = np.vstack([points, points[:1]])
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def point_segment_distances(points: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                            chunk: int = 2048) -> np.ndarray:
    """Distance of every point to the nearest of a set of segments, any dimension.

    points : (n, d); starts, ends : (s, d). Returns (n,). Chunked so memory stays O(chunk * s).
    """
    points = np.asarray(points, dtype=float)
    direction = ends - starts
    length2 = np.maximum(np.einsum("sd,sd->s", direction, direction), 1e-300)
    best = np.empty(len(points))
    for first in range(0, len(points), chunk):
        block = points[first:first + chunk]
        rel = block[:, None, :] - starts[None, :, :]
        t = np.clip(np.einsum("nsd,sd->ns", rel, direction) / length2, 0.0, 1.0)
        foot = starts[None] + t[..., None] * direction[None]
        best[first:first + chunk] = np.linalg.norm(block[:, None, :] - foot, axis=2).min(axis=1)
    return best
