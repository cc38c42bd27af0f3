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
facet cutting a 90° corner at 0.32 m panels made two 56 mm edges).

A small opening (perimeter up to ``SMALL_OPENING`` panel sizes, a round or oval hole or a
rectangle about a panel across) gets four corners: a smooth one four of its vertices, a quarter
of its perimeter apart and set square to the cross field that the rest of the outline would
give there; a rectangle its own four, taken one by one even where its short sides are shorter
than twice ``merge``. The mesher then gets it filled in, and the quad over it is punched out
afterwards (:mod:`.punch`), or, where no quad can be, as its four corners joined by straight
lines (each side then gets two edges). The quad grid runs past it as past a missing panel,
three panels at each of the four corners. Seen as a smooth loop, a 0.8 m hole at 1 m panels
got a ring of eight panels and five or six singular vertices round it, with a third of their
corners outside 60-120°; a 0.8 x 0.48 m rectangle its short sides' corners merged in pairs and
two panel corners of 150-158°. The layout's sides on the opening follow it on the surface.

A tight rounding (a rounded corner of the plan, radius under about a panel) is a corner too:
where the outline turns more than ``ROUNDING_TURN`` within one panel size of arc, and not more
than ``ROUNDING_MOST`` within two, the vertex in the middle of the turn is a corner and the
rounding's other vertices within half a panel of it are left out. Seen as smooth, a 90°
rounding of 0.6-0.9 m radius at 1 m panels got one boundary node half way round with two panels
of 130-135° there, or a valence-3 vertex just inside it; as a corner, one panel turns it, its
two sides following the rounding on the surface (the nodes are put on the design boundary
afterwards). A rounded end turning further (an ellipse's tip, a lobe) stays smooth: one corner
could not take it. Angles are measured in the conformal flattening, which keeps them; lengths
on the surface.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..data import Surface
from .skeleton_input import turning_angles

#: a vertex left out beside a corner that turns more than this (degrees) was a facet of it
FACET_TURN = 5.0
#: an opening shorter than this round (x the panel size), smooth or with four corners, is a
#: missing panel of the grid (:class:`SmallOpenings`) ...
SMALL_OPENING = 5.0
#: ... unless shorter than this: four sides of the gates' shortest edge (0.3 x panel size)
SMALLEST_OPENING = 1.2
#: a small opening without four corners whose smallest enclosing rectangle is this much
#: longer than wide (a slot) gets its four corners at the rectangle's (:func:`_oblong_corners`)
OBLONG = 1.3
#: a rounding that turns more than this (degrees) within one panel size of arc is one corner
ROUNDING_TURN = 60.0
#: ... unless it turns more than this within two panel sizes (a rounded end, not a corner)
ROUNDING_MOST = 135.0


@dataclass(frozen=True)
class OutlineCorners:
    """Per boundary loop: the vertex ids the mesher gets (surface vertex ids, in loop order)
    and which of them are corners; and the surface vertex ids of the corners that were cut
    (the vertices left out beside them): there the design outline has a short facet that a
    smooth sheet edge cannot follow exactly."""

    loops: tuple[np.ndarray, ...]
    corners: tuple[np.ndarray, ...]
    cut_corners: np.ndarray
    corner_angle: float  # degrees, and the stretch (mm) that they were found with
    merge: float


def outline_corners(
    surface: Surface,
    flat: np.ndarray,
    corner_angle: float,
    merge: float,
    panel_size: float | None = None,
) -> OutlineCorners:
    """The outline's corners (see the module docstring); ``merge`` and ``panel_size`` in mm
    (no tight roundings are looked for without a panel size)."""
    loops, corners, cut = [], [], []
    for loop in surface.boundary_loops:
        turning = turning_angles(flat[loop])
        arc = _arc_lengths(surface.vertices[loop])
        corner, dropped = _loop_corners(turning, arc, corner_angle, merge, panel_size)
        corner, dropped = _one_corner_of_close_pairs(corner, dropped, turning, arc, 2 * merge)
        keep = ~dropped
        loops.append(loop[keep])
        corners.append(corner[keep])
        cut.append(loop[_cut_of(corner, dropped, turning, arc, 2 * merge)])
    return OutlineCorners(
        loops=tuple(loops),
        corners=tuple(corners),
        cut_corners=np.concatenate(cut),
        corner_angle=corner_angle,
        merge=merge,
    )


def _loop_corners(
    turning: np.ndarray, arc: np.ndarray, corner_angle: float, merge: float, size: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex of one loop: is it a corner, is it left out (close pairs not yet merged)."""
    candidate = (np.abs(turning) > corner_angle) | (
        np.abs(_window_sums(turning, arc, merge)) > corner_angle
    )
    corner, dropped = _sharpest_of_each_run(candidate, turning, arc, merge)
    if size is not None:
        corner, dropped = _tight_roundings(corner, dropped, turning, arc, size)
    return corner, dropped


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


def _tight_roundings(
    corner: np.ndarray, dropped: np.ndarray, turning: np.ndarray, arc: np.ndarray, size: float
) -> tuple[np.ndarray, np.ndarray]:
    """Corners and left-out vertices with the tight roundings added (module docstring): per
    run of vertices whose turning within ``size`` of arc is over ``ROUNDING_TURN``, the one
    turning most within that window, unless the turning within ``2 x size`` is over
    ``ROUNDING_MOST`` or an existing corner lies within ``size``."""
    swept = np.abs(_window_sums(turning, arc, size))
    wide = np.abs(_window_sums(turning, arc, 2.0 * size))
    candidate = swept > ROUNDING_TURN
    if not candidate.any() or candidate.all():
        return corner, dropped
    corner, dropped = corner.copy(), dropped.copy()
    total, n = arc[-1], len(corner)
    start = int(np.flatnonzero(~candidate)[0])
    order = (start + np.arange(n)) % n
    runs = np.split(order, np.flatnonzero(np.diff(candidate[order].astype(int)) != 0) + 1)
    for run in runs:
        if not candidate[run[0]]:
            continue
        middle = int(run[np.argmax(swept[run])])
        gap = np.abs(arc[:-1] - arc[middle])
        gap = np.minimum(gap, total - gap)
        if wide[middle] > ROUNDING_MOST or (corner & (gap < size)).any():
            continue
        corner[middle] = True
        dropped[(gap <= 0.5 * size) & ~corner] = True
    return corner, dropped


@dataclass(frozen=True)
class SmallOpenings:
    """The small openings of an outline (module docstring) and the outlines made of them.

    ``kept``: the outline with each small opening given four corners (a smooth one's a quarter
    round apart, set square to the cross field; a rectangle's its own four, not merged in pairs
    however short its sides); ``squared``: the outline the mesher gets with those openings as
    their four corners joined by straight lines; ``filled``: the outline the mesher gets without
    them, the quad over each punched out afterwards (:mod:`.punch`); ``indices``: the small
    openings' loop indices in the outline."""

    kept: OutlineCorners
    squared: OutlineCorners
    filled: OutlineCorners
    indices: tuple[int, ...]


def small_openings(
    outline: OutlineCorners,
    surface: Surface,
    flat: np.ndarray,
    panel_size: float,
) -> SmallOpenings | None:
    """The small openings of ``outline`` (:class:`SmallOpenings`), or None where it has none."""
    four = {
        index: corners
        for index, corners in enumerate(_four_corners_of_small(outline, surface, flat, panel_size))
        if corners is not None
    }
    if not four:
        return None
    from .cross_field import boundary_cross_field

    smooth = [index for index, (_, corner, _) in four.items() if not len(corner)]
    if smooth:
        steering = [loop for i, loop in enumerate(surface.boundary_loops) if i not in four]
        theta = boundary_cross_field(surface.faces, flat, steering)
    loops, corners = list(outline.loops), list(outline.corners)
    mesher_loops, mesher_corners = list(outline.loops), list(outline.corners)
    for index, (loop, corner, _) in four.items():
        if not len(corner):  # rounded: four vertices, at an oblong's ends or set to the field
            corner = np.zeros(len(loop), dtype=bool)
            oblong = _oblong_corners(flat[loop])
            if oblong is None:
                oblong = _square_corners(flat[loop], _field_angle_at(surface.faces, theta, loop))
            corner[oblong] = True
        loops[index], corners[index] = loop, corner
        mesher_loops[index] = loop[corner]
        mesher_corners[index] = np.ones(4, dtype=bool)
    unfilled = [i for i in range(len(outline.loops)) if i not in four]

    # their corners are taken one by one now, not merged in pairs: only their own cuts stay
    whole = np.concatenate([surface.boundary_loops[i] for i in four])
    in_small = np.isin(outline.cut_corners, whole)
    cut = np.concatenate([outline.cut_corners[~in_small], *[c for _, _, c in four.values()]])

    def _outline(loops: list, corners: list) -> OutlineCorners:
        return replace(outline, loops=tuple(loops), corners=tuple(corners), cut_corners=cut)

    return SmallOpenings(
        kept=_outline(loops, corners),
        squared=_outline(mesher_loops, mesher_corners),
        filled=_outline([loops[i] for i in unfilled], [corners[i] for i in unfilled]),
        indices=tuple(sorted(four)),
    )


def _four_corners_of_small(
    outline: OutlineCorners, surface: Surface, flat: np.ndarray, panel_size: float
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
    """Per loop of the outline: for a small opening, its vertices and corner flags with
    exactly four corners (no flags for a smooth one: its four are chosen later) and its cut
    corners (:class:`OutlineCorners`); else None.
    A small opening with corners is looked at again without merging close corners in pairs:
    a 0.8 x 0.5 m rectangle at 1 m panels has four corners, not the two that merging its
    short sides' ends left (two 150° corners of the layout there)."""
    found: list[tuple[np.ndarray, np.ndarray, np.ndarray] | None] = [None] * len(outline.loops)
    for index, loop in enumerate(surface.boundary_loops):
        perimeter = _arc_lengths(surface.vertices[loop])[-1]
        if index == 0 or len(loop) < 4 or perimeter > SMALL_OPENING * panel_size:
            continue
        if perimeter < SMALLEST_OPENING * panel_size:
            continue  # its four panel sides would be shorter than the gates' shortest edge
        rounded = (loop, np.zeros(0, dtype=bool), np.zeros(0, int))
        if not outline.corners[index].any():
            found[index] = rounded
            continue
        turning = turning_angles(flat[loop])
        arc = _arc_lengths(surface.vertices[loop])
        corner, dropped = _loop_corners(turning, arc, outline.corner_angle, outline.merge, None)
        if int(corner.sum()) == 4:
            cut = loop[_cut_of(corner, dropped, turning, arc, 2 * outline.merge)]
            found[index] = (loop[~dropped], corner[~dropped], cut)
        elif np.abs(turning).max() <= outline.corner_angle:
            # no vertex turns like a corner: its "corners" are a tight round's turning within
            # ``merge`` (a 1 m round hole sampled at 0.15 m turns 34° within 0.3 m) or a slot's
            # round ends; its four are chosen like a smooth opening's
            found[index] = rounded
    return found


def _oblong_corners(points: np.ndarray) -> np.ndarray | None:
    """Four distinct vertex indices of a closed flat loop nearest the corners of its smallest
    enclosing rectangle, where that is oblong (sides differing by more than ``OBLONG``): a
    slot's four are where its straight sides meet its round ends, so the panels along it
    run with it. None for a loop about as wide as long (its rectangle's turn is arbitrary)."""
    from shapely.geometry import Polygon

    rectangle = Polygon(points).minimum_rotated_rectangle
    if rectangle.geom_type != "Polygon":
        return None
    box = np.asarray(rectangle.exterior.coords)[:4]
    sides = np.linalg.norm(np.roll(box, -1, axis=0) - box, axis=1)
    if sides.max() < OBLONG * sides.min():
        return None
    nearest = np.argmin(np.linalg.norm(points[None, :, :] - box[:, None, :], axis=2), axis=1)
    if len(np.unique(nearest)) < 4:
        return None
    return np.sort(nearest)


def _field_angle_at(faces: np.ndarray, theta: np.ndarray, loop: np.ndarray) -> float:
    """The mean direction of a cross field (angle per triangle) over the triangles touching
    ``loop``, averaged as ``exp(4 i theta)`` (a cross is the same turned by 90°)."""
    touching = np.isin(faces, loop).any(axis=1)
    return float(np.angle(np.exp(4j * theta[touching]).mean()) / 4.0)


def _square_corners(points: np.ndarray, angle: float) -> np.ndarray:
    """Four distinct vertex indices of a closed flat loop, a quarter of its perimeter apart,
    placed so that the square through them has its sides along ``angle`` (the corners at
    ``angle + 45° + k x 90°`` seen from the loop's centroid)."""
    arc = _arc_lengths(points)
    centre = points.mean(axis=0)
    toward = np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0])
    first = int(np.argmin(np.abs(np.angle(np.exp(1j * (toward - angle - np.pi / 4))))))
    targets = (arc[first] + arc[-1] * np.arange(4) / 4.0) % arc[-1]
    gap = np.abs(arc[:-1][None, :] - targets[:, None])
    picked = np.argmin(np.minimum(gap, arc[-1] - gap), axis=1)
    if len(np.unique(picked)) < 4:  # a loop of very few vertices: every fourth of them
        picked = (first + (np.arange(4) * len(points)) // 4) % len(points)
    return picked
