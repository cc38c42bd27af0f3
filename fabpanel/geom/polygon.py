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
