"""Layout corners on a smooth stretch of the outline dissolved (issue 15): the topology edit
of :mod:`fabpanel.panelize.false_corners` on generated grids, and on shapes whose rounded ends
gave 137-165° corners."""

from __future__ import annotations

import numpy as np

from fabpanel.panelize.false_corners import dissolve_corners, one_panel_nodes
from fabpanel.panelize.gates import euler_characteristic


def _grid(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An n x n grid of unit quads, counter-clockwise; nodes, quads and the boundary flags."""
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="xy")
    nodes = np.column_stack([x.ravel(), y.ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    first = (j * (n + 1) + i).ravel()
    quads = np.column_stack([first, first + 1, first + n + 2, first + n + 1])
    on_curve = (nodes == 0).any(axis=1) | (nodes == n).any(axis=1)
    return nodes, quads, on_curve


def test_the_corners_of_a_grid_are_its_one_panel_boundary_nodes():
    _, quads, on_curve = _grid(3)
    assert sorted(one_panel_nodes(quads, on_curve)) == [0, 3, 12, 15]


def test_a_dissolved_corner_leaves_a_valence_three_vertex_and_the_topology():
    nodes, quads, on_curve = _grid(3)
    movable = on_curve.copy()
    new_nodes, new_quads, new_on_curve, done = dissolve_corners(
        nodes, quads, on_curve, np.array([0]), movable
    )
    assert done == 1
    assert len(new_quads) == len(quads) - 1 and len(new_nodes) == len(nodes) - 2
    assert (np.sort(new_quads, axis=1)[:, 1:] != np.sort(new_quads, axis=1)[:, :-1]).all()
    assert euler_characteristic(len(new_nodes), new_quads) == 1  # still a disc
    valence = np.bincount(new_quads.ravel(), minlength=len(new_nodes))
    assert sorted(valence[~new_on_curve]) == [3, 4, 4, 4]  # the inner corner lost one panel
    # the two outline neighbours became one node where the corner was, in two panels
    merged = np.flatnonzero((new_nodes == [0.0, 0.0]).all(axis=1))
    assert len(merged) == 1 and valence[merged[0]] == 2 and new_on_curve[merged[0]]
    assert new_on_curve.sum() == on_curve.sum() - 2
    # no panel is folded: every quad still turns counter-clockwise
    corners = new_nodes[new_quads]
    area = 0.5 * np.sum(
        corners[:, :, 0] * np.roll(corners[:, :, 1], -1, 1)
        - np.roll(corners[:, :, 0], -1, 1) * corners[:, :, 1],
        axis=1,
    )
    assert (area > 0).all()


def test_corners_are_kept_where_the_outline_has_them_or_the_inner_vertex_is_irregular():
    nodes, quads, on_curve = _grid(3)
    fixed_corner = on_curve.copy()
    fixed_corner[0] = False  # a corner of the outline: it stays
    assert dissolve_corners(nodes, quads, on_curve, np.array([0]), fixed_corner)[3] == 0
    fixed_neighbour = on_curve.copy()
    fixed_neighbour[1] = False  # a neighbour on a corner of the outline or a singular point
    assert dissolve_corners(nodes, quads, on_curve, np.array([0]), fixed_neighbour)[3] == 0
    # a 1 x 1 grid: the inner corner of the one quad is on the outline
    nodes, quads, on_curve = _grid(1)
    assert dissolve_corners(nodes, quads, on_curve, np.array([0]), on_curve.copy())[3] == 0
    # a 2 x 2 grid: the inner corner has four panels but dissolving two corners of the same
    # inner vertex would leave it with two: only the first is dissolved
    nodes, quads, on_curve = _grid(2)
    result = dissolve_corners(nodes, quads, on_curve, np.array([0, 2]), on_curve.copy())
    assert result[3] == 1
