"""Strip densification and Catmull-Clark on hand-made coarse layouts (no skeleton needed)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from fabpanel.errors import GeometryError
from fabpanel.panelize.coarse import CoarseLayout
from fabpanel.panelize.densify import (
    catmull_clark,
    collect_strips,
    densify,
    edge_lengths_2d,
    quad_edges,
    signed_quad_areas,
    strip_counts,
)


# ------------------------------------------------------------------------------ fixtures
def make_layout(
    vertices, quads, loop_of_vertex=None, corner=None, curves=None, loops=()
) -> CoarseLayout:
    """A CoarseLayout with straight edges unless ``curves`` gives a polyline (a -> b, a < b)."""
    vertices = np.asarray(vertices, dtype=float)
    quads = np.asarray(quads, dtype=np.int64)
    edge_curves = {}
    for quad in quads:
        for s in range(4):
            key = tuple(sorted((int(quad[s]), int(quad[(s + 1) % 4]))))
            if curves and key in curves:
                edge_curves[key] = curves[key]
            else:
                edge_curves[key] = vertices[list(key)]
    n = len(vertices)
    return CoarseLayout(
        vertices=vertices,
        quads=quads,
        edge_curves=edge_curves,
        loop_of_vertex=np.zeros(n, dtype=np.int64)
        if loop_of_vertex is None
        else np.asarray(loop_of_vertex, dtype=np.int64),
        corner=np.ones(n, dtype=bool) if corner is None else np.asarray(corner, dtype=bool),
        singular=np.zeros(0, dtype=np.int64),
        loops=tuple(loops),
    )


def rectangle_layout() -> CoarseLayout:
    """1000 x 500 mm as two 500 x 500 coarse quads; the four outer corners are corners."""
    vertices = [(0, 0), (500, 0), (1000, 0), (1000, 500), (500, 500), (0, 500)]
    corner = [True, False, True, True, False, True]
    return make_layout(vertices, [[0, 1, 4, 5], [1, 2, 3, 4]], corner=corner)


def grid_layout() -> CoarseLayout:
    """A 2 x 2 grid of 500 mm coarse quads."""
    xs, ys = np.meshgrid([0.0, 500.0, 1000.0], [0.0, 500.0, 1000.0], indexing="ij")
    vertices = np.stack([xs.ravel(), ys.ravel()], axis=1)  # id = 3 i + j
    quads = [
        [3 * i + j, 3 * (i + 1) + j, 3 * (i + 1) + j + 1, 3 * i + j + 1]
        for i in range(2)
        for j in range(2)
    ]
    loop = np.zeros(9, dtype=np.int64)
    loop[4] = -1
    corner = np.zeros(9, dtype=bool)
    corner[[0, 2, 6, 8]] = True
    return make_layout(vertices, quads, loop, corner)


def annulus_layout(outer: float = 1000.0, inner: float = 500.0) -> CoarseLayout:
    """A ring of 4 coarse quads between two circles; edges on the circles are arcs."""
    angles = np.radians([45.0, 135.0, 225.0, 315.0])
    vertices = np.vstack(
        [
            np.c_[outer * np.cos(angles), outer * np.sin(angles)],
            np.c_[inner * np.cos(angles), inner * np.sin(angles)],
        ]
    )
    quads = [[k, (k + 1) % 4, 4 + (k + 1) % 4, 4 + k] for k in range(4)]
    curves = {}
    for k in range(4):
        t = np.linspace(angles[k], angles[k] + np.pi / 2, 25)
        for radius, offset in ((outer, 0), (inner, 4)):
            a, b = k + offset, (k + 1) % 4 + offset
            arc = np.c_[radius * np.cos(t), radius * np.sin(t)]
            curves[(min(a, b), max(a, b))] = arc if a < b else arc[::-1]
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    loops = (
        np.c_[outer * np.cos(t), outer * np.sin(t)],
        np.c_[inner * np.cos(t), inner * np.sin(t)][::-1],
    )
    return make_layout(vertices, quads, [0] * 4 + [1] * 4, [False] * 8, curves, loops)


def t_layout() -> CoarseLayout:
    """A T of four unit-ish quads: three in a row on top of one stem quad."""
    vertices = [
        (100, 0),
        (200, 0),
        (0, 100),
        (100, 100),
        (200, 100),
        (300, 100),
        (0, 200),
        (100, 200),
        (200, 200),
        (300, 200),
    ]
    quads = [[0, 1, 4, 3], [2, 3, 7, 6], [3, 4, 8, 7], [4, 5, 9, 8]]
    return make_layout(vertices, quads)


# ------------------------------------------------------------------------------ mesh checks
def mesh_invariants(vertices, quads) -> dict:
    """Euler characteristic, index sum, boundary loops; asserts manifoldness."""
    quads = np.asarray(quads)
    assert np.all([len(set(q)) == 4 for q in quads.tolist()]), "a quad repeats a vertex"
    half = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    assert len(np.unique(half, axis=0)) == len(half), "a half-edge is used twice"
    edges, eos = quad_edges(quads)
    use = np.bincount(eos.ravel(), minlength=len(edges))
    assert use.max() <= 2, "an edge has more than two faces"
    n = len(vertices)
    degree = np.bincount(edges.ravel(), minlength=n)
    boundary = np.zeros(n, dtype=bool)
    boundary[edges[use == 1].ravel()] = True
    bdeg = np.bincount(edges[use == 1].ravel(), minlength=n)
    assert np.all(bdeg[boundary] == 2), "a boundary vertex is not a simple half-disk"
    index = (4 - degree[~boundary]).sum() + (3 - degree[boundary]).sum()
    # boundary loops by connected components of the boundary edges
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    b = edges[use == 1]
    graph = coo_matrix((np.ones(len(b)), (b[:, 0], b[:, 1])), shape=(n, n))
    _comps, label = connected_components(graph, directed=False)
    loops = len(np.unique(label[boundary]))
    return {"euler": n - len(edges) + len(quads), "index": int(index), "loops": loops}


def assert_distinct(vertices, tolerance=1e-6):
    distance, _ = cKDTree(vertices).query(vertices, k=2)
    assert distance[:, 1].min() > tolerance, "two dense vertices coincide"


# ------------------------------------------------------------------------------ strips
def test_strips_of_2x2_grid():
    strip_of_edge, strips = collect_strips(grid_layout().quads)
    # two strips each way (a row or column of two quads, three edges each): 4 in all
    assert len(strips) == 4
    assert len(strip_of_edge) == 12
    assert all(len(s.edges) == 3 and len(s.quads) == 2 and not s.closed for s in strips)
    assert len({e for s in strips for e in s.edges}) == 12


def test_strips_of_annulus_ring():
    strip_of_edge, strips = collect_strips(annulus_layout().quads)
    closed = [s for s in strips if s.closed]
    assert len(closed) == 1 and len(closed[0].edges) == 4 and len(closed[0].quads) == 4
    radial = [s for s in strips if not s.closed]
    assert len(radial) == 4 and all(len(s.edges) == 2 for s in radial)
    # every undirected edge in exactly one strip
    listed = [e for s in strips for e in s.edges]
    assert len(listed) == len(set(listed)) == len(strip_of_edge) == 12


def test_strips_of_t_shape():
    strip_of_edge, strips = collect_strips(t_layout().quads)
    assert len(strips) == 5
    sizes = sorted(len(s.edges) for s in strips)
    assert sizes == [2, 2, 2, 3, 4]
    # the stem's bottom edge shares its strip with the top edges of the middle quad
    assert strip_of_edge[(0, 1)] == strip_of_edge[(3, 4)] == strip_of_edge[(7, 8)]
    assert sum(len(s.edges) for s in strips) == len(strip_of_edge) == 13


def test_strip_counts_use_the_longest_edge():
    layout = t_layout()
    lengths = edge_lengths_2d(layout)
    lengths[(7, 8)] = 250.0  # a lifted edge longer than in the plane
    _, strips = collect_strips(layout.quads)
    counts = strip_counts(layout, lengths, 100.0)
    by_strip = {tuple(s.edges): c for s, c in zip(strips, counts)}
    assert by_strip[((0, 1), (3, 4), (7, 8))] == 3
    assert all(c == 1 for e, c in by_strip.items() if (7, 8) not in e)
    # a callable of the polyline works too
    assert np.array_equal(
        strip_counts(layout, lambda c: 2 * np.linalg.norm(c[-1] - c[0]), 100.0), [2, 2, 2, 2, 2]
    )
    with pytest.raises(GeometryError):
        strip_counts(layout, lengths, 0.0)


# ------------------------------------------------------------------------------ densify
def test_densify_rectangle_band_and_orientation():
    layout = rectangle_layout()
    target = 100.0
    counts = strip_counts(layout, None, target)
    dense = densify(layout, counts)
    assert len(dense.vertices) == 11 * 6 and len(dense.quads) == 50
    edges, _ = quad_edges(dense.quads)
    lengths = np.linalg.norm(np.diff(dense.vertices[edges], axis=1)[:, 0], axis=1)
    # band measured: exactly [1.0, 1.0] x target here (500 mm sides, 5 divisions each)
    assert lengths.min() >= 0.5 * target - 1e-9 and lengths.max() <= 1.0 * target + 1e-9
    np.testing.assert_allclose(lengths, target, atol=1e-9)
    assert np.all(signed_quad_areas(dense.vertices, dense.quads) > 0)
    assert_distinct(dense.vertices)
    inv = mesh_invariants(dense.vertices, dense.quads)
    assert inv == {"euler": 1, "index": 4, "loops": 1}
    # coarse vertices keep their ids, corners are flagged, the middle edge's samples are inside
    np.testing.assert_array_equal(dense.vertices[:6], layout.vertices)
    assert dense.fixed.sum() == 4 and np.all(dense.fixed[[0, 2, 3, 5]])
    middle = dense.edge_of_vertex >= 0
    on_middle = middle & np.isclose(dense.vertices[:, 0], 500.0)
    assert on_middle.sum() == 4 and np.all(dense.loop_of_vertex[on_middle] == -1)
    assert np.all(dense.loop_of_vertex[middle & ~on_middle] == 0)
    assert np.array_equal(np.bincount(dense.face_of_quad), [25, 25])
    # unpacks in the pipeline's order
    vertices, _quads, _loop_of_vertex, fixed = dense
    assert vertices is dense.vertices and fixed is dense.fixed


def test_densify_uneven_strips_band():
    """A tapered layout: a 1000 mm side opposite a 600 mm side; the strip count follows the
    longer, the shorter gets 60 mm edges: band [0.6, 1.0] x target."""
    vertices = [(0, 0), (1000, 0), (1000, 400), (1000, 800), (800, 700), (200, 600), (0, 400)]
    # quad 0: bottom strip between y=0 and the middle line; quad 1: tapering top
    vertices = [(0, 0), (1000, 0), (1000, 400), (0, 400), (800, 800), (200, 800)]
    layout = make_layout(vertices, [[0, 1, 2, 3], [3, 2, 4, 5]])
    target = 100.0
    dense = densify(layout, strip_counts(layout, None, target))
    edges, _ = quad_edges(dense.quads)
    ratio = np.linalg.norm(np.diff(dense.vertices[edges], axis=1)[:, 0], axis=1) / target
    assert ratio.max() <= 1.0 + 1e-9 and ratio.min() >= 0.6 - 1e-9
    assert np.all(signed_quad_areas(dense.vertices, dense.quads) > 0)
    assert_distinct(dense.vertices)


def test_densify_annulus_topology():
    layout = annulus_layout()
    counts = strip_counts(layout, None, 100.0)
    dense = densify(layout, counts)
    inv = mesh_invariants(dense.vertices, dense.quads)
    assert inv == {"euler": 0, "index": 0, "loops": 2}
    assert_distinct(dense.vertices)
    assert np.all(signed_quad_areas(dense.vertices, dense.quads) > 0)
    # F_dense = sum over coarse faces of n_i * m_i
    strip_of_edge, _ = collect_strips(layout.quads)
    expected = sum(
        counts[strip_of_edge[tuple(sorted((q[0], q[1])))]]
        * counts[strip_of_edge[tuple(sorted((q[1], q[2])))]]
        for q in layout.quads.tolist()
    )
    assert len(dense.quads) == expected
    # boundary samples lie on their circle and carry its loop id
    radius = np.linalg.norm(dense.vertices, axis=1)
    np.testing.assert_allclose(radius[dense.loop_of_vertex == 0], 1000.0, rtol=1e-2)
    np.testing.assert_allclose(radius[dense.loop_of_vertex == 1], 500.0, rtol=1e-2)
    # (boundary samples lie on the arcs' chords: up to 0.6 mm inside the circles)
    assert np.all((radius > 500.0 + 1.0) & (radius < 1000.0 - 1.0) == (dense.loop_of_vertex == -1))


def test_densify_t_shape_is_watertight():
    layout = t_layout()
    dense = densify(layout, [3, 2, 4, 5, 1])
    inv = mesh_invariants(dense.vertices, dense.quads)
    assert inv["euler"] == 1 and inv["index"] == 4 and inv["loops"] == 1
    assert_distinct(dense.vertices)
    assert np.all(signed_quad_areas(dense.vertices, dense.quads) > 0)


def test_catmull_clark_layout_and_mesh():
    layout = annulus_layout()
    dense = catmull_clark(layout, 2)
    assert len(dense.quads) == 4 * 16
    inv = mesh_invariants(dense.vertices, dense.quads)
    assert inv == {"euler": 0, "index": 0, "loops": 2}
    assert np.all(signed_quad_areas(dense.vertices, dense.quads) > 0)
    radius = np.linalg.norm(dense.vertices, axis=1)
    np.testing.assert_allclose(radius[dense.loop_of_vertex == 0], 1000.0, rtol=1e-3)
    np.testing.assert_allclose(radius[dense.loop_of_vertex == 1], 500.0, rtol=1e-3)
    # on a plain quad mesh: a flat grid stays flat and keeps its 2-valent corners
    grid = grid_layout()
    sub = catmull_clark(np.c_[grid.vertices, np.zeros(9)], grid.quads, 1)
    assert len(sub.quads) == 16 and len(sub.vertices) == 25
    np.testing.assert_allclose(sub.vertices[:, 2], 0.0)
    np.testing.assert_allclose(sub.vertices[[0, 2, 6, 8], :2], grid.vertices[[0, 2, 6, 8]])
    assert mesh_invariants(sub.vertices, sub.quads) == {"euler": 1, "index": 4, "loops": 1}
