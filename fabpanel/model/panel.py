"""One panel's steel parts, built in a worker process from plain data (arrays in, BREP out).

Parts of a sandwich panel (ids ``P012-TOP``, ``-BOT``, ``-RIB-0..3``, ``-STF-0..3``, and
``-PCK-<side>-<bolt>`` with an erection gap):

- **sheets**: each face of a sheet (outer and inner) is the developed grid moved along the
  developed normals, trimmed at the four rib planes (:mod:`fabpanel.model.trim`) moved into the
  panel by the weld set-back on interior sides (:mod:`fabpanel.buildup`: the fillet weld then
  stays off the face the neighbour's rib seats against); the solid is sewn from the two faces
  and the ruled strips between their edges (planar, parallel to the rib plane).
- **ribs**: a flat plate per side in the side's rib plane (moved in by half the erection gap on
  interior sides), extruded into the panel by the rib thickness, so back-to-back ribs of
  neighbours touch in that plane, or stand the gap apart. Its outline runs along the
  top sheet's inner face and the bottom sheet's upper face; where the sheet is bevelled against
  the rib, the edge is taken at whichever face of the plate meets the sheet first, so the plate
  never enters a sheet (a wedge of at most ``t_rib tan(bevel)`` is left for the weld). Ribs 0
  and 2 run to the outer faces of ribs 1 and 3, which stop at the inner faces of ribs 0 and 2:
  the corners are closed and no two ribs overlap.
- **corner stiffeners**: at each corner, a flat plate across the corner through the points at
  ``stiffener_offset`` along both sides (the thesis's construction, §7.3.2 d), in the plane
  holding that chord and the panel normal at the corner, between the sheets, its ends at the
  two ribs' inner faces. It faces the corner and is extruded away from it. Stiffeners, and
  ribs 1 and 3 at their ends, are sniped where three welds would meet (:mod:`.plates`).
- **bolt holes** (interior sides only: a boundary rib has no partner) at the stations of
  :mod:`fabpanel.model.joints`, and **access openings** in the sheet chosen in the job beside
  every bolt, drilled along the sheet normal.
- **packing plates**, with an erection gap: a square plate filling the gap at each bolt, holed
  for it, supplied by the joint's panel with the lower index.

A cladding panel is the top sheet alone, untrimmed (no ribs to meet).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import Finding, KernelError
from ..fasteners import AccessDesign
from ..tolerances import TOLERANCES
from . import joints, occ
from .access import ReachScene, reach_findings, reach_scene
from .bolt_room import end_bolt_room, rooms_of
from .openings import (
    Opening,
    bolt_designs,
    opening_loops,
    slot_openings,
)
from .plates import packing_plate, rib, stiffener
from .records import PanelPayload, PanelResult
from .trim import TrimmedFace, side_curve, side_rows, trimmed_face

#: dense samples of sheet fibre grids per sample interval of the developed grid
GRID_REFINE = 4
#: corners opening wider than this get no stiffener (degrees): the two ribs are nearly one line
MAX_STIFFENED_ANGLE = 150.0


class _Faces:
    """The build-up's faces of one panel, each trimmed at the rib planes moved into the panel
    by ``shifts (4,)`` mm (0: the contact planes), each trim made once."""

    def __init__(self, payload: PanelPayload, findings: list[Finding]) -> None:
        self.payload, self.findings = payload, findings
        k = payload.samples.shape[0]
        self.centre_normal = payload.normals[k // 2, k // 2]
        self.planes = payload.planes / np.linalg.norm(payload.planes[:, :3], axis=1, keepdims=True)
        self.done: dict[tuple[str, bytes], tuple[TrimmedFace, np.ndarray]] = {}
        self.reported: set[tuple[str, int]] = set()

    def __call__(self, face: str, shifts: np.ndarray) -> TrimmedFace:
        key = (face, np.asarray(shifts, float).tobytes())
        if key not in self.done:
            self.done[key] = (self._trim(face, shifts), shifts)
        return self.done[key][0]

    def _trim(self, face: str, shifts: np.ndarray) -> TrimmedFace:
        p = self.payload
        part = f"{p.panel_id}-{'TOP' if face.startswith('top') else 'BOT'}"
        limit = p.slide_limit + float(np.max(shifts))
        result = trimmed_face(
            p.samples + p.buildup.offset(face) * p.normals,
            self.centre_normal,
            moved_in(self.planes, shifts),
            np.full(4, p.buildup.sandwich),
            limit,
            f"{part} {face}",
        )
        for side in np.flatnonzero(result.untrimmed):
            if (part, int(side)) not in self.reported:
                self.reported.add((part, int(side)))
                self.findings.append(
                    _untrimmed_finding(
                        part, int(side), result, moved_in(self.planes, shifts), p.origin
                    )
                )
        return result

    def measures(self) -> dict[str, float]:
        """The largest fit error and the largest slide beyond the planned shift, mm."""
        faces = list(self.done.values())
        return {
            "sheet_fit_error_mm": max(f.fit_error for f, _ in faces),
            "sheet_trim_slide_mm": max(float(np.max(f.slide - s)) for f, s in faces),
        }


def _untrimmed_finding(
    part: str, side: int, face: TrimmedFace, planes: np.ndarray, origin: np.ndarray
) -> Finding:
    """A sheet face edge left at the developed edge: an error when it stands farther off its
    rib plane than a weld bridges (the sheet does not meet its rib), a warning otherwise; it
    says where, at the edge's point farthest off (model coordinates)."""
    edge = side_curve(face.surface, side, 33)
    distance = np.abs(edge @ planes[side, :3] - planes[side, 3])
    off = float(distance.max())
    where = ", ".join(f"{c:.0f}" for c in edge[int(np.argmax(distance))] + origin)
    why = (
        f"sheet face edge {side} left at the developed edge, {off:.1f} mm off its rib plane "
        f"at ({where}) mm: "
        "the plane meets the face only after a long slide or not at all (a rib plane nearly "
        "tangent to the sheet, or two rib planes meeting along a line nearly in it)"
    )
    if off <= TOLERANCES.untrimmed_gap:
        return ("sheet-not-trimmed", part, why)
    fix = (
        "the sheet does not meet its rib, so the panel cannot be closed as built: "
        "make the panels smaller or raise [develop] rib_planarity"
    )
    return ("sheet-not-trimmed", part, f"{why}; {fix}", "error")


def folded_cells(samples: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(k-1, k-1) bool: the cells of a sample grid ``samples (k, k, 3)`` that face against its
    ``normals (k, k, 3)`` or have no area (below :data:`FOLDED_AREA` of the median cell's):
    the grid folds back over itself or collapses there. The cell's vector area is half the
    cross product of its diagonals, taken against the mean of its four corner normals."""
    d1 = samples[1:, 1:] - samples[:-1, :-1]
    d2 = samples[:-1, 1:] - samples[1:, :-1]
    mean = normals[1:, 1:] + normals[:-1, :-1] + normals[:-1, 1:] + normals[1:, :-1]
    signed = np.einsum("ijk,ijk->ij", np.cross(d1, d2), mean)
    signed = signed * np.sign(np.median(signed))  # the grid's own turning sense
    return signed <= FOLDED_AREA * np.abs(np.median(signed))


#: a cell of a developed grid whose area is below this share of the median cell's is collapsed
FOLDED_AREA = 1e-6


def _refuse_folded_grid(payload: PanelPayload) -> None:
    """Raise :class:`KernelError` where the developed grid folds back over itself or collapses:
    no sheet can be built through it (OCCT would make a self-overlapping face, or none)."""
    folded = folded_cells(payload.samples, payload.normals)
    if folded.any():
        rows, cols = np.nonzero(folded)
        raise KernelError(
            f"developed samples of {payload.panel_id} fold back over themselves or collapse "
            f"in {int(folded.sum())} of {folded.size} cells (rows {rows.min()}-{rows.max() + 1}, "
            f"columns {cols.min()}-{cols.max() + 1} of the sample grid): the panel cannot be "
            "made as one sheet; develop it again (a smaller panel size where it folds)"
        )


def moved_in(planes: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """(4, 4) float: unit ``planes`` (normals into the panel) moved ``shifts (4,)`` mm in."""
    moved = np.array(planes, float, copy=True)
    moved[:, 3] += shifts
    return moved


def build_panel(payload: PanelPayload, where: list[str] | None = None) -> PanelResult:
    """All parts of one panel (see the module docstring): part records (BREP bytes, outlines,
    holes) and the panel's measures and findings.

    where : when given, its last item is set to the id of the part being built, so that a
    caller can name the part an exception came from (not every kernel message names it).
    """
    pid = payload.panel_id
    where = [pid] if where is None else where

    def building(part: str) -> None:
        where[-1] = part

    bu = payload.buildup
    interior = np.asarray(payload.interior, bool)
    _refuse_folded_grid(payload)
    # the ribs stand half the erection gap in from the contact plane, the sheets the set-back
    # further at the joints (boundary sides stay flush: see fabpanel.buildup)
    rib_shift = np.where(interior, bu.welds.erection_gap / 2, 0.0)
    sheet_shift = rib_shift + np.where(interior, bu.welds.setback, 0.0)
    findings: list[Finding] = []
    faces = _Faces(payload, findings)
    building(f"{pid}-TOP")
    sheets = {"top_outer": faces("top_outer", sheet_shift)}
    sheets["top_inner"] = faces("top_inner", sheet_shift)
    bolts: dict[int, np.ndarray] = {}
    if bu.sandwich:
        building(f"{pid}-BOT")
        sheets["bottom_upper"] = faces("bottom_upper", sheet_shift)
        sheets["bottom_lower"] = faces("bottom_lower", sheet_shift)
        bolts = _bolt_centres(payload, faces.planes, building)
    on_ribs = {s: c + rib_shift[s] * faces.planes[s, :3] for s, c in bolts.items()}
    design: AccessDesign | None = bu.access if bu.sandwich else None
    access = bu.bolts.access_sheet if design is not None else "none"
    rib_planes = moved_in(faces.planes, rib_shift)
    frames = _joint_frames(payload.samples, payload.normals, rib_planes, on_ribs, access)
    designs: dict[int, list[AccessDesign]] = {}
    if design is not None and frames:
        outside = sheets["top_outer"] if access == "top" else sheets["bottom_lower"]
        designs = bolt_designs(design, outside.surface, frames)
    building(f"{pid}-TOP")
    k = payload.samples.shape[0]
    parts = [
        _sheet(
            f"{pid}-TOP",
            "sheet-top",
            sheets["top_outer"],
            sheets["top_inner"],
            bu.t_top,
            payload.fibre,
            k,
            frames if access == "top" else {},
            designs,
        )
    ]
    measures: dict = {}
    if bu.sandwich:
        building(f"{pid}-BOT")
        parts.append(
            _sheet(
                f"{pid}-BOT",
                "sheet-bottom",
                sheets["bottom_upper"],
                sheets["bottom_lower"],
                bu.t_bot,
                payload.fibre,
                k,
                frames if access == "bottom" else {},
                designs,
            )
        )
        plates = _plates(payload, faces, rib_shift, on_ribs, findings, building)
        plates += _packing_plates(payload, faces.planes, bolts, building)
        parts += plates
        measures["plate_planarity_mm"] = {r["id"]: r["planarity"] for r in plates}
        measures["rib_node_cut_mm"] = {
            r["id"]: round(r["node_cut"], 2) for r in plates if r.get("node_cut", 0.0) > 0.01
        }
        building(pid)
        findings += _clearance_findings(pid, parts, bolts, bu.bolts.diameter)
        if design is not None:
            scene = reach_scene(parts, f"{pid}-{'TOP' if access == 'top' else 'BOT'}")
            found, blocked = reach_findings(pid, scene, frames, designs)
            findings += found
            measures["bolts_in_the_way"] = blocked
            access_faces = (
                (sheets["top_outer"], sheets["top_inner"])
                if access == "top"
                else (sheets["bottom_upper"], sheets["bottom_lower"])
            )
            measures["end_bolt_room"] = _end_bolt_rooms(
                payload,
                faces.planes,
                rib_shift,
                bolts,
                blocked,
                design,
                access,
                access_faces,
                scene,
            )
    measures.update(faces.measures())
    measures["bolts"] = int(sum(len(b) for b in bolts.values()))
    measures["access_openings"] = int(
        sum(len(p["openings"]) for p in parts if p["kind"].startswith("sheet"))
    )
    # (side, bolt index) of each bolt the tool cannot reach from this panel
    measures["bolts_unreachable"] = sorted(
        {(b[0], b[1]) for b in measures.get("bolts_in_the_way", []) if b[3]}
    )
    measures["bolts_checked"] = design is not None
    measures["valid"] = all(p["valid"] for p in parts)
    building(f"{pid}-TOP")
    # the top sheet's outer edges at the contact planes: neighbours share them exactly
    contact_top = faces("top_outer", np.zeros(4))
    return PanelResult(
        panel_id=pid,
        parts=tuple(parts),
        measures=measures,
        findings=tuple(findings),
        bolts=bolts,
        top_edges=tuple(side_curve(contact_top.surface, side, 129) for side in range(4)),
    )


def _bolt_centres(
    payload: PanelPayload, planes: np.ndarray, building: Callable[[str], None]
) -> dict[int, np.ndarray]:
    """Side -> (n, 3) float: the bolt centres of each interior side, on its contact plane at
    mid-height of the ribs."""
    bolts = {}
    for side in np.flatnonzero(payload.interior):
        building(f"{payload.panel_id}-RIB-{side}")
        bolts[int(side)] = _centres_at(payload, planes, int(side), payload.stations_of(int(side)))
    return bolts


def _centres_at(
    payload: PanelPayload, planes: np.ndarray, side: int, stations: np.ndarray | None
) -> np.ndarray:
    """(n, 3) float: bolt centres on ``side``'s contact plane at mid-height of the ribs, at
    the arc lengths ``stations`` (None: the job's spacing and edge distance)."""
    bu = payload.buildup
    mid = (bu.offset("top_inner") + bu.offset("bottom_upper")) / 2
    return joints.bolt_centres(
        side_rows(payload.samples)[side],
        side_rows(payload.normals)[side],
        planes[side],
        mid,
        bu.bolts.spacing,
        bu.bolts.edge_distance,
        stations,
    )


def _end_bolt_rooms(
    payload: PanelPayload,
    planes: np.ndarray,
    rib_shift: np.ndarray,
    bolts: dict[int, np.ndarray],
    blocked: list[tuple[int, int, str, bool]],
    design: AccessDesign,
    access: str,
    access_faces: tuple[TrimmedFace, TrimmedFace],
    scene: ReachScene,
) -> dict[tuple[int, int], tuple[int, ...]]:
    """(side, end) -> where the end bolts in the way could be reached
    (:mod:`fabpanel.model.bolt_room`), for the build to move them."""
    wanted = sorted(
        {
            (side, 0 if i == 0 else 1, i)
            for side, i, _, _ in blocked
            if len(bolts.get(side, ())) >= 2 and i in (0, len(bolts[side]) - 1)
        }
    )
    if not wanted:
        return {}
    rib_planes = moved_in(planes, rib_shift)
    outside = access_faces[1] if access == "bottom" else access_faces[0]

    def frames_at(side: int, stations: np.ndarray) -> np.ndarray:
        centres = _centres_at(payload, planes, side, stations) + rib_shift[side] * planes[side, :3]
        return _joint_frames(payload.samples, payload.normals, rib_planes, {side: centres}, access)[
            side
        ]

    def probe(bolt: tuple[int, int], frames: np.ndarray) -> np.ndarray:
        return end_bolt_room(
            bolt,
            frames,
            design,
            (access_faces[0].surface, access_faces[1].surface),
            outside.surface,
            scene,
        )

    lengths = {
        side: float(np.linalg.norm(np.diff(side_rows(payload.samples)[side], axis=0), axis=1).sum())
        for side, _, _ in wanted
    }
    return rooms_of(wanted, lengths, 1.2 * design.bolt.hole, frames_at, probe)


def _plates(
    payload: PanelPayload,
    faces: _Faces,
    shifts: np.ndarray,
    bolts: dict[int, np.ndarray],
    findings: list[Finding],
    building: Callable[[str], None],
) -> list[dict]:
    """The four ribs and the corner stiffeners, against the sheet faces trimmed at the rib
    planes (moved in by ``shifts``); what cannot be built goes to ``findings``."""
    pid, bu = payload.panel_id, payload.buildup
    planes = moved_in(faces.planes, shifts)
    top_outer, top_inner, bottom_upper = (
        faces(face, shifts) for face in ("top_outer", "top_inner", "bottom_upper")
    )
    k_mid = payload.samples.shape[0] // 2
    ribs = []
    for side in range(4):
        name = f"{pid}-RIB-{side}"
        normal = side_rows(payload.normals)[side][k_mid]
        tilt = float(np.degrees(np.arcsin(min(1.0, abs(normal @ planes[side, :3])))))
        if tilt > 90.0 - TOLERANCES.rib_tangent_deg:
            findings.append(
                (
                    "rib-plane-tangent",
                    name,
                    (
                        f"rib plane within {90 - tilt:.0f} degrees of the sheet: the rib lies "
                        "nearly flat, not between the sheets; change the layout at this edge"
                    ),
                )
            )
    for side in range(4):
        name = f"{pid}-RIB-{side}"
        building(name)
        try:
            ribs.append(
                rib(
                    name,
                    side,
                    planes,
                    top_inner,
                    bottom_upper,
                    bu.t_rib,
                    bolts.get(side),
                    bu.bolts.diameter,
                    bu.welds.snipe,
                    _rib_nodes(payload, side),
                )
            )
        except KernelError as err:
            # a degenerate panel edge (e.g. a boundary rib plane nearly tangent to the
            # sheet): the rest of the panel is built, the missing rib is an error issue
            findings.append(("plate-failed", name, f"not built: {err}", "error"))
    return ribs + _stiffeners(
        payload, planes, (top_outer, top_inner, bottom_upper), findings, building
    )


def _rib_nodes(payload: PanelPayload, side: int) -> tuple[np.ndarray, np.ndarray]:
    """The rib-plane pairs of the panels meeting this one only at either corner of ``side``
    (:func:`fabpanel.model.nodes.node_planes`; none when the payload has none)."""
    if not payload.nodes:
        return np.empty((0, 2, 5)), np.empty((0, 2, 5))
    return payload.nodes[side], payload.nodes[(side + 1) % 4]


def _stiffeners(
    payload: PanelPayload,
    planes: np.ndarray,
    faces: tuple[TrimmedFace, TrimmedFace, TrimmedFace],
    findings: list[Finding],
    building: Callable[[str], None],
) -> list[dict]:
    """The corner stiffeners (``faces``: top outer, top inner, bottom upper at the rib
    planes); corners skipped go to ``findings``."""
    pid, bu = payload.panel_id, payload.buildup
    lengths = [
        float(np.linalg.norm(np.diff(row, axis=0), axis=1).sum())
        for row in side_rows(payload.samples)
    ]
    short = [s for s in range(4) if lengths[s] < 2 * bu.stiffener_offset + 1.0]
    if short:
        # the stiffeners at both ends of a side would meet or cross
        findings.append(
            (
                "stiffeners-skipped",
                pid,
                (
                    f"no corner stiffeners: side(s) {short} shorter than twice the stiffener "
                    f"offset ({bu.stiffener_offset:g} mm); lower [sandwich] stiffener_offset or "
                    "enlarge the panels"
                ),
            )
        )
        return []
    stiffeners = []
    for corner in range(4):
        name = f"{pid}-STF-{corner}"
        building(name)
        angle = _corner_angle(payload.samples, corner)
        if angle > MAX_STIFFENED_ANGLE:
            findings.append(
                (
                    "stiffener-skipped",
                    name,
                    (
                        f"corner opens {angle:.0f} degrees (> {MAX_STIFFENED_ANGLE:g}): "
                        "nothing to stiffen"
                    ),
                )
            )
            continue
        try:
            stiffeners.append(
                stiffener(
                    name,
                    corner,
                    planes,
                    *faces,
                    bu.stiffener_offset,
                    bu.t_stf,
                    bu.t_rib,
                    bu.welds.snipe,
                )
            )
        except KernelError as err:
            findings.append(("stiffener-skipped", name, _unseated(payload, planes, corner, err)))
    return stiffeners


def _unseated(payload: PanelPayload, planes: np.ndarray, corner: int, err: KernelError) -> str:
    """Why a corner's stiffener could not be built: where one of its two ribs stands well off
    square to the sheet (a boundary rib following a design edge that curves in the sheet's
    plane: a vault's level base ribs under sheets rising at 44 degrees), that rib, not the
    panel's size, left the stiffener no seat."""
    rows = side_rows(payload.normals)
    leans = {}
    for side in (corner, (corner - 1) % 4):
        normal = planes[side, :3] / np.linalg.norm(planes[side, :3])
        sines = np.abs(rows[side][1:-1] @ normal)
        leans[side] = float(np.degrees(np.arcsin(min(1.0, sines.max()))))
    side = max(leans, key=lambda s: leans[s])
    if leans[side] <= TOLERANCES.square_rib_lean_deg:
        return f"not built: {err}"
    return (
        f"not built: rib {side} stands {leans[side]:.0f} degrees off square to the sheet (a "
        "boundary rib following a design edge that curves in the sheet's plane), which leaves "
        "the stiffener no seat; the corner is held by its ribs alone"
    )


def _packing_plates(
    payload: PanelPayload,
    planes: np.ndarray,
    bolts: dict[int, np.ndarray],
    building: Callable[[str], None],
) -> list[dict]:
    """The packing plates closing the erection gap at every bolt of the sides this panel
    supplies them for (one panel per joint)."""
    bu = payload.buildup
    if bu.welds.erection_gap <= 0:
        return []
    plates = []
    for side, centres in sorted(bolts.items()):
        if not payload.packs[side]:
            continue
        row = side_rows(payload.samples)[side]
        for i, centre in enumerate(centres):
            name = f"{payload.panel_id}-PCK-{side}-{i}"
            building(name)
            plates.append(
                packing_plate(
                    name,
                    planes[side],
                    centre,
                    row[-1] - row[0],
                    bu.welds.packing,
                    bu.welds.erection_gap,
                    bu.bolts.diameter,
                )
            )
    return plates


def _corner_angle(samples: np.ndarray, corner: int) -> float:
    """Interior angle of the developed grid at a corner, degrees."""
    rows = side_rows(samples)
    incoming, outgoing = rows[(corner - 1) % 4], rows[corner]
    a, b = incoming[-2] - incoming[-1], outgoing[1] - outgoing[0]
    cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _joint_frames(
    samples: np.ndarray,
    normals: np.ndarray,
    planes: np.ndarray,
    bolts: dict[int, np.ndarray],
    access: str,
) -> dict[int, np.ndarray]:
    """Side -> the joint frames of its bolts (:func:`joints.joint_frames`), z towards the
    access sheet; empty without one."""
    if access == "none":
        return {}
    sign = 1.0 if access == "top" else -1.0
    return {
        side: joints.joint_frames(
            side_rows(samples)[side],
            planes[side],
            centres,
            sign * side_rows(normals)[side].mean(axis=0),
        )
        for side, centres in bolts.items()
    }


# --------------------------------------------------------------------------------------------
# sheets
# --------------------------------------------------------------------------------------------
def _sheet(
    name: str,
    kind: str,
    outer: TrimmedFace,
    inner: TrimmedFace,
    thickness: float,
    fibre: str,
    k: int,
    frames: dict[int, np.ndarray],
    designs: dict[int, list[AccessDesign]],
) -> dict:
    """A sheet solid between two trimmed faces (``outer``: away from the ribs for the top
    sheet, the face on the ribs for the bottom sheet), with the access slots of the bolts whose
    joint frames are ``frames`` (empty: none)."""
    dense = GRID_REFINE * (k - 1) + 1
    grid_a = occ.sample_surface(outer.surface, dense, dense)
    grid_b = occ.sample_surface(inner.surface, dense, dense)
    # "outer" and "inner" fibres: the sheet's face away from / towards the panel's ribs
    cavity_face_first = kind == "sheet-bottom"
    depth = {
        "mid": 0.5,
        "outer": 1.0 if cavity_face_first else 0.0,
        "inner": 0.0 if cavity_face_first else 1.0,
    }[fibre]
    surface_grid = (1 - depth) * grid_a + depth * grid_b
    mid_area = _grid_area((grid_a + grid_b) / 2)
    kept: list[tuple[Opening, np.ndarray, np.ndarray]] = []
    # bolts without a slot -> why (reported by the reach check as unreachable)
    missing: dict[tuple[int, int], str] = {}
    if designs and frames:
        openings = slot_openings(designs, frames, thickness)
        loops_a = opening_loops(outer.surface, openings)
        loops_b = opening_loops(inner.surface, openings)
        for opening, a, b in zip(openings, loops_a, loops_b, strict=True):
            if isinstance(a, str) or isinstance(b, str):
                why = a if isinstance(a, str) else str(b)
                untrimmed = np.flatnonzero(outer.untrimmed | inner.untrimmed)
                if len(untrimmed):
                    why += f" (its edge {', '.join(map(str, untrimmed))} was left untrimmed)"
                missing.update(dict.fromkeys(opening.bolts, why))
            else:
                kept.append((opening, a, b))
    try:
        solid = occ.slab(outer.surface, inner.surface, name, [(a, b) for _, a, b in kept])
    except KernelError as err:
        if not kept:
            raise
        why = f"the sheet with its slots was not valid ({err})"
        missing.update(dict.fromkeys((b for o, _, _ in kept for b in o.bolts), why))
        solid = occ.slab(outer.surface, inner.surface, name)
        kept = []
    opening_area = sum(o.area for o, _, _ in kept)
    cavity = 1 if kind == "sheet-top" else 0
    volume, centroid = occ.mass_properties(solid)
    return {
        "slot_missing": missing,
        "id": name,
        "kind": kind,
        "thickness": thickness,
        "volume": volume,
        "centroid": centroid,
        "area": float(mid_area - opening_area),
        "brep": occ.to_brep(solid),
        "surface_grid": surface_grid,
        "holes": [],
        "openings": [o for o, _, _ in kept],
        "opening_loops": [loops[cavity] for loops in ((a, b) for _, a, b in kept)],
        "opening_area": float(opening_area),
        "valid": occ.is_valid(solid),
        "clash_shape": ("slab", grid_a, grid_b),
    }


def _grid_area(grid: np.ndarray) -> float:
    """Area of a dense (a, b, 3) grid as two triangles per cell, mm2."""
    a, b, c, d = grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]
    return float(
        0.5
        * (
            np.linalg.norm(np.cross(b - a, c - a), axis=-1).sum()
            + np.linalg.norm(np.cross(c - a, d - a), axis=-1).sum()
        )
    )


# --------------------------------------------------------------------------------------------
# clearances
# --------------------------------------------------------------------------------------------
def _clearance_findings(
    pid: str, parts: list[dict], bolts: dict[int, np.ndarray], d_bolt: float
) -> list[Finding]:
    """Bolt holes that do not fit their rib: ``(code, part id, message)`` each."""
    from shapely.geometry import Point, Polygon

    findings: list[Finding] = []
    by_id = {p["id"]: p for p in parts}
    for side in bolts:
        rib = by_id.get(f"{pid}-RIB-{side}")
        if rib is None:
            continue
        outline = Polygon(rib["outline"])
        for hole in rib["holes"]:
            margin = outline.exterior.distance(Point(hole.centre)) - hole.diameter / 2
            if not outline.contains(Point(hole.centre)) or margin < d_bolt / 2:
                findings.append(
                    (
                        "bolt-clearance",
                        rib["id"],
                        (
                            f"bolt hole at {np.round(hole.centre, 1).tolist()} is "
                            f"{margin:.1f} mm from the rib edge (needs {d_bolt / 2:g} mm); "
                            "lower the bolt edge distance or raise the rib height"
                        ),
                    )
                )
    return findings
