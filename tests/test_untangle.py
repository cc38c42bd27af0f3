"""Fold-free smoothing of planar quad meshes (Garanzha et al. 2021 barrier energy)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import unit_quad_grid
from scipy.optimize import check_grad

from fabpanel.panelize.untangle import _corners, _energy_and_gradient, corner_determinants, untangle


def test_gradient_matches_finite_differences():
    points, quads, movable = unit_quad_grid(3)
    points[movable] += np.random.default_rng(0).normal(0.0, 0.4, (movable.sum(), 2))
    args = (points, movable, _corners(quads), 1.3, 0.1)
    x = points[movable].ravel()
    error = check_grad(
        lambda v: _energy_and_gradient(v, *args)[0], lambda v: _energy_and_gradient(v, *args)[1], x
    )
    assert error < 1e-4 * np.linalg.norm(_energy_and_gradient(x, *args)[1])


def test_a_corner_folded_far_past_eps_keeps_a_finite_energy_and_gradient():
    # a line search's trial step can fold a corner far beyond the schedule's eps: (det +
    # sqrt(eps² + det²)) / 2 cancelled to 0 there (divide-by-zero warnings on a random blob)
    points, quads, movable = unit_quad_grid(3)
    folded = points.copy()
    folded[movable] = [[3.0e6, 2.0e6], [-1.0e6, 1.5e6], [2.0, -4.0e6], [1.0, 1.0]]
    with np.errstate(all="raise"):
        energy, gradient = _energy_and_gradient(
            folded[movable].ravel(), folded, movable, _corners(quads), 1.0, 1e-4
        )
    assert np.isfinite(energy) and energy > 1e12 and np.isfinite(gradient).all()
    # unfolded corners are as before: the energy at the grid itself is unchanged
    flat, _ = _energy_and_gradient(
        points[movable].ravel(), points, movable, _corners(quads), 1.0, 1e-4
    )
    assert flat == pytest.approx(36 * (2.0 + 0.25 * 2.0), rel=1e-6)


def test_badly_folded_grid_becomes_the_regular_grid():
    points, quads, movable = unit_quad_grid(6)
    tangled = points.copy()
    rng = np.random.default_rng(1)
    # throw the interior vertices about: many corners folded
    tangled[movable] = rng.uniform(0.0, 6.0, (movable.sum(), 2))
    assert (corner_determinants(tangled, quads) <= 0).sum() > 20
    out, info = untangle(tangled, quads, movable)
    assert info["folded_before"] > 20 and info["folded_after"] == 0
    assert (corner_determinants(out, quads) > 0).all()
    np.testing.assert_array_equal(out[~movable], points[~movable])  # boundary kept
    np.testing.assert_allclose(out, points, atol=1e-3)  # the unique optimum


def test_non_convex_domain_is_untangled():
    # an L-shaped block of quads whose interior starts collapsed onto one point
    points, quads, movable = unit_quad_grid(6)
    keep = ~((points[quads].mean(axis=1)[:, 0] > 3) & (points[quads].mean(axis=1)[:, 1] > 3))
    quads = quads[keep]
    used = np.unique(quads)
    sides = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], 2).reshape(-1, 2), axis=1)
    edges, counts = np.unique(sides, axis=0, return_counts=True)
    boundary = np.zeros(len(points), dtype=bool)
    boundary[edges[counts == 1].ravel()] = True
    movable = np.isin(np.arange(len(points)), used) & ~boundary
    tangled = points.copy()
    tangled[movable] = [4.5, 4.5]  # outside the domain, in the notch
    out, info = untangle(tangled, quads, movable)
    assert info["folded_after"] == 0
    assert (corner_determinants(out, quads) > 0).all()
