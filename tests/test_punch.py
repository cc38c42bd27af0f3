"""Small openings punched out of a quad mesh: one quad out, its nodes on the opening's corners."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.panelize.punch import PunchFailed, punched


def _grid(count: int, step: float = 1000.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A count x count grid of square quads (counter-clockwise), with its boundary nodes."""
    i, j = np.meshgrid(np.arange(count + 1), np.arange(count + 1), indexing="ij")
    nodes = np.column_stack([i.ravel(), j.ravel()]).astype(float) * step
    index = (np.arange(count)[:, None] * (count + 1) + np.arange(count)[None, :]).ravel()
    quads = np.column_stack([index, index + count + 1, index + count + 2, index + 1])
    on_curve = (nodes == 0).any(axis=1) | (nodes == count * step).any(axis=1)
    return nodes, quads, on_curve


def _signed_areas(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    x, y = nodes[quads][..., 0], nodes[quads][..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=1) - y * np.roll(x, -1, axis=1)).sum(axis=1)


@pytest.mark.parametrize("clockwise", [False, True])
@pytest.mark.parametrize("quads_clockwise", [False, True])
def test_the_quad_over_the_opening_goes_and_its_nodes_move_onto_the_corners(
    clockwise, quads_clockwise
):
    nodes, quads, on_curve = _grid(5)
    if quads_clockwise:  # gmsh's quads may turn either way
        quads = quads[:, ::-1]
    # a 0.8 x 0.5 m rectangle turned 20° in the middle cell (2.5, 2.5) m, corners in loop order
    turn = np.radians(20.0)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    corners = np.array([[-400, -250], [400, -250], [400, 250], [-400, 250]]) @ rotation.T
    corners = corners + 2500.0
    if clockwise:  # a hole's loop runs clockwise: the matching keeps the turning sense anyway
        corners = corners[::-1]
    moved, kept, boundary = punched(
        nodes, quads, on_curve, (corners,), np.zeros(len(nodes), dtype=bool)
    )
    assert len(kept) == len(quads) - 1
    gone = quads[~(quads[:, None, :] == kept[None, :, :]).all(axis=2).any(axis=1)]
    assert len(gone) == 1
    np.testing.assert_allclose(nodes[gone[0]].mean(axis=0), [2500.0, 2500.0])
    # every corner of the opening is one of the punched quad's nodes, now on the boundary
    np.testing.assert_allclose(np.sort(moved[gone[0]], axis=0), np.sort(corners, axis=0))
    assert boundary[gone[0]].all() and boundary.sum() == on_curve.sum() + 4
    # matched round without a twist: the mesh stays unfolded (every quad turns one way)
    turning = _signed_areas(moved, kept)
    assert (turning < 0).all() if quads_clockwise else (turning > 0).all()
    # the least movement of the four matchings round the cell (0.25-0.40 m each)
    assert np.linalg.norm(moved - nodes, axis=1).max() < 410.0


def test_an_opening_whose_quads_all_touch_the_boundary_cannot_be_punched():
    nodes, quads, on_curve = _grid(2)  # every quad has a node on the boundary
    corners = np.array([[800.0, 800.0], [1200.0, 800.0], [1200.0, 1200.0], [800.0, 1200.0]])
    with pytest.raises(PunchFailed):
        punched(nodes, quads, on_curve, (corners,), np.zeros(len(nodes), dtype=bool))


def test_two_openings_take_two_quads_and_a_fixed_node_is_not_moved():
    nodes, quads, on_curve = _grid(8)
    first = np.array([[2100, 2100], [2900, 2100], [2900, 2900], [2100, 2900]], float)
    second = first + 2000.0
    fixed = np.zeros(len(nodes), dtype=bool)
    fixed[int(np.argmin(np.linalg.norm(nodes - [4000.0, 4000.0], axis=1)))] = True
    moved, kept, _ = punched(nodes, quads, on_curve, (first, second), fixed)
    assert len(kept) == len(quads) - 2
    # the second opening's own cell (4-5 m) has the fixed node: a free cell beside it is taken
    np.testing.assert_array_equal(moved[fixed], nodes[fixed])
    for corners in (first, second):
        hit = np.linalg.norm(moved[:, None] - corners[None], axis=2).min(axis=0)
        np.testing.assert_allclose(hit, 0.0, atol=1e-9)
    # the first opening sat in its own cell: the quads round it stay unfolded
    around = (np.abs(moved[kept].mean(axis=1) - 2500.0) < 1600.0).all(axis=1)
    assert (_signed_areas(moved, kept[around]) > 0).all()


def test_an_opening_needs_four_corners():
    nodes, quads, on_curve = _grid(5)
    triangle = np.array([[2200.0, 2200.0], [2800.0, 2200.0], [2500.0, 2800.0]])
    with pytest.raises(PunchFailed):
        punched(nodes, quads, on_curve, (triangle,), np.zeros(len(nodes), dtype=bool))
