"""Moving a joint's end bolts where the fitter's tool cannot reach them.

Both panels of a joint must drill the same bolt positions, so stations are decided in the main
process with both panels in view. After a build, every bolt a panel reports in the way (its
tool's path or its slot meets a part, :func:`fabpanel.model.access.reach_findings`) that is the
first or last of its joint moves along the joint by ``MOVE_STEP``:

- towards the corner when a stiffener is in the way: the slot goes deeper into the stiffener's
  pocket (at a corner of a curved shell the stiffener, standing along the corner normal, leans
  over the slot on the access sheet), down to where the slot still clears the other rib; a bolt
  already there jumps past the stiffener instead;
- away from the corner otherwise (the other rib across an acute corner, the sheet's edge).

The other bolts are spread evenly again (:func:`fabpanel.model.joints.bolt_stations` with the two
end distances); both panels get the new stations (the other panel reads them from its own end)
and are rebuilt, up to ``MOVE_ROUNDS`` rounds. What is still in the way stays reported.
"""

from __future__ import annotations

import numpy as np

from ..buildup import Buildup
from ..data import DevelopedPanels
from ..fasteners import SHEET_BEFORE_RIB
from .bolt_room import ROOM_STEP
from .joints import bolt_stations
from .records import PanelPayload, PanelResult
from .trim import side_rows

#: how far an end bolt moves per round, mm
MOVE_STEP = 20.0
#: rounds of moving and rebuilding
MOVE_ROUNDS = 3


def _length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _facing_side(developed: DevelopedPanels, p: int, side: int, q: int) -> int:
    """The side of panel ``q`` that is panel ``p``'s side ``side`` (its polyline reversed)."""
    mine = side_rows(developed.samples[p])[side]
    candidates = np.flatnonzero(developed.layout.side_neighbours[q] == p)
    gaps = [np.linalg.norm(side_rows(developed.samples[q])[t][0] - mine[-1]) for t in candidates]
    return int(candidates[int(np.argmin(gaps))])


def _end_distances(payload: PanelPayload, side: int, length: float) -> tuple[float, float]:
    stations = payload.stations_of(side)
    if stations is None:
        bolts = payload.buildup.bolts
        stations = bolt_stations(length, bolts.spacing, bolts.edge_distance)
    return float(stations[0]), float(length - stations[-1])


#: the rooms known so far: (lower panel, its side, end) -> grid steps where both panels that
#: reported one can reach the bolt (:mod:`fabpanel.model.bolt_room`)
Rooms = dict[tuple[int, int, int], set[int]]


def _joint_end(
    developed: DevelopedPanels, p: int, side: int, end: int
) -> tuple[tuple[int, int], int] | None:
    """The joint seen from its lower panel, ``((panel, side), end)``, for panel ``p``'s
    ``side`` and ``end`` (0 start, 1 end); None on a boundary side."""
    q = int(developed.layout.side_neighbours[p, side])
    if q < 0:
        return None
    if q < p:
        return (q, _facing_side(developed, p, side, q)), 1 - end
    return (p, side), end


def _gather_rooms(developed: DevelopedPanels, results: list[PanelResult | None], rooms: Rooms):
    """Intersect the rooms the panels just reported into ``rooms``."""
    for p, result in enumerate(results):
        if result is None or result.failure is not None:
            continue
        for (side, end), steps in result.measures.get("end_bolt_room", {}).items():
            joint = _joint_end(developed, p, side, end)
            if joint is None:
                continue
            key = (*joint[0], joint[1])
            rooms[key] = rooms[key] & set(steps) if key in rooms else set(steps)


def _moved_distance(
    current: float, towards: bool, room: set[int] | None, lowest: float, beyond: float
) -> float | None:
    """The new end distance of a bolt in the way: the nearest in its room (None when the room
    is known and empty, or holds only where the bolt is), else a step towards the corner past
    a stiffener in the way or away from it otherwise."""
    if room is not None:
        others = [k * ROOM_STEP for k in room if abs(k * ROOM_STEP - current) > 1e-6]
        return min(others, key=lambda d: (abs(d - current), d)) if others else None
    if towards:
        return beyond if current <= lowest + 1e-6 else max(current - MOVE_STEP, lowest)
    return current + MOVE_STEP


def move_blocked_end_bolts(
    developed: DevelopedPanels,
    payloads: list[PanelPayload],
    results: list[PanelResult | None],
    buildup: Buildup,
    rooms: Rooms,
) -> set[int]:
    """Move the end bolts in the way (see the module docstring) in ``payloads``' stations;
    return the panels to rebuild (both panels of every joint changed). ``rooms`` keeps what
    the panels found out about where their end bolts can go, round after round."""
    design = buildup.access
    assert design is not None
    _gather_rooms(developed, results, rooms)
    half = float(np.ptp(design.slot[:, 0])) / 2
    lowest = half + buildup.t_rib + SHEET_BEFORE_RIB + 1.0
    beyond = buildup.stiffener_offset + 2 * half + buildup.t_stf
    neighbours = developed.layout.side_neighbours
    # per joint, seen from its lower panel: the end (0 start, 1 end) -> towards the corner
    wanted: dict[tuple[int, int], dict[int, bool]] = {}
    for p, result in enumerate(results):
        if result is None or result.failure is not None:
            continue
        for side, i, part_id, _ in result.measures.get("bolts_in_the_way", []):
            count = len(result.bolts.get(side, ()))
            joint = _joint_end(developed, p, side, 0 if i == 0 else 1)
            if count < 2 or i not in (0, count - 1) or joint is None:
                continue
            wanted.setdefault(joint[0], {}).setdefault(joint[1], "-STF-" in part_id)
    moved: set[int] = set()
    for (p, side), ends in sorted(wanted.items()):
        points = side_rows(developed.samples[p])[side]
        length = _length(points)
        distances = list(_end_distances(payloads[p], side, length))
        before = list(distances)
        for end, towards in ends.items():
            room = rooms.get((p, side, end))
            d = _moved_distance(distances[end], towards, room, lowest, beyond)
            if d is not None:
                distances[end] = min(d, length / 2)
        if distances == before:
            continue
        stations = bolt_stations(length, buildup.bolts.spacing, distances[0], distances[1])
        q = int(neighbours[p, side])
        t = _facing_side(developed, p, side, q)
        other = _length(side_rows(developed.samples[q])[t])
        payloads[p] = payloads[p].with_stations(side, stations)
        payloads[q] = payloads[q].with_stations(t, other - stations[::-1])
        moved |= {p, q}
    return moved
