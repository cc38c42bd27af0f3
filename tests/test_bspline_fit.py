"""Plate outlines as cubics with the fewest poles (issue 18): a smooth chain is fitted within
the tolerance everywhere along it, with its ends kept; a kinked chain keeps the cubic through
every point; the edge made from a fit lies in its plate's plane."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.geom.bspline_fit import FIT_TOLERANCE, chord_parameters, fit_cubic


def _arc(radius: float, span: float, points: int) -> np.ndarray:
    """A rib's edge along a sheet of ``radius``: ``points`` stations over ``span`` mm."""
    x = np.linspace(-span / 2, span / 2, points)
    return np.c_[x, radius - np.sqrt(radius**2 - x**2)]


@pytest.mark.parametrize("radius", [12000.0, 4000.0, 1500.0])
def test_a_smooth_rib_edge_needs_few_poles_and_keeps_the_tolerance_between_them(radius):
    chain = _arc(radius, 1200.0, 65)
    fit = fit_cubic(chain)
    assert fit is not None
    assert len(fit.poles) <= 16  # against 65 for the cubic through every station
    # ends exact: the edge meets the plate's straight edges at the same vertices
    np.testing.assert_array_equal(fit.poles[[0, -1]], chain[[0, -1]])
    # within the tolerance of the true arc everywhere, not only at the stations
    dense = fit.evaluate(np.linspace(0.0, chord_parameters(chain)[-1], 5000))
    off = np.abs(np.linalg.norm(dense - [0.0, radius], axis=1) - radius)
    assert off.max() < FIT_TOLERANCE + 1e-4


def test_a_kinked_chain_keeps_the_cubic_through_every_point():
    # two sections crossing (a rib edge where the plate's two faces meet the sheet): 3 degrees
    x = np.linspace(0.0, 600.0, 61)
    chain = np.c_[x, np.where(x < 300.0, 0.0, (x - 300.0) * np.tan(np.radians(3.0)))]
    assert fit_cubic(chain) is None


def test_a_fitted_plate_outline_makes_a_valid_planar_plate():
    from fabpanel.model import occ

    chain = _arc(1500.0, 1000.0, 65)
    frame = np.eye(4)
    # a frame turned out of every coordinate plane, far from the origin, as a rib's
    frame[:3, :3] = np.linalg.qr(np.array([[1.0, 0.3, 0.2], [0.1, 1.0, 0.4], [0.3, 0.2, 1.0]]))[0]
    frame[:3, 3] = [6000.0, -2500.0, 3100.0]
    depth = 150.0
    chains = [
        chain,
        np.array([chain[-1], [500.0, depth]]),
        np.array([[500.0, depth], [-500.0, depth]]),
        np.array([[-500.0, depth], chain[0]]),
    ]
    solid = occ.prism(chains, frame, 8.0, "test rib")
    assert occ.check_valid(solid, "test rib") is None
    # the outline's area times the thickness, the area under the true arc exactly
    r, a = 1500.0, 500.0
    segment = 2 * a * r - (a * np.sqrt(r**2 - a**2) + r**2 * np.arcsin(a / r))
    assert occ.volume(solid) == pytest.approx(8.0 * (1000.0 * depth - segment), rel=1e-5)


def test_a_slot_has_a_joint_where_each_run_meets_a_round_and_a_circle_none():
    from fabpanel.fasteners import SLOT_CORNER, rounded_rectangle
    from fabpanel.geom.bspline_fit import joints

    slot = rounded_rectangle(22.0, -20.0, 45.0, SLOT_CORNER)
    found = joints(slot)
    assert len(found) == 8
    # each joint's neighbours: one on its round (turning), one on its run (straight)
    ahead = np.roll(slot, -1, axis=0) - slot
    behind = np.roll(ahead, 1, axis=0)
    straight = np.abs(ahead[:, 0] * behind[:, 1] - ahead[:, 1] * behind[:, 0]) < 1e-9
    assert all(straight[(i + 1) % len(slot)] or straight[i - 1] for i in found)
    angle = np.linspace(0.0, 2 * np.pi, 60, endpoint=False)
    assert not len(joints(np.c_[np.cos(angle), np.sin(angle)] * 20.0))


def _cylinder_grid(radius: float, n: int = 19, width: float = 1200.0) -> np.ndarray:
    angles, ys = np.meshgrid(
        np.linspace(0, width / radius, n), np.linspace(0, width, n), indexing="ij"
    )
    return np.stack([radius * np.sin(angles), ys, radius * np.cos(angles)], axis=-1)


def _exact_cylinder_distance(points: np.ndarray, radius: float) -> float:
    return float(np.abs(np.hypot(points[..., 0], points[..., 2]) - radius).max())


@pytest.mark.parametrize("radius", [4000.0, 1500.0])
def test_a_rolled_sheet_needs_few_poles_and_stays_on_its_cylinder(radius):
    """A sheet face's 19 x 19 grid on a cylinder: straight along the axis (4 poles), a few
    spans round it; on the exact cylinder within the tolerance at and between the grid
    points, its boundary rows exactly on the grid's."""
    from fabpanel.geom.bspline_fit import SURFACE_TOLERANCE, fit_grid

    grid = _cylinder_grid(radius)
    fit = fit_grid(grid)
    assert fit is not None
    assert fit.poles.shape[1] == 4 and fit.poles.shape[0] <= 11
    dense = np.linspace(0, 1, 97)
    assert _exact_cylinder_distance(fit.evaluate(dense, dense), radius) <= SURFACE_TOLERANCE
    np.testing.assert_allclose(fit.poles[[0, -1]][:, [0, -1]], grid[[0, -1]][:, [0, -1]])


def test_a_boundary_row_in_a_plane_gives_a_boundary_curve_in_it():
    """The trimmed sheet's rows lie in the rib planes: the fitted face's boundary curves must
    stay in them (to round-off), not just within the tolerance."""
    from fabpanel.geom.bspline_fit import fit_grid

    grid = _cylinder_grid(4000.0)
    # shear the grid so its v = 0 row lies in an oblique plane through the first row
    tilt = np.array([0.2, 0.0, 0.1])
    grid = grid + (grid[..., 1:2] / 1200.0) * tilt * 30.0
    normal = np.cross(grid[-1, 0] - grid[0, 0], [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    grid[:, 0] -= np.outer(grid[:, 0] @ normal - grid[0, 0] @ normal, normal)
    fit = fit_grid(grid, tolerance=0.05)
    assert fit is not None
    edge = fit.evaluate(np.linspace(0, 1, 200), np.array([0.0]))[:, 0]
    assert np.abs(edge @ normal - grid[0, 0] @ normal).max() < 1e-9


def test_a_noisy_grid_is_left_to_interpolation():
    """Points off a smooth surface by 0.01 mm (a faceted mesh's samples): no fit with fewer
    poles holds 0.001 mm, and None says so (the build then interpolates every point)."""
    from fabpanel.geom.bspline_fit import fit_grid

    grid = _cylinder_grid(4000.0) + np.random.default_rng(0).normal(0, 0.01, (19, 19, 3))
    assert fit_grid(grid) is None
