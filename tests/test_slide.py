"""Boundary nodes sliding along the flat boundary during fold-free smoothing."""

from __future__ import annotations

import numpy as np
from conftest import unit_quad_grid
from scipy.optimize import check_grad

from fabpanel.panelize.slide import BoundaryTrack, SlidingNodes
from fabpanel.panelize.untangle import _corners, _energy_and_gradient, corner_determinants, untangle


def _square_loop(side: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """A square's outline sampled every ``step``, counter-clockwise, its four corners flagged."""
    ticks = np.arange(0.0, side, step)
    zeros, full = np.zeros_like(ticks), np.full_like(ticks, side)
    points = np.vstack(
        [
            np.column_stack([ticks, zeros]),
            np.column_stack([full, ticks]),
            np.column_stack([side - ticks, full]),
            np.column_stack([zeros, side - ticks]),
        ]
    )
    corners = np.zeros(len(points), dtype=bool)
    corners[:: len(ticks)] = True
    return points, corners


def _circle(radius: float, count: int) -> np.ndarray:
    angles = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    return radius * np.column_stack([np.cos(angles), np.sin(angles)]) + 10.0


def _track() -> BoundaryTrack:
    square, corners = _square_loop(6.0, 0.5)
    circle = _circle(1.0, 64)
    # the square starts half way along a side, so the loop must be rotated to a corner
    square, corners = np.roll(square, 5, axis=0), np.roll(corners, 5)
    return BoundaryTrack.from_loops([square, circle], [corners, np.zeros(64, dtype=bool)])


def test_points_on_the_loops_are_found_again_and_corners_are_recognised():
    track = _track()
    probe = np.array([[0.0, 0.0], [6.0, 6.0], [2.3, 0.0], [6.0, 4.1], [11.0, 10.0], [9.0, 10.0]])
    t, on_corner = track.locate(probe, tolerance=1e-6)
    np.testing.assert_allclose(track.at(t)[0], probe, atol=1e-9)
    np.testing.assert_array_equal(on_corner, [True, True, False, False, False, False])
    # a node on a side may move between that side's two corners only
    low, high = track.bounds(t[2:3])[0]
    np.testing.assert_allclose(track.at(np.array([low, high]))[0], [[0, 0], [6, 0]], atol=1e-5)
    # on the circle (no corner) a node wraps round
    assert track.bounds(t[4:5]) == [(None, None)]
    loops = np.searchsorted(track.spans[:, 1], t[4:5])
    length = track.spans[1, 1] - track.spans[1, 0]
    wrapped = track.wrap(t[4:5] + 3 * length, loops)
    np.testing.assert_allclose(track.at(wrapped)[0], probe[4:5], atol=1e-9)


def _sheared(n: int, amount: float):
    """The regular n x n grid on [0, n]² with every node moved by amount x (sin(pi x / n),
    sin(pi y / n)): boundary nodes move along their sides, corners stay, boundary quads lean."""
    points, quads, interior = unit_quad_grid(n)
    sheared = points + amount * np.sin(np.pi * points / n)
    return points, sheared, quads, ~interior


def _sliding_on_square(n: int, sheared: np.ndarray, boundary: np.ndarray, step: float):
    """The square [0, n]² as the track (sampled every ``step``), its boundary nodes on it."""
    square, corners = _square_loop(float(n), step)
    track = BoundaryTrack.from_loops([square], [corners])
    return SlidingNodes.on_track(track, sheared, np.flatnonzero(boundary), 1e-6)


def test_leaning_boundary_quads_are_squared_by_sliding_nodes():
    n = 6
    regular, sheared, quads, boundary = _sheared(n, 0.35)
    sliding = _sliding_on_square(n, sheared, boundary, 1.0)
    assert len(sliding.ids) == 4 * (n - 1)  # every boundary node but the four corners
    fixed_only, _ = untangle(sheared, quads, ~boundary)
    out, info = untangle(sheared, quads, ~boundary, sliding=sliding)
    assert info["folded_after"] == 0 and info["vertices_sliding"] == 4 * (n - 1)
    # the unique optimum is the regular grid again: boundary nodes slid back along the sides
    np.testing.assert_allclose(out, regular, atol=1e-3)
    # without sliding the boundary rows keep their lean
    assert np.abs(fixed_only - regular).max() > 0.1
    # every boundary node is still on the square, its corners where they were
    on_side = np.isclose(out[boundary], 0.0, atol=1e-9) | np.isclose(out[boundary], n, atol=1e-9)
    assert on_side.any(axis=1).all()
    corner_ids = [0, n, n * (n + 1), (n + 1) ** 2 - 1]
    np.testing.assert_array_equal(out[corner_ids], regular[corner_ids])
    assert (corner_determinants(out, quads) > 0).all()


def test_gradient_with_sliding_nodes_matches_finite_differences():
    n = 3
    _, sheared, quads, boundary = _sheared(n, 0.3)
    sliding = _sliding_on_square(n, sheared, boundary, 0.5)
    movable = ~boundary
    args = (sheared, movable, _corners(quads), 1.1, 0.1, sliding)
    x = np.concatenate([sheared[movable].ravel(), sliding.t + 0.05])

    def energy(v):
        return _energy_and_gradient(v, *args)[0]

    def gradient(v):
        return _energy_and_gradient(v, *args)[1]

    assert check_grad(energy, gradient, x, epsilon=1e-7) < 1e-4 * np.linalg.norm(gradient(x))


def test_a_parameter_a_rounding_error_past_a_loops_end_stays_on_that_loop():
    # the foot of a node at the very end of the last loop came out 1e-12 past it, and the
    # node's bounds were looked up for a third loop that does not exist
    track = _track()
    end = track.spans[:, 1]
    np.testing.assert_array_equal(track.loop_of(end + 1e-9), [0, 1])
    np.testing.assert_array_equal(track.loop_of(track.spans[:, 0]), [0, 1])
    square_side = track.bounds(np.array([end[0] - 0.1]))[0]
    assert square_side[1] <= end[0]
    assert track.bounds(np.array([end[1] + 1e-9])) == [(None, None)]  # the circle wraps
