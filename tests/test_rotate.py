"""Edge rotations towards the panel counts the vertices' angles ask for (issue 15): the
topology edit of :mod:`fabpanel.panelize.rotate` on generated grids, and on random shapes
whose gmsh layouts have crowded boundary vertices or outline corners of one panel."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_surface

import fabpanel as fp
from fabpanel.panelize.quality import corner_angles
from fabpanel.panelize.rotate import out_of_reach, rotate_towards_ideal


def _grid(n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A square grid of n x n unit quads, counter-clockwise: nodes (3D, z = 0), quads and
    which nodes are on the boundary."""
    j, i = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    nodes = np.column_stack([j.ravel(), i.ravel(), np.zeros(j.size)]).astype(float)
    ids = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    quads = np.column_stack(
        [ids[:-1, :-1].ravel(), ids[:-1, 1:].ravel(), ids[1:, 1:].ravel(), ids[1:, :-1].ravel()]
    )
    on_curve = (j == 0) | (j == n) | (i == 0) | (i == n)
    return nodes, quads, on_curve.ravel()


def _angle_sums(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    angles = corner_angles(nodes[quads])
    return np.bincount(quads.ravel(), weights=angles.ravel(), minlength=len(nodes))


def _as_sets(quads: np.ndarray) -> set[frozenset]:
    return {frozenset(q.tolist()) for q in quads}


def _signed_areas(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    p = nodes[quads][:, :, :2]
    x, y = p[..., 0], p[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)


def test_a_corner_given_two_panels_gets_its_one_back():
    nodes, quads, on_curve = _grid()
    sums = _angle_sums(nodes, quads)
    # the square's corner 0 has 90° and one panel; rotate the edge 1-6 so that it has two
    # (45° each, beyond reach of 60-120°), node 6 three and node 7 five
    bad = quads.copy()
    first, second = np.flatnonzero((quads == 1).any(1) & (quads == 6).any(1))
    bad[first], bad[second] = [0, 1, 2, 7], [7, 6, 5, 0]
    counts = np.bincount(bad.ravel(), minlength=len(nodes))
    assert counts[0] == 2 and out_of_reach(counts, sums)[0]

    rotated, done = rotate_towards_ideal(bad, on_curve, sums)

    assert done == 1
    assert _as_sets(rotated) == _as_sets(quads)
    assert (np.bincount(rotated.ravel(), minlength=len(nodes)) == np.bincount(quads.ravel())).all()
    # the orientation is kept: every quad still counter-clockwise in the plane
    assert (_signed_areas(nodes, rotated) > 0).all()


def test_a_layout_whose_counts_fit_their_angles_is_left_alone():
    nodes, quads, on_curve = _grid()
    rotated, done = rotate_towards_ideal(quads, on_curve, _angle_sums(nodes, quads))
    assert done == 0 and (rotated == quads).all()


def test_rotations_keep_the_mesh_manifold_and_its_euler_characteristic():
    nodes, quads, on_curve = _grid(6)
    sums = _angle_sums(nodes, quads)
    # crowd two corners and a side vertex (as above, at three places)
    bad = quads.copy()
    for a, b, new in (
        (1, 8, ([0, 1, 2, 9], [9, 8, 7, 0])),
        (5, 12, ([6, 13, 12, 11], [11, 4, 5, 6])),
    ):
        first, second = np.flatnonzero((bad == a).any(1) & (bad == b).any(1))
        bad[first], bad[second] = new
    before = np.bincount(bad.ravel(), minlength=len(nodes))
    assert out_of_reach(before, sums).sum() >= 2

    rotated, done = rotate_towards_ideal(bad, on_curve, sums)

    assert done >= 2
    after = np.bincount(rotated.ravel(), minlength=len(nodes))
    assert not out_of_reach(after, sums).any()
    sides = np.sort(np.stack([rotated, np.roll(rotated, -1, 1)], 2).reshape(-1, 2), 1)
    edges, uses = np.unique(sides, axis=0, return_counts=True)
    assert uses.max() == 2  # manifold
    assert (np.unique(rotated, axis=None).size - len(edges) + len(rotated)) == 1  # a disc
    assert (_signed_areas(nodes, rotated) > 0).all()


def test_the_band_measure_gives_a_wide_outline_corner_a_second_panel():
    # the outline turns at two neighbours: corner 0 at 139° with one panel, node 1 at 110°
    # with two (55° each). Rotating the edge 1-6 moves a panel from node 1 to corner 0 at the
    # price of a valence-3 vertex inside (6) and a valence-5 one (7): the counts measure
    # refuses it (squared differences 0.30 + 0.61 + 0 + 0 to 0.21 + 0.05 + 1 + 1), the band
    # measure makes it (20° + 12° of excess gone, 3° added at the valence-3 vertex)
    nodes, quads, on_curve = _grid()
    sums = _angle_sums(nodes, quads)
    sums[0], sums[1] = 139.0, 110.0
    counts = np.bincount(quads.ravel(), minlength=len(nodes))
    assert out_of_reach(counts, sums)[[0, 1]].all()

    _, done = rotate_towards_ideal(quads, on_curve, sums, "counts")
    assert done == 0
    rotated, done = rotate_towards_ideal(quads, on_curve, sums, "band")

    assert done == 1
    after = np.bincount(rotated.ravel(), minlength=len(nodes))
    assert (after[[0, 1, 6, 7]] == [2, 1, 3, 5]).all()
    assert not out_of_reach(after, sums)[[0, 1]].any()
    assert (_signed_areas(nodes, rotated) > 0).all()


@pytest.mark.parametrize(
    "seed",
    [
        # a rounded slab, an opening punched: gmsh's layout has boundary vertices of four
        # panels at 226° and 238°, 94 % of corners in 60-120° after the smoothing; one
        # rotation (made by the counts measure alone before the band measure came first),
        # 0.973 (0.936 without)
        72,
        # a rounded slab, an opening punched: outline corners of one panel at 121-134° and a
        # 170 mm edge; the counts' rotations were not kept (94.9 % of corners in 60-120°),
        # the band's are: 0.972
        39,
    ],
)
def test_random_shapes_pass_every_gate_with_their_rotations_kept(seed, tmp_path):
    # seeds of benchmarks/random_shapes.py
    job = fp.Job.from_dict(
        {"input": {"path": "x.obj"}, "panelize": {"panel_size": "1 m", "method": "field"}}
    )
    layout = fp.panelize(random_surface(seed, tmp_path), job)
    rotations = layout.metrics["field"]["relaxation"]["edge_rotations_by_band"]
    assert rotations["rotated"] >= 1 and rotations["kept"]
    gates = layout.metrics["gates"]
    assert gates["corners_in_60_120"] >= 0.95
    assert gates["corners_in_45_135"] == 1.0
    assert gates["edges_in_band"] >= 0.9 and gates["shortest_edge_vs_panel_size"] >= 0.3
    assert gates["euler_characteristic"] == gates["surface_euler_characteristic"]
    assert gates["failed"] == []
