"""Least-squares fits on point sets, batched over a leading axis."""

from __future__ import annotations

import numpy as np


def bestfit_planes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Best-fitting plane of each point set (total least squares).

    points : (b, n, 3) float
    Returns ``normals (b, 3)`` unit, ``offsets (b,)`` with ``n . x = d`` and ``residuals (b,)``:
    the largest absolute distance of a point of the set to its plane.
    """
    points = np.asarray(points, dtype=float)
    centroids = points.mean(axis=1)
    centred = points - centroids[:, None, :]
    # smallest right-singular vector = plane normal; batched SVD on (b, n, 3)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    normals = vt[:, -1, :]
    offsets = np.einsum("bi,bi->b", normals, centroids)
    residuals = np.abs(np.einsum("bni,bi->bn", points, normals) - offsets[:, None]).max(axis=1)
    return normals, offsets, residuals


def distance_point_plane(points: np.ndarray, plane: np.ndarray) -> np.ndarray:
    """Signed distances of ``points (..., 3)`` to ``plane (4,)`` = (nx, ny, nz, d)."""
    return np.asarray(points) @ plane[:3] - plane[3]
