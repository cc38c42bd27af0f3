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

from .gate_band import GateBand
from .slide import SlidingNodes

log = logging.getLogger(__name__)

#: weight of the area term against the conformal term (Garanzha et al. use a small theta too:
#: shape first, sizes evened only gently so that the strip densities stay as chosen)
AREA_WEIGHT = 0.25
#: weight of a boundary edge's (length / reference - 1)² against one corner's distortion,
#: where boundary nodes slide (:mod:`.slide`)
EDGE_WEIGHT = 4.0
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


def _positions(
    x: np.ndarray, base: np.ndarray, free: np.ndarray, sliding: SlidingNodes | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertex positions from the unknowns: free vertices' coordinates, then sliding vertices'
    parameters along the boundary; and the sliding vertices' tangents."""
    p = base.copy()
    count = 2 * int(free.sum())
    p[free] = x[:count].reshape(-1, 2)
    if sliding is None:
        return p, None
    p[sliding.ids], tangents = sliding.positions(x[count:])
    return p, tangents


def _energy_and_gradient(
    x: np.ndarray,
    base: np.ndarray,
    free: np.ndarray,
    ids,
    scale,
    eps: float,
    sliding: SlidingNodes | None = None,
    band: GateBand | None = None,
) -> tuple[float, np.ndarray]:
    """The energy and its gradient; ``scale`` is one reference size or one per corner;
    ``band`` adds the penalty on corners and edges outside their limits (:mod:`.gate_band`)."""
    centre, nxt, prev = ids
    p, tangents = _positions(x, base, free, sliding)
    per_corner = np.ndim(scale) > 0
    s = np.asarray(scale)[:, None] if per_corner else scale
    a = (p[nxt] - p[centre]) / s
    b = (p[prev] - p[centre]) / s
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    trace = (a * a).sum(axis=1) + (b * b).sum(axis=1)
    root = np.sqrt(eps * eps + det * det)
    # (det + root) / 2 cancels to 0 where det is far below -eps (a line search's trial step
    # can fold a corner far past the schedule's eps): the same value as eps^2 / (2 (root - det))
    folded = det < 0.0
    chi = 0.5 * (det + root)
    chi[folded] = 0.5 * eps * eps / (root[folded] - det[folded])
    dchi = 0.5 * (1.0 + det / root)
    dchi[folded] = chi[folded] / root[folded]  # the same, stably
    numerator = trace + AREA_WEIGHT * (det * det + 1.0)
    energy = float((numerator / chi).sum())
    d_trace = 1.0 / chi
    d_det = 2.0 * AREA_WEIGHT * det / chi - numerator * dchi / (chi * chi)
    # d det / d a = (b_y, -b_x), d det / d b = (-a_y, a_x)
    grad_a = 2.0 * d_trace[:, None] * a + d_det[:, None] * np.stack([b[:, 1], -b[:, 0]], axis=1)
    grad_b = 2.0 * d_trace[:, None] * b + d_det[:, None] * np.stack([-a[:, 1], a[:, 0]], axis=1)
    if band is not None:  # on the scaled edges: lengths relative to the reference size
        penalty, band_a, band_b = band.energy(a, b)
        energy += penalty
        grad_a += band_a
        grad_b += band_b
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
    if not per_corner:
        grad /= scale
    if sliding is None:
        return energy, grad[free].ravel()
    held, held_grad = sliding.edge_energy(p, EDGE_WEIGHT)
    energy += held
    grad += held_grad
    assert tangents is not None
    along = np.einsum("ij,ij->i", grad[sliding.ids], tangents)
    return energy, np.concatenate([grad[free].ravel(), along])


def untangle(
    vertices2d: np.ndarray,
    quads: np.ndarray,
    movable: np.ndarray,
    tolerance: float = 1e-6,
    reference: np.ndarray | None = None,
    sliding: SlidingNodes | None = None,
    band: GateBand | None = None,
    max_outer: int = MAX_OUTER,
    max_inner: int = INNER_ITERATIONS,
) -> tuple[np.ndarray, dict]:
    """Fold-free, evenly shaped positions of the movable vertices of a planar quad mesh.

    vertices2d : (n, 2) float, mm; quads : (m, 4) int, counter-clockwise.
    movable : (n,) bool, the vertices that may move (the interior; boundary samples stay).
    reference : (m,) float, each quad's reference side length (a size field, e.g. on a
        flattening whose scale varies); default one size for all, from the mean panel area.
    sliding : boundary vertices (not movable) that move along the boundary (:mod:`.slide`).
    band : limits of every corner's angle and edge's length, kept by a penalty (:mod:`.gate_band`).
    max_outer : outer iterations at most (a start that is not folded needs one or two).
    max_inner : L-BFGS iterations at most in each outer iteration.
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
    bounds: list[tuple[float | None, float | None]] = [(None, None)] * len(x)
    if sliding is not None:
        x = np.concatenate([x, sliding.t])
        bounds += sliding.track.bounds(sliding.t)
        info["vertices_sliding"] = len(sliding.ids)
    previous = np.inf
    energy = np.inf
    outer = 0
    for outer in range(1, max_outer + 1):
        p, _ = _positions(x, vertices2d, movable, sliding)
        worst = float(corner_determinants(p, quads).min()) / scale**2
        # the paper's schedule: eps follows the worst fold, tiny once nothing is folded
        eps = float(np.sqrt(1e-8 + 0.04 * min(worst, 0.0) ** 2))
        result = minimize(
            _energy_and_gradient,
            x,
            args=(vertices2d, movable, ids, sizes, eps, sliding, band),
            jac=True,
            method="L-BFGS-B",
            bounds=bounds if sliding is not None else None,
            options={"maxiter": max_inner, "gtol": 1e-9, "ftol": 1e-12},
        )
        x = result.x
        energy = float(result.fun)
        p, _ = _positions(x, vertices2d, movable, sliding)
        folded = int((corner_determinants(p, quads) <= 0).sum())
        if folded == 0 and abs(previous - energy) <= tolerance * abs(energy):
            break
        previous = energy
    out, _ = _positions(x, vertices2d, movable, sliding)
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
