"""One panel's steel parts, built in a worker process from plain data (arrays in, BREP out).

Parts of a sandwich panel (ids ``P012-TOP``, ``-BOT``, ``-RIB-0..3``, ``-STF-0..3``):

- **sheets**: each face of a sheet (outer and inner) is the developed grid moved along the
  developed normals, trimmed at the four rib planes (:mod:`fabpanel.model.trim`); the solid is
  sewn from the two faces and the ruled strips between their edges (planar, in the rib plane).
- **ribs**: a flat plate per side in the side's rib plane, extruded into the panel by the rib
  thickness, so back-to-back ribs of neighbours touch in that plane. Its outline runs along the
  top sheet's inner face and the bottom sheet's upper face; where the sheet is bevelled against
  the rib, the edge is taken at whichever face of the plate meets the sheet first, so the plate
  never enters a sheet (a wedge of at most ``t_rib tan(bevel)`` is left for the weld). Ribs 0
  and 2 run to the outer faces of ribs 1 and 3, which stop at the inner faces of ribs 0 and 2:
  the corners are closed and no two ribs overlap.
- **corner stiffeners**: at each corner, a flat plate across the corner through the points at
  ``stiffener_offset`` along both sides (the thesis's construction, §7.3.2 d), in the plane
  holding that chord and the panel normal at the corner, between the sheets, its ends at the
  two ribs' inner faces. It faces the corner and is extruded away from it.
- **bolt holes** (interior sides only: a boundary rib has no partner) at the stations of
  :mod:`fabpanel.model.joints`, and **access openings** in the sheet chosen in the job beside
  every bolt, drilled along the sheet normal.

A cladding panel is the top sheet alone, untrimmed (no ribs to meet).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..data import Hole
from ..errors import Finding, KernelError
from ..fasteners import AccessDesign
from ..geom.polygon import polygon_area
from . import joints, occ
from .access import bolt_names, reach_findings
from .openings import Opening, opening_loops, reaches_along_z, slot_openings
from .trim import TrimmedFace, side_rows, trimmed_face

#: points along each rib edge curve (top and bottom), corner to corner
RIB_CURVE_POINTS = 65
#: points along each stiffener edge
STIFFENER_POINTS = 41
#: points of sheet edges and plane sections that plate edges are interpolated from
SECTION_POINTS = 257
#: dense samples of sheet fibre grids per sample interval of the developed grid
GRID_REFINE = 4
#: clear distance an access opening keeps from ribs and stiffeners, mm
ACCESS_MIN_CLEAR = 3.0
#: a plate is not cut at another plate's plane whose normal has less than this component along
#: the plate (sin 30 degrees): that plane runs along the plate instead of across its end
TANGENT_RIB = 0.5
#: the same for a corner stiffener against its two ribs: it meets them at half the corner's
#: supplement (45 degrees at a right corner, 30 at 120, 15 at 150), so only a corner flatter
#: than 170 degrees leaves its ends uncut (sin 5 degrees)
TANGENT_STIFFENER = 0.087
#: a rib plane tilted more than 30 degrees from the sheet normal (sin 30 degrees): its
#: stiffeners keep the ribs' rule
RIB_TILT_SIN = 0.5
#: corners opening wider than this get no stiffener (degrees): the two ribs are nearly one line
MAX_STIFFENED_ANGLE = 150.0
#: points per access opening outline (a periodic cubic through 24 points is within 1e-4 mm of
#: a 40 mm circle)
HOLE_POINTS = 24


def build_panel(payload: dict[str, Any], where: list[str] | None = None) -> dict[str, Any]:
    """All parts of one panel (see the module docstring); returns part records (BREP bytes,
    outlines, holes, tessellations) and the panel's measures and findings.

    where : when given, its last item is set to the id of the part being built, so that a
    caller can name the part an exception came from (not every kernel message names it).
    """
    pid = payload["panel_id"]
    where = [pid] if where is None else where

    def building(part: str) -> None:
        where[-1] = part

    samples, normals = payload["samples"], payload["normals"]
    planes = payload["planes"] / np.linalg.norm(payload["planes"][:, :3], axis=1, keepdims=True)
    offsets = payload["offsets"]
    k = samples.shape[0]
    centre_normal = normals[k // 2, k // 2]
    sandwich = payload["buildup"] == "sandwich"
    trim = np.full(4, sandwich)
    limit = payload["slide_limit"]
    findings: list[Finding] = []
    measures: dict[str, Any] = {}

    def face(offset: float, what: str) -> TrimmedFace:
        result = trimmed_face(
            samples + offset * normals, centre_normal, planes, trim, limit, f"{pid}-{what}"
        )
        for side in np.flatnonzero(result.untrimmed):
            findings.append(
                (
                    "sheet-not-trimmed",
                    f"{pid}-{what[:3]}",
                    (
                        f"sheet face edge {side} left at the developed edge: its rib plane "
                        f"meets the face only {limit:g}+ mm away (nearly tangent)"
                    ),
                )
            )
        return result

    building(f"{pid}-TOP")
    top_outer, top_inner = (
        face(offsets["top_outer"], "TOP outer"),
        face(offsets["top_inner"], "TOP inner"),
    )
    faces = {"top_outer": top_outer, "top_inner": top_inner}
    bolts: dict[int, np.ndarray] = {}
    if sandwich:
        building(f"{pid}-BOT")
        faces["bottom_upper"] = face(offsets["bottom_upper"], "BOT upper")
        faces["bottom_lower"] = face(offsets["bottom_lower"], "BOT lower")
        mid = (offsets["top_inner"] + offsets["bottom_upper"]) / 2
        bolt = payload["bolt"]
        for interior_side in np.flatnonzero(payload["interior"]):
            building(f"{pid}-RIB-{interior_side}")
            bolts[int(interior_side)] = joints.bolt_centres(
                side_rows(samples)[interior_side],
                side_rows(normals)[interior_side],
                planes[interior_side],
                mid,
                bolt["spacing"],
                bolt["edge_distance"],
                payload.get("stations", {}).get(int(interior_side)),
            )
    measures["sheet_fit_error_mm"] = max(f.fit_error for f in faces.values())
    measures["sheet_trim_slide_mm"] = max(float(f.slide.max()) for f in faces.values())

    design: AccessDesign | None = payload["access"] if sandwich else None
    access = payload["bolt"]["access_sheet"] if design is not None else "none"
    frames = _joint_frames(samples, normals, planes, bolts, access)
    designs: dict[int, list[AccessDesign]] = {}
    if design is not None and frames:
        outside = faces["top_outer"] if access == "top" else faces["bottom_lower"]
        reaches = reaches_along_z(outside.surface, frames, design.reach)
        designs = {side: [design.at_reach(r) for r in reach] for side, reach in reaches.items()}
    building(f"{pid}-TOP")
    parts = [
        _sheet(
            f"{pid}-TOP",
            "sheet-top",
            top_outer,
            top_inner,
            payload["t_top"],
            payload["fibre"],
            k,
            frames if access == "top" else {},
            designs,
        )
    ]
    if sandwich:
        building(f"{pid}-BOT")
        parts.append(
            _sheet(
                f"{pid}-BOT",
                "sheet-bottom",
                faces["bottom_upper"],
                faces["bottom_lower"],
                payload["t_bot"],
                payload["fibre"],
                k,
                frames if access == "bottom" else {},
                designs,
            )
        )
        ribs, stiffeners = [], []
        k_mid = samples.shape[0] // 2
        for side in range(4):
            normal = side_rows(normals)[side][k_mid]
            tilt = float(np.degrees(np.arcsin(min(1.0, abs(normal @ planes[side, :3])))))
            if tilt > 90.0 - 30.0:
                findings.append(
                    (
                        "rib-plane-tangent",
                        f"{pid}-RIB-{side}",
                        (
                            f"rib plane within "
                            f"{90 - tilt:.0f} degrees of the sheet: the rib lies nearly "
                            "flat, not between the sheets; change the layout at this edge"
                        ),
                    )
                )
        for side in range(4):
            name = f"{pid}-RIB-{side}"
            building(name)
            try:
                ribs.append(
                    _rib(
                        name,
                        side,
                        planes,
                        top_inner,
                        faces["bottom_upper"],
                        payload["t_rib"],
                        bolts.get(side),
                        payload["bolt"]["diameter"],
                    )
                )
            except KernelError as err:
                # a degenerate panel edge (e.g. a boundary rib plane nearly tangent to the
                # sheet): the rest of the panel is built, the missing rib is an error issue
                findings.append(("plate-failed", name, f"not built: {err}", "error"))
        lengths = [
            float(np.linalg.norm(np.diff(row, axis=0), axis=1).sum()) for row in side_rows(samples)
        ]
        short = [s for s in range(4) if lengths[s] < 2 * payload["stiffener_offset"] + 1.0]
        if short:
            # the stiffeners at both ends of a side would meet or cross
            findings.append(
                (
                    "stiffeners-skipped",
                    pid,
                    (
                        f"no corner stiffeners: side(s) "
                        f"{short} shorter than twice the stiffener offset "
                        f"({payload['stiffener_offset']:g} mm); lower "
                        "[sandwich] stiffener_offset or enlarge the panels"
                    ),
                )
            )
        for corner in range(4 if not short else 0):
            name = f"{pid}-STF-{corner}"
            building(name)
            angle = _corner_angle(samples, corner)
            if angle > MAX_STIFFENED_ANGLE:
                findings.append(
                    (
                        "stiffener-skipped",
                        name,
                        (
                            f"corner opens {angle:.0f} degrees "
                            f"(> {MAX_STIFFENED_ANGLE:g}): nothing to stiffen"
                        ),
                    )
                )
                continue
            try:
                stiffeners.append(
                    _stiffener(
                        name, corner, planes, top_outer, top_inner, faces["bottom_upper"], payload
                    )
                )
            except KernelError as err:
                findings.append(("stiffener-skipped", name, f"not built: {err}"))
        parts += ribs + stiffeners
        measures["plate_planarity_mm"] = {r["id"]: r["planarity"] for r in ribs + stiffeners}
        building(pid)
        findings += _clearance_findings(pid, parts, bolts, payload)
        if design is not None:
            found, blocked = reach_findings(pid, parts, frames, designs)
            findings += found
            measures["bolts_in_the_way"] = blocked
    findings += [
        ("access-clash", part["id"], message)
        for part in parts
        for message in part.get("dropped", ())
    ]
    measures["bolts"] = int(sum(len(b) for b in bolts.values()))
    measures["access_openings"] = int(
        sum(len(p["openings"]) for p in parts if p["kind"].startswith("sheet"))
    )
    # (side, bolt index) of each bolt the tool cannot reach from this panel
    # (side, bolt index) of each bolt the tool cannot reach from this panel
    measures["bolts_unreachable"] = sorted(
        {(b[0], b[1]) for b in measures.get("bolts_in_the_way", []) if b[3]}
    )
    measures["bolts_checked"] = design is not None
    measures["valid"] = all(p["valid"] for p in parts)
    building(f"{pid}-TOP")
    edges = [side_curve(top_outer.surface, side, 129) for side in range(4)]
    return {
        "panel_id": pid,
        "parts": parts,
        "measures": measures,
        "findings": findings,
        "bolts": bolts,
        "top_edges": edges,
    }


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
    dropped: list[str] = []
    if designs and frames:
        openings = slot_openings(designs, frames)
        loops_a = opening_loops(outer.surface, openings)
        loops_b = opening_loops(inner.surface, openings)
        for opening, a, b in zip(openings, loops_a, loops_b, strict=True):
            if isinstance(a, str) or isinstance(b, str):
                why = a if isinstance(a, str) else b
                dropped.append(f"access slot of {bolt_names(name, opening.bolts)} left out: {why}")
            else:
                kept.append((opening, a, b))
    try:
        solid = occ.slab(outer.surface, inner.surface, name, [(a, b) for _, a, b in kept])
    except KernelError as err:
        if not kept:
            raise
        dropped.append(f"access slots left out: the sheet with them was not valid ({err})")
        solid = occ.slab(outer.surface, inner.surface, name)
        kept = []
    opening_area = sum(o.area for o, _, _ in kept)
    cavity = 1 if kind == "sheet-top" else 0
    return {
        "dropped": dropped,
        "id": name,
        "kind": kind,
        "thickness": thickness,
        "volume": occ.volume(solid),
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


def side_curve(surface, side: int, n: int) -> np.ndarray:
    """(n, 3) float: the boundary iso-curve of side ``side`` of a surface fitted to a panel grid,
    from corner ``side`` to corner ``side + 1``."""
    return occ.surface_points(surface, *_side_uv(side, n))


def _side_uv(side: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    return {
        0: (t, np.zeros(n)),
        1: (np.ones(n), t),
        2: (1 - t, np.ones(n)),
        3: (np.zeros(n), 1 - t),
    }[side]


# --------------------------------------------------------------------------------------------
# ribs and stiffeners: flat plates
# --------------------------------------------------------------------------------------------
def _rib(
    name: str,
    side: int,
    planes: np.ndarray,
    top_inner: TrimmedFace,
    bottom_upper: TrimmedFace,
    t_rib: float,
    bolts: np.ndarray | None,
    bolt_diameter: float,
) -> dict:
    """One rib plate in its side plane (see the module docstring)."""
    plane = planes[side]
    # the edges densely (as the plane sections), so interpolating them between stations does
    # not cut chords into a convex sheet
    upper = side_curve(top_inner.surface, side, SECTION_POINTS)
    lower = side_curve(bottom_upper.surface, side, SECTION_POINTS)
    frame = plane_frame(plane, upper[0], upper[-1] - upper[0])
    span = float(np.linalg.norm(upper[-1] - upper[0]))
    chains = [
        _section_edge(face, plane, frame, t_rib, span, top, name, curve, RIB_CURVE_POINTS)
        for curve, face, top in ((upper, top_inner, True), (lower, bottom_upper, False))
    ]
    for other in ((side - 1) % 4, (side + 1) % 4):
        # ribs 0 and 2 run to the outer faces of ribs 1 and 3, which stop at their inner faces
        inset = 0.0 if side % 2 == 0 else t_rib
        chains = _trim_chains(chains, frame, planes[other], inset, t_rib, name, other)
    holes = []
    if bolts is not None:
        local = (np.c_[bolts, np.ones(len(bolts))] @ np.linalg.inv(frame).T)[:, :2]
        holes = [(centre, bolt_diameter) for centre in local]
    return _plate(name, "rib", chains, frame, t_rib, plane, holes)


def _corner_angle(samples: np.ndarray, corner: int) -> float:
    """Interior angle of the developed grid at a corner, degrees."""
    rows = side_rows(samples)
    incoming, outgoing = rows[(corner - 1) % 4], rows[corner]
    a, b = incoming[-2] - incoming[-1], outgoing[1] - outgoing[0]
    cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _stiffener(
    name: str,
    corner: int,
    planes: np.ndarray,
    top_outer: TrimmedFace,
    top_inner: TrimmedFace,
    bottom_upper: TrimmedFace,
    payload: dict,
) -> dict:
    """The corner stiffener at ``corner`` (see the module docstring)."""
    offset, t_stf, t_rib = payload["stiffener_offset"], payload["t_stf"], payload["t_rib"]
    before, after = (corner - 1) % 4, corner
    incoming = side_curve(top_outer.surface, before, 129)[::-1]
    outgoing = side_curve(top_outer.surface, after, 129)
    a, _ = joints.along_polyline(incoming, np.array([offset]))
    b, _ = joints.along_polyline(outgoing, np.array([offset]))
    a, b, tip = a[0], b[0], outgoing[0]
    normal = top_outer.normals(np.array([_CORNER_UV[corner]]))[0]
    z = np.cross(b - a, normal)
    z /= np.linalg.norm(z)
    if z @ (tip - a) > 0:
        z = -z  # the plate's face looks at the corner and the plate stands away from it
    plane = np.r_[z, z @ a]
    frame = plane_frame(plane, a, b - a)
    span = float(np.linalg.norm(b - a))
    chains = []
    for face, top in ((top_inner, True), (bottom_upper, False)):
        chains.append(_section_edge(face, plane, frame, t_stf, span, top, name))
    for other in (before, after):
        # a rib tilted far from the sheet normal keeps the ribs' rule (a cut at its plane can
        # remove the whole stiffener); a rib standing square to the sheet is met at half the
        # corner's supplement, and cut however obtuse the corner
        tilted = abs(planes[other][:3] @ normal) > RIB_TILT_SIN
        tangent = TANGENT_RIB if tilted else TANGENT_STIFFENER
        chains = _trim_chains(chains, frame, planes[other], t_rib, t_stf, name, other, tangent)
    return _plate(name, "stiffener", chains, frame, t_stf, plane, [])


_CORNER_UV = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))


def _plate(
    name: str,
    kind: str,
    chains: list[np.ndarray],
    frame: np.ndarray,
    thickness: float,
    plane: np.ndarray,
    holes: list,
) -> dict:
    top, bottom = (_drop_duplicates(chain, closed=False) for chain in chains)
    outline = _drop_duplicates(np.r_[top, bottom[::-1]])
    solid = occ.prism(
        [top, np.array([top[-1], bottom[-1]]), bottom[::-1], np.array([bottom[0], top[0]])],
        frame,
        thickness,
        name,
        holes,
    )
    if polygon_area(outline) < 0:
        outline = outline[::-1]
    # both plate faces must be flat: every point of the edges bounding the two faces (the
    # edges through the thickness skipped) against the plane and its offset
    flatness = 0.0
    for points in occ.edge_points(solid, per_edge=8):
        dist = points @ plane[:3] - plane[3]
        if abs(dist[-1] - dist[0]) > thickness / 2:
            continue
        flatness = max(flatness, float(np.minimum(np.abs(dist), np.abs(dist - thickness)).max()))
    net = abs(polygon_area(outline)) - sum(np.pi * d**2 / 4 for _, d in holes)
    return {
        "id": name,
        "kind": kind,
        "thickness": thickness,
        "volume": occ.volume(solid, adaptive=False),
        "area": float(net),
        "brep": occ.to_brep(solid),
        "outline": outline,
        "frame": frame,
        "holes": [Hole((float(c[0]), float(c[1])), float(d), "bolt") for c, d in holes],
        "valid": occ.is_valid(solid),
        "planarity": flatness,
        "plane": plane,
        "clash_shape": ("plate", outline, frame, thickness),
    }


def _section_edge(
    face: TrimmedFace,
    plane: np.ndarray,
    frame: np.ndarray,
    thickness: float,
    span: float,
    top: bool,
    name: str,
    edge: np.ndarray | None = None,
    points: int = STIFFENER_POINTS,
) -> np.ndarray:
    """(n, 2) float: a plate's edge against a sheet face, in the plate frame: the face's
    sections with the plate's two faces (``edge (m, 3)``: the face's own boundary in the
    plate's plane, used instead of the section there), keeping per station the one the plate
    meets first (``top``: the plate lies below the face), so the plate touches the sheet along
    one face edge and never enters it; a wedge of at most ``thickness x tan(bevel)`` is left
    for the weld."""
    profiles = []
    for shift in (0.0, thickness):
        if shift == 0.0 and edge is not None:
            points_3d = edge
        else:
            points_3d = occ.plane_section(
                face.surface, np.r_[plane[:3], plane[3] + shift], name=name
            )
        local = (np.c_[points_3d, np.ones(len(points_3d))] @ np.linalg.inv(frame).T)[:, :2]
        keep = (local[:, 0] > -span) & (local[:, 0] < 2 * span)
        local = local[keep][np.argsort(local[keep][:, 0])]
        if len(local) >= 2:
            profiles.append(local)
        elif edge is None or shift == 0.0:
            raise KernelError(f"{name}: its plane does not cut the sheet")
        # else: a rib plane nearly tangent to the sheet: its inner face misses the sheet, the
        # edge alone is used (the clash check measures what that leaves)
    if edge is not None:
        # a rib runs along its whole edge; the section through its inner face ends at the
        # neighbouring rib planes and is held at its end value beyond (the trim cuts there)
        lo, hi = profiles[0][0, 0], profiles[0][-1, 0]
    else:
        lo = max(p[0, 0] for p in profiles)
        hi = min(p[-1, 0] for p in profiles)
    xs = np.linspace(lo, hi, points)
    heights = [np.interp(xs, p[:, 0], p[:, 1]) for p in profiles]
    up = face.normals(np.array([[0.5, 0.5]]))[0] @ frame[:3, 1]
    sign = 1.0 if up >= 0 else -1.0
    pick = np.minimum if top else np.maximum
    return np.c_[xs, sign * pick.reduce([sign * h for h in heights])]


def _trim_chains(
    chains: list[np.ndarray],
    frame: np.ndarray,
    plane: np.ndarray,
    inset: float,
    thickness: float,
    name: str,
    other: int,
    tangent: float = 0.0,
) -> list[np.ndarray]:
    """Cut both edge chains of a plate (extruded ``thickness`` along the frame's z) where the
    whole plate thickness stays ``inset`` mm inside ``plane`` (normal into the panel); not
    where the plane's normal has less than ``tangent`` (default ``TANGENT_RIB``) along the
    plate."""
    a, b, c = (plane[:3] @ frame[:3, i] for i in range(3))
    if abs(a) < (tangent or TANGENT_RIB):
        # the other plate's plane runs along this one (a boundary rib plane nearly tangent to
        # the sheet, reported as rib-plane-tangent): a cut there would remove the whole plate
        return chains
    limit = plane[3] + inset - plane[:3] @ frame[:3, 3] - min(0.0, c * thickness)
    chains = [clip_polyline(chain, np.array([a, b]), limit) for chain in chains]
    if min(len(chain) for chain in chains) < 2:
        raise KernelError(
            f"outline of {name} vanished when trimmed at rib {other}; the panel "
            f"is too small for its ribs and stiffeners"
        )
    return chains


def plane_frame(plane: np.ndarray, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(4, 4) float: frame on ``plane (4,)`` with z = the plane normal, x = ``direction``
    projected into the plane, origin = ``origin`` projected onto the plane."""
    z = plane[:3] / np.linalg.norm(plane[:3])
    o = origin - (origin @ z - plane[3]) * z
    x = direction - (direction @ z) * z
    norm = np.linalg.norm(x)
    if norm < 1e-9:
        raise KernelError("plate direction is normal to its plane")
    x /= norm
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, o
    return frame


def clip_polyline(points: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """(n', 2) float: the longest run of the open polyline ``points (n, 2)`` with
    ``normal . p >= offset``, ended exactly on the line where it is cut."""
    value = points @ normal - offset
    inside = np.r_[False, value >= 0, False].astype(int)
    starts = np.flatnonzero(np.diff(inside) == 1)
    ends = np.flatnonzero(np.diff(inside) == -1)
    if len(starts) == 0:
        return points[:0]
    longest = int(np.argmax(ends - starts))
    i0, i1 = int(starts[longest]), int(ends[longest])
    run = [points[i0:i1]]
    if i0 > 0:
        p, q, vp, vq = points[i0 - 1], points[i0], value[i0 - 1], value[i0]
        run.insert(0, (p + (q - p) * (vp / (vp - vq)))[None])
    if i1 < len(points):
        p, q, vp, vq = points[i1 - 1], points[i1], value[i1 - 1], value[i1]
        run.append((p + (q - p) * (vp / (vp - vq)))[None])
    return np.concatenate(run)


def _drop_duplicates(points: np.ndarray, closed: bool = True, eps: float = 1e-6) -> np.ndarray:
    """Points without consecutive repeats (within ``eps`` mm)."""
    if closed:
        keep = np.linalg.norm(points - np.roll(points, -1, axis=0), axis=1) > eps
        return points[keep]
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > eps]
    return points[keep]


# --------------------------------------------------------------------------------------------
# clearances
# --------------------------------------------------------------------------------------------
def _clearance_findings(
    pid: str, parts: list[dict], bolts: dict[int, np.ndarray], payload: dict
) -> list[tuple[str, str, str]]:
    """Bolt holes that do not fit their rib: ``(code, part id, message)`` each."""
    from shapely.geometry import Point, Polygon

    findings = []
    by_id = {p["id"]: p for p in parts}
    d_bolt = payload["bolt"]["diameter"]
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
