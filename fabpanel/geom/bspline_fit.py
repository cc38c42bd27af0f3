"""Cubic B-splines with the fewest poles that hold a tolerance (issue 18: "no 2D/3D curve
approximated with more poles than its tolerance needs").

A plate's curved outline comes as a chain of points: a rib's edge along its sheet, sampled at
the developed grid's 33-65 stations, a stiffener's edges. A cubic *through* every point keeps
every point as a pole (a quarter of the demo's STEP poles). A smooth chain is fitted here in
the least squares sense on a clamped knot vector that starts with one span and has every span
bisected that misses a point by more than the tolerance (:func:`fit_cubic`): a rib edge needs
4-7 poles, not 65. The ends are kept exactly, so the edge meets its neighbours at the same
vertices.

An access opening's outline (:func:`fit_loop`) is straight runs and 5 mm rounds, its points
graded to crowd where they meet, since a cubic with simple knots overshoots where the curvature
jumps (a least-squares one with simple knots needed more poles than points, or swung 6 mm off
between them). So the knots are double at those joints (:func:`joints`: the curve is only
tangent-continuous there, as the outline is) and the spans between are bisected: a slot's 50
points become 26 poles. The opening's edges on the sheet's two faces and their parameter-plane
images share the knots and parameters, so the ruled wall between the edges has the poles of one
curve twice, and each p-curve follows its 3D curve within twice the tolerance.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

#: the largest distance a fitted curve may leave one of its points, mm (the plasma holds
#: +-0.5 mm; the model's edges and the cut file's points then agree far below that)
FIT_TOLERANCE = 0.001
#: the same for an access opening's outline, mm: its cubic through every point left up to
#: 0.017 mm between the points of a slot's 5 mm rounds (tests/test_openings.py), and a 5 mm
#: round then needs two spans a quarter, not four
LOOP_TOLERANCE = 0.005
#: an outline no fit holds to LOOP_TOLERANCE (two slots merged into one opening: concave
#: fillets between rounds, unevenly spaced points) is fitted to this, mm, before every point is
#: interpolated: its points stand for the exact union of the two slots only within 0.07 mm
#: anyway (tests/test_openings.py), and the demo's 324 merged openings went from 126 poles a
#: loop to 48 (4.5 MB of its STEP file)
LOOSE_LOOP_TOLERANCE = 0.02
#: bisection rounds: up to 2^8 spans from one
MAX_ROUNDS = 8
#: a fit needing more poles than this share of the points is not worth its risk: the chain
#: has a kink (a rib edge where two sections cross), and the cubic through every point is kept
MAX_POLE_SHARE = 0.5
#: an opening's outline has its points graded already (crowded where runs meet rounds): a fit
#: of its joints and spans may keep up to this share of them (a slot's 50 points: 26 poles);
#: its swings between the points are checked against the chords
LOOP_POLE_SHARE = 0.75
#: a closed outline turns at least this much (radians) where a straight run meets a round:
#: half a chord's 22.5 degrees on a slot's 5 mm round, where a run's 8 mm steps turn by 0.1-1.4
#: degrees, the slot's prism cutting a curved sheet at a slant
JOINT_TURN = np.radians(5.0)
DEGREE = 3


#: the largest distance a sheet face fitted with fewer poles may leave its point grid (and the
#: cubic through the grid between its points), mm: half of it for each parameter direction
SURFACE_TOLERANCE = 0.001
#: a sheet face's grid is smooth (sampled on the developed surface): a fit may keep up to
#: this share of its points each way (a 1.2 m sheet rolled to 1.5 m: 13 of 19)
SURFACE_POLE_SHARE = 0.75


@dataclass(frozen=True)
class CubicFit:
    """A clamped cubic B-spline: ``knots`` (m + 1,) distinct, from 0 to the chain's length,
    ``multiplicities`` (m + 1,) as OCCT takes them (the ends degree + 1; 2 at a joint where the
    curvature may jump); ``poles`` (p, d), the first and the last on the chain's end points
    (one per fitted set in ``more``, on the same knots)."""

    knots: np.ndarray
    multiplicities: np.ndarray
    poles: np.ndarray
    more: tuple[np.ndarray, ...] = ()

    def evaluate(self, params: np.ndarray, which: int = 0) -> np.ndarray:
        """Curve ``which`` (0: ``poles``, 1...: ``more``) at ``params`` (n,): (n, d)."""
        poles = self.poles if which == 0 else self.more[which - 1]
        return design_matrix(params, self.knots, self.multiplicities) @ poles


def chord_parameters(points: np.ndarray) -> np.ndarray:
    """(n,) float: the cumulative chord length of ``points`` (n, d), from 0."""
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]


def design_matrix(params: np.ndarray, knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """(n, p) float: the clamped cubic B-spline basis on ``knots`` of multiplicities ``mults``
    at ``params``."""
    t = np.repeat(knots, mults)
    x = np.clip(np.asarray(params, float), knots[0], knots[-1])
    return BSpline.design_matrix(x, t, DEGREE).toarray()


def _clamped(knots: np.ndarray, inner: int = 1) -> np.ndarray:
    """Multiplicities of a clamped knot vector: the ends degree + 1, the others ``inner``."""
    mults = np.full(len(knots), inner)
    mults[[0, -1]] = DEGREE + 1
    return mults


def fit_cubic(points: np.ndarray, tolerance: float = FIT_TOLERANCE) -> CubicFit | None:
    """The clamped cubic with the fewest knots found by bisection that passes within
    ``tolerance`` of every one of ``points`` (n, d), at their chord-length parameters, through
    the first and the last exactly. None where no fit with fewer poles than points holds it (a
    chain with a kink): the caller then interpolates every point."""
    points = np.asarray(points, float)
    params = chord_parameters(points)
    if len(points) < 5 or np.diff(params).min() <= 0:  # too few, or repeated points
        return None
    knots = np.array([0.0, params[-1]])
    found = _refined(points, params, knots, _clamped(knots), np.ones_like(points), tolerance)
    if found is None:
        return None
    knots, mults, poles = found
    fit = CubicFit(knots, mults, poles)
    return fit if _follows_between(fit, params, points, tolerance) else None


def fit_loop(
    sets: list[np.ndarray],
    steps: np.ndarray,
    scales: list[np.ndarray],
    tolerance: float = LOOP_TOLERANCE,
) -> CubicFit | None:
    """One knot vector for several closed loops of points, point ``i`` of each on one line
    (each (n, d), not closed): the first loop's points in mm, the others scaled to mm by
    ``scales`` (each (n, d)); ``steps`` (n,) the parameter step from each point to the next
    (the last back to the first). The curves start at a joint of the first loop's runs and
    rounds (:func:`joints`); there and at its other joints the knots are double, so the
    curvature may jump as the outline's does; the spans between are bisected while a point is
    missed. The curves start and end on that point exactly (closed, tangent-continuous there
    to the tolerance). None where the first loop has no joint or no fit with at most
    :data:`LOOP_POLE_SHARE` of the points holds the tolerance."""
    found = joints(sets[0])
    if not len(found):
        return None
    start = int(found[0])

    def closed(a: np.ndarray) -> np.ndarray:
        a = np.roll(a, -start, axis=0)
        return np.vstack([a, a[:1]])

    params = np.r_[0.0, np.cumsum(np.roll(steps, -start))]
    values = np.concatenate([closed(a) for a in sets], axis=1)
    scale = np.concatenate([closed(a) for a in scales], axis=1)
    widths = np.cumsum([0] + [a.shape[1] for a in sets])
    inner = np.sort((found - start) % len(steps))[1:]
    knots = np.r_[0.0, params[inner], params[-1]]
    fitted = _refined(
        values, params, knots, _clamped(knots, 2), scale, tolerance, widths, LOOP_POLE_SHARE
    )
    if fitted is None:
        return None
    knots, mults, poles = fitted
    split = [poles[:, a:b] for a, b in itertools.pairwise(widths)]
    fit = CubicFit(knots, mults, split[0], tuple(split[1:]))
    # the 3D curves on both faces between their points (a p-curve that swung would show in
    # its own face's curve: they follow the same points at the same parameters)
    keeps = all(_keeps_to_chords(fit, params, closed(sets[k]), tolerance, k) for k in (0, 1))
    return fit if keeps else None


@dataclass(frozen=True)
class SurfaceFit:
    """A clamped bicubic B-spline surface over the unit square: ``u`` and ``v`` the knot
    vectors of its two directions (as :class:`CubicFit`s without poles of their own),
    ``poles`` (a, b, 3), mm."""

    u: CubicFit
    v: CubicFit
    poles: np.ndarray

    def evaluate(self, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
        """The surface on the grid ``us (a,)`` x ``vs (b,)``: (a, b, 3)."""
        bu = design_matrix(us, self.u.knots, self.u.multiplicities)
        bv = design_matrix(vs, self.v.knots, self.v.multiplicities)
        return np.einsum("ia,abd,jb->ijd", bu, self.poles, bv)


def fit_grid(grid: np.ndarray, tolerance: float = SURFACE_TOLERANCE) -> SurfaceFit | None:
    """The bicubic with the fewest knots found by bisection within ``tolerance`` of every point
    of ``grid`` (n, m, 3), ``grid[i, j]`` at ``(i / (n - 1), j / (n - 1))``, and of the bicubic
    through every point halfway between them. The surface's four boundary curves are fitted to
    the grid's four boundary rows alone (the end poles of every row and column on its end
    points), so a boundary row lying in a plane gives a boundary curve in that plane (a
    least-squares fit keeps the partition of unity's affine invariance). Fitted first along
    ``u`` (every column at once, to half the tolerance), then its pole rows along ``v`` (the
    other half: the surface leaves the first fit by no more than its poles do). None where
    no fit with at most :data:`SURFACE_POLE_SHARE` of the points each way holds (the caller then
    interpolates every point)."""
    grid = np.asarray(grid, float)
    n, m = grid.shape[:2]
    if min(n, m) < 5:
        return None
    us, vs = np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, m)
    along_u = _one_direction(grid.reshape(n, m * 3), us, m, 0.5 * tolerance)
    if along_u is None:
        return None
    (u_knots, u_mults), rows = along_u
    a = rows.shape[0]
    middle = rows.reshape(a, m, 3).transpose(1, 0, 2).reshape(m, a * 3)
    along_v = _one_direction(middle, vs, a, 0.5 * tolerance)
    if along_v is None:
        return None
    (v_knots, v_mults), columns = along_v
    poles = columns.reshape(-1, a, 3).transpose(1, 0, 2)
    empty = np.zeros((0, 3))
    fit = SurfaceFit(CubicFit(u_knots, u_mults, empty), CubicFit(v_knots, v_mults, empty), poles)
    if np.linalg.norm(fit.evaluate(us, vs) - grid, axis=2).max() > tolerance:
        return None
    # between the points: against the bicubic through them (a least-squares one can swing)
    half_u, half_v = 0.5 * (us[1:] + us[:-1]), 0.5 * (vs[1:] + vs[:-1])
    through = make_interp_spline(
        vs, make_interp_spline(us, grid, k=DEGREE)(half_u), k=DEGREE, axis=1
    )
    if np.linalg.norm(fit.evaluate(half_u, half_v) - through(half_v), axis=2).max() > tolerance:
        return None
    return fit


def _one_direction(
    values: np.ndarray, params: np.ndarray, sets: int, tolerance: float
) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray] | None:
    """``values`` (n, 3 sets) fitted along their rows, every set of 3 columns a curve of one
    knot vector: ((knots, mults), poles (p, 3 sets)), or None."""
    knots = np.array([0.0, 1.0])
    widths = 3 * np.arange(sets + 1)
    found = _refined(
        values,
        params,
        knots,
        _clamped(knots),
        np.ones_like(values),
        tolerance,
        widths,
        SURFACE_POLE_SHARE,
    )
    if found is None:
        return None
    knots, mults, poles = found
    return (knots, mults), poles


def joints(loop: np.ndarray) -> np.ndarray:
    """Indices of the points of a closed ``loop`` (n, d) where a straight run meets a round:
    the loop turns there by at least :data:`JOINT_TURN`, and at one of its neighbours by less
    than a quarter as much (a round's chords turn alike, a run's points hardly at all; at the
    joint itself by half a chord's angle)."""
    ahead = np.roll(loop, -1, axis=0) - loop
    behind = loop - np.roll(loop, 1, axis=0)
    cos = np.einsum("ij,ij->i", ahead, behind) / np.maximum(
        np.linalg.norm(ahead, axis=1) * np.linalg.norm(behind, axis=1), 1e-300
    )
    turn = np.arccos(np.clip(cos, -1.0, 1.0))
    calmer = np.minimum(np.roll(turn, 1), np.roll(turn, -1))
    return np.flatnonzero((turn >= JOINT_TURN) & (calmer < 0.25 * turn))


def _refined(
    values: np.ndarray,
    params: np.ndarray,
    knots: np.ndarray,
    mults: np.ndarray,
    scale: np.ndarray,
    tolerance: float,
    widths: np.ndarray | None = None,
    share: float = MAX_POLE_SHARE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Bisect the spans of ``knots`` that miss a point of ``values`` at ``params`` by more
    than ``tolerance`` (residuals times ``scale``, a point's miss the largest of its sets'
    ``widths`` column groups) until none does: ``(knots, mults, poles)``, or None."""
    widths = np.array([0, values.shape[1]]) if widths is None else widths
    for _ in range(MAX_ROUNDS + 1):
        basis = design_matrix(params, knots, mults)
        if basis.shape[1] > share * len(values):
            return None
        poles = _least_squares(basis, values)
        if poles is None:
            return None
        residual = (basis @ poles - values) * scale
        miss = np.max(
            [np.linalg.norm(residual[:, a:b], axis=1) for a, b in itertools.pairwise(widths)],
            axis=0,
        )
        if miss.max() <= tolerance:
            return knots, mults, poles
        span = np.clip(np.searchsorted(knots, params, side="right") - 1, 0, len(knots) - 2)
        bad = np.unique(span[miss > tolerance])
        middles = 0.5 * (knots[bad] + knots[bad + 1])
        order = np.argsort(np.r_[knots, middles], kind="stable")
        knots = np.r_[knots, middles][order]
        mults = np.r_[mults, np.ones(len(middles), int)][order]
    return None


def _keeps_to_chords(
    fit: CubicFit, params: np.ndarray, points: np.ndarray, tolerance: float, which: int = 0
) -> bool:
    """Whether ``fit``'s curve ``which`` stays near each chord of ``points`` halfway along it: within the
    tolerance and the sagitta a curve turning as the points do there would have (a
    least-squares cubic can swing between points it meets)."""
    middle = 0.5 * (params[1:] + params[:-1])
    chord = np.diff(points, axis=0)
    length = np.linalg.norm(chord, axis=1)
    ahead = np.r_[chord[1:], chord[:1]]
    cos = np.einsum("ij,ij->i", chord, ahead) / np.maximum(
        length * np.linalg.norm(ahead, axis=1), 1e-300
    )
    turn = np.arccos(np.clip(cos, -1.0, 1.0))
    turn = np.maximum(turn, np.roll(turn, 1))  # at either end of the chord
    sagitta = length * turn / 4.0  # twice chord * angle / 8
    off = np.linalg.norm(fit.evaluate(middle, which) - 0.5 * (points[1:] + points[:-1]), axis=1)
    return bool((off <= sagitta + tolerance).all())


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
