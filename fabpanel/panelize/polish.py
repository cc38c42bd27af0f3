"""The last touch on a layout: each vertex nudged, on the surface, where that brings more of
its panels' corners and sides inside the layout gates' bands.

The smoothing before it (:mod:`.untangle`, :mod:`.gate_band`) works in the flat domain, with
each corner's chord metric frozen at the start and a margin for what moving the nodes changes;
its penalties are quadratic, so a corner pushed against a limit settles a little past it. What
is left are corners a degree or two outside 60-120° and sides a few percent outside 0.5-1.25 x
the panel size, mostly at singular vertices: the three corners of a valence-3 vertex add up to
about 360°, and the smoothing, told to keep each under 118.5°, gives up one of them to 133°
where 119.8° each would do. Measured on the surface itself, with the gates' own limits, a
vertex moved by a few centimetres often brings them all in.

Each vertex whose panels fail a band is tried at ``DIRECTIONS`` directions times the
``STEPS`` distances: an interior vertex in its tangent plane and projected back onto the
surface, a boundary vertex along the design boundary (never over a kink of it, and never one
that only one panel touches: that is a corner of the layout). A move is kept only where it
makes its panels strictly better, judged in this order: the hard limits (corners outside
45-135°, sides under 0.3 x the panel size, folded panels, panels narrower than the gate's
``min_panel_width`` or missing the stock plate) and how far outside them, then the corners and
sides outside the bands and how far outside they are; no corner or side already past a hard
limit may go further, and no kind of failure (corners or sides past the hard limits or outside
the bands, panels folded, narrow or off the plate) may grow in number for another's sake. So no gate gets worse, and the sweeps stop when no vertex moves
(at most ``SWEEPS``). The vertices are visited in index order, and the result is the same from
run to run.

Measured on the seeded random shapes of ``benchmarks/random_shapes.py`` at 1 m (field
layouts): corners in 60-120° from 94.8 to 96.0 % (seed 10), 92.1 to 95.2 % (23), 93.6 to 97.1 %
(6), moving 20-70 vertices by up to 0.17 m, in 0.1-0.3 s; 1000-panel layouts in 0.2-0.3 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..job import Job
from ..surface import SurfaceQuery
from ..surface.design_boundary import DesignBoundary
from .gates import CORNER_GOOD, CORNER_LIMITS, EDGE_BAND, MIN_EDGE, min_panel_width, panel_widths
from .quality import corner_angles, panel_extents, vertex_valences

#: distances tried, x the panel size
STEPS = (0.005, 0.01, 0.02, 0.04, 0.08)
#: directions tried at each distance (an interior vertex; a boundary vertex goes both ways)
DIRECTIONS = 12
#: at most this many passes over the vertices
SWEEPS = 12
#: a layout with more than this share of its panels outside the bands is not polished:
#: its panels are far from the asked size (a subdivided grid, a size the mesher could not
#: meet), and nudging five thousand of them by a few centimetres took 45 s and helped none
MOSTLY_FAILING = 0.8
_SKIPPED = f"more than {MOSTLY_FAILING:.0%} of the panels outside the bands"
#: degrees, and fraction of the panel size, kept inside the bands' limits
ANGLE_MARGIN = 0.05
EDGE_MARGIN = 0.001
#: a quad whose corners add up to less than this (degrees) is folded or has a reflex corner
#: (the four corners of a warped 1 m panel on a curved surface add up to 359.x°)
FOLDED_SUM = 350.0
#: degrees: where the design boundary turns more than this between two of its points, it has
#: a kink that a boundary vertex stays on and does not slide over
KINK_TURN = 15.0
#: mm: a boundary vertex farther than this from the design boundary stays where it is
ON_BOUNDARY = 1.0


@dataclass(frozen=True)
class PolishLimits:
    """What a moved vertex must keep: the panel ``size`` (mm) that the bands are relative
    to, the stock plate's usable ``plate`` (long, short) sides and the gate's narrowest panel
    ``min_width``, mm."""

    size: float
    plate: tuple[float, float]
    min_width: float

    @classmethod
    def of(cls, job: Job) -> PolishLimits:
        """The limits of ``job``: its panel size, plate and narrowest panel."""
        from ..buildup import Buildup

        long, short = Buildup.of(job).usable_plate
        return cls(job.panelize.panel_size, (long, short), min_panel_width(job))


def polish_layout(
    vertices: np.ndarray,
    quads: np.ndarray,
    query: SurfaceQuery,
    boundary: DesignBoundary,
    limits: PolishLimits,
    fixed: np.ndarray,
) -> tuple[np.ndarray, dict]:
    """The layout's ``vertices`` (n, 3) moved as the module docstring says, with ``fixed``
    (n,) bool ones left where they are; and a JSON-ready report (vertices moved, sweeps,
    the largest move in mm).

    Vertices are tried in batches of one colour: no two of a colour share a panel, so each
    one's trials change only its own panels, and a batch gives what one vertex after the
    other would."""
    vertices = vertices.copy()
    failing = float(np.mean(_quad_failures(vertices[quads], limits))) if len(quads) else 0.0
    if failing > MOSTLY_FAILING:
        return vertices, {"vertices_moved": 0, "sweeps": 0, "skipped": _SKIPPED}
    original = vertices.copy()
    incident = _incident_quads(quads, len(vertices))
    colours = _colours(incident, quads)
    track = _BoundaryTrack.of(vertices, quads, boundary, fixed)
    movable = ~fixed & ~track.stays
    sweeps = 0
    for sweep in range(SWEEPS):
        candidates = np.flatnonzero(movable & _touches_a_failing_panel(vertices, quads, limits))
        if not len(candidates):
            break
        sweeps = sweep + 1
        trials, valid = _trial_positions(vertices, candidates, query, track, limits.size)
        moved = False
        for colour in np.unique(colours[candidates]):
            batch = colours[candidates] == colour
            ids = candidates[batch]
            best = _best_trials(
                vertices, quads, incident[ids], ids, trials[batch], valid[batch], limits
            )
            chosen = np.flatnonzero(best >= 0)
            if not len(chosen):
                continue
            # interior trials were taken in the tangent plane: the chosen ones are put on
            # the surface and must still be better there
            final = trials[batch][chosen, best[chosen]]
            inner = ~track.on[ids[chosen]]
            if inner.any():
                final[inner] = query.closest(final[inner])[0]
            kept = (
                _best_trials(
                    vertices,
                    quads,
                    incident[ids[chosen]],
                    ids[chosen],
                    final[:, None],
                    np.ones((len(chosen), 1), bool),
                    limits,
                )
                == 0
            )
            vertices[ids[chosen][kept]] = final[kept]
            moved |= bool(kept.any())
        if not moved:
            break
    shift = np.linalg.norm(vertices - original, axis=1)
    return vertices, {
        "vertices_moved": int(np.count_nonzero(shift > 0)),
        "sweeps": sweeps,
        "largest_move_mm": round(float(shift.max()) if len(shift) else 0.0, 1),
    }


def _incident_quads(quads: np.ndarray, count: int) -> np.ndarray:
    """(n, k) int: per vertex, the ids of the quads that have it as a corner, padded with -1
    to the largest count."""
    flat = quads.ravel()
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], np.arange(count + 1))
    per_vertex = np.diff(starts)
    table = np.full((count, max(int(per_vertex.max(initial=0)), 1)), -1)
    rank = np.arange(len(flat)) - np.repeat(starts[:-1], per_vertex)
    table[flat[order], rank] = order // 4
    return table


def _colours(incident: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(n,) int: a colour per vertex such that no two vertices of one panel share one
    (greedy, in vertex order)."""
    colours = np.full(len(incident), -1)
    for vertex, around in enumerate(incident):
        taken = colours[quads[around[around >= 0]].ravel()]
        free = np.setdiff1d(np.arange(len(taken) + 1), taken)
        colours[vertex] = free[0]
    return colours


def _touches_a_failing_panel(
    vertices: np.ndarray, quads: np.ndarray, limits: PolishLimits
) -> np.ndarray:
    """(n,) bool: the vertices of every quad with a corner or a side outside the bands."""
    failing = _quad_failures(vertices[quads], limits)
    touched = np.zeros(len(vertices), dtype=bool)
    touched[quads[failing].ravel()] = True
    return touched


def _quad_failures(corners: np.ndarray, limits: PolishLimits) -> np.ndarray:
    """(m,) bool: quads (corners (m, 4, 3)) with any corner or side outside the bands."""
    angles = corner_angles(corners)
    sides = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=2) / limits.size
    return (_outside_angle_band(angles) | _outside_edge_band(sides)).any(axis=1)


def _outside_angle_band(angles: np.ndarray) -> np.ndarray:
    return (angles < CORNER_GOOD[0] + ANGLE_MARGIN) | (angles > CORNER_GOOD[1] - ANGLE_MARGIN)


def _outside_edge_band(sides: np.ndarray) -> np.ndarray:
    return (sides < EDGE_BAND[0] + EDGE_MARGIN) | (sides > EDGE_BAND[1] - EDGE_MARGIN)


def _failures(
    corners: np.ndarray, limits: PolishLimits
) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """For each trial (corners (t, k, 4, 3), the k quads round one vertex), each (t,): in
    the order they are judged, the count of hard failures, how far outside the hard limits
    they are, the count of band failures, and how far outside the bands it is (degrees² and
    (percent of the panel size)²); (t, 8k) how far each corner and side is past a hard limit;
    and (5, t) the failures by kind: corners and sides past the hard limits, panels folded,
    narrow or off the plate, corners and sides outside the bands."""
    t, k = corners.shape[:2]
    flat = corners.reshape(t * k, 4, 3)
    angles = corner_angles(flat).reshape(t, k, 4)
    sides = np.linalg.norm(np.roll(flat, -1, axis=1) - flat, axis=2).reshape(t, k, 4) / limits.size
    extents = np.sort(panel_extents(flat), axis=1)[:, ::-1].reshape(t, k, 2)
    oversize = ~np.all(extents <= np.asarray(limits.plate), axis=2)
    narrow = panel_widths(flat).reshape(t, k) < limits.min_width
    folded = angles.sum(axis=2) < FOLDED_SUM
    kinds = np.stack(
        [
            ((angles < CORNER_LIMITS[0]) | (angles > CORNER_LIMITS[1])).sum(axis=(1, 2)),
            (sides < MIN_EDGE).sum(axis=(1, 2)),
            (oversize | narrow | folded).sum(axis=1),
            _outside_angle_band(angles).sum(axis=(1, 2)),
            _outside_edge_band(sides).sum(axis=(1, 2)),
        ]
    )
    hard, band = kinds[:3].sum(axis=0), kinds[3:].sum(axis=0)
    over = np.maximum(angles - (CORNER_GOOD[1] - ANGLE_MARGIN), 0.0)
    under = np.maximum(CORNER_GOOD[0] + ANGLE_MARGIN - angles, 0.0)
    long = np.maximum(sides - (EDGE_BAND[1] - EDGE_MARGIN), 0.0) * 100.0
    short = np.maximum(EDGE_BAND[0] + EDGE_MARGIN - sides, 0.0) * 100.0
    excess = (over**2 + under**2 + long**2 + short**2).sum(axis=(1, 2))
    past = _past_hard_limits(angles, sides)
    keys = (hard.astype(float), past.sum(axis=1), band.astype(float), excess)
    return keys, past, kinds


def _past_hard_limits(angles: np.ndarray, sides: np.ndarray) -> np.ndarray:
    """(t, 8k): how far each of the trials' corners and sides is past the hard limits
    (degrees, percent of the panel size)."""
    wide = np.maximum(angles - CORNER_LIMITS[1], 0.0) + np.maximum(CORNER_LIMITS[0] - angles, 0.0)
    short = np.maximum(MIN_EDGE - sides, 0.0) * 100.0
    return np.concatenate([wide, short], axis=2).reshape(len(angles), -1)


def _best_trials(
    vertices: np.ndarray,
    quads: np.ndarray,
    around: np.ndarray,
    batch: np.ndarray,
    positions: np.ndarray,
    valid: np.ndarray,
    limits: PolishLimits,
) -> np.ndarray:
    """(b,) int: for each vertex of ``batch`` (no two on one panel), with its quads
    ``around`` (b, k) (padded with -1), the best of its ``positions`` (b, p, 3) (where
    ``valid`` (b, p)) if that is strictly better for its panels than where it is, else -1.

    A vertex with fewer panels than the most has its rows padded with a square panel of the
    panel size away from it, the same in every trial, so it changes no comparison."""
    local = quads[np.maximum(around, 0)]  # (b, k, 4)
    corners = vertices[local]
    size = limits.size
    corners[around < 0] = [[0.0, 0.0, 0.0], [size, 0.0, 0.0], [size, size, 0.0], [0.0, size, 0.0]]
    count, trials = len(batch), positions.shape[1] + 1
    trial = np.repeat(corners[:, None], trials, axis=1)  # (b, p + 1, k, 4, 3)
    at = (local == batch[:, None, None]) & (around >= 0)[:, :, None]  # (b, k, 4)
    moved_corner = np.broadcast_to(at[:, None], trial.shape[:-1]).copy()
    moved_corner[:, 0] = False
    trial[moved_corner] = np.broadcast_to(
        np.concatenate([positions[:, :1], positions], axis=1)[:, :, None, None, :],
        trial.shape,
    )[moved_corner]
    keys, past, kinds = _failures(trial.reshape(count * trials, *trial.shape[2:]), limits)
    keys = tuple(key.reshape(count, trials) for key in keys)
    past = past.reshape(count, trials, -1)
    kinds = kinds.reshape(len(kinds), count, trials)
    # no corner or side already past a hard limit goes further, whatever else improves; no
    # kind of failure grows in number for another's sake (a layout whose corners passed could
    # fail them for sides that still fail: the pavilion's skeleton went from 100 to 84 % of
    # corners in 60-120° that way, and a 153° corner closed by a side shortened to 0.18 x);
    # a trial off the boundary's stretch is no trial
    now = past[:, :1]
    barred = (
        ((now > 0) & (past > now)).any(axis=2)
        | (kinds > kinds[:, :, :1]).any(axis=0)
        | ~np.concatenate([np.ones((count, 1), bool), valid], 1)
    )
    hard = np.where(barred, np.inf, keys[0])
    rows = np.repeat(np.arange(count), trials)
    order = np.lexsort((*(key.ravel() for key in keys[:0:-1]), hard.ravel(), rows))
    best = order[np.searchsorted(rows[order], np.arange(count))] % trials
    pick = np.arange(count)
    better = _lexicographically_less(
        (hard[pick, best], *(key[pick, best] for key in keys[1:])),
        tuple(key[:, 0] for key in keys),
    )
    return np.where(better & (best > 0), best - 1, -1)


def _lexicographically_less(a: tuple[np.ndarray, ...], b: tuple[np.ndarray, ...]) -> np.ndarray:
    """(b,) bool: element-wise, whether the tuple of keys ``a`` sorts before ``b``."""
    less = np.zeros(len(a[0]), dtype=bool)
    tied = np.ones(len(a[0]), dtype=bool)
    for x, y in zip(a, b):
        less |= tied & (x < y)
        tied &= x == y
    return less


def _trial_positions(
    vertices: np.ndarray,
    candidates: np.ndarray,
    query: SurfaceQuery,
    track: _BoundaryTrack,
    size: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Per candidate vertex, the positions it is tried at (c, p, 3), and which are trials
    (c, p): in the tangent plane round an interior vertex (a panel's chord angles change by
    hundredths of a degree when the one chosen is put on the surface, and hundreds of
    thousands of closest points would cost a minute at five thousand panels), along the
    design boundary from a boundary one (fewer, and none past a kink)."""
    steps = np.asarray(STEPS) * size
    per = len(steps) * DIRECTIONS
    trials = np.repeat(vertices[candidates][:, None], per, axis=1)
    valid = np.zeros((len(candidates), per), dtype=bool)
    on = track.on[candidates]
    inner = candidates[~on]
    if len(inner):
        _, normals, _ = query.closest(vertices[inner])
        u, v = _tangent_frames(normals)
        turn = np.linspace(0.0, 2.0 * np.pi, DIRECTIONS, endpoint=False)
        ring = np.cos(turn)[:, None, None] * u[None] + np.sin(turn)[:, None, None] * v[None]
        offsets = steps[:, None, None, None] * ring[None]  # (steps, directions, c, 3)
        points = vertices[inner][None, None] + offsets
        trials[~on] = np.moveaxis(points, 2, 0).reshape(len(inner), per, 3)
        valid[~on] = True
    for row in np.flatnonzero(on):
        slid, ok = track.slides(int(candidates[row]), steps)
        trials[row, : len(slid)] = slid
        valid[row, : len(slid)] = ok
    return trials, valid


def _tangent_frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors square to each normal (c, 3) and to each other."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(normals, u)


@dataclass(frozen=True)
class _BoundaryTrack:
    """The layout's boundary vertices on the design boundary: which ones are on it (``on``),
    which stay (``stays``: corners of the layout, vertices on a kink or off the boundary), each
    one's loop and arc length, and the arc lengths of each loop's kinks."""

    boundary: DesignBoundary
    on: np.ndarray
    stays: np.ndarray
    loop: np.ndarray
    s: np.ndarray
    kinks: tuple[np.ndarray, ...]

    @classmethod
    def of(
        cls, vertices: np.ndarray, quads: np.ndarray, boundary: DesignBoundary, fixed: np.ndarray
    ) -> _BoundaryTrack:
        _, on = vertex_valences(quads, len(vertices))
        loop = np.full(len(vertices), -1)
        s = np.zeros(len(vertices))
        stays = on & (np.bincount(quads.ravel(), minlength=len(vertices)) == 1)
        kinks = tuple(_kinks(boundary, i) for i in range(len(boundary.loops)))
        ids = np.flatnonzero(on)
        if len(ids) and len(boundary.loops):
            _, distance, loop[ids], s[ids] = boundary.locate(vertices[ids])
            stays[ids[distance > ON_BOUNDARY]] = True
            for vertex in ids:
                near = _gap(kinks[loop[vertex]], s[vertex], boundary.loop_length[loop[vertex]])
                if len(near) and near.min() <= ON_BOUNDARY:
                    stays[vertex] = True
        else:
            stays |= on
        return cls(boundary, on, stays | fixed, loop, s, kinks)

    def slides(self, vertex: int, steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points along the design boundary ``steps`` (mm) either way from ``vertex``, and
        which of them lie before the first kink."""
        loop, s = int(self.loop[vertex]), float(self.s[vertex])
        total = float(self.boundary.loop_length[loop])
        shifts = np.concatenate([steps, -steps])
        ok = np.ones(len(shifts), dtype=bool)
        kinks = self.kinks[loop]
        if len(kinks):
            ahead = (kinks - s) % total
            behind = (s - kinks) % total
            ok = (shifts < ahead.min()) & (-shifts < behind.min())
        return self.boundary.at(loop, (s + shifts) % total), ok


def _kinks(boundary: DesignBoundary, loop: int) -> np.ndarray:
    """Arc lengths of the points where the loop's smooth curve turns more than ``KINK_TURN``."""
    points = boundary.loops[loop]
    incoming = points - np.roll(points, 1, axis=0)
    outgoing = np.roll(points, -1, axis=0) - points
    cos = np.einsum("ij,ij->i", incoming, outgoing) / np.maximum(
        np.linalg.norm(incoming, axis=1) * np.linalg.norm(outgoing, axis=1), 1e-300
    )
    turning = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    first = boundary.first_segment[loop]
    return boundary.segment_start_s[first : first + len(points)][turning > KINK_TURN]


def _gap(kinks: np.ndarray, s: float, total: float) -> np.ndarray:
    """Distances along a loop of length ``total`` from arc length ``s`` to each kink."""
    forward = (kinks - s) % total
    return np.minimum(forward, total - forward)
