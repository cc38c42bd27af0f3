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


def point_segment_distances(
    points: np.ndarray, starts: np.ndarray, ends: np.ndarray, chunk: int = 2048
) -> np.ndarray:
    """Distance of every point to the nearest of a set of segments, any dimension.

    points : (n, d); starts, ends : (s, d). Returns (n,). Chunked so memory stays O(chunk * s).
    """
    points = np.asarray(points, dtype=float)
    direction = ends - starts
    length2 = np.maximum(np.einsum("sd,sd->s", direction, direction), 1e-300)
    best = np.empty(len(points))
    for first in range(0, len(points), chunk):
        block = points[first : first + chunk]
        rel = block[:, None, :] - starts[None, :, :]
        t = np.clip(np.einsum("nsd,sd->ns", rel, direction) / length2, 0.0, 1.0)
        foot = starts[None] + t[..., None] * direction[None]
        best[first : first + chunk] = np.linalg.norm(block[:, None, :] - foot, axis=2).min(axis=1)
    return best


#: largest (point, segment) pairs evaluated at once by closest_on_polylines
MAX_PAIRS = 4_000_000


def closest_on_polylines(
    points: np.ndarray, polyline: np.ndarray, closed: bool = True
) -> np.ndarray:
    """Closest point on a polyline for every point (any dimension), vectorised.

    points : (p, d) float; polyline : (k, d) float (first point not repeated when ``closed``).
    Returns (p, d) float.
    """
    points = np.asarray(points, dtype=float)
    poly = np.asarray(polyline, dtype=float)
    starts = poly
    ends = np.roll(poly, -1, axis=0)
    if not closed:
        starts, ends = poly[:-1], poly[1:]
    direction = ends - starts
    length2 = np.maximum(np.einsum("sd,sd->s", direction, direction), 1e-300)
    out = np.empty_like(points)
    chunk = max(1, MAX_PAIRS // max(len(starts), 1))
    for first in range(0, len(points), chunk):
        block = points[first : first + chunk]
        rel = block[:, None, :] - starts[None]
        t = np.clip(np.einsum("psd,sd->ps", rel, direction) / length2, 0.0, 1.0)
        foot = starts[None] + t[..., None] * direction[None]
        best = np.argmin(
            np.einsum("psd,psd->ps", block[:, None] - foot, block[:, None] - foot), axis=1
        )
        out[first : first + chunk] = foot[np.arange(len(block)), best]
    return out


def resample_closed(ring: np.ndarray, step: float) -> np.ndarray:
    """A closed polyline ``(n, 2)`` with points at most ``step`` apart: every run split evenly,
    its vertices kept."""
    out = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + np.linspace(0.0, 1.0, n, endpoint=False)[:, None] * (b - a))
    points = np.concatenate(out)
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-6]
    return points[keep]
