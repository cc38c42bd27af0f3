"""Access slots in a sheet: one per bolt in its joint frame, merged where two come close, and
their outlines on the sheet's faces.

Each slot is the rounded rectangle of :class:`fabpanel.fasteners.AccessDesign` in its bolt's
joint frame, cut along the frame's z (the tool's way in), so the slot's wall is the prism the
reach check subtracts. Two slots closer than ``MIN_WEB`` (at a corner, the first bolts of the
two ribs) become one opening: both outlines in the first one's frame, united and closed with
``SLOT_CORNER`` rounds, so no web thinner than that is left between them to be cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..errors import KernelError
from ..fasteners import SLOT_CORNER, AccessDesign
from ..geom.polygon import graded_ring, polygon_area
from . import occ

#: slots closer than this become one opening, mm (a thinner web is a sliver to the plasma)
MIN_WEB = 10.0
#: a merged outline's rounds get this many chords per quarter circle (about 2 mm on a
#: ``SLOT_CORNER`` round, as a single slot's), its straight runs points graded up to
#: ``OUTLINE_STEP`` mm apart (:func:`.geom.polygon.graded_ring`): a periodic cubic through them
#: keeps within 0.1 mm of the exact union of the two slots (tests/test_openings.py; the
#: plasma holds ±0.5 mm, and the model and the cut file use the same points), and every point
#: is a pole of the hole's curves in the model files
ROUND_CHORDS = 4
OUTLINE_STEP = 8.0
#: points closer than this to the line through their neighbours are left out, mm
STRAIGHT = 0.005
#: every this many slot outline points are checked for the farthest reach
FOOTPRINT_STRIDE = 3


@dataclass(frozen=True)
class Opening:
    """One opening of a sheet: its outline ``(n, 2)`` in ``frame``'s (x, y), cut along the
    frame's z, and the bolts ``(side, index)`` it serves."""

    frame: np.ndarray
    outline: np.ndarray
    bolts: tuple[tuple[int, int], ...]
    #: from the bolt to the access sheet's outer face along the frame's z, mm
    reach: float

    @property
    def area(self) -> float:
        return abs(polygon_area(self.outline))


def slot_openings(
    designs: dict[int, list[AccessDesign]], frames: dict[int, np.ndarray], depth: float
) -> list[Opening]:
    """The openings for the bolts whose joint frames are ``frames`` (side -> (n, 4, 4)), each
    bolt's slot from its own design (its reach), in a sheet ``depth`` mm thick."""
    openings = [
        Opening(frame, designs[side][i].slot, ((side, i),), designs[side][i].reach)
        for side, stack in sorted(frames.items())
        for i, frame in enumerate(stack)
    ]
    merged = True
    while merged:
        merged = False
        for a in range(len(openings)):
            for b in range(a + 1, len(openings)):
                joined = _joined(openings[a], openings[b], depth)
                if joined is not None:
                    openings[a] = joined
                    del openings[b]
                    merged = True
                    break
            if merged:
                break
    return openings


def _in_frame(opening: Opening, frame: np.ndarray, level: float) -> np.ndarray:
    """``opening``'s outline at ``z = level`` of its frame, in ``frame``'s (x, y)."""
    local = np.c_[
        opening.outline, np.full(len(opening.outline), level), np.ones(len(opening.outline))
    ]
    world = local @ opening.frame.T
    return (world @ np.linalg.inv(frame).T)[:, :2]


def _joined(first: Opening, second: Opening, depth: float) -> Opening | None:
    """Both openings as one in ``first``'s frame when they come within ``MIN_WEB``."""
    if np.linalg.norm(first.frame[:3, 3] - second.frame[:3, 3]) > 4 * np.ptp(first.outline).max():
        return None
    mine = Polygon(first.outline)
    # the second tool comes in along its own z: its slot on both faces of the sheet
    theirs = shapely.union_all(
        [Polygon(_in_frame(second, first.frame, second.reach - dz)) for dz in (0.0, depth)]
    ).convex_hull
    if mine.distance(theirs) >= MIN_WEB:
        return None
    union = shapely.union(mine, theirs)
    union = union.buffer(SLOT_CORNER, quad_segs=ROUND_CHORDS).buffer(
        -SLOT_CORNER, quad_segs=ROUND_CHORDS
    )
    if union.geom_type != "Polygon":
        union = union.convex_hull
    ring = np.asarray(union.simplify(STRAIGHT).exterior.coords)[:-1]
    if polygon_area(ring) < 0:
        ring = ring[::-1]
    return Opening(
        first.frame,
        graded_ring(ring, longest=OUTLINE_STEP),
        first.bolts + second.bolts,
        first.reach,
    )


def _stacked(openings: list[Opening]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """Every opening's outline points ``(n, 2)``, the frame of each ``(n, 4, 4)``, the point
    on the line through each opening's centre at its reach ``(m, 3)`` and the counts."""
    counts = [len(o.outline) for o in openings]
    frames = np.repeat(np.array([o.frame for o in openings]), counts, axis=0)
    goal = np.concatenate([o.outline for o in openings])
    centres = np.array([o.frame[:3, 3] + o.reach * o.frame[:3, 2] for o in openings])
    return goal, frames, centres, counts


def _walls_on_surface(
    surface, openings: list[Opening]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """Where the lines along each frame's z through the openings' outline points meet
    ``surface``: ``(n, 2)`` surface parameters, ``(n,)`` found and ``(n,)`` within the
    surface's domain, and the points per opening. 2D Newton per point (the surface point whose
    (x, y) in the frame is the outline point), from the projection of its opening's centre."""
    goal, frames, centres, counts = _stacked(openings)
    e1, e2, origin = frames[:, :3, 0], frames[:, :3, 1], frames[:, :3, 3]
    uv = np.repeat(occ.project_to_surface(surface, centres), counts, axis=0)
    f = np.full_like(goal, np.inf)
    for _ in range(30):
        p, du, dv = occ.surface_derivatives(surface, uv)
        rel = p - origin
        f = np.stack([np.einsum("nd,nd->n", rel, e1), np.einsum("nd,nd->n", rel, e2)], 1) - goal
        if np.abs(f).max() < 1e-7:
            break
        jac = np.stack(
            [
                np.stack([np.einsum("nd,nd->n", e1, du), np.einsum("nd,nd->n", e1, dv)], 1),
                np.stack([np.einsum("nd,nd->n", e2, du), np.einsum("nd,nd->n", e2, dv)], 1),
            ],
            axis=1,
        )
        step = np.linalg.solve(jac + 1e-12 * np.eye(2), f[..., None])[..., 0]
        uv = np.where(np.isfinite(step), uv - step, uv)
    found = np.asarray(np.isfinite(f).all(axis=1) & (np.abs(f).max(axis=1, initial=0.0) < 1e-6))
    inside = np.asarray(((uv > -1e-9) & (uv < 1 + 1e-9)).all(axis=1))
    return uv, found, inside, counts


def opening_loops(surface, openings: list[Opening]) -> list[np.ndarray | str]:
    """Where each opening's wall (its outline moved along the frame's z) meets a surface, as a
    closed loop of surface parameters, or why there is none (the opening leaves the sheet, or
    the surface curves so strongly under it that its outline was not found)."""
    if not openings:
        return []
    uv, found, inside, counts = _walls_on_surface(surface, openings)
    ok = found & inside
    loops: list[np.ndarray | str] = []
    cuts = np.cumsum(counts)[:-1]
    for chunk, chunk_found, chunk_ok in zip(
        np.split(uv, cuts), np.split(found, cuts), np.split(ok, cuts), strict=True
    ):
        if chunk_ok.all():
            loops.append(chunk)
        elif chunk_found.all():
            loops.append("it would reach past the sheet's edge")
        else:
            loops.append("its outline on the sheet was not found (the sheet curves too much there)")
    return loops


def footprint_reaches(
    surface, frames: dict[int, np.ndarray], designs: dict[int, list[AccessDesign]]
) -> dict[int, np.ndarray]:
    """Side -> (n,) float: the farthest ``surface`` (the access sheet's outer face) stands
    along each bolt's frame z over the outline of its slot, at least the design's reach, mm.
    On a sheet curving away under the slot the tool's handle leaves the sheet farther out and
    swings wider there than at the bolt's own reach (outline points every ``FOOTPRINT_STRIDE``
    and points not found or beyond the sheet's edge are left out)."""
    keys = [(side, i) for side, stack in sorted(frames.items()) for i in range(len(stack))]
    if not keys:
        return {side: np.zeros(0) for side in frames}
    openings = [
        Opening(frames[s][i], designs[s][i].slot[::FOOTPRINT_STRIDE], (), designs[s][i].reach)
        for s, i in keys
    ]
    try:
        uv, found, inside, counts = _walls_on_surface(surface, openings)
    except KernelError:  # a degenerate panel: its sheet build will say what is wrong
        return {side: np.array([d.reach for d in designs[side]]) for side in frames}
    points = occ.surface_points(surface, uv[:, 0], uv[:, 1])
    _, stacked, _, _ = _stacked(openings)
    along = np.einsum("nd,nd->n", points - stacked[:, :3, 3], stacked[:, :3, 2])
    # only the sheet itself: beyond its edge the surface is the boundary span's cubic
    # extrapolated, which runs metres off within a slot's width; a slot past the edge is
    # refused anyway (opening_loops), and its reach must not feed a wider slot
    along = np.where(found & inside, along, -np.inf)
    out = {side: np.array([d.reach for d in designs[side]]) for side in frames}
    for (side, i), chunk in zip(keys, np.split(along, np.cumsum(counts)[:-1]), strict=True):
        out[side][i] = max(out[side][i], float(chunk.max()))
    return out


def reaches_along_z(surface, frames: dict[int, np.ndarray], guess: float) -> dict[int, np.ndarray]:
    """Side -> (n,) float: how far each bolt's frame z runs to ``surface`` (the access sheet's
    outer face), mm; ``guess`` where it was not found."""
    out = {}
    for side, stack in frames.items():
        points = [Opening(f, np.zeros((1, 2)), (), guess) for f in stack]
        try:
            found = opening_loops(surface, points) if points else []
        except KernelError:  # a degenerate panel: its sheet build will say what is wrong
            found = ["not found"] * len(points)
        reach = []
        for frame, uv in zip(stack, found, strict=True):
            if isinstance(uv, str):
                reach.append(guess)
                continue
            point = occ.surface_points(surface, uv[:, 0], uv[:, 1])[0]
            reach.append(float((point - frame[:3, 3]) @ frame[:3, 2]))
        out[side] = np.array(reach)
    return out


def bolt_designs(
    design: AccessDesign, surface, frames: dict[int, np.ndarray]
) -> dict[int, list[AccessDesign]]:
    """Side -> the tool and slot of each bolt whose joint frames are ``frames``, sized for its
    own reach to ``surface`` (the access sheet's outer face): at first the reach above the bolt,
    then twice the farthest over the slot (a wider slot may run farther up a curving sheet)."""
    reaches = reaches_along_z(surface, frames, design.reach)
    designs = {side: [design.at_reach(r) for r in reach] for side, reach in reaches.items()}
    for _ in range(2):
        reaches = footprint_reaches(surface, frames, designs)
        designs = {side: [design.at_reach(r) for r in reach] for side, reach in reaches.items()}
    return designs
