"""Relax a quad panel layout on the design surface: even edges, fair grid lines, no flips.

Constrained smoothing as compas_singular does it in Rhino (``constrained_smoothing``: all
vertices to the surface, boundary vertices to their border curve, corners fixed; see
shared/notes/quadmesh.md §1.6 and §6 step 11), but as a global solve per iteration instead of
Jacobi sweeps, so that it converges in tens of iterations on meshes of thousands of vertices:

1. the spring energy ``1/2 sum_edges |x_i - x_j|^2`` (symmetric graph Laplacian ``K``): its
   minimiser puts every vertex at the average of its edge neighbours (the umbrella operator,
   which evens edge lengths; at a regular vertex that average is the mean of the two grid
   lines' midpoints, so grid lines stay fair). Boundary vertices take part with all their
   edges (natural boundary condition: interior edges meet the boundary square);
2. one damped Newton step of that energy restricted to the directions each vertex may move in
   (two tangent vectors per interior vertex, the loop tangent per boundary vertex, none for
   fixed ones): ``T' (mu D + K) T u = -T' K x``, with every vertex move capped at
   ``MAX_STEP x target``;
3. the vertices are moved by their step factor and put back exactly: interior vertices onto the
   surface (``SurfaceQuery.closest``), boundary vertices onto their boundary polyline;
4. the flip guard (§6 step 11, and RV2 issue #160: Laplacian smoothing makes edges overlap
   around openings): every quad corner's turn is measured against the surface normal; a corner
   that was convex and is no longer makes the step of its quad's vertices halve and the step is
   redone from the previous positions.

It stops when the largest vertex move of an iteration is below ``tolerance`` (mm), or after
``max_iterations`` (reported as not converged).

Fabrication note: relaxation trades the strip method's edges perpendicular to the boundary for
even panels (the 2026 fork measured feature perpendicularity drop from ~90 to 45-65 degrees);
skip it (``[panelize] relax = false``) where ribs must meet the boundary square.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import GeometryError, SolverError
from ..surface import SurfaceQuery
from .densify import quad_edges
from .quality import corner_angles

log = logging.getLogger(__name__)

#: mu of the damped step (T' (mu I + L) T) u = -T' L x: small against L's entries (O(1)), so the
#: step is nearly the full solve, but keeps the system regular where L has a null space in the
#: tangent directions (an opening's boundary ring without a fixed corner slides freely)
REGULARISATION = 1e-3
#: largest move of a vertex in one iteration, as a fraction of the target edge length
MAX_STEP = 0.25
#: step halvings tried per iteration before the offending vertices are frozen for it
MAX_HALVINGS = 12
#: largest (point, segment) pairs evaluated at once by closest_on_polylines
MAX_PAIRS = 4_000_000


def closest_on_polylines(points: np.ndarray, polyline: np.ndarray,
                         closed: bool = True) -> np.ndarray:
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
        block = points[first:first + chunk]
        rel = block[:, None, :] - starts[None]
        t = np.clip(np.einsum("psd,sd->ps", rel, direction) / length2, 0.0, 1.0)
        foot = starts[None] + t[..., None] * direction[None]
        best = np.argmin(np.einsum("psd,psd->ps", block[:, None] - foot, block[:, None] - foot),
                         axis=1)
        out[first:first + chunk] = foot[np.arange(len(block)), best]
    return out


class LoopCurve:
    """A closed boundary polyline parametrised by arc length, for sliding vertices along it.

    points : (k, d) float, first point not repeated, mm.
    """

    def __init__(self, points: np.ndarray):
        self.points = np.asarray(points, dtype=float)
        closed = np.vstack([self.points, self.points[:1]])
        steps = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        self.cumulative = np.concatenate([[0.0], np.cumsum(steps)])
        self.length = float(self.cumulative[-1])
        self.closed = closed
        self.steps = steps

    def parameters(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Arc-length parameter of each point's closest loop point (p,) and the unit tangent
        there (p, d), following the loop's direction."""
        points = np.asarray(points, dtype=float)
        starts, ends = self.closed[:-1], self.closed[1:]
        direction = ends - starts
        length2 = np.maximum(self.steps ** 2, 1e-300)
        seg = np.empty(len(points), dtype=np.int64)
        frac = np.empty(len(points))
        chunk = max(1, MAX_PAIRS // max(len(starts), 1))
        for first in range(0, len(points), chunk):
            block = points[first:first + chunk]
            rel = block[:, None, :] - starts[None]
            t = np.clip(np.einsum("psd,sd->ps", rel, direction) / length2, 0.0, 1.0)
            foot = starts[None] + t[..., None] * direction[None]
            gap = block[:, None] - foot
            best = np.argmin(np.einsum("psd,psd->ps", gap, gap), axis=1)
            seg[first:first + chunk] = best
            frac[first:first + chunk] = t[np.arange(len(block)), best]
        s = self.cumulative[seg] + frac * self.steps[seg]
        tangent = direction[seg] / np.maximum(self.steps[seg], 1e-300)[:, None]
        return s, tangent

    def evaluate(self, s: np.ndarray) -> np.ndarray:
        """(p, d) float: loop points at arc-length parameters (taken modulo the loop length)."""
        s = np.mod(np.asarray(s, dtype=float), self.length)
        return np.stack([np.interp(s, self.cumulative, self.closed[:, c])
                         for c in range(self.closed.shape[1])], axis=1)


def _quad_areas(vertices: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(m,) float: area of each quad, half the cross product of its diagonals, mm2."""
    c = vertices[quads]
    return 0.5 * np.linalg.norm(np.cross(c[:, 2] - c[:, 0], c[:, 3] - c[:, 1]), axis=1)


def corner_turns(vertices: np.ndarray, quads: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(m, 4) float: (next - v) x (prev - v) . n at each quad corner; > 0 where the corner turns
    counter-clockwise seen from the outer side (a convex, unflipped corner), mm2.

    normals : (n, 3) unit outward vertex normals; a quad's reference normal is their sum.
    """
    c = vertices[quads]
    ref = normals[quads].sum(axis=1)
    cross = np.cross(np.roll(c, -1, axis=1) - c, np.roll(c, 1, axis=1) - c)
    return np.einsum("mci,mi->mc", cross, ref)


def _edge_stats(vertices: np.ndarray, edges: np.ndarray) -> dict:
    lengths = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    return {"min": round(float(lengths.min()), 3), "median": round(float(np.median(lengths)), 3),
            "max": round(float(lengths.max()), 3),
            "spread": round(float(lengths.max() / max(lengths.min(), 1e-300)), 4)}


def _angle_stats(vertices: np.ndarray, quads: np.ndarray) -> dict:
    angles = corner_angles(vertices[quads])
    return {"min": round(float(angles.min()), 3), "max": round(float(angles.max()), 3)}


def averaging_matrix(vertices: np.ndarray, quads: np.ndarray, edges: np.ndarray,
                     boundary_edge: np.ndarray, loop_of_vertex: np.ndarray, fixed: np.ndarray,
                     area_weight: float = 0.0, boundary_mix: float = 0.0) -> sp.csr_matrix:
    """(n, n) sparse row-stochastic averaging operator of the relaxation (rows of fixed vertices
    are the identity).

    Interior vertices: ``(1 - area_weight)`` x umbrella (mean of the edge neighbours) +
    ``area_weight`` x area-weighted mean of the adjacent quad centroids. Boundary vertices
    (``loop_of_vertex >= 0``): mean of their neighbours along boundary edges of their loop.
    """
    n = len(vertices)
    on_loop = loop_of_vertex >= 0
    # umbrella over all edges
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    umbrella = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    degree = np.asarray(umbrella.sum(axis=1)).ravel()
    umbrella = sp.diags(1.0 / np.maximum(degree, 1)) @ umbrella
    operator = umbrella
    if area_weight > 0:
        areas = _quad_areas(vertices, quads)
        r = np.repeat(quads, 4, axis=1).ravel()            # vertex i of the quad ...
        c = np.tile(quads, (1, 4)).ravel()                 # ... takes a quarter of every corner
        w = np.repeat(areas / 4.0, 16)
        area = sp.csr_matrix((w, (r, c)), shape=(n, n))
        total = np.asarray(area.sum(axis=1)).ravel()
        area = sp.diags(1.0 / np.maximum(total, 1e-300)) @ area
        operator = (1.0 - area_weight) * umbrella + area_weight * area
    # boundary vertices: along the boundary edges of their own loop only
    b = edges[boundary_edge]
    same = (loop_of_vertex[b[:, 0]] == loop_of_vertex[b[:, 1]]) | fixed[b[:, 0]] | fixed[b[:, 1]]
    b = b[same]
    brow = np.concatenate([b[:, 0], b[:, 1]])
    bcol = np.concatenate([b[:, 1], b[:, 0]])
    along = sp.csr_matrix((np.ones(len(brow)), (brow, bcol)), shape=(n, n))
    bdeg = np.asarray(along.sum(axis=1)).ravel()
    along = sp.diags(1.0 / np.maximum(bdeg, 1)) @ along
    pick_inner = sp.diags((~on_loop & ~fixed).astype(float))
    pick_loop = sp.diags((on_loop & ~fixed).astype(float))
    pick_fixed = sp.diags(fixed.astype(float))
    return (pick_inner @ operator + pick_loop @ (boundary_mix * along + (1.0 - boundary_mix) * umbrella)
            + pick_fixed).tocsr()


def _tangent_basis(x: np.ndarray, normals: np.ndarray, inner_ids: np.ndarray,
                   curves: list, members: list) -> sp.csr_matrix:
    """(3n, k) sparse: the directions each vertex may move in, as columns.

    Interior vertices: two unit vectors spanning the tangent plane (normal to ``normals``);
    loop vertices: the loop's unit tangent; fixed vertices: none.
    """
    n = len(x)
    nrm = normals[inner_ids]
    helper = np.eye(3)[np.argmin(np.abs(nrm), axis=1)]
    e1 = np.cross(nrm, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(nrm, e1)
    ids, vectors = [inner_ids, inner_ids], [e1, e2]
    for curve, mine in zip(curves, members):
        if len(mine):
            ids.append(mine)
            vectors.append(curve.parameters(x[mine])[1])
    vertex = np.concatenate(ids)
    vec = np.concatenate(vectors)
    column = np.arange(len(vertex))
    rows = (3 * vertex[:, None] + np.arange(3)[None]).ravel()
    cols = np.repeat(column, 3)
    return sp.csr_matrix((vec.ravel(), (rows, cols)), shape=(3 * n, len(vertex)))


def relax_on_surface(vertices: np.ndarray, quads: np.ndarray, query: SurfaceQuery,
                     boundary_loops_3d: list, loop_of_vertex: np.ndarray, fixed: np.ndarray,
                     target: float, tolerance: float | None = None, max_iterations: int = 500,
                     *, area_weight: float = 0.0, regularisation: float = REGULARISATION
                     ) -> tuple[np.ndarray, dict]:
    """Relax a quad mesh on the surface (see the module docstring).

    vertices : (n, 3) float, mm, on (or near) the surface.
    quads : (m, 4) int, counter-clockwise seen from the outer side.
    query : closeness queries of the design surface.
    boundary_loops_3d : list of (k, 3) float closed polylines (first point not repeated), mm;
        loop ``i`` is the one ``loop_of_vertex == i`` refers to.
    loop_of_vertex : (n,) int, boundary loop of each vertex, -1 for interior vertices.
    fixed : (n,) bool, vertices kept in place (the corners).
    target : target edge length, mm (sets the default tolerance).
    tolerance : stop when the largest vertex move of an iteration is below this, mm
        (default ``1e-3 * target``).
    max_iterations : most iterations; reaching it is reported as ``converged: false``.
    area_weight : currently ignored (the solve uses the symmetric umbrella / spring energy);
        kept for the report and for a later area-weighted variant.
    regularisation : ``mu`` of the damped tangential solve (see ``REGULARISATION``).
    Returns the relaxed ``vertices (n, 3)`` and a JSON-ready report: iterations, max_move_mm,
    converged, tolerance_mm, rejected_steps, frozen_vertices (held by the flip guard in the last
    iteration), edge_length_mm and corner_angle_deg before and after, seconds.

    Mesh boundary vertices with ``loop_of_vertex == -1`` are kept fixed (there is no curve to
    slide them on). Interior vertices end on the surface to the query's accuracy; boundary
    vertices on their polyline (which is on a mesh surface; within the tessellation's chord of
    a B-rep).
    """
    started = time.perf_counter()
    x = np.asarray(vertices, dtype=float).reshape(-1, 3).copy()
    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    n = len(x)
    loop_of_vertex = np.asarray(loop_of_vertex, dtype=np.int64).ravel()
    fixed = np.asarray(fixed, dtype=bool).ravel().copy()
    if len(loop_of_vertex) != n or len(fixed) != n:
        raise GeometryError(f"relax_on_surface: loop_of_vertex ({len(loop_of_vertex)}) and fixed "
                            f"({len(fixed)}) must have one entry per vertex ({n})")
    loops = [np.asarray(loop, dtype=float).reshape(-1, 3) for loop in boundary_loops_3d]
    if loop_of_vertex.max(initial=-1) >= len(loops):
        raise GeometryError(f"relax_on_surface: a vertex refers to boundary loop "
                            f"{loop_of_vertex.max()}, only {len(loops)} loops given")
    tolerance = 1e-3 * target if tolerance is None else float(tolerance)
    edges, eos = quad_edges(quads)
    boundary_edge = np.bincount(eos.ravel(), minlength=len(edges)) == 1
    on_mesh_boundary = np.zeros(n, dtype=bool)
    on_mesh_boundary[edges[boundary_edge].ravel()] = True
    loose = on_mesh_boundary & (loop_of_vertex < 0) & ~fixed
    fixed |= loose
    on_loop = (loop_of_vertex >= 0) & ~fixed
    inner = (loop_of_vertex < 0) & ~fixed
    free = ~fixed
    free_ids, fixed_ids = np.flatnonzero(free), np.flatnonzero(fixed)
    before = {"edge_length_mm": _edge_stats(x, edges), "corner_angle_deg": _angle_stats(x, quads)}

    curves = [LoopCurve(loop) for loop in loops]
    members = [np.flatnonzero(on_loop & (loop_of_vertex == k)) for k in range(len(loops))]

    def advance(points: np.ndarray, normals: np.ndarray,
                delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move by ``delta`` and put back: interior vertices onto the surface (closest point),
        loop vertices slid along their loop by delta's tangential part (arc length, so that
        they pass the polyline's kinks; a closest-point projection would stick to them)."""
        out, nrm = points.copy(), normals.copy()
        if inner.any():
            out[inner], nrm[inner], _ = query.closest(points[inner] + delta[inner])
        for curve, mine in zip(curves, members):
            if len(mine):
                s, tangent = curve.parameters(points[mine])
                out[mine] = curve.evaluate(s + np.einsum("ij,ij->i", delta[mine], tangent))
        rest = ~inner
        if rest.any():
            _, nrm[rest], _ = query.closest(out[rest])
        return out, nrm

    x, normals = advance(x, np.zeros_like(x), np.zeros_like(x))
    if loose.any():
        log.info("relaxation: %d boundary vertices without a loop are kept fixed", loose.sum())
    if not free.any():
        return x, {"iterations": 0, "max_move_mm": 0.0, "converged": True,
                   "tolerance_mm": tolerance, "rejected_steps": 0, "frozen_vertices": 0,
                   "before": before, "after": before, "seconds": 0.0}
    step = np.ones(n)
    m = None
    rejected = frozen = 0
    move = np.inf
    converged = False
    iteration = 0
    inner_ids = np.flatnonzero(inner)
    for iteration in range(1, max_iterations + 1):
        if m is None:
            # spring energy 1/2 sum_edges |x_i - x_j|^2 (its minimiser is the umbrella average);
            # the symmetric graph Laplacian makes the step a Newton step of that energy in the
            # tangent directions, free of drift along rigid motions of free boundary rings
            rows = np.concatenate([edges[:, 0], edges[:, 1]])
            cols = np.concatenate([edges[:, 1], edges[:, 0]])
            adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
            degree = np.asarray(adjacency.sum(axis=1)).ravel()
            m = sp.diags(degree) - adjacency
            lap3 = sp.kron(m, sp.identity(3), format="csr")
            scale3 = sp.diags(np.repeat(degree, 3))
        basis = _tangent_basis(x, normals, inner_ids, curves, members)
        system = (basis.T @ (regularisation * scale3 + lap3) @ basis).tocsc()
        rhs = -(basis.T @ (lap3 @ x.ravel()))
        try:
            delta = (basis @ splu(system).solve(rhs)).reshape(n, 3)
        except RuntimeError as err:
            raise SolverError(f"relaxation: the smoothing system is singular ({err})") from err
        # trust region: no vertex moves farther than MAX_STEP x target in one iteration (the
        # linearised step is unreliable farther out, and near-null modes such as the rotation
        # of an opening's free boundary ring would otherwise take huge steps)
        length = np.linalg.norm(delta, axis=1)
        delta *= np.minimum(1.0, MAX_STEP * target / np.maximum(length, 1e-300))[:, None]
        good_before = corner_turns(x, quads, normals) > 0
        frozen = 0
        for _ in range(MAX_HALVINGS + 1):
            trial, trial_normals = advance(x, normals, step[:, None] * delta)
            flipped = (corner_turns(trial, quads, trial_normals) <= 0) & good_before
            bad_quads = flipped.any(axis=1)
            if not bad_quads.any():
                break
            rejected += 1
            involved = np.unique(quads[bad_quads])
            step[involved] *= 0.5
        else:
            # still flipping: freeze the vertices of the offending quads for this iteration
            involved = np.unique(quads[bad_quads])
            frozen = len(involved)
            step[involved] = 0.0
            trial, trial_normals = advance(x, normals, step[:, None] * delta)
        move = float(np.linalg.norm(trial - x, axis=1).max())
        x, normals = trial, trial_normals
        step = np.minimum(1.0, np.maximum(step, 1.0 / 2 ** MAX_HALVINGS) * 1.5)
        if move < tolerance:
            converged = True
            break
    report = {"iterations": iteration, "max_move_mm": round(move, 9), "converged": converged,
              "tolerance_mm": tolerance, "rejected_steps": rejected, "frozen_vertices": frozen,
              "area_weight": area_weight, "before": before,
              "after": {"edge_length_mm": _edge_stats(x, edges),
                        "corner_angle_deg": _angle_stats(x, quads)},
              "seconds": round(time.perf_counter() - started, 3)}
    if not converged:
        log.warning("relaxation did not converge in %d iterations (last move %.3g mm > %.3g mm)",
                    iteration, move, tolerance)
    return x, report
