"""Least-squares fits on point sets, batched over a leading axis."""

from __future__ import annotations

import numpy as np


def bestfit_planes(
    points: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Best-fitting plane of each point set (total least squares, optionally weighted).

    points : (b, n, 3) float; weights : (n,) float, the same for every set (default all 1).
    Returns ``normals (b, 3)`` unit, ``offsets (b,)`` with ``n . x = d`` and ``residuals (b,)``:
    the largest absolute distance of a point of the set to its plane.
    """
    points = np.asarray(points, dtype=float)
    w = np.ones(points.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    centroids = np.einsum("n,bni->bi", w, points) / w.sum()
    centred = (points - centroids[:, None, :]) * np.sqrt(w)[None, :, None]
    # smallest right-singular vector = plane normal; batched SVD on (b, n, 3)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    normals = vt[:, -1, :]
    offsets = np.einsum("bi,bi->b", normals, centroids)
    residuals = np.abs(np.einsum("bni,bi->bn", points, normals) - offsets[:, None]).max(axis=1)
    return normals, offsets, residuals


def distance_point_plane(points: np.ndarray, plane: np.ndarray) -> np.ndarray:
    """Signed distances of ``points (..., 3)`` to ``plane (4,)`` = (nx, ny, nz, d)."""
    return np.asarray(points) @ plane[:3] - plane[3]
