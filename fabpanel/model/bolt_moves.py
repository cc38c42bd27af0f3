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


def move_blocked_end_bolts(
    developed: DevelopedPanels,
    payloads: list[PanelPayload],
    results: list[PanelResult | None],
    buildup: Buildup,
) -> set[int]:
    """Move the end bolts in the way (see the module docstring) in ``payloads``' stations;
    return the panels to rebuild (both panels of every joint changed)."""
    design = buildup.access
    assert design is not None
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
            q = int(neighbours[p, side])
            if count < 2 or i not in (0, count - 1) or q < 0:
                continue
            end = 0 if i == 0 else 1
            key = (p, side)
            if q < p:
                key, end = (q, _facing_side(developed, p, side, q)), 1 - end
            wanted.setdefault(key, {}).setdefault(end, "-STF-" in part_id)
    moved: set[int] = set()
    for (p, side), ends in sorted(wanted.items()):
        points = side_rows(developed.samples[p])[side]
        length = _length(points)
        distances = list(_end_distances(payloads[p], side, length))
        for end, towards in ends.items():
            d = distances[end]
            if towards:
                d = beyond if d <= lowest + 1e-6 else max(d - MOVE_STEP, lowest)
            else:
                d += MOVE_STEP
            distances[end] = min(d, length / 2)
        spacing = buildup.bolts.spacing
        stations = bolt_stations(length, spacing, distances[0], distances[1])
        q = int(neighbours[p, side])
        t = _facing_side(developed, p, side, q)
        other = _length(side_rows(developed.samples[q])[t])
        payloads[p] = payloads[p].with_stations(side, stations)
        payloads[q] = payloads[q].with_stations(t, other - stations[::-1])
        moved |= {p, q}
    return moved
