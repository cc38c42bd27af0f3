"""The tool's swept envelope and the slot's prism as manifold3d solids, in the joint frame of
:mod:`fabpanel.fasteners` (where the sizes and the path are defined), and the reach check of a
built panel (:func:`reach_findings`)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import manifold3d as m3d
import numpy as np

from ..errors import Finding
from ..fasteners import AccessDesign
from .clash import part_solid
from .openings import Opening

#: the tool's path starts this far outside the access sheet's outer face, mm
OUTSIDE = 30.0
#: angles the swing is sampled at (consecutive positions are hulled)
SWING_STEPS = 7
#: segments of the tool's round parts
CIRCLE_SEGMENTS = 32


# --------------------------------------------------------------------------------------------
# the envelope
# --------------------------------------------------------------------------------------------
def _along_y(length: float, radius: float, start: float) -> m3d.Manifold:
    """A cylinder on the y axis from ``start`` to ``start + length``."""
    return (
        m3d.Manifold.cylinder(length, radius, -1.0, CIRCLE_SEGMENTS)
        .rotate((-90.0, 0.0, 0.0))
        .translate((0.0, start, 0.0))
    )


def _body(design: AccessDesign, shift: float) -> m3d.Manifold:
    tool = design.tool
    y = design.inner_end + shift
    parts = [_along_y(tool.head_thickness, tool.head_diameter / 2, y + tool.socket_length)]
    if tool.kind == "socket":
        parts.append(_along_y(tool.socket_length, tool.socket_diameter / 2, y))
    return m3d.Manifold.batch_boolean(parts, m3d.OpType.Add)


def tool_envelope(design: AccessDesign) -> m3d.Manifold:
    """The space the tool sweeps on its path (in, onto the hex, the swing), joint frame."""
    out = design.reach + OUTSIDE
    slid = _body(design, design.slide)
    insertion = m3d.Manifold.batch_hull([slid, slid.translate((0.0, 0.0, out))])
    onto = m3d.Manifold.batch_hull([slid, _body(design, 0.0)])
    tool = design.tool
    handle = m3d.Manifold.cube((tool.handle_width, tool.head_thickness, out), False).translate(
        (-tool.handle_width / 2, design.handle_start, 0.0)
    )
    angles = np.linspace(-tool.swing / 2, tool.swing / 2, SWING_STEPS)
    turned = [handle.rotate((0.0, float(a), 0.0)) for a in angles]
    sweeps = [m3d.Manifold.batch_hull([a, b]) for a, b in itertools.pairwise(turned)]
    # the handle rides along with the head while it slides onto the hex
    riding = m3d.Manifold.batch_hull([handle, handle.translate((0.0, design.slide, 0.0))])
    return m3d.Manifold.batch_boolean([insertion, onto, riding, *sweeps], m3d.OpType.Add)


def placed(solid: m3d.Manifold, frame: np.ndarray) -> m3d.Manifold:
    """A joint-frame solid moved to the world by ``frame`` (4, 4): columns x, y, z, origin."""
    return solid.transform(np.asarray(frame, dtype=float)[:3])


#: a tool path or a slot sharing more than this with a part is blocked, mm3
REACH_OVERLAP = 1.0


def opening_prism(
    outline: np.ndarray, frame: np.ndarray, reach: float, depth: float, margin: float = 10.0
):
    """An opening's outline ``(n, 2)`` extruded along its frame's z through the access sheet
    (``depth``: the sheet's thickness), ``margin`` mm past both faces at the frame's reach, in
    the world."""
    section = m3d.CrossSection([np.asarray(outline, dtype=float).tolist()])
    prism = section.extrude(depth + 2 * margin).translate((0.0, 0.0, reach - depth - margin))
    return placed(prism, frame)


def cut_prism(opening: Opening, depth: float) -> m3d.Manifold:
    """What an opening takes out of the sheet: its wall runs along z through the whole sheet,
    which may stand farther from the frame's reach across a merged opening (a corner's two
    slots in the first one's frame) on a curving sheet, so the prism runs as far again as the
    opening is wide past both faces."""
    margin = 10.0 + float(np.ptp(opening.outline, axis=0).max())
    return opening_prism(opening.outline, opening.frame, opening.reach, depth, margin)


def blocked_bolts(
    designs: dict[int, list[AccessDesign]],
    frames: dict[int, np.ndarray],
    obstacles: dict[str, m3d.Manifold],
) -> list[tuple[int, int, str, float]]:
    """The bolts whose tool path hits a part: ``(side, index, part id, common volume mm3)``,
    the part it shares the most with; each bolt's tool from its own design (its reach). ``obstacles``: the panel's parts as solids, the access
    sheet with its openings taken out."""
    if not obstacles:
        return []
    envelopes: dict[float, m3d.Manifold] = {}  # by reach, to 0.1 mm

    def envelope(design: AccessDesign) -> m3d.Manifold:
        key = round(design.reach, 1)
        if key not in envelopes:
            envelopes[key] = tool_envelope(design)
        return envelopes[key]

    paths = {
        (side, i): placed(envelope(designs[side][i]), frame)
        for side, stack in sorted(frames.items())
        for i, frame in enumerate(stack)
    }
    everything = m3d.Manifold.batch_boolean(list(obstacles.values()), m3d.OpType.Add)
    every_path = m3d.Manifold.batch_boolean(list(paths.values()), m3d.OpType.Add)
    if (every_path ^ everything).volume() <= REACH_OVERLAP:
        return []
    blocked = []
    for (side, i), path in paths.items():
        if (path ^ everything).volume() <= REACH_OVERLAP:
            continue
        shared = {pid: float((path ^ solid).volume()) for pid, solid in obstacles.items()}
        worst = max(shared, key=lambda pid: shared[pid])
        blocked.append((side, i, worst, shared[worst]))
    return blocked


def bolt_names(sheet: str, bolts: tuple[tuple[int, int], ...]) -> str:
    """``P012-RIB-1 bolt 2 and P012-RIB-2 bolt 0`` for an opening's bolts (numbered from 0)."""
    panel = sheet.rsplit("-", 1)[0] if sheet.count("-") else sheet
    names = [f"{panel}-RIB-{side} bolt {i}" for side, i in bolts]
    if len(names) > 3:
        return f"{', '.join(names[:2])} and {len(names) - 2} more bolts"
    return " and ".join(names)


@dataclass(frozen=True)
class ReachScene:
    """A built panel as the reach check sees it: each part as a solid (``solids``, the access
    sheet with its openings taken out), the access sheet without them (``bare``, None without
    one) and its openings with the prism each takes out of it."""

    solids: dict[str, m3d.Manifold]
    sheet_id: str | None
    bare: m3d.Manifold | None
    depth: float
    openings: tuple[Opening, ...]
    cuts: tuple[m3d.Manifold, ...]
    #: every part but the sheets (what an opening must not run under)
    plate_ids: tuple[str, ...]
    #: bolts (side, index) without a slot -> why
    missing: dict[tuple[int, int], str]

    @property
    def plates(self) -> dict[str, m3d.Manifold]:
        return {k: self.solids[k] for k in self.plate_ids}

    def sheet_without(self, bolt: tuple[int, int]) -> m3d.Manifold | None:
        """The access sheet with every opening cut but ``bolt``'s (None without one)."""
        if self.bare is None:
            return None
        sheet = self.bare
        for opening, cut in zip(self.openings, self.cuts, strict=True):
            if bolt not in opening.bolts:
                sheet = sheet - cut
        return sheet

    def others(self) -> m3d.Manifold:
        """Every part but the access sheet, as one solid."""
        rest = [solid for k, solid in self.solids.items() if k != self.sheet_id]
        return m3d.Manifold.batch_boolean(rest, m3d.OpType.Add)


def reach_scene(parts: list[dict], sheet_id: str) -> ReachScene:
    """The panel's ``parts`` as solids (:class:`ReachScene`), ``sheet_id`` the access sheet."""
    sheet = next((p for p in parts if p["id"] == sheet_id), None)
    openings: tuple[Opening, ...] = tuple(sheet["openings"]) if sheet else ()
    depth = sheet["thickness"] if sheet else 0.0
    cuts = tuple(cut_prism(o, depth) for o in openings)
    solids = {p["id"]: part_solid(p["clash_shape"], p["id"]) for p in parts}
    bare = None
    if sheet is not None:
        bare = solids[sheet["id"]]
        for cut in cuts:
            solids[sheet["id"]] = solids[sheet["id"]] - cut
    plates = tuple(p["id"] for p in parts if not p["kind"].startswith("sheet"))
    missing = dict(sheet["slot_missing"]) if sheet else {}
    return ReachScene(
        solids, sheet["id"] if sheet else None, bare, depth, openings, cuts, plates, missing
    )


def slot_clashes(pid: str, scene: ReachScene) -> tuple[list[Finding], list[tuple]]:
    """Openings that run under a rib or a stiffener (``access-clash``, a warning: the plate
    loses some of its seat on the sheet) and their bolts, as in :func:`reach_findings`."""
    findings: list[Finding] = []
    in_the_way: list[tuple[int, int, str, bool]] = []
    for opening in scene.openings:
        prism = opening_prism(opening.outline, opening.frame, opening.reach, scene.depth)
        for part_id, solid in scene.plates.items():
            shared = float((solid ^ prism).volume())
            if shared > REACH_OVERLAP:
                in_the_way += [(b[0], b[1], part_id, False) for b in opening.bolts]
                findings.append(
                    (
                        "access-clash",
                        scene.sheet_id or pid,
                        (
                            f"the access slot of {bolt_names(pid, opening.bolts)} runs "
                            f"under {part_id} ({shared:.0f} mm3)"
                        ),
                    )
                )
    return findings, in_the_way


def reach_findings(
    pid: str,
    scene: ReachScene,
    frames: dict[int, np.ndarray],
    designs: dict[int, list[AccessDesign]],
) -> tuple[list[Finding], list[tuple[int, int, str, bool]]]:
    """Openings that run under a plate (:func:`slot_clashes`), and bolts the tool cannot reach
    (``bolt-unreachable``, error): no slot was cut for them, or the tool's path hits a part of
    the panel (:func:`fabpanel.model.access.blocked_bolts`). Also the bolts in the way:
    ``(side, index, part id in the way or "", unreachable)``, for the build to move."""
    findings, in_the_way = slot_clashes(pid, scene)
    cut = {bolt for o in scene.openings for bolt in o.bolts}
    for side, stack in frames.items():
        for i in range(len(stack)):
            if (side, i) not in cut:
                in_the_way.append((side, i, "", True))
                findings.append(
                    (
                        "bolt-unreachable",
                        f"{pid}-RIB-{side}",
                        (
                            f"{pid}-RIB-{side} bolt {i}: no access slot could be cut for it: "
                            f"{scene.missing.get((side, i), 'its sheet has none')}"
                        ),
                        "error",
                    )
                )
    for side, i, part_id, shared in blocked_bolts(designs, frames, scene.solids):
        design = designs[side][i]
        if (side, i) not in cut:
            continue
        in_the_way.append((side, i, part_id, True))
        centre = np.round(frames[side][i][:3, 3], 1).tolist()
        findings.append(
            (
                "bolt-unreachable",
                f"{pid}-RIB-{side}",
                (
                    f"{pid}-RIB-{side} bolt {i}: the {design.tool.describe()} hits {part_id} "
                    f"({shared:.0f} mm3) on its way to the {design.bolt.name} at {centre}; "
                    "move the bolts (edge_distance, spacing), the stiffeners "
                    "(stiffener_offset) or choose another tool"
                ),
                "error",
            )
        )
    return findings, in_the_way
