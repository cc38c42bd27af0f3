"""Skeleton (medial-axis) coarse quad layout: hard invariants of shared/notes/quadmesh.md §6."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from fabpanel.errors import GeometryError
from fabpanel.panelize.skeleton import skeleton_layout


def circle(c, r, n=96):
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)], 1)


def rect(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)


def ngon(k, r=1000.0):
    t = np.pi / 2 + 2 * np.pi * np.arange(k) / k
    return np.stack([r * np.cos(t), r * np.sin(t)], 1)


FIXTURES = {
    "square": [rect(0, 0, 1000, 1000)],
    "rectangle_2_1": [rect(0, 0, 2000, 1000)],
    "triangle": [ngon(3)],
    "pentagon": [ngon(5)],
    "L": [
        np.array([[0, 0], [2000, 0], [2000, 1000], [1000, 1000], [1000, 2000], [0, 2000]], float)
    ],
    "rect_square_hole": [rect(0, 0, 3000, 2000), rect(1000, 700, 2000, 1300)],
    "annulus": [circle((0, 0), 1000), circle((0, 0), 500)],
    "disc": [circle((0, 0), 1000)],
    "rect_3_holes": [
        rect(0, 0, 4000, 1500),
        circle((700, 750), 300, 48),
        circle((2000, 750), 300, 48),
        circle((3300, 750), 300, 48),
    ],
}

_CACHE: dict = {}


def layout(name):
    if name not in _CACHE:
        _CACHE[name] = skeleton_layout(FIXTURES[name])
    return _CACHE[name]


def domain_area(loops):
    return abs(Polygon(loops[0]).area) - sum(abs(Polygon(h).area) for h in loops[1:])


def edge_poly(L, q):
    parts = [L.edge_curve(int(q[i]), int(q[(i + 1) % 4])) for i in range(4)]
    return np.vstack([parts[0]] + [p[1:] for p in parts[1:]])[:-1]


def signed_area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


@pytest.mark.parametrize("name", list(FIXTURES))
def test_hard_invariants(name):
    loops = FIXTURES[name]
    h = len(loops) - 1
    L = layout(name)
    V, Q = L.vertices, L.quads
    assert Q.ndim == 2 and Q.shape[1] == 4 and len(Q) > 0
    # all quads, 4 distinct ids, no two with the same vertex set
    assert all(len(set(q)) == 4 for q in Q.tolist())
    assert max(Counter(frozenset(q) for q in Q.tolist()).values()) == 1
    # manifold with consistent orientation
    half = Counter((int(q[i]), int(q[(i + 1) % 4])) for q in Q for i in range(4))
    assert max(half.values()) == 1
    und = Counter(tuple(sorted(e)) for e in half)
    assert max(und.values()) <= 2
    bnd = [e for e in half if (e[1], e[0]) not in half]
    # boundary loops = 1 + h
    nxt = {}
    for a, b in bnd:
        assert a not in nxt
        nxt[a] = b
    seen, nloops = set(), 0
    for a in nxt:  # noqa: PLC0206 - walks the successor map, a moves along it
        if a in seen:
            continue
        nloops += 1
        while a not in seen:
            seen.add(a)
            a = nxt[a]
    assert nloops == 1 + h
    # every edge has a curve and nothing else
    assert set(L.edge_curves) == set(und)
    for (a, b), g in L.edge_curves.items():
        assert a < b
        np.testing.assert_allclose(g[0], V[a], atol=1e-9)
        np.testing.assert_allclose(g[-1], V[b], atol=1e-9)
    # Euler characteristic and index sum
    nV = len(np.unique(Q))
    assert nV == len(V)
    assert nV - len(und) + len(Q) == 1 - h
    deg = Counter()
    for a, b in und:
        deg[a] += 1
        deg[b] += 1
    bverts = {a for a, _ in bnd}
    index = sum((3 - deg[v]) if v in bverts else (4 - deg[v]) for v in range(nV))
    assert index == 4 * (1 - h)
    # boundary vertices on their input loop, interior ones not marked
    for v in range(nV):
        if v in bverts:
            li = int(L.loop_of_vertex[v])
            assert li >= 0
            ring = LineString(np.vstack([loops[li], loops[li][:1]]))
            assert ring.distance(Polygon(V[v : v + 1].repeat(3, 0)).centroid) < 1e-6
        else:
            assert L.loop_of_vertex[v] == -1
    # singular = interior vertices of valence != 4
    assert sorted(L.singular.tolist()) == sorted(
        v for v in range(nV) if v not in bverts and deg[v] != 4
    )
    # every input corner is a vertex
    for li, lp in enumerate(loops):
        p = np.asarray(lp)
        d_in = p - np.roll(p, 1, 0)
        d_out = np.roll(p, -1, 0) - p
        turn = np.degrees(
            np.arctan2(
                d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                np.einsum("ij,ij->i", d_in, d_out),
            )
        )
        for c in p[np.abs(turn) > 35.0]:
            assert np.linalg.norm(V - c, axis=1).min() < 1e-6
    # positive quads, areas add up to the domain
    areas = []
    for q in Q:
        poly = edge_poly(L, q)
        a = signed_area(poly)
        assert a > 0, f"quad {q} has non-positive polyline area"
        assert Polygon(poly).is_valid, f"quad {q} polyline polygon is not simple"
        areas.append(a)
    assert abs(sum(areas) - domain_area(loops)) <= 1e-3 * domain_area(loops)


EXPECTED = {  # quads, singular valences: hand-worked answers of notes §6
    "square": (4, {}),
    "rectangle_2_1": (6, {}),
    "triangle": (3, {3: 1}),
    "pentagon": (5, {5: 1}),
}


@pytest.mark.parametrize("name", list(EXPECTED))
def test_golden_counts(name):
    L = layout(name)
    deg = Counter()
    for a, b in L.edge_curves:
        deg[a] += 1
        deg[b] += 1
    nq, sing = EXPECTED[name]
    assert len(L.quads) == nq
    assert dict(Counter(deg[v] for v in L.singular.tolist())) == sing


def test_annulus_ring():
    L = layout("annulus")
    assert len(L.quads) >= 4
    for li in (0, 1):
        assert int(np.sum(L.loop_of_vertex == li)) >= 3


def signature(L):
    deg = Counter()
    for a, b in L.edge_curves:
        deg[a] += 1
        deg[b] += 1
    return len(L.quads), sorted(deg[v] for v in L.singular.tolist())


@pytest.mark.parametrize("name", ["L", "rect_square_hole", "annulus", "rect_3_holes", "pentagon"])
def test_rotation_and_scale_invariance(name):
    ref = signature(layout(name))
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    rot = [np.asarray(p) @ R.T for p in FIXTURES[name]]
    assert signature(skeleton_layout(rot)) == ref
    big = [np.asarray(p) * 1000.0 for p in FIXTURES[name]]
    assert signature(skeleton_layout(big)) == ref


def test_deterministic():
    a = skeleton_layout(FIXTURES["rect_3_holes"])
    b = skeleton_layout(FIXTURES["rect_3_holes"])
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.quads, b.quads)
    assert a.edge_curves.keys() == b.edge_curves.keys()
    for k in a.edge_curves:
        np.testing.assert_array_equal(a.edge_curves[k], b.edge_curves[k])


def test_orientation_is_fixed():
    loops = [FIXTURES["rect_square_hole"][0][::-1], FIXTURES["rect_square_hole"][1][::-1]]
    assert signature(skeleton_layout(loops)) == signature(layout("rect_square_hole"))


def test_bow_tie_is_rejected():
    with pytest.raises(GeometryError, match="loop 0 intersects itself"):
        skeleton_layout([np.array([[0, 0], [1000, 1000], [1000, 0], [0, 1000]], float)])


def test_opening_outside_is_rejected():
    with pytest.raises(GeometryError, match="opening 1 lies outside"):
        skeleton_layout([rect(0, 0, 1000, 1000), rect(2000, 0, 2500, 500)])


def test_touching_openings_are_rejected():
    with pytest.raises(GeometryError, match="opening 1 touches"):
        skeleton_layout(
            [rect(0, 0, 3000, 1000), rect(500, 200, 1500, 800), rect(1500, 200, 2500, 800)]
        )


def test_point_features_only_matched_when_on_a_vertex(caplog):
    import logging

    caplog.set_level(logging.WARNING)
    loops = FIXTURES["square"]
    L = skeleton_layout(loops, point_features=np.array([[0.0, 0.0], [123.0, 456.0]]))
    assert L.info["point_features_matched"] == 1
    assert L.info["point_features_ignored"] == 1
    assert "not supported" in caplog.text


@pytest.mark.parametrize("name", ["L", "rect_square_hole", "rect_3_holes", "pentagon"])
def test_halved_boundary_sampling_gives_the_same_layout(name):
    loops = FIXTURES[name]
    points = np.vstack(loops)
    diameter = float(np.linalg.norm(points.max(0) - points.min(0)))
    ref = signature(skeleton_layout(loops, sample_spacing=0.02 * diameter))
    assert signature(skeleton_layout(loops, sample_spacing=0.01 * diameter)) == ref


def test_rounded_corners_become_corners_at_any_sampling():
    # a 16 x 12 rectangle with 2.5 m rounded corners and an off-centre opening (the one-opening
    # roof): the rounded corners must anchor branches, not vanish as noise (else: polar grid)
    t = np.linspace(0, np.pi / 2, 12, endpoint=False)
    arc = np.stack([np.cos(t), np.sin(t)], 1) * 2.5
    outer = np.vstack(
        [
            arc + [5.5, 3.5],
            arc @ [[0, 1], [-1, 0]] + [-5.5, 3.5],
            -arc + [-5.5, -3.5],
            arc @ [[0, -1], [1, 0]] + [5.5, -3.5],
        ]
    )
    s = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    hole = np.stack([2 + 1.5 * np.cos(s), 1 + np.sin(s)], 1)[::-1]
    for spacing in (0.1, 0.2, 0.4):
        layout_ = skeleton_layout([outer, hole], corner_angle=30.0, sample_spacing=spacing)
        assert layout_.info["rounded_corners"] >= 3
        assert len(layout_.singular) >= 3
