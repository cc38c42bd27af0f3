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
