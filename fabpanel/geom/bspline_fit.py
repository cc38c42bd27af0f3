"""Cubic B-splines with the fewest poles that hold a tolerance (issue 18: "no 2D/3D curve
approximated with more poles than its tolerance needs").

A plate's curved outline comes as a chain of points: a rib's edge along its sheet, sampled at
the developed grid's 33-65 stations, a stiffener's edges. A cubic *through* every point keeps
every point as a pole (a third of a STEP file's poles on the demo). A smooth chain is fitted
here in the least squares sense on a clamped knot vector that starts with one span and has
every span bisected that misses a point by more than the tolerance: a rib edge along a 4 m
radius needs 4-8 poles, not 65. The ends are kept exactly, so the edge meets its neighbours
at the same vertices.

Access openings keep their interpolating cubics (:func:`fabpanel.model.occ._hole_edges`): their
outlines are straight runs and 5 mm rounds whose points are already graded to the fewest a
cubic through them needs, and a least-squares cubic with simple knots cannot follow the jump
in curvature where a run meets a round (tried: more poles than points, or 6 mm off between
the points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

#: the largest distance a fitted curve may leave one of its points, mm (the plasma holds
#: +-0.5 mm; the model's edges and the cut file's points then agree far below that)
FIT_TOLERANCE = 0.001
#: bisection rounds: up to 2^8 spans from one
MAX_ROUNDS = 8
#: a fit needing more poles than this share of the points is not worth its risk: the chain
#: has a kink (a rib edge where two sections cross), and the cubic through every point is kept
MAX_POLE_SHARE = 0.5
DEGREE = 3


@dataclass(frozen=True)
class CubicFit:
    """A clamped cubic B-spline: ``knots`` (m + 1,) distinct, from 0 to the chain's length;
    ``poles`` (m + 3, d), the first and the last the chain's end points."""

    knots: np.ndarray
    poles: np.ndarray

    @property
    def multiplicities(self) -> np.ndarray:
        """The knots' multiplicities as OCCT takes them (the ends: degree + 1)."""
        mults = np.ones(len(self.knots), int)
        mults[[0, -1]] = DEGREE + 1
        return mults

    def evaluate(self, params: np.ndarray) -> np.ndarray:
        """The curve at ``params`` (n,): (n, d)."""
        return design_matrix(params, self.knots) @ self.poles


def chord_parameters(points: np.ndarray) -> np.ndarray:
    """(n,) float: the cumulative chord length of ``points`` (n, d), from 0."""
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]


def design_matrix(params: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(n, m + 3) float: the clamped cubic B-spline basis on ``knots`` at ``params``."""
    t = np.r_[[knots[0]] * DEGREE, knots, [knots[-1]] * DEGREE]
    x = np.clip(np.asarray(params, float), knots[0], knots[-1])
    return BSpline.design_matrix(x, t, DEGREE).toarray()


def fit_cubic(points: np.ndarray, tolerance: float = FIT_TOLERANCE) -> CubicFit | None:
    """The clamped cubic with the fewest knots found by bisection that passes within
    ``tolerance`` of every one of ``points`` (n, d), at their chord-length parameters, through
    the first and the last exactly. None where no fit with fewer poles than points holds it (a
    chain with a kink): the caller then interpolates every point."""
    points = np.asarray(points, float)
    params = chord_parameters(points)
    if len(points) < 5 or params[-1] <= 0:
        return None
    knots = np.array([0.0, params[-1]])
    for _ in range(MAX_ROUNDS + 1):
        basis = design_matrix(params, knots)
        if basis.shape[1] > MAX_POLE_SHARE * len(points):
            return None
        poles = _least_squares(basis, points)
        if poles is None:
            return None
        miss = np.linalg.norm(basis @ poles - points, axis=1)
        if miss.max() <= tolerance:
            fit = CubicFit(knots, poles)
            return fit if _follows_between(fit, params, points, tolerance) else None
        span = np.clip(np.searchsorted(knots, params, side="right") - 1, 0, len(knots) - 2)
        bad = np.unique(span[miss > tolerance])
        knots = np.sort(np.r_[knots, 0.5 * (knots[bad] + knots[bad + 1])])
    return None


def _follows_between(
    fit: CubicFit, params: np.ndarray, points: np.ndarray, tolerance: float
) -> bool:
    """Whether ``fit`` keeps within ``tolerance`` of the cubic through every point halfway
    between the points too (a least-squares cubic can swing between points it meets)."""
    middle = 0.5 * (params[1:] + params[:-1])
    through = make_interp_spline(params, points, k=DEGREE)(middle)
    return bool(np.linalg.norm(fit.evaluate(middle) - through, axis=1).max() <= tolerance)


def _least_squares(basis: np.ndarray, points: np.ndarray) -> np.ndarray | None:
    """The poles of the least-squares fit with the end poles on the end points; None where a
    span holds too few points to fix its poles."""
    inner = basis[:, 1:-1]
    rhs = points - np.outer(basis[:, 0], points[0]) - np.outer(basis[:, -1], points[-1])
    middle, _, rank, _ = np.linalg.lstsq(inner, rhs, rcond=None)
    if rank < inner.shape[1]:
        return None
    return np.vstack([points[:1], middle, points[-1:]])
