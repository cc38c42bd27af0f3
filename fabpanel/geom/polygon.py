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


def graded_ring(ring: np.ndarray, first: float = 1.5, longest: float = 8.0) -> np.ndarray:
    """A closed outline of straight runs and finely chorded rounds ``(n, 2)`` with points
    added along every run longer than ``2 x first``: ``first`` from each end, then steps
    doubling up to ``longest``. A periodic cubic through the points keeps within 0.02 mm of a
    slot's outline of 5 mm rounds with a third fewer points than a point every 2 mm: the
    points crowd where a run meets a round, which is where the cubic overshoots. Runs no
    longer than ``2 x first`` (a round's chords) are kept as they are."""
    out = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        out.append(a[None, :])
        length = float(np.linalg.norm(b - a))
        if length <= 2.0 * first:
            continue
        half, x, step = [], 0.0, first
        while x + step < 0.5 * length:
            x += step
            half.append(x)
            step = min(2.0 * step, longest)
        positions = np.asarray(half)
        middle = [0.5 * length] if length - 2.0 * x > step else []
        positions = np.r_[positions, middle, length - positions[::-1]]
        out.append(a + positions[:, None] / length * (b - a))
    return np.concatenate(out)
