"""The corners of a surface's outline, as the field method's quad mesher should see them.

A mesh's boundary is a polyline, and where the design outline has a corner the mesh often cuts
it: a 100° corner sampled at 0.2 m becomes two vertices turning 40° each, 150 mm apart. Taken
vertex by vertex, both are corners, the mesher puts a curve end at each and the layout gets a
150 mm edge between them. Here a corner is where the outline turns by more than
``corner_angle`` within a short stretch (``merge``, tied to the shortest edge the layout gates
allow); the sharpest vertex of the stretch is the corner, and the stretch's other vertices near
it are left out of the outline the mesher gets (a curve through them would bend sharply
without a corner). Two corners closer than twice that along the outline (a facet longer than
``merge``, each end turning on its own) are one corner too: the quasi-structured mesher splits
its triangles into quads, so a boundary curve always gets an even number of edges, at least
two, and a curve shorter than ``2 x merge`` gives edges shorter than the gates allow (a 112 mm
facet cutting a 90° corner at 0.32 m panels made two 56 mm edges). Angles are measured in the
conformal flattening, which keeps them; lengths on the surface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data import Surface
from .skeleton_input import turning_angles

#: a vertex left out beside a corner that turns more than this (degrees) was a facet of it
FACET_TURN = 5.0


@dataclass(frozen=True)
class OutlineCorners:
    """Per boundary loop: the vertex ids the mesher gets (surface vertex ids, in loop order)
    and which of them are corners; and the surface vertex ids of the corners that were cut
    (the vertices left out beside them): there the design outline has a short facet that a
    smooth sheet edge cannot follow exactly."""

    loops: tuple[np.ndarray, ...]
    corners: tuple[np.ndarray, ...]
    cut_corners: np.ndarray


def outline_corners(
    surface: Surface, flat: np.ndarray, corner_angle: float, merge: float
) -> OutlineCorners:
    """The outline's corners (see the module docstring); ``merge`` in mm."""
    loops, corners, cut = [], [], []
    for loop in surface.boundary_loops:
        turning = turning_angles(flat[loop])
        arc = _arc_lengths(surface.vertices[loop])
        candidate = (np.abs(turning) > corner_angle) | (
            np.abs(_window_sums(turning, arc, merge)) > corner_angle
        )
        corner, dropped = _sharpest_of_each_run(candidate, turning, arc, merge)
        corner, dropped = _one_corner_of_close_pairs(corner, dropped, turning, arc, 2 * merge)
        keep = ~dropped
        loops.append(loop[keep])
        corners.append(corner[keep])
        cut.append(loop[_cut_of(corner, dropped, turning, arc, 2 * merge)])
    return OutlineCorners(
        loops=tuple(loops), corners=tuple(corners), cut_corners=np.concatenate(cut)
    )


def _cut_of(
    corner: np.ndarray, dropped: np.ndarray, turning: np.ndarray, arc: np.ndarray, merge: float
) -> np.ndarray:
    """The corners with a dropped vertex within ``merge`` of them that turns by more than
    ``FACET_TURN`` (points left out of a straight side beside a corner are no facet)."""
    facets = np.flatnonzero(dropped & (np.abs(turning) > FACET_TURN))
    if not len(facets):
        return np.zeros(0, dtype=int)
    ids = np.flatnonzero(corner)
    gap = np.abs(arc[ids][:, None] - arc[facets][None, :])
    gap = np.minimum(gap, arc[-1] - gap)
    return ids[(gap <= merge).any(axis=1)]


def _arc_lengths(points: np.ndarray) -> np.ndarray:
    """(n + 1,) arc length at every vertex of the closed polyline, and its total last."""
    steps = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _window_sums(turning: np.ndarray, arc: np.ndarray, window: float) -> np.ndarray:
    """The signed turning within ``window / 2`` of arc length either side of every vertex of
    a closed loop (the loop is laid out three times so that windows wrap round)."""
    total, at = arc[-1], arc[:-1]
    tripled = np.concatenate([at - total, at, at + total])
    summed = np.concatenate([[0.0], np.cumsum(np.tile(turning, 3))])
    low = np.searchsorted(tripled, at - window / 2, side="left")
    high = np.searchsorted(tripled, at + window / 2, side="right")
    return summed[high] - summed[low]


def _sharpest_of_each_run(
    candidate: np.ndarray, turning: np.ndarray, arc: np.ndarray, merge: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex: is it a corner, and is it left out. A run is consecutive candidates, each
    within ``merge`` of the one before; its vertex turning most is a corner and the run's
    other vertices within ``merge`` of it are left out (a long run, a tight bend rather than
    a corner, keeps its vertices further away, and the mesher's curve bends through them)."""
    n = len(candidate)
    corner = np.zeros(n, dtype=bool)
    dropped = np.zeros(n, dtype=bool)
    steps = np.diff(arc)  # steps[i]: from vertex i to vertex i + 1
    linked = candidate & np.roll(candidate, 1) & (np.roll(steps, 1) <= merge)  # to the previous
    if linked.all():  # one run all round: the sharpest vertex only
        corner[int(np.argmax(np.abs(turning)))] = True
        return corner, dropped
    first = int(np.flatnonzero(~linked)[0])  # a walk from here starts no run half way
    order = (first + np.arange(n)) % n
    run: list[int] = []
    total = arc[-1]
    for index in [*order, -1]:
        if run and (index < 0 or not linked[index]):  # the run before ends here
            members = np.asarray(run)
            sharpest = members[int(np.argmax(np.abs(turning[members])))]
            corner[sharpest] = True
            gap = np.abs(arc[members] - arc[sharpest])
            near = np.minimum(gap, total - gap) <= merge
            dropped[members[near & (members != sharpest)]] = True
            run = []
        if index >= 0 and candidate[index]:
            run.append(int(index))
    return corner, dropped


def _one_corner_of_close_pairs(
    corner: np.ndarray, dropped: np.ndarray, turning: np.ndarray, arc: np.ndarray, apart: float
) -> tuple[np.ndarray, np.ndarray]:
    """Corners and left-out vertices after merging every pair of consecutive corners less
    than ``apart`` from each other along the loop: the one turning more stays, the other and
    the vertices between them are left out. Pairs are taken shortest first, so a run of close
    corners keeps its sharpest."""
    corner, dropped = corner.copy(), dropped.copy()
    total, n = arc[-1], len(corner)
    while True:
        ids = np.flatnonzero(corner)
        if len(ids) < 2:
            return corner, dropped
        following = np.roll(ids, -1)
        gaps = (arc[following] - arc[ids]) % total
        shortest = int(np.argmin(gaps))
        if gaps[shortest] >= apart:
            return corner, dropped
        first, second = int(ids[shortest]), int(following[shortest])
        kept, lost = (
            (first, second) if abs(turning[first]) >= abs(turning[second]) else (second, first)
        )
        corner[lost] = False
        between = (first + 1 + np.arange((second - first - 1) % n)) % n
        dropped[between] = True
        dropped[lost] = True
        dropped[kept] = False
