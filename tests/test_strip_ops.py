"""Strip operations (fabpanel/panelize/strip_ops.py): splits and collapses on analytic grids
(halved or removed crossing edges, valid quads, the same topology, the refusals), the choice
of the strip, and a random shape whose layout passes the edge band only with a split."""

from __future__ import annotations

import numpy as np
from conftest import random_surface

import fabpanel as fp
from fabpanel.panelize.densify import collect_strips, quad_edges, signed_quad_areas
from fabpanel.panelize.gates import EDGE_BAND, euler_characteristic, meets_every_gate
from fabpanel.panelize.strip_ops import (
    collapse_strip,
    split_strip,
    strips_to_collapse,
    strips_to_split,
)


def _grid(widths: list[float], heights: list[float]):
    """A structured grid of quads, counter-clockwise: columns ``widths``, rows ``heights``."""
    xs = np.concatenate([[0.0], np.cumsum(widths)])
    ys = np.concatenate([[0.0], np.cumsum(heights)])
    nodes = np.array([(x, y) for y in ys for x in xs])
    n = len(xs)
    quads = np.array(
        [
            [j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i]
            for j in range(len(heights))
            for i in range(len(widths))
        ]
    )
    on_curve = (
        np.isclose(nodes[:, 0], 0)
        | np.isclose(nodes[:, 0], xs[-1])
        | np.isclose(nodes[:, 1], 0)
        | np.isclose(nodes[:, 1], ys[-1])
    )
    return nodes, quads, on_curve


def _lengths(nodes, quads):
    edges, _ = quad_edges(quads)
    return np.linalg.norm(nodes[edges[:, 0]] - nodes[edges[:, 1]], axis=1)


def test_the_tall_row_is_chosen_and_split_into_two_rows():
    # three columns of 1 m; rows of 1.0, 1.6 and 1.0 m: the middle row's verticals are over
    # the band (1.25), the others' halves would fall under it
    nodes, quads, on_curve = _grid([1000.0] * 3, [1000.0, 1600.0, 1000.0])
    lengths = _lengths(nodes, quads)
    (strip, *others) = strips_to_split(quads, lengths, 1000.0, EDGE_BAND)
    assert not others
    assert sorted(strip.quads) == [3, 4, 5] and not strip.closed
    split = split_strip(nodes, quads, on_curve, strip)
    assert len(split.quads) == 12 and len(split.nodes) == len(nodes) + 4
    assert (signed_quad_areas(split.nodes, split.quads) > 0).all()
    assert np.isclose(signed_quad_areas(split.nodes, split.quads).sum(), 3000.0 * 3600.0)
    # the four new nodes halve the verticals at y = 1.8 m; the two at the ends are on the curve
    new = split.nodes[len(nodes) :]
    assert np.allclose(new[:, 1], 1800.0)
    assert sorted(new[:, 0]) == [0.0, 1000.0, 2000.0, 3000.0]
    assert split.on_curve[len(nodes) :].sum() == 2
    assert split.on_curve[len(nodes) :][np.isin(new[:, 0], [0.0, 3000.0])].all()
    assert euler_characteristic(len(split.nodes), split.quads) == 1
    # no edge over 1.25 m is left, none under 0.5 m was made
    after = _lengths(split.nodes, split.quads)
    assert after.max() <= 1000.0 and after.min() == 800.0
    # every side is used once (boundary) or twice (inside): a manifold
    _, uses = np.unique(
        np.sort(np.stack([split.quads, np.roll(split.quads, -1, 1)], 2).reshape(-1, 2), 1),
        axis=0,
        return_counts=True,
    )
    assert uses.max() == 2


def test_a_ring_round_an_opening_splits_into_two_rings():
    # an annulus of 12 x 1 quads (radii 1 and 3 m): the ring strip crosses the 2 m radial edges
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    inner = 1000.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    nodes = np.vstack([inner, 3.0 * inner])
    quads = np.array([[i, 12 + i, 12 + (i + 1) % 12, (i + 1) % 12] for i in range(12)])
    on_curve = np.ones(24, dtype=bool)
    _, strips = collect_strips(quads)
    (ring,) = [s for s in strips if s.closed]
    split = split_strip(nodes, quads, on_curve, ring)
    assert len(split.quads) == 24
    assert (signed_quad_areas(split.nodes, split.quads) > 0).all()
    assert not split.on_curve[24:].any()  # a ring has no boundary edge to cross
    assert np.allclose(np.linalg.norm(split.nodes[24:], axis=1), 2000.0)
    assert euler_characteristic(len(split.nodes), split.quads) == 0


def test_no_strip_is_chosen_where_halving_makes_more_short_edges_than_it_mends():
    # four columns of 1 m; the first row's height falls from 1.3 m to 0.6 m along x, the second
    # is 1 m: the first row's strip crosses one edge over 1.25 m and three whose halves would
    # fall under 0.5 m
    nodes, quads, _ = _grid([1000.0] * 4, [1000.0, 1000.0])
    low = np.isclose(nodes[:, 1], 1000.0)
    nodes[low, 1] = 1300.0 - 700.0 * nodes[low, 0] / 4000.0
    top = np.isclose(nodes[:, 1], 2000.0)
    nodes[top, 1] = nodes[low, 1] + 1000.0
    assert strips_to_split(quads, _lengths(nodes, quads), 1000.0, EDGE_BAND) == []


def test_a_random_shape_passes_the_edge_band_with_a_strip_ops(tmp_path):
    # seed 22 of benchmarks/random_shapes.py: a rounded slab with a punched opening, whose
    # layout at 1 m had three rows of 1.45 m on one side (84 % of edges in band, count 0.91)
    surface = random_surface(22, tmp_path)
    job = fp.Job.from_dict({"panelize": {"panel_size": "1 m", "method": "field"}})
    layout = fp.panelize(surface, job)
    split = layout.metrics["field"]["strip_edits"]
    assert split["split"] >= 1
    assert split["edges_in_band"][0] < 0.9 <= split["edges_in_band"][1]
    assert split["panels"][1] > split["panels"][0]
    gates = layout.metrics["gates"]
    assert meets_every_gate(gates, 300.0)
    assert gates["count_ratio"] <= 1.3


def test_a_thin_row_is_chosen_and_collapsed_into_its_neighbours():
    # rows of 1.0, 0.3 and 1.0 m across three 1 m columns: the thin row's verticals are under
    # the band (0.5 m) and collapsing it leaves two rows of quads
    nodes, quads, on_curve = _grid([1000.0] * 3, [1000.0, 300.0, 1000.0])
    lengths = _lengths(nodes, quads)
    (strip,) = strips_to_collapse(quads, lengths, 1000.0, EDGE_BAND)
    assert sorted(strip.quads) == [3, 4, 5]
    fixed = np.zeros(len(nodes), dtype=bool)
    fixed[[0, 3, 12, 15]] = True  # the outline's corners
    done = collapse_strip(nodes, quads, on_curve, strip, fixed)
    assert done is not None
    assert len(done.quads) == 6 and len(done.nodes) == len(nodes) - 4
    assert (signed_quad_areas(done.nodes, done.quads) > 0).all()
    assert np.isclose(signed_quad_areas(done.nodes, done.quads).sum(), 3000.0 * 2300.0)
    assert euler_characteristic(len(done.nodes), done.quads) == 1
    # the joined nodes stand half way across the removed row; the ends stay on the outline
    middle = done.nodes[np.isclose(done.nodes[:, 1], 1150.0)]
    assert sorted(middle[:, 0]) == [0.0, 1000.0, 2000.0, 3000.0]
    assert done.on_curve[np.isclose(done.nodes[:, 1], 1150.0)].sum() == 2
    # a grid with no thin row has nothing to collapse
    full = _grid([1000.0] * 3, [1000.0] * 3)
    assert strips_to_collapse(full[1], _lengths(*full[:2]), 1000.0, EDGE_BAND) == []


def test_a_collapse_that_would_change_the_layout_is_refused():
    nodes, quads, on_curve = _grid([1000.0] * 3, [1000.0, 300.0, 1000.0])
    (strip,) = strips_to_collapse(quads, _lengths(nodes, quads), 1000.0, EDGE_BAND)
    none = np.zeros(len(nodes), dtype=bool)
    # two fixed nodes would be made one (both ends of an edge the strip crosses)
    fixed = np.zeros(len(nodes), dtype=bool)
    fixed[[5, 9]] = True
    assert collapse_strip(nodes, quads, on_curve, strip, fixed) is None
    # an end edge of the strip joins two boundary loops (its nodes at y = 1.0 and 1.3 m): the
    # loops would become one
    loops = np.where(nodes[:, 1] < 1100.0, 0, 1)
    assert collapse_strip(nodes, quads, on_curve, strip, none, lambda ids: loops[ids]) is None
    # an inner edge of the strip with both ends on the curve (across the domain) is refused
    across = np.array(on_curve, copy=True)
    across[[5, 9]] = True
    assert collapse_strip(nodes, quads, across, strip, none) is None
    # a one-row grid: taking its only row out leaves nothing
    one = _grid([1000.0] * 3, [300.0])
    (row,) = [s for s in collect_strips(one[1])[1] if sorted(s.quads) == [0, 1, 2]]
    assert collapse_strip(*one, row, np.zeros(8, dtype=bool)) is None
