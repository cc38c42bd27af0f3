"""Conformal flattening of a triangle mesh: least-squares conformal maps (Lévy et al. 2002).

A conformal map keeps angles and scales lengths equally in every direction at each point, so a
size field divided by the local scale factor is exact in all directions at once (a projection
onto a plane stretches only along the slope). The map is the least-squares solution of the
Cauchy-Riemann equations per triangle with two vertices pinned; one sparse linear solve.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import GeometryError


def _local_triangle_coordinates(vertices: np.ndarray, faces: np.ndarray):
    """Each triangle's corners in its own plane: x1 = (l01, 0), x2 = (a, b); and its area."""
    p0, p1, p2 = (vertices[faces[:, i]] for i in range(3))
    e01, e02 = p1 - p0, p2 - p0
    length01 = np.linalg.norm(e01, axis=1)
    normal = np.cross(e01, e02)
    double_area = np.linalg.norm(normal, axis=1)
    safe = np.maximum(length01, 1e-300)
    x_axis = e01 / safe[:, None]
    a = np.einsum("ij,ij->i", e02, x_axis)
    b = double_area / safe
    return length01, a, b, 0.5 * double_area


def _pinned_pair(vertices: np.ndarray, loop: np.ndarray) -> tuple[int, int]:
    """Two far-apart vertices of a boundary loop (pinning them fixes the map's similarity)."""
    points = vertices[loop]
    first = int(loop[np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1))])
    second = int(loop[np.argmax(np.linalg.norm(points - vertices[first], axis=1))])
    return first, second


def conformal_flattening(
    vertices: np.ndarray, faces: np.ndarray, boundary_loop: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """2D coordinates per vertex of a conformal flattening, and the scale per vertex.

    vertices : (n, 3) mm; faces : (m, 3) int; boundary_loop : vertex indices of one boundary
    loop (two of its vertices are pinned; the result is scaled to the surface's area).
    Returns ``flat (n, 2)`` (counter-clockwise where the triangles are) and ``scale (n,)``,
    the flat length of a unit surface length at each vertex (area-weighted over its triangles).
    Raises :class:`GeometryError` when the flattening folds (a triangle turns over).
    """
    n, m = len(vertices), len(faces)
    length01, a, b, area = _local_triangle_coordinates(vertices, faces)
    root = np.sqrt(np.maximum(2.0 * area, 1e-300))
    # W_j = x_{j+2} - x_{j+1} for the local corners x0 = 0, x1 = (l01, 0), x2 = (a, b)
    w_real = np.stack([a - length01, -a, length01], axis=1) / root[:, None]
    w_imag = np.stack([b, -b, np.zeros(m)], axis=1) / root[:, None]
    rows = np.repeat(np.arange(m), 3)
    cols = faces.ravel()
    real = sp.csr_matrix((w_real.ravel(), (rows, cols)), shape=(m, n))
    imag = sp.csr_matrix((w_imag.ravel(), (rows, cols)), shape=(m, n))
    # |M U|^2 with U = u + i v: real rows Mr u - Mi v, imaginary rows Mi u + Mr v
    system = sp.vstack([sp.hstack([real, -imag]), sp.hstack([imag, real])]).tocsc()
    first, second = _pinned_pair(vertices, boundary_loop)
    pinned_values = np.zeros(2 * n)
    pinned_values[second] = np.linalg.norm(vertices[second] - vertices[first])
    pinned = np.zeros(2 * n, dtype=bool)
    pinned[[first, second, n + first, n + second]] = True
    free = np.flatnonzero(~pinned)
    a_free = system[:, free]
    rhs = -(system[:, np.flatnonzero(pinned)] @ pinned_values[pinned])
    solution = spla.spsolve((a_free.T @ a_free).tocsc(), a_free.T @ rhs)
    values = pinned_values.copy()
    values[free] = solution
    flat = np.column_stack([values[:n], values[n:]])
    signed = _signed_areas(flat, faces)
    if signed.sum() < 0:
        flat[:, 1] *= -1.0
        signed = -signed
    if (signed <= 0).any():
        raise GeometryError(
            f"the conformal flattening folds over at {int((signed <= 0).sum())} triangles"
        )
    # the pins sit at their straight distance, not along the surface: equal total areas
    stretch = np.sqrt(area.sum() / signed.sum())
    flat *= stretch
    signed = signed * stretch**2
    return flat, _vertex_scale(flat, faces, signed, area, n)


def _signed_areas(flat: np.ndarray, faces: np.ndarray) -> np.ndarray:
    tri = flat[faces]
    return 0.5 * (
        (tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1])
        - (tri[:, 2, 0] - tri[:, 0, 0]) * (tri[:, 1, 1] - tri[:, 0, 1])
    )


def _vertex_scale(
    flat: np.ndarray, faces: np.ndarray, flat_area: np.ndarray, area: np.ndarray, n: int
) -> np.ndarray:
    """Length scale flat/surface per vertex: sqrt of the area ratio of its triangles."""
    flat_sum = np.bincount(faces.ravel(), np.repeat(flat_area, 3), minlength=n)
    surface_sum = np.bincount(faces.ravel(), np.repeat(area, 3), minlength=n)
    return np.sqrt(flat_sum / np.maximum(surface_sum, 1e-300))
