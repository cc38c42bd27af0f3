"""Where along its joint an end bolt can be reached: the room probe behind the bolt moves.

A bolt at the end of a joint sits beside the panel's corner, where the other rib, the corner
stiffener and (on a tilted boundary rib) the sheet's edge crowd its slot and its tool. When the
reach check finds such a bolt in the way, the worker tries the bolt at every end distance on a
grid of ``ROOM_STEP`` mm, up to ``ROOM_FARTHEST`` from the corner, against the panel as built
(:class:`fabpanel.model.access.ReachScene`): the slot must lie on the sheet, clear of every plate,
and the tool's swept envelope must clear every part, the access sheet holding the candidate's
slot. The distances that pass are the bolt's *room*; the main process intersects the rooms of
both panels of the joint and moves the bolt to the nearest distance in both
(:mod:`fabpanel.model.bolt_moves`). The rest of the panel does not depend on where the end bolt
goes, so a room holds until the panel's other parts change.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..fasteners import AccessDesign
from .access import (
    REACH_OVERLAP,
    ReachScene,
    cut_prism,
    opening_prism,
    placed,
    tool_envelope,
)
from .openings import Opening, bolt_designs, opening_loops

#: the grid of end distances tried, mm (both panels of a joint try the same grid)
ROOM_STEP = 10.0
#: an end bolt moves at most this far from its corner, mm
ROOM_FARTHEST = 300.0


def room_grid(length: float, nearest: float) -> np.ndarray:
    """(n,) int: the grid steps tried on a side of ``length`` mm, from ``nearest`` mm to
    ``ROOM_FARTHEST`` or half the side."""
    first = math.ceil(nearest / ROOM_STEP - 1e-9)
    last = math.floor(min(ROOM_FARTHEST, length / 2) / ROOM_STEP + 1e-9)
    return np.arange(first, last + 1)


def end_bolt_room(
    bolt: tuple[int, int],
    frames: np.ndarray,
    design: AccessDesign,
    sheet_faces: tuple,
    outside,
    scene: ReachScene,
) -> np.ndarray:
    """(n,) bool: whether ``bolt`` (side, index) at each of its candidate joint ``frames``
    ``(n, 4, 4)`` can be reached (see the module docstring). ``sheet_faces``: the access sheet's
    two trimmed surfaces (the slot must meet both), ``outside`` the one the tool comes
    through."""
    designs = bolt_designs(design, outside, {0: frames})[0]
    openings = [Opening(f, d.slot, (bolt,), d.reach) for f, d in zip(frames, designs, strict=True)]
    on_sheet = np.ones(len(frames), bool)
    for face in sheet_faces:
        on_sheet &= [not isinstance(loop, str) for loop in opening_loops(face, openings)]
    sheet = scene.sheet_without(bolt)
    rest = scene.others()
    plates = [solid for solid in scene.plates.values()]
    ok = np.zeros(len(frames), bool)
    envelopes: dict[float, object] = {}
    for k in np.flatnonzero(on_sheet):
        opening, d = openings[k], designs[k]
        slot = opening_prism(opening.outline, opening.frame, opening.reach, scene.depth)
        if any((slot ^ plate).volume() > REACH_OVERLAP for plate in plates):
            continue
        key = round(d.reach, 1)
        if key not in envelopes:
            envelopes[key] = tool_envelope(d)
        path = placed(envelopes[key], opening.frame)  # type: ignore[arg-type]
        if (path ^ rest).volume() > REACH_OVERLAP:
            continue
        if sheet is not None:
            holed = sheet - cut_prism(opening, scene.depth)
            if (path ^ holed).volume() > REACH_OVERLAP:
                continue
        ok[k] = True
    return ok


def rooms_of(
    wanted: list[tuple[int, int, int]],
    lengths: dict[int, float],
    nearest: float,
    frames_at: Callable[[int, np.ndarray], np.ndarray],
    probe: Callable[[tuple[int, int], np.ndarray], np.ndarray],
) -> dict[tuple[int, int], tuple[int, ...]]:
    """(side, end) -> the grid steps (end distances / ``ROOM_STEP``) where the bolt can be
    reached, for each ``wanted`` (side, end, bolt index): ``frames_at(side, stations)`` gives
    the joint frames at arc lengths along the side, ``probe(bolt, frames)`` which of them pass
    (:func:`end_bolt_room`)."""
    rooms: dict[tuple[int, int], tuple[int, ...]] = {}
    for side, end, index in wanted:
        steps = room_grid(lengths[side], nearest)
        if not len(steps):
            rooms[(side, end)] = ()
            continue
        distances = steps * ROOM_STEP
        stations = distances if end == 0 else lengths[side] - distances
        ok = probe((side, index), frames_at(side, stations))
        rooms[(side, end)] = tuple(int(s) for s in steps[ok])
    return rooms
