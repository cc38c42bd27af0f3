"""Densify a coarse quad layout: strips, per-strip division counts, Coons patches, Catmull-Clark.

Strip densification follows compas_singular / compas_quad (Oval et al. 2018; see
shared/notes/quadmesh.md §1.5 and §6 step 10): the coarse edges fall into *strips* by walking
from an edge to the opposite edge through each quad; every edge of a strip gets the same number
of divisions, so opposite sides of every coarse quad match and each coarse quad becomes a
structured ``n0 x n1`` grid (a discrete bilinearly blended Coons patch, Coons 1967). Each coarse
edge is sampled once along its polyline and the samples are shared by both adjacent faces: the
dense mesh is welded by topology (ids), never by rounded coordinates.

The count of a strip is ``max(1, ceil(longest 3D edge of the strip / target))``, so no dense edge
along a strip exceeds the target on the coarse edge (up to the Coons patch's interior blending),
and short strips (near narrow supports) are not over-divided as an equal subdivision of every
coarse face (Catmull-Clark, the thesis §7.1.3) would do. Catmull-Clark (Catmull & Clark 1978) is
kept as an alternative (``[panelize] density = "catmull-clark"``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..errors import GeometryError
from ..geom.quads import coons_patch, resample_polylines
from .coarse import CoarseLayout

log = logging.getLogger(__name__)

#: a coarse edge is measured on the surface at this many points at least (``arc_length``)
ARC_LENGTH_POINTS = 65


# --------------------------------------------------------------------------------------------
# topology helpers
# --------------------------------------------------------------------------------------------
def quad_edges(quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges of a quad mesh and the edge of every quad side.

    quads : (m, 4) int. Side ``s`` of quad ``q`` runs from ``quads[q, s]`` to ``quads[q, s+1]``.
    Returns ``edges (e, 2) int`` (sorted pairs, lexicographic order) and
    ``edge_of_side (m, 4) int``.
    """
    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    sides = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    edges, inverse = np.unique(np.sort(sides, axis=1), axis=0, return_inverse=True)
    return edges.reshape(-1, 2), inverse.reshape(-1, 4)


class Strip(NamedTuple):
    """One strip of quads: its edges in walking order, the quads crossed, and whether it closes.

    edges : list of (a, b) sorted vertex pairs, consecutive edges are opposite sides of a quad.
    quads : list of int, ``quads[k]`` lies between ``edges[k]`` and ``edges[k + 1]`` (for a
        closed strip the last quad joins the last edge back to the first).
    closed : bool, a ring (e.g. around an opening).
    """

    edges: list
    quads: list
    closed: bool


def collect_strips(quads: np.ndarray) -> tuple[dict, list[Strip]]:
    """The strips of a quad mesh by opposite-edge traversal.

    quads : (m, 4) int, four distinct vertices each.
    Returns ``strip_of_edge``: dict ``(a, b) -> strip index`` for every undirected edge
    (``a < b``; every edge lies in exactly one strip), and ``strips``: list of :class:`Strip`,
    open strips walked from one boundary edge to the other. A strip may cross a quad twice
    (self-intersecting strip); the quad then appears twice in its ``quads``.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    edges, eos = quad_edges(quads)
    e = len(edges)
    # strips = connected components of the graph "edge -- opposite edge in a quad"
    rows = np.concatenate([eos[:, 0], eos[:, 1]])
    cols = np.concatenate([eos[:, 2], eos[:, 3]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(e, e))
    n_strips, label = connected_components(graph, directed=False)
    # ordered walk per strip (a loop over coarse edges; coarse meshes have a few hundred)
    links: list[list[tuple[int, int]]] = [[] for _ in range(e)]  # edge -> [(quad, opposite)]
    for q in range(len(quads)):
        for s in range(4):
            links[eos[q, s]].append((q, int(eos[q, (s + 2) % 4])))
    keys = [tuple(int(v) for v in edge) for edge in edges]
    strips: list[Strip] = []
    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(n_strips))
    for strip in range(n_strips):
        members = order[starts[strip] : (starts[strip + 1] if strip + 1 < n_strips else e)]
        ends = [m for m in members if len(links[m]) == 1]
        first = int(ends[0]) if ends else int(members[0])
        walk_edges, walk_quads = [first], []
        came_from = -1  # index into links[current] of the link we arrived through
        current = first
        while True:
            options = [k for k in range(len(links[current])) if k != came_from]
            if not options:
                break  # reached the other boundary end
            quad, nxt = links[current][options[0]]
            walk_quads.append(quad)
            if nxt == first and not ends:
                break  # closed ring
            # the link of `nxt` that leads back through the same quad (and to `current`)
            back = [k for k, (q2, o2) in enumerate(links[nxt]) if q2 == quad and o2 == current]
            came_from = back[0]
            walk_edges.append(nxt)
            current = nxt
        strips.append(Strip([keys[i] for i in walk_edges], walk_quads, not ends))
    strip_of_edge = {keys[i]: int(label[i]) for i in range(e)}
    # renumber so that strip_of_edge matches list order (labels are the list order already)
    return strip_of_edge, strips


def edge_lengths_2d(layout: CoarseLayout) -> dict:
    """Length of every coarse edge's polyline in the plane, mm: dict ``(a, b) -> float``."""
    return {
        key: float(np.linalg.norm(np.diff(curve, axis=0), axis=1).sum())
        for key, curve in layout.edge_curves.items()
    }


def strip_counts(
    layout: CoarseLayout, lengths: Mapping | Callable | np.ndarray | None, target: float
) -> np.ndarray:
    """Divisions per strip: ``max(1, ceil(longest edge of the strip / target))``.

    layout : the coarse layout; strips as :func:`collect_strips` ``(layout.quads)`` orders them.
    lengths : the 3D length of every coarse edge, mm, as a dict ``(a, b) -> float`` (sorted
        pairs, like ``layout.edge_curves``), an array aligned with ``quad_edges(layout.quads)[0]``,
        a callable taking the edge's (k, 2) plane polyline and returning its 3D length, or
        ``None`` for the plane lengths (:func:`edge_lengths_2d`).
    target : target panel edge length, mm.
    Returns ``counts (s,) int``.
    """
    if not target > 0:
        raise GeometryError(f"the target panel size must be positive, got {target!r}")
    strip_of_edge, strips = collect_strips(layout.quads)
    edges, _ = quad_edges(layout.quads)
    keys = [tuple(int(v) for v in edge) for edge in edges]
    if lengths is None:
        lengths = edge_lengths_2d(layout)
    if callable(lengths) and not isinstance(lengths, Mapping):
        values = np.array([float(lengths(layout.edge_curves[k])) for k in keys])
    elif isinstance(lengths, Mapping):
        values = np.array([float(lengths[k]) for k in keys])
    else:
        values = np.asarray(lengths, dtype=float).ravel()
        if len(values) != len(keys):
            raise GeometryError(
                f"strip_counts: {len(values)} edge lengths for {len(keys)} coarse edges"
            )
    label = np.array([strip_of_edge[k] for k in keys], dtype=np.int64)
    longest = np.zeros(len(strips))
    np.maximum.at(longest, label, values)
    return np.maximum(1, np.ceil(longest / target - 1e-9)).astype(np.int64)


# --------------------------------------------------------------------------------------------
# the dense mesh
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DenseMesh:
    """A dense quad mesh in the plane (or in 3D for :func:`catmull_clark` on 3D input).

    vertices : (n, d) float, mm; quads : (m, 4) int, counter-clockwise in the plane.
    loop_of_vertex : (n,) int, boundary loop of each vertex (0 outer, 1.. openings), -1 inside.
    fixed : (n,) bool, the coarse corners (kept in place by relaxation).
    face_of_vertex : (n,) int, a coarse face the vertex lies in or on.
    face_of_quad : (m,) int, the coarse face each dense quad came from.
    edge_of_vertex : (n,) int, for samples on a coarse edge the edge's index in
        ``quad_edges(coarse.quads)[0]``; -1 for coarse vertices and face interiors.
    info : dict, counts and checks (JSON-ready).

    Unpacks as ``vertices, quads, loop_of_vertex, fixed`` (the pipeline's order).
    """

    vertices: np.ndarray
    quads: np.ndarray
    loop_of_vertex: np.ndarray
    fixed: np.ndarray
    face_of_vertex: np.ndarray
    face_of_quad: np.ndarray
    edge_of_vertex: np.ndarray
    info: dict = field(default_factory=dict)

    def __iter__(self):
        return iter((self.vertices, self.quads, self.loop_of_vertex, self.fixed))


def signed_quad_areas(vertices2d: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(m,) float: signed area of each quad in the plane (shoelace), positive when CCW, mm2."""
    p = np.asarray(vertices2d)[quads]
    x, y = p[..., 0], p[..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1)


def _grid_quads(ids: np.ndarray) -> np.ndarray:
    """(a-1)(b-1) quads of an (a, b) id grid, corner order (i,j) (i+1,j) (i+1,j+1) (i,j+1)."""
    return np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(
        -1, 4
    )


def refine_polyline(curve: np.ndarray, points: int) -> np.ndarray:
    """The polyline with every segment split evenly so that it has at least ``points`` points;
    its own vertices are kept (corners of the curve are not cut)."""
    curve = np.asarray(curve, dtype=float)
    pieces = max(1, int(np.ceil((points - 1) / max(len(curve) - 1, 1))))
    t = np.arange(pieces)[None, :, None] / pieces
    body = (curve[:-1, None, :] + t * (curve[1:, None, :] - curve[:-1, None, :])).reshape(
        -1, curve.shape[1]
    )
    return np.vstack([body, curve[-1:]])


def resample_by_measure(curve: np.ndarray, cumulative: np.ndarray, count: int) -> np.ndarray:
    """(count, d) points of a polyline evenly spaced in a given arc-length measure, ends kept.

    curve : (k, d) float; cumulative : (k,) float, non-decreasing measure of each point (e.g. the
    3D arc length of a plane polyline lifted onto the surface).
    """
    cumulative = np.asarray(cumulative, dtype=float)
    targets = np.linspace(cumulative[0], cumulative[-1], count)
    out = np.stack(
        [np.interp(targets, cumulative, curve[:, c]) for c in range(curve.shape[1])], axis=1
    )
    out[0], out[-1] = curve[0], curve[-1]
    return out


def densify(
    layout: CoarseLayout,
    counts: np.ndarray | int,
    arc_length: Callable[[np.ndarray], np.ndarray] | None = None,
) -> DenseMesh:
    """Densify a coarse layout per strip (see the module docstring).

    layout : the coarse layout (plane, mm).
    counts : (s,) int divisions per strip, in :func:`collect_strips` order (an int applies to
        every strip).
    arc_length : optional callable taking a coarse edge's (k, 2) polyline and returning the
        (k,) cumulative length of its points on the surface; the edge samples are then evenly
        spaced on the surface, not in the plane (steep parts are foreshortened in the plane).
    Returns a :class:`DenseMesh` in the plane: coarse vertex ``i`` keeps id ``i``; then come the
    inner samples of every coarse edge (edge order of :func:`quad_edges`), then the inner grid
    points of every coarse face. Quads are counter-clockwise wherever the Coons patch of the coarse
    face does not fold (``info["inverted_quads"]`` counts those that do).
    """
    coarse_quads = np.asarray(layout.quads, dtype=np.int64).reshape(-1, 4)
    nc = len(layout.vertices)
    strip_of_edge, strips = collect_strips(coarse_quads)
    counts = np.broadcast_to(np.asarray(counts, dtype=np.int64), (len(strips),))
    if np.any(counts < 1):
        raise GeometryError("densify: every strip needs at least one division")
    edges, eos = quad_edges(coarse_quads)
    keys = [tuple(int(v) for v in edge) for edge in edges]
    edge_count = counts[[strip_of_edge[k] for k in keys]]
    faces_per_edge = np.bincount(eos.ravel(), minlength=len(edges))
    first_face = np.full(len(edges), -1, dtype=np.int64)
    first_face[eos[::-1].ravel()] = np.repeat(np.arange(len(coarse_quads))[::-1], 4)

    # ---- sample every coarse edge once, from a to b (a < b)
    points = [np.asarray(layout.vertices, dtype=float)]
    loop = [np.asarray(layout.loop_of_vertex, dtype=np.int64)]
    fixed = [np.asarray(layout.corner, dtype=bool)]
    face_of_vertex = [np.full(nc, -1, dtype=np.int64)]
    edge_of_vertex = [np.full(nc, -1, dtype=np.int64)]
    edge_ids: list[np.ndarray] = []
    next_id = nc
    for e, (a, b) in enumerate(keys):  # a loop over coarse edges
        n = int(edge_count[e])
        curve = np.asarray(layout.edge_curves[(a, b)], dtype=float)
        if arc_length is None:
            samples = resample_polylines(curve[None], n + 1)[0]
        else:
            fine = refine_polyline(curve, ARC_LENGTH_POINTS)
            samples = resample_by_measure(fine, arc_length(fine), n + 1)
        inner = np.arange(next_id, next_id + n - 1)
        next_id += n - 1
        edge_ids.append(np.concatenate([[a], inner, [b]]))
        points.append(samples[1:-1])
        on_loop = -1
        if faces_per_edge[e] == 1:  # boundary edge: its samples lie on the endpoints' loop
            on_loop = int(max(layout.loop_of_vertex[a], layout.loop_of_vertex[b]))
        loop.append(np.full(n - 1, on_loop, dtype=np.int64))
        fixed.append(np.zeros(n - 1, dtype=bool))
        face_of_vertex.append(np.full(n - 1, first_face[e]))
        edge_of_vertex.append(np.full(n - 1, e, dtype=np.int64))
    face_of_vertex[0][coarse_quads[::-1].ravel()] = np.repeat(np.arange(len(coarse_quads))[::-1], 4)
    edge_points = np.concatenate(points)

    def side(q: int, s: int) -> tuple[np.ndarray, np.ndarray]:
        """ids and points of side s of coarse quad q, from corner s to corner s+1."""
        e = eos[q, s]
        ids = edge_ids[e]
        if coarse_quads[q, s] != keys[e][0]:
            ids = ids[::-1]
        return ids, edge_points[ids]

    # ---- one Coons patch per coarse face (a loop over coarse faces)
    dense_quads, face_of_quad = [], []
    for q in range(len(coarse_quads)):
        (i0, p0), (i1, p1), (i2, p2), (i3, p3) = (side(q, s) for s in range(4))
        a, b = len(i0), len(i1)
        grid = coons_patch(p0, p1, p2, p3)  # (a, b, 2)
        ids = np.empty((a, b), dtype=np.int64)
        ids[:, 0], ids[-1, :], ids[:, -1], ids[0, :] = i0, i1, i2[::-1], i3[::-1]
        n_inner = (a - 2) * (b - 2)
        if n_inner > 0:
            ids[1:-1, 1:-1] = np.arange(next_id, next_id + n_inner).reshape(a - 2, b - 2)
            next_id += n_inner
            points.append(grid[1:-1, 1:-1].reshape(-1, grid.shape[-1]))
            loop.append(np.full(n_inner, -1, dtype=np.int64))
            fixed.append(np.zeros(n_inner, dtype=bool))
            face_of_vertex.append(np.full(n_inner, q, dtype=np.int64))
            edge_of_vertex.append(np.full(n_inner, -1, dtype=np.int64))
        cells = _grid_quads(ids)
        dense_quads.append(cells)
        face_of_quad.append(np.full(len(cells), q, dtype=np.int64))
    vertices = np.concatenate(points)
    quads = np.concatenate(dense_quads)
    areas = signed_quad_areas(vertices, quads)
    info = {
        "strips": len(strips),
        "strip_counts": [int(c) for c in counts],
        "closed_strips": int(sum(s.closed for s in strips)),
        "vertices": len(vertices),
        "quads": len(quads),
        "inverted_quads": int((areas <= 0).sum()),
    }
    if info["inverted_quads"]:
        log.info(
            "densify: %d dense quads are inverted in the plane (folded Coons patches)",
            info["inverted_quads"],
        )
    return DenseMesh(
        vertices,
        quads,
        np.concatenate(loop),
        np.concatenate(fixed),
        np.concatenate(face_of_vertex),
        np.concatenate(face_of_quad),
        np.concatenate(edge_of_vertex),
        info,
    )


# --------------------------------------------------------------------------------------------
# Catmull-Clark
# --------------------------------------------------------------------------------------------
def _catmull_clark_once(vertices, quads, loop_of_vertex, fixed):
    """One Catmull-Clark step on a quad mesh with boundary (vectorised)."""
    n, m, d = len(vertices), len(quads), vertices.shape[1]
    edges, eos = quad_edges(quads)
    ne = len(edges)
    faces_per_edge = np.bincount(eos.ravel(), minlength=ne)
    boundary_edge = faces_per_edge == 1
    face_points = vertices[quads].mean(axis=1)  # (m, d)
    # edge points: interior (v0 + v1 + f0 + f1) / 4, boundary the midpoint
    face_sum = np.stack(
        [
            np.bincount(eos.ravel(), weights=np.repeat(face_points[:, c], 4), minlength=ne)
            for c in range(d)
        ],
        axis=1,
    )
    mid = 0.5 * (vertices[edges[:, 0]] + vertices[edges[:, 1]])
    edge_points = np.where(
        boundary_edge[:, None],
        mid,
        0.5 * mid + 0.5 * face_sum / np.maximum(faces_per_edge, 1)[:, None],
    )

    def scatter(index, values, length):
        return np.stack(
            [np.bincount(index, weights=values[:, c], minlength=length) for c in range(d)], axis=1
        )

    # interior vertices: (F + 2R + (k - 3) P) / k with k the valence
    valence = np.bincount(edges.ravel(), minlength=n).astype(float)
    faces_at = np.bincount(quads.ravel(), minlength=n).astype(float)
    f_avg = (
        scatter(quads.ravel(), np.repeat(face_points, 4, axis=0), n)
        / np.maximum(faces_at, 1)[:, None]
    )
    r_avg = scatter(edges.ravel(), np.repeat(mid, 2, axis=0), n) / np.maximum(valence, 1)[:, None]
    k = np.maximum(valence, 1)[:, None]
    new_vertices = (f_avg + 2 * r_avg + (k - 3) * vertices) / k
    # boundary vertices: the cubic B-spline curve rule (6 P + a + b) / 8 along the boundary
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[edges[boundary_edge].ravel()] = True
    b_edges = edges[boundary_edge]
    b_sum = scatter(b_edges.ravel(), vertices[b_edges[:, ::-1].ravel()], n)
    b_count = np.bincount(b_edges.ravel(), minlength=n)
    curve = (6 * vertices + b_sum) / 8
    regular_boundary = on_boundary & (b_count == 2)
    new_vertices[regular_boundary] = curve[regular_boundary]
    keep = fixed | (on_boundary & (b_count != 2)) | (on_boundary & (faces_at == 1))
    new_vertices[keep] = vertices[keep]
    # topology: old vertices, then edge points, then face points
    e_ids, f_ids = n + eos, n + ne + np.arange(m)
    out = []
    for c in range(4):
        out.append(np.stack([quads[:, c], e_ids[:, c], f_ids, e_ids[:, (c - 1) % 4]], axis=1))
    new_quads = np.stack(out, axis=1).reshape(-1, 4)
    edge_loop = np.where(
        boundary_edge, np.maximum(loop_of_vertex[edges[:, 0]], loop_of_vertex[edges[:, 1]]), -1
    )
    return (
        np.concatenate([new_vertices, edge_points, face_points]),
        new_quads,
        np.concatenate([loop_of_vertex, edge_loop, np.full(m, -1)]),
        np.concatenate([fixed, np.zeros(ne + m, dtype=bool)]),
    )


def catmull_clark(
    vertices, quads=None, levels: int = 1, *, loop_of_vertex=None, fixed=None
) -> DenseMesh:
    """Catmull-Clark subdivision of a quad mesh with boundary (Catmull & Clark 1978).

    Either ``catmull_clark(vertices (n, d), quads (m, 4), levels)`` or
    ``catmull_clark(layout: CoarseLayout, levels)``.
    Interior vertices move by the standard rule, boundary vertices by the cubic B-spline curve
    rule; boundary vertices in a single face (the 2-valent corners) and ``fixed`` vertices stay.
    For a :class:`CoarseLayout` the first level follows the stored edge curves (it is
    ``densify(layout, 2)``: curve midpoints and Coons patch centres), the coarse corners are
    fixed, and after every further level the boundary vertices are put back onto their loop
    polyline (``layout.loops``; the curve rule cuts the corners of a curved boundary). Each level multiplies every strip count by 2 and keeps the singularities.
    Returns a :class:`DenseMesh` (``face_of_quad`` and ``face_of_vertex`` refer to the input
    quads; ``edge_of_vertex`` is -1 throughout).
    """
    layout = None
    if isinstance(vertices, CoarseLayout):
        layout = vertices
        levels = int(quads if quads is not None else levels)
        vertices, quads = layout.vertices, layout.quads
        loop_of_vertex, fixed = layout.loop_of_vertex, layout.corner
    vertices = np.asarray(vertices, dtype=float)
    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    n = len(vertices)
    loop_of_vertex = (
        np.full(n, -1, dtype=np.int64)
        if loop_of_vertex is None
        else np.asarray(loop_of_vertex, dtype=np.int64)
    )
    fixed = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    if levels < 0:
        raise GeometryError(f"catmull_clark: levels must be >= 0, got {levels}")
    if loop_of_vertex.max(initial=-1) < 0:
        # no loops given: mark the boundary as loop 0 so the curve rule and edge loops apply
        edges, eos = quad_edges(quads)
        counts = np.bincount(eos.ravel(), minlength=len(edges))
        loop_of_vertex = loop_of_vertex.copy()
        loop_of_vertex[edges[counts == 1].ravel()] = 0
    face_of_quad = np.arange(len(quads))
    v, q, lv, fx = vertices, quads, loop_of_vertex, fixed
    first = 0
    if layout is not None and levels > 0:
        # level 1 on a layout follows its edge curves: the curves' arc-length midpoints as edge
        # points and the Coons patch centres as face points, i.e. densify with 2 per strip
        start = densify(layout, 2)
        v, q, lv, fx = start.vertices, start.quads, start.loop_of_vertex, start.fixed
        face_of_quad = start.face_of_quad
        first = 1
    for _ in range(first, levels):
        v, q, lv, fx = _catmull_clark_once(v, q, lv, fx)
        face_of_quad = np.repeat(face_of_quad, 4)
        if layout is not None and layout.loops:
            v = _snap_to_loops(v, lv, fx, layout.loops)
    face_of_vertex = np.full(len(v), -1, dtype=np.int64)
    face_of_vertex[q[::-1].ravel()] = np.repeat(face_of_quad[::-1], 4)
    info = {"levels": int(levels), "vertices": len(v), "quads": len(q)}
    if v.shape[1] == 2:
        info["inverted_quads"] = int((signed_quad_areas(v, q) <= 0).sum())
    return DenseMesh(
        v, q, lv, fx, face_of_vertex, face_of_quad, np.full(len(v), -1, dtype=np.int64), info
    )


def _snap_to_loops(
    vertices: np.ndarray, loop_of_vertex: np.ndarray, fixed: np.ndarray, loops: tuple
) -> np.ndarray:
    """Boundary vertices (not fixed) moved to the closest point of their loop polyline."""
    from ..geom.polygon import closest_on_polylines

    out = vertices.copy()
    snap = (loop_of_vertex >= 0) & ~fixed
    for k, loop in enumerate(loops):
        mine = snap & (loop_of_vertex == k)
        if mine.any():
            out[mine] = closest_on_polylines(
                vertices[mine], np.asarray(loop, dtype=float), closed=True
            )
    return out
