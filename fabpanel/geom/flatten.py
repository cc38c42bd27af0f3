"""Isometric flattening of a (near-)developable sample grid.

The grid is triangulated (two triangles per cell), laid out first with least-squares conformal maps
(LSCM: B. Lévy, S. Petitjean, N. Ray, J. Maillot, "Least squares conformal maps for automatic
texture atlas generation", SIGGRAPH 2002) and then relaxed by a damped Gauss-Newton solve on the
lengths of all grid edges and both cell diagonals (sparse normal equations, scipy.sparse). For a
grid whose cells are planar and whose 3D edge lengths admit an exact planar layout (a cylinder or
cone sampled along its rulings) the result is exact to round-off; for a doubly curved grid it is
the least-squares compromise and the returned strain says how far it is from isometric.

Grid convention (see ``fabpanel.data.DevelopedPanels``): ``grid[i, j]`` with ``i`` along side 0
(corner 0 -> corner 1) and ``j`` along side 3 reversed (corner 0 -> corner 3); the outer normal is
``d_i x d_j``. The flat layout keeps that orientation: corner 0 at the origin, corner 1 on +x,
corner 3 at y > 0, so the sides run counter-clockwise and the layout reads as the sheet seen from
its outer side.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .quads import grid_triangles

log = logging.getLogger(__name__)

#: Gauss-Newton stops when the largest relative edge-length error falls below this
_STRAIN_EXACT = 1e-13
_MAX_ITERATIONS = 60


def grid_edges(a: int, b: int) -> np.ndarray:
    """(e, 2) int: the grid lines' edges in both directions and both diagonals of every cell."""
    idx = np.arange(a * b).reshape(a, b)
    pairs = [
        (idx[:-1, :], idx[1:, :]),
        (idx[:, :-1], idx[:, 1:]),
        (idx[:-1, :-1], idx[1:, 1:]),
        (idx[1:, :-1], idx[:-1, 1:]),
    ]
    return np.concatenate([np.stack([p.ravel(), q.ravel()], 1) for p, q in pairs])


def _lscm(points: np.ndarray, triangles: np.ndarray, pin: tuple[int, int]) -> np.ndarray:
    """(n, 2) float: LSCM layout with vertex ``pin[0]`` at the origin and ``pin[1]`` on +x at its
    3D distance. Orientation follows the triangles' right-hand normals."""
    n = len(points)
    p0, p1, p2 = (points[triangles[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    normal = np.cross(e1, e2)
    area2 = np.linalg.norm(normal, axis=1)
    ex = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    ey = np.cross(normal / area2[:, None], ex)
    # local 2D coordinates of the three corners (corner 0 at the origin)
    local = np.zeros((len(triangles), 3, 2))
    local[:, 1, 0] = np.einsum("ij,ij->i", e1, ex)
    local[:, 2, 0] = np.einsum("ij,ij->i", e2, ex)
    local[:, 2, 1] = np.einsum("ij,ij->i", e2, ey)
    # gradient operator: grad f = sum_k f_k * rot90(opposite edge_k) / (2 A)
    opposite = np.roll(local, -2, axis=1) - np.roll(local, -1, axis=1)  # edge k+1 -> k+2
    gx = -opposite[:, :, 1] / area2[:, None]
    gy = opposite[:, :, 0] / area2[:, None]
    w = np.sqrt(0.5 * area2)[:, None]
    t = len(triangles)
    rows = np.repeat(np.arange(t), 3)
    cols = triangles.ravel()
    # Cauchy-Riemann: u_x - v_y = 0, u_y + v_x = 0 (columns: u then v)
    r = np.concatenate([rows, rows, rows + t, rows + t])
    c = np.concatenate([cols, cols + n, cols, cols + n])
    v = np.concatenate([(w * gx).ravel(), (-w * gy).ravel(), (w * gy).ravel(), (w * gx).ravel()])
    matrix = sp.csr_matrix((v, (r, c)), shape=(2 * t, 2 * n))
    fixed = np.array([pin[0], pin[0] + n, pin[1], pin[1] + n])
    fixed_values = np.array([0.0, 0.0, np.linalg.norm(points[pin[1]] - points[pin[0]]), 0.0])
    free = np.setdiff1d(np.arange(2 * n), fixed)
    rhs = -matrix[:, fixed] @ fixed_values
    a_free = matrix[:, free].tocsc()
    x = np.zeros(2 * n)
    x[fixed] = fixed_values
    x[free] = _solve_spd(a_free.T @ a_free, a_free.T @ rhs)
    return np.stack([x[:n], x[n:]], axis=1)


def _solve_spd(matrix: sp.spmatrix, rhs: np.ndarray) -> np.ndarray:
    """Solve a symmetric positive definite sparse system: SuperLU in symmetric mode with a
    minimum-degree ordering of A + A' (no pivoting needed), a fifth faster than the default
    column ordering on these grid Laplacian-like matrices."""
    factor = spla.splu(
        sp.csc_matrix(matrix),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return factor.solve(rhs)


def _edge_residuals(uv: np.ndarray, edges: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(e,) float: relative edge-length errors of a layout."""
    return np.linalg.norm(uv[edges[:, 1]] - uv[edges[:, 0]], axis=1) / lengths - 1.0


def _gauss_newton(
    uv: np.ndarray, edges: np.ndarray, lengths: np.ndarray, fixed: np.ndarray
) -> np.ndarray:
    """Damped Gauss-Newton on relative edge-length errors; ``fixed`` are flat coordinate indices
    (into ``uv.ravel()``) held constant to remove the rigid motion."""
    n = len(uv)
    e = len(edges)
    free = np.setdiff1d(np.arange(2 * n), fixed)
    x = uv.ravel().copy()
    damping = 1e-9
    cost = np.sum(_edge_residuals(uv, edges, lengths) ** 2)
    for _ in range(_MAX_ITERATIONS):
        points = x.reshape(n, 2)
        d = points[edges[:, 1]] - points[edges[:, 0]]
        dist = np.linalg.norm(d, axis=1)
        r = dist / lengths - 1.0
        if np.abs(r).max() < _STRAIN_EXACT:
            break
        g = d / (dist * lengths)[:, None]  # d r / d x_b ; d r / d x_a = -g
        rows = np.repeat(np.arange(e), 4)
        cols = np.stack(
            [2 * edges[:, 0], 2 * edges[:, 0] + 1, 2 * edges[:, 1], 2 * edges[:, 1] + 1], 1
        ).ravel()
        vals = np.stack([-g[:, 0], -g[:, 1], g[:, 0], g[:, 1]], 1).ravel()
        jac = sp.csr_matrix((vals, (rows, cols)), shape=(e, 2 * n))[:, free].tocsc()
        normal = (jac.T @ jac).tocsc()
        grad = jac.T @ r
        scale = normal.diagonal().mean()
        while True:
            step = _solve_spd(
                normal + damping * scale * sp.identity(len(free), format="csc"), -grad
            )
            if np.abs(step).max() < 1e-12 * scale**-0.5:
                # a step of round-off size: converged (trying it would only raise the damping
                # through a dozen more solves, as round-off never lowers the cost)
                return x.reshape(n, 2)
            trial = x.copy()
            trial[free] += step
            trial_cost = np.sum(_edge_residuals(trial.reshape(n, 2), edges, lengths) ** 2)
            if trial_cost <= cost or damping > 1e6:
                break
            damping *= 10.0
        converged = abs(cost - trial_cost) <= 1e-16 * max(cost, 1e-300)
        x, cost = trial, trial_cost
        damping = max(damping / 10.0, 1e-12)
        if converged:
            break
    return x.reshape(n, 2)


def flatten_grid(grid: np.ndarray) -> tuple[np.ndarray, float]:
    """Unroll a sample grid into the plane as isometrically as possible.

    grid : (a, b, 3) float
        surface samples, mm, with the side convention of ``DevelopedPanels.samples``.

    Returns ``(uv, strain)``: ``uv`` (a, b, 2) float, the flat grid in mm with corner 0 at the
    origin, side 0 along +x and the sides counter-clockwise (seen from the outer side); ``strain``
    the largest relative length change of any grid edge or cell diagonal (0 for an exact unroll;
    1e-3 is 1.5 mm on a 1.5 m sheet).
    """
    grid = np.asarray(grid, dtype=float)
    if grid.ndim != 3 or grid.shape[2] != 3 or min(grid.shape[:2]) < 2:
        raise ValueError(f"flatten_grid needs an (a, b, 3) grid with a, b >= 2, got {grid.shape}")
    if not np.all(np.isfinite(grid)):
        raise ValueError("flatten_grid: the grid holds non-finite coordinates")
    a, b = grid.shape[:2]
    points = grid.reshape(-1, 3)
    corner0, corner1 = 0, (a - 1) * b
    uv = _lscm(points, grid_triangles(a, b), (corner0, corner1))
    edges = grid_edges(a, b)
    lengths = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    if np.any(lengths <= 0):
        raise ValueError("flatten_grid: the grid has coincident neighbouring samples")
    uv = _gauss_newton(
        uv, edges, lengths, np.array([2 * corner0, 2 * corner0 + 1, 2 * corner1 + 1])
    )
    uv = _pin_rigid_motion(uv, corner0, corner1)
    strain = float(np.abs(_edge_residuals(uv, edges, lengths)).max())
    log.debug("flattened %dx%d grid, strain %.3g", a, b, strain)
    return uv.reshape(a, b, 2), strain


def _pin_rigid_motion(uv: np.ndarray, corner0: int, corner1: int) -> np.ndarray:
    """Move corner 0 to the origin and turn corner 1 onto +x (a rotation, never a mirror)."""
    uv = uv - uv[corner0]
    angle = np.arctan2(uv[corner1, 1], uv[corner1, 0])
    c, s = np.cos(angle), np.sin(angle)
    return uv @ np.array([[c, -s], [s, c]])
