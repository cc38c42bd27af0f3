"""Fold-free smoothing of a planar quad mesh with a fixed boundary.

The Coons patch of a coarse face is only guaranteed not to fold when the face is convex-ish;
skeleton patches along curved branches (around openings, in concave bays) are not, and a single
folded panel makes the layout unusable. Laplacian smoothing does not repair folds (RV2 issue
#160: it creates them). This module minimises the barrier-regularised distortion energy of
Garanzha, Kaporin, Kudryavtseva, Protais, Ray & Sokolov, *Foldover-free maps in 50 lines of
code* (ACM TOG 40(4), 2021) — our own vectorised implementation — over the interior vertices:

* every quad contributes its four corner triangles ``(p[c-1], p[c], p[c+1])`` mapped from a
  reference right-angled corner of side ``s`` (``s^2`` = mean panel area), with Jacobian
  ``J = [p[c+1] - p[c], p[c-1] - p[c]] / s``; all four corners positive ⇔ the quad is convex;
* per corner ``f = (|J|_F^2 + AREA_WEIGHT (det J^2 + 1)) / chi(det J, eps)`` with
  ``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2``: the first part is conformal distortion (right
  angles, even sides), the second evens panel areas; ``chi`` is a smooth positive stand-in for
  ``det J`` that lets folded corners take part while ``eps > 0`` and becomes a barrier as ``eps``
  shrinks;
* an outer loop lowers ``eps`` from the worst negative determinant (the paper's schedule) and
  minimises with L-BFGS (scipy) each time; it stops when no corner is folded and the energy
  changes by less than ``tolerance`` relative.

The result keeps the boundary samples (and therefore the strip counts) exactly.
"""

from __future__ import annotations

import logging

import numpy as np
from scipy.optimize import minimize

log = logging.getLogger(__name__)

#: weight of the area term against the conformal term (Garanzha et al. use a small theta too:
#: shape first, sizes evened only gently so that the strip densities stay as chosen)
AREA_WEIGHT = 0.25
#: outer iterations (eps updates) at most; the paper needs a handful on hard cases
MAX_OUTER = 40
#: L-BFGS iterations per outer step
INNER_ITERATIONS = 400


def _corners(quads: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertex ids of every quad corner: centre, next and previous (each (4m,))."""
    centre = quads.ravel()
    nxt = np.roll(quads, -1, axis=1).ravel()
    prev = np.roll(quads, 1, axis=1).ravel()
    return centre, nxt, prev


def corner_determinants(vertices: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(4m,) float: cross product of the two edges at every quad corner (>0: convex CCW corner)."""
    centre, nxt, prev = _corners(np.asarray(quads))
    a = vertices[nxt] - vertices[centre]
    b = vertices[prev] - vertices[centre]
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _energy_and_gradient(
    x: np.ndarray, base: np.ndarray, free: np.ndarray, ids, scale, eps: float
) -> tuple[float, np.ndarray]:
    """The energy and its gradient; ``scale`` is one reference size or one per corner."""
    centre, nxt, prev = ids
    p = base.copy()
    p[free] = x.reshape(-1, 2)
    per_corner = np.ndim(scale) > 0
    s = np.asarray(scale)[:, None] if per_corner else scale
    a = (p[nxt] - p[centre]) / s
    b = (p[prev] - p[centre]) / s
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    trace = (a * a).sum(axis=1) + (b * b).sum(axis=1)
    root = np.sqrt(eps * eps + det * det)
    chi = 0.5 * (det + root)
    dchi = 0.5 * (1.0 + det / root)
    numerator = trace + AREA_WEIGHT * (det * det + 1.0)
    energy = float((numerator / chi).sum())
    d_trace = 1.0 / chi
    d_det = 2.0 * AREA_WEIGHT * det / chi - numerator * dchi / (chi * chi)
    # d det / d a = (b_y, -b_x), d det / d b = (-a_y, a_x)
    grad_a = 2.0 * d_trace[:, None] * a + d_det[:, None] * np.stack([b[:, 1], -b[:, 0]], axis=1)
    grad_b = 2.0 * d_trace[:, None] * b + d_det[:, None] * np.stack([-a[:, 1], a[:, 0]], axis=1)
    if per_corner:  # the chain rule's 1 / scale, per corner before the sums
        grad_a, grad_b = grad_a / s, grad_b / s
    n = len(base)
    grad = np.zeros((n, 2))
    for c in range(2):
        grad[:, c] = (
            np.bincount(nxt, weights=grad_a[:, c], minlength=n)
            + np.bincount(prev, weights=grad_b[:, c], minlength=n)
            - np.bincount(centre, weights=grad_a[:, c] + grad_b[:, c], minlength=n)
        )
    return energy, (grad[free] if per_corner else grad[free] / scale).ravel()


def untangle(
    vertices2d: np.ndarray,
    quads: np.ndarray,
    movable: np.ndarray,
    tolerance: float = 1e-6,
    reference: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Fold-free, evenly shaped positions of the movable vertices of a planar quad mesh.

    vertices2d : (n, 2) float, mm; quads : (m, 4) int, counter-clockwise.
    movable : (n,) bool, the vertices that may move (the interior; boundary samples stay).
    reference : (m,) float, each quad's reference side length (a size field, e.g. on a
        flattening whose scale varies); default one size for all, from the mean panel area.
    tolerance : relative energy change that ends the outer loop once nothing is folded.
    Returns ``(vertices (n, 2), info)``; ``info`` has ``folded_before``, ``folded_after``
    (corners with a non-positive determinant), ``outer_iterations`` and ``energy``.
    """
    vertices2d = np.asarray(vertices2d, dtype=float)
    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    movable = np.asarray(movable, dtype=bool)
    ids = _corners(quads)
    det = corner_determinants(vertices2d, quads)
    info: dict[str, int | float] = {
        "folded_before": int((det <= 0).sum()),
        "vertices_moved": int(movable.sum()),
    }
    if not movable.any() or not len(quads):
        info.update(folded_after=info["folded_before"], outer_iterations=0, energy=0.0)
        return vertices2d, info
    # reference corner size: the mean panel area, from the absolute corner determinants
    scale = float(np.sqrt(np.abs(det).sum() / (2.0 * len(det))))
    scale = scale if scale > 0 else 1.0
    sizes = scale if reference is None else np.repeat(np.asarray(reference, dtype=float), 4)
    x = vertices2d[movable].ravel().copy()
    previous = np.inf
    energy = np.inf
    outer = 0
    for outer in range(1, MAX_OUTER + 1):
        p = vertices2d.copy()
        p[movable] = x.reshape(-1, 2)
        worst = float(corner_determinants(p, quads).min()) / scale**2
        # the paper's schedule: eps follows the worst fold, tiny once nothing is folded
        eps = float(np.sqrt(1e-8 + 0.04 * min(worst, 0.0) ** 2))
        result = minimize(
            _energy_and_gradient,
            x,
            args=(vertices2d, movable, ids, sizes, eps),
            jac=True,
            method="L-BFGS-B",
            options={"maxiter": INNER_ITERATIONS, "gtol": 1e-9, "ftol": 1e-12},
        )
        x = result.x
        energy = float(result.fun)
        p[movable] = x.reshape(-1, 2)
        folded = int((corner_determinants(p, quads) <= 0).sum())
        if folded == 0 and abs(previous - energy) <= tolerance * abs(energy):
            break
        previous = energy
    out = vertices2d.copy()
    out[movable] = x.reshape(-1, 2)
    info.update(
        folded_after=int((corner_determinants(out, quads) <= 0).sum()),
        outer_iterations=outer,
        energy=energy,
    )
    log.info(
        "untangle: %d folded corners -> %d in %d outer iterations",
        info["folded_before"],
        info["folded_after"],
        outer,
    )
    return out, info
