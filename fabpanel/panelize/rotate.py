"""Quad edges turned where a vertex has more or fewer panels than its angle can take.

The corners at a vertex add up to its angle: 360° inside (a little less on a dome), the
outline's angle on the boundary. ``k`` panels there give corners of ``angle / k`` on average,
so a boundary vertex of five panels at an opening's 232° corner has corners of 46°, and no
smoothing can open them into the gates' 60-120°; a boundary vertex of two panels at a 270°
corner has 135° corners. gmsh's quads have such vertices where an outline corner meets the
cross field's singularities badly, and they cost the layout its share of good corners (random
shapes at 1 m: 5-9 of the 13-26 corners out of band on the failing ones).

The fix is the edge rotation of quad mesh clean-up: the two quads either side of an inner
edge ``(v, w)`` form a hexagon, which is split again by one of its two other diagonals. ``v``
and ``w`` lose a panel each and the diagonal's two ends gain one. Every vertex has an ideal
count, its angle over 90°, and a rotation is made where it brings the six vertices' counts
closer to theirs (the sum of squared differences falls), the best one first, around the
vertices whose corners cannot fit 60-120° on average. The nodes do not move; the caller
smooths the layout again and keeps it only where the gates' measures say it is better.
"""

from __future__ import annotations

import numpy as np

from .gates import CORNER_GOOD

#: the two ways a rotation's gain is measured (:func:`_gain`)
MEASURES = ("band", "counts")
#: a rotation is made only where its gain is at least this much (squared differences of
#: counts, or degrees of band excess)
MIN_GAIN = {"counts": 0.2, "band": 2.0}
#: degrees: the band the corners' average is held in by the "band" measure, a degree inside
#: the gates' 60-120°: three corners of 120.0° at a valence-3 vertex on a flat stretch are in
#: the gates' band on paper, but one of them ends a fraction over it
BAND = (CORNER_GOOD[0] + 1.0, CORNER_GOOD[1] - 1.0)
#: the "band" measure's weight on the squared differences of counts, which break its ties
COUNTS_WEIGHT = 0.5
#: rotations made at most, per crowded or starved vertex
ROTATIONS_PER_VERTEX = 3


def ideal_counts(angle_sums: np.ndarray) -> np.ndarray:
    """Each vertex's ideal count of panels: its angle (degrees) over 90°."""
    return angle_sums / 90.0


def out_of_reach(counts: np.ndarray, angle_sums: np.ndarray) -> np.ndarray:
    """(n,) bool: vertices whose corners cannot all lie in 60-120°: their angle over their
    count of panels is outside the band."""
    mean = angle_sums / np.maximum(counts, 1)
    return (counts > 0) & ((mean < CORNER_GOOD[0]) | (mean > CORNER_GOOD[1]))


def rotate_towards_ideal(
    quads: np.ndarray, on_curve: np.ndarray, angle_sums: np.ndarray, measure: str = "counts"
) -> tuple[np.ndarray, int]:
    """``quads`` (m, 4) with inner edges rotated (module docstring) around the vertices whose
    corners are out of reach; ``on_curve`` (n,) bool marks the boundary nodes, ``angle_sums``
    (n,) each node's angle in degrees (the sum of its corners before); ``measure`` one of
    :data:`MEASURES` (:func:`_gain`). Returns the new quads (same count, same orientation)
    and how many edges were rotated."""
    quads = quads.copy()
    ideal = ideal_counts(angle_sums)
    counts = np.bincount(quads.ravel(), minlength=len(on_curve))
    targets = np.flatnonzero(out_of_reach(counts, angle_sums))
    budget = ROTATIONS_PER_VERTEX * len(targets)
    done = 0
    while done < budget and len(targets):
        best = _best_rotation(quads, on_curve, counts, ideal, targets, measure)
        if best is None:
            break
        (first, second), new = best
        quads[first], quads[second] = new
        counts = np.bincount(quads.ravel(), minlength=len(on_curve))
        targets = np.flatnonzero(out_of_reach(counts, angle_sums))
        done += 1
    return quads, done


def _best_rotation(
    quads: np.ndarray,
    on_curve: np.ndarray,
    counts: np.ndarray,
    ideal: np.ndarray,
    targets: np.ndarray,
    measure: str,
) -> tuple[tuple[int, int], tuple[np.ndarray, np.ndarray]] | None:
    """The rotation of an inner edge of the quads round ``targets`` with the largest gain by
    ``measure`` (``MIN_GAIN`` at least): the two quads it replaces and the two new ones, or
    None."""
    sides = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2)  # (m, 4, 2), directed
    owner = {(int(a), int(b)): q for q, quad in enumerate(sides) for a, b in quad}
    near = np.flatnonzero(np.isin(quads, targets).any(axis=1))
    best, best_gain = None, MIN_GAIN[measure]
    for q in near:
        for at in range(4):
            v, w = int(quads[q, at]), int(quads[q, (at + 1) % 4])
            other = owner.get((w, v))
            if other is None or other < q and other in near:
                continue  # a boundary side, or the pair seen from the other quad
            for new in _hexagon_splits(quads[q], at, quads[other], v):
                gain = _gain(new, (quads[q], quads[other]), counts, ideal, on_curve, measure)
                if gain > best_gain and _valid(new, owner):
                    best, best_gain = ((int(q), int(other)), new), gain
    return best


def _hexagon_splits(
    first: np.ndarray, at: int, second: np.ndarray, v: int
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The two other splits of the hexagon of quads ``first`` (whose side ``at`` runs from
    ``v`` to ``w``) and ``second`` (which runs ``w`` to ``v``), in their orientation."""
    _, w, a1, a2 = np.roll(first, -at)
    start = int(np.flatnonzero(second == w)[0])
    _, _, b1, b2 = np.roll(second, -start)
    ring = np.array([v, b1, b2, w, a1, a2])
    if len(np.unique(ring)) < 6:
        return []
    return [
        (ring[[0, 1, 2, 5]], ring[[2, 3, 4, 5]]),  # the diagonal b2-a2
        (ring[[1, 2, 3, 4]], ring[[4, 5, 0, 1]]),  # the diagonal b1-a1
    ]


def _gain(
    new: tuple[np.ndarray, np.ndarray],
    old: tuple[np.ndarray, np.ndarray],
    counts: np.ndarray,
    ideal: np.ndarray,
    on_curve: np.ndarray,
    measure: str,
) -> float:
    """How much ``new`` for ``old`` lowers the six vertices' distance from their ideal:
    by ``"counts"``, the sum of squared differences of their counts from ``ideal``; by
    ``"band"``, the degrees by which their angles cannot be shared into :data:`BAND`, plus
    ``COUNTS_WEIGHT`` x the first. The band measure gives a second panel to a 139° outline
    corner of one panel at the price of a valence-3 vertex inside, which the counts refuse
    (0.3 to 0.2 there against 0 to 1 inside), and which takes the layout's corners back
    inside the gates' hard limit. Minus infinity where a vertex would be left with too few
    panels (an inner vertex under three, a boundary one under one)."""
    ids = np.unique(np.concatenate(old))
    change = np.zeros(len(ids), dtype=int)
    for quad in new:
        change += np.isin(ids, quad)
    for quad in old:
        change -= np.isin(ids, quad)
    after = counts[ids] + change
    if (after < np.where(on_curve[ids], 1, 3)).any():
        return -np.inf
    squared = np.sum((counts[ids] - ideal[ids]) ** 2) - np.sum((after - ideal[ids]) ** 2)
    if measure == "counts":
        return float(squared)
    angle = ideal[ids] * 90.0
    excess = np.sum(_excess(counts[ids], angle)) - np.sum(_excess(after, angle))
    return float(excess + COUNTS_WEIGHT * squared)


def _excess(counts: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Degrees by which a vertex's angle exceeds what its panels' corners can take inside
    the band (less a margin), or falls short of it."""
    low, high = BAND
    return np.maximum(angle - high * counts, 0.0) + np.maximum(low * counts - angle, 0.0)


def _valid(new: tuple[np.ndarray, np.ndarray], owner: dict) -> bool:
    """Whether the new diagonal (the side the two new quads share) is not already a side of
    another quad."""
    a, b = (int(node) for node in np.intersect1d(new[0], new[1]))
    return (a, b) not in owner and (b, a) not in owner
