"""Corner angles and edge lengths held inside the layout gates' bands while the flat quads
are smoothed.

The smoothing energy (:mod:`.untangle`) squares every corner towards 90° and so spreads any
excess evenly: the three corners at a valence-3 vertex settle at 120° each, half of them a
fraction of a degree over the gate's 60-120° (:mod:`.gates`), and a boundary vertex of three
panels at 60° each, half of them just under. Where a vertex's corners cannot all fit the band
(their sum, 360° inside or the boundary's angle on it, is more than ``corners x upper`` or
less than ``corners x lower``), the fewest corners that can take the excess within the hard
limits (45-135°) are chosen, the widest (or narrowest) ones first, and the rest are held in the
band: one corner of 122° and two of 119° in place of three of 120°. A quadratic penalty on
every corner outside its own limits is added to the smoothing energy.

Edge lengths get the same kind of penalty outside the gate's 0.5-1.25 x panel size: the
squaring alone leaves interior edges at 1.25-1.32 x where a size field changes quickly, and
holding the angles would otherwise be paid for in lengths.

Both are measured as the gates measure them, on the surface's chords: each corner carries the
linear map that takes its two flat edges to their chords on the surface at the start
(:func:`chord_metrics`), fixed while the nodes move a fraction of a panel. The conformal
flattening alone would keep angles and lengths only up to the curvature across a panel and the
change of its scale along an edge, several percent on a 1 m edge. The limits still carry a
margin (``MARGIN``, ``EDGE_MARGIN``) for what moving the nodes changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gates import (
    CORNER_GOOD,
    CORNER_LIMITS,
    EDGE_BAND,
    MIN_BAND_SHARE,
    MIN_EDGE,
    MIN_GOOD_CORNERS,
)
from .quality import corner_angles

#: degrees kept inside the gate's limits
MARGIN = 1.5
#: fraction of the panel size kept inside the gate's edge band
EDGE_MARGIN = 0.04
#: weights of the penalties (per radian² of a corner, per (panel size)² of an edge outside
#: its limits) against one corner's distortion energy (about 2.5 for a square corner)
WEIGHT = 4000.0
EDGE_WEIGHT = 4000.0
#: weight of a corner's excess beyond the gate's hard limits (45-135°), over that of its band:
#: a corner that has to leave the 60-120° band is otherwise pushed further by its neighbours
HARD_WEIGHT = 10.0 * WEIGHT


@dataclass(frozen=True)
class GateBand:
    """Per quad corner (in the order of ``quads.ravel()``), the lowest and highest angle the
    smoothing lets it take without a penalty, radians, (4m,) each; and the linear map
    ``metric`` (4m, 2, 2) that takes the corner's flat edges, in units of its reference size,
    to its chords on the surface in units of the panel size (:func:`chord_metrics`)."""

    lower: np.ndarray
    upper: np.ndarray
    metric: np.ndarray
    hard_lower: np.ndarray
    hard_upper: np.ndarray
    edge_lower: float = EDGE_BAND[0] + EDGE_MARGIN
    edge_upper: float = EDGE_BAND[1] - EDGE_MARGIN

    def energy(self, a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """The penalty on every corner's angle from its next edge ``a`` to its previous edge
        ``b`` (both (4m, 2), in units of the corner's reference size) and on the length of
        ``a`` (each side of a quad is one corner's next edge), both on the surface; and its
        derivatives by ``a`` and ``b``."""
        penalty, grad_a, grad_b = self._on_surface(
            np.einsum("kij,kj->ki", self.metric, a), np.einsum("kij,kj->ki", self.metric, b)
        )
        # through the fixed linear map: d/da = metric^T d/d(metric a)
        return (
            penalty,
            np.einsum("kji,kj->ki", self.metric, grad_a),
            np.einsum("kji,kj->ki", self.metric, grad_b),
        )

    def _on_surface(self, a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """The penalty of corners with edges ``a``, ``b`` on the surface, and its derivatives."""
        angle = interior_angles(a, b)
        over = np.maximum(angle - self.upper, 0.0)
        under = np.maximum(self.lower - angle, 0.0)
        hard_over = np.maximum(angle - self.hard_upper, 0.0)
        hard_under = np.maximum(self.hard_lower - angle, 0.0)
        d_angle = 2.0 * WEIGHT * (over - under) + 2.0 * HARD_WEIGHT * (hard_over - hard_under)
        da, db = angle_gradients(a, b)
        length = np.maximum(np.linalg.norm(a, axis=1), 1e-300)
        long = np.maximum(length - self.edge_upper, 0.0)
        short = np.maximum(self.edge_lower - length, 0.0)
        d_length = 2.0 * EDGE_WEIGHT * (long - short)
        penalty = (
            WEIGHT * (over**2 + under**2).sum()
            + HARD_WEIGHT * (hard_over**2 + hard_under**2).sum()
            + EDGE_WEIGHT * (long**2 + short**2).sum()
        )
        grad_a = d_angle[:, None] * da + (d_length / length)[:, None] * a
        return float(penalty), grad_a, d_angle[:, None] * db


def chord_metrics(
    flat: np.ndarray, on_surface: np.ndarray, quads: np.ndarray, reference: np.ndarray, size: float
) -> np.ndarray:
    """(4m, 2, 2): for every corner of the counter-clockwise flat ``quads``, the linear map
    that takes its two flat edges (``flat`` (n, 2) nodes, divided by the corner's
    ``reference`` size (4m,)) to two plane vectors with the lengths of their chords between
    the nodes ``on_surface`` (n, 3) and the angle between them, divided by ``size``. A
    folded or degenerate corner gets the mean scale of its edges instead."""
    centre = quads.ravel()
    nxt, prev = np.roll(quads, -1, axis=1).ravel(), np.roll(quads, 1, axis=1).ravel()
    a, b = flat[nxt] - flat[centre], flat[prev] - flat[centre]
    a3, b3 = on_surface[nxt] - on_surface[centre], on_surface[prev] - on_surface[centre]
    la, lb = np.linalg.norm(a3, axis=1), np.linalg.norm(b3, axis=1)
    cos = np.einsum("ki,ki->k", a3, b3) / np.maximum(la * lb, 1e-300)
    sin = np.sqrt(np.clip(1.0 - cos**2, 0.0, 1.0))
    target = np.stack([np.stack([la, lb * cos], 1), np.stack([np.zeros_like(la), lb * sin], 1)], 1)
    source = np.stack([np.stack([a[:, 0], b[:, 0]], 1), np.stack([a[:, 1], b[:, 1]], 1)], 1)
    det = source[:, 0, 0] * source[:, 1, 1] - source[:, 0, 1] * source[:, 1, 0]
    lengths = np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1)
    usable = (det > 1e-6 * lengths**2) & (sin > 1e-3)
    metric = np.empty((len(centre), 2, 2))
    metric[usable] = target[usable] @ np.linalg.inv(source[usable])
    mean_scale = (la + lb) / np.maximum(lengths, 1e-300)
    metric[~usable] = mean_scale[~usable, None, None] * np.eye(2)
    return metric * (reference / size)[:, None, None]


def interior_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k,) float: the counter-clockwise angle from edge ``a`` to edge ``b`` (both (k, 2)),
    in [0, 2π): a reflex corner is over π, never negative, so that its penalty pulls it back
    towards convex rather than further round."""
    angle = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1))
    return np.where(angle < 0.0, angle + 2.0 * np.pi, angle)


def angle_gradients(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Derivatives of the angle from edge ``a`` to edge ``b`` (both (k, 2)) by ``a`` and ``b``:
    the angle is the direction of ``b`` less that of ``a``, and a direction ``v`` changes by
    ``(-v_y, v_x) / |v|²``."""
    da = np.stack([a[:, 1], -a[:, 0]], axis=1) / np.maximum((a * a).sum(axis=1), 1e-300)[:, None]
    db = np.stack([-b[:, 1], b[:, 0]], axis=1) / np.maximum((b * b).sum(axis=1), 1e-300)[:, None]
    return da, db


def gate_band(
    flat: np.ndarray,
    on_surface: np.ndarray,
    quads: np.ndarray,
    reference: np.ndarray,
    size: float,
    sliding: np.ndarray | None = None,
    longest: float = np.inf,
) -> GateBand:
    """The limits of every corner of the counter-clockwise flat ``quads`` (see the module
    docstring), with the arguments of :func:`chord_metrics`; edges are held under ``longest``
    (mm) too where that is below the band's top: the plate's usable width, where panels a
    quarter over the panel size would not fit it (1.2 m panels on a 1.5 m plate), so that a
    layout that misses the plate is brought onto it without a smaller size everywhere. The
    one corner at a vertex of one panel gets none where that vertex is a corner of the outline
    (its angle is the outline's); where it slides along a smooth stretch (``sliding``, node
    ids; none by default) it gets the same limits as any other: on a rounded end (the tip of
    an ellipse, a lobe) its angle is made by where it and its neighbours sit, and left alone
    it opens to 140-165°."""
    metric = chord_metrics(flat, on_surface, quads, reference, size)
    angle = np.radians(corner_angles(on_surface[quads]).ravel())
    good = np.radians([CORNER_GOOD[0] + MARGIN, CORNER_GOOD[1] - MARGIN])
    hard = np.radians([CORNER_LIMITS[0] + MARGIN, CORNER_LIMITS[1] - MARGIN])
    lower = np.full(len(angle), good[0])
    upper = np.full(len(angle), good[1])
    centre = quads.ravel()
    total = np.bincount(centre, weights=angle, minlength=len(flat))
    count = np.bincount(centre, minlength=len(flat))
    for vertex in np.flatnonzero((total > count * good[1]) | (total < count * good[0])):
        corners = np.flatnonzero(centre == vertex)
        if total[vertex] > count[vertex] * good[1]:
            widest = corners[np.argsort(-angle[corners], kind="stable")]
            needed = _corners_to_sacrifice(total[vertex], len(corners), good[1], hard[1])
            upper[widest[:needed]] = hard[1]
        else:
            narrowest = corners[np.argsort(angle[corners], kind="stable")]
            needed = _corners_to_sacrifice(total[vertex], len(corners), good[0], hard[0])
            lower[narrowest[:needed]] = hard[0]
    hard_lower = np.full(len(angle), hard[0])
    hard_upper = np.full(len(angle), hard[1])
    on_smooth_outline = np.zeros(len(flat), dtype=bool)
    if sliding is not None:
        on_smooth_outline[sliding] = True
    loose = (count[centre] == 1) & ~on_smooth_outline[centre]
    for limit, value in (
        (lower, 0.0),
        (upper, 2.0 * np.pi),
        (hard_lower, 0.0),
        (hard_upper, 2.0 * np.pi),
    ):
        limit[loose] = value
    # (never below the band's bottom: a plate narrower than about 0.6 x the panel size is the
    # plate round's to meet, not this smoothing's)
    edge_upper = max(min(EDGE_BAND[1], longest / size), EDGE_BAND[0] + 0.25) - EDGE_MARGIN
    return GateBand(lower, upper, metric, hard_lower, hard_upper, edge_upper=edge_upper)


def _corners_to_sacrifice(total: float, corners: int, good: float, hard: float) -> int:
    """How many of a vertex's corners must leave the good band (up to ``hard``) for the
    corners to add up to ``total``; all of them where even that is not enough."""
    needed = int(np.ceil((total - corners * good) / (hard - good) - 1e-9))
    return int(np.clip(needed, 1, corners))


@dataclass(frozen=True)
class BandMeasures:
    """The part of :func:`.gates.layout_score` that smoothing changes (``score``: the shares
    of edges in the band and of corners in 60-120°, less 0.5 for an edge under 0.3 x the
    panel size and 0.5 for a corner outside 45-135°), and whether those gates all pass."""

    score: float
    passes: bool
    hard: int = 0  # corners outside 45-135° and edges under 0.3 x the panel size


def band_measures(vertices: np.ndarray, quads: np.ndarray, size: float) -> BandMeasures:
    """:class:`BandMeasures` of the quads on surface points ``vertices`` (n, 3), against the
    panel ``size``."""
    sides = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2), 1)
    edges = np.unique(sides, axis=0)
    relative = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1) / size
    angles = corner_angles(vertices[quads])
    in_band = float(np.mean((relative >= EDGE_BAND[0]) & (relative <= EDGE_BAND[1])))
    good = float(np.mean((angles >= CORNER_GOOD[0]) & (angles <= CORNER_GOOD[1])))
    shorts = int(np.count_nonzero(relative < MIN_EDGE))
    outsides = int(np.count_nonzero((angles < CORNER_LIMITS[0]) | (angles > CORNER_LIMITS[1])))
    short, outside = shorts > 0, outsides > 0
    return BandMeasures(
        score=in_band + good - 0.5 * short - 0.5 * outside,
        passes=in_band >= MIN_BAND_SHARE and good >= MIN_GOOD_CORNERS and not short and not outside,
        hard=shorts + outsides,
    )
