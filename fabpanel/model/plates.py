"""The flat plates of a panel: ribs, corner stiffeners and packing plates.

Each plate lies in a plane and is an outline extruded by its thickness (:func:`occ.prism`). Its
long edges follow the sheets: the sections of the sheet faces with the plate's two faces, keeping
per station the one the plate meets first, so the plate touches the sheet along one face edge and
never enters it (:func:`section_edge`). Its ends are cut at the neighbouring plates' planes
(:func:`trim_chains`). Where three welds would meet (a stiffener's corners against rib and sheet,
the ends of ribs 1 and 3 against ribs 0 and 2 and the sheets) the corners are sniped: cut at 45
degrees with legs of ``[sandwich.welds] snipe`` (:func:`outline_edges`).
"""

from __future__ import annotations

import numpy as np

from ..data import Hole
from ..errors import KernelError
from ..geom.polygon import polygon_area
from . import joints, occ
from .nodes import facing
from .trim import TrimmedFace, side_curve

#: points along each rib edge curve (top and bottom), corner to corner
RIB_CURVE_POINTS = 65
#: points along each stiffener edge
STIFFENER_POINTS = 41
#: points of sheet edges and plane sections that plate edges are interpolated from
SECTION_POINTS = 257
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
#: a snipe is cut only where the edges it cuts are longer than this many snipe legs (a short
#: plate end keeps its corner: the snipe would take the whole end)
SNIPE_ROOM = 2.5

_CORNER_UV = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))


def rib(
    name: str,
    side: int,
    planes: np.ndarray,
    top_inner: TrimmedFace,
    bottom_upper: TrimmedFace,
    t_rib: float,
    bolts: np.ndarray | None,
    bolt_diameter: float,
    snipe: float = 0.0,
    nodes: tuple[np.ndarray, np.ndarray] = (np.empty((0, 2, 5)), np.empty((0, 2, 5))),
) -> dict:
    """One rib plate in its side plane (see the module docstring); ribs 1 and 3, which butt
    against ribs 0 and 2, get ``snipe`` mm snipes at their four corners. ``nodes``: at its start
    and end corners, the rib-plane pairs of the panels meeting its panel only there
    (:func:`fabpanel.model.nodes.node_planes`), which cut its ends too (:func:`_cut_at_node`)."""
    plane = planes[side]
    # the edges densely (as the plane sections), so interpolating them between stations does
    # not cut chords into a convex sheet
    upper = side_curve(top_inner.surface, side, SECTION_POINTS)
    lower = side_curve(bottom_upper.surface, side, SECTION_POINTS)
    frame = plane_frame(plane, upper[0], upper[-1] - upper[0])
    span = float(np.linalg.norm(upper[-1] - upper[0]))
    chains = [
        section_edge(face, plane, frame, t_rib, span, top, name, curve, RIB_CURVE_POINTS)
        for curve, face, top in ((upper, top_inner, True), (lower, bottom_upper, False))
    ]
    for other in ((side - 1) % 4, (side + 1) % 4):
        # ribs 0 and 2 run to the outer faces of ribs 1 and 3, which stop at their inner faces
        inset = 0.0 if side % 2 == 0 else t_rib
        chains = trim_chains(chains, frame, planes[other], inset, t_rib, name, f"rib {other}")
    middle = upper[len(upper) // 2]
    uncut = chains
    for node in nodes:
        for pair in node:
            chains = _cut_at_node(chains, frame, pair, middle, t_rib, name)
    node_cut = _shortening(uncut, chains)
    holes = []
    if bolts is not None:
        local = (np.c_[bolts, np.ones(len(bolts))] @ np.linalg.inv(frame).T)[:, :2]
        holes = [(centre, bolt_diameter) for centre in local]
    top, bottom = chains
    edges = outline_edges(top, bottom, snipe if side % 2 == 1 else 0.0)
    return {**plate(name, "rib", edges, frame, t_rib, plane, holes), "node_cut": float(node_cut)}


def _shortening(before: list[np.ndarray], after: list[np.ndarray]) -> float:
    """How far a cut shortened the edge chains of a plate at either end, mm (the chains run
    along the frame's x)."""
    return max(
        float(max(new[0, 0] - old[0, 0], old[-1, 0] - new[-1, 0]))
        for old, new in zip(before, after, strict=True)
    )


def _cut_at_node(
    chains: list[np.ndarray],
    frame: np.ndarray,
    pair: np.ndarray,
    middle: np.ndarray,
    t_rib: float,
    name: str,
) -> list[np.ndarray]:
    """A rib's edge chains kept out of a panel that meets its own only at a node: cut at the
    one of that panel's two rib planes there (``pair (2, 5)``, see
    :func:`fabpanel.model.nodes.node_planes`) that takes less off, on the side of the rib's
    ``middle``; either keeps the rib out of the wedge between them, if the rib's middle lies
    outside the panel's side of it (the planes' normals point into that panel). A plane running
    along the rib (``TANGENT_RIB``) cannot cut it, nor one the rib would vanish at."""
    best: tuple[float, list[np.ndarray]] | None = None
    for plane in pair:
        if plane[:3] @ middle - plane[3] >= 0:
            continue  # the rib's middle on the panel's side: this plane does not part them
        cut = facing(plane, middle)
        if abs(cut[:3] @ frame[:3, 0]) < TANGENT_RIB:
            continue
        try:
            trimmed = trim_chains(chains, frame, cut, 0.0, t_rib, name, "a rib plane at its node")
        except KernelError:
            continue
        removed = _shortening(chains, trimmed)
        if best is None or removed < best[0]:
            best = (removed, trimmed)
    return chains if best is None else best[1]


def stiffener(
    name: str,
    corner: int,
    planes: np.ndarray,
    top_outer: TrimmedFace,
    top_inner: TrimmedFace,
    bottom_upper: TrimmedFace,
    offset: float,
    t_stf: float,
    t_rib: float,
    snipe: float = 0.0,
) -> dict:
    """The corner stiffener at ``corner`` (see the module docstring), its four corners sniped
    by ``snipe`` mm."""
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
        chains.append(section_edge(face, plane, frame, t_stf, span, top, name))
    for other in (before, after):
        # a rib tilted far from the sheet normal keeps the ribs' rule (a cut at its plane can
        # remove the whole stiffener); a rib standing square to the sheet is met at half the
        # corner's supplement, and cut however obtuse the corner
        tilted = abs(planes[other][:3] @ normal) > RIB_TILT_SIN
        tangent = TANGENT_RIB if tilted else TANGENT_STIFFENER
        chains = trim_chains(
            chains, frame, planes[other], t_rib, t_stf, name, f"rib {other}", tangent
        )
    upper, lower = chains
    return plate(name, "stiffener", outline_edges(upper, lower, snipe), frame, t_stf, plane, [])


def packing_plate(
    name: str,
    plane: np.ndarray,
    centre: np.ndarray,
    along: np.ndarray,
    side: float,
    gap: float,
    hole: float,
) -> dict:
    """A square packing plate of ``side`` mm filling an erection gap of ``gap`` mm at one bolt:
    its faces in the two ribs' planes (``plane``: the panel's contact plane, the gap's middle),
    centred on the bolt ``centre``, its sides along and across the rib (``along``), holed for
    the bolt."""
    low = np.r_[plane[:3], plane[3] - gap / 2]
    frame = plane_frame(low, centre, along)
    h = side / 2
    square = np.array([(-h, -h), (h, -h), (h, h), (-h, h), (-h, -h)])
    edges = [square[i : i + 2] for i in range(4)]
    return plate(name, "packing", edges, frame, gap, low, [(np.zeros(2), hole)])


def outline_edges(top: np.ndarray, bottom: np.ndarray, snipe: float) -> list[np.ndarray]:
    """The closed outline of a plate between its ``top`` and ``bottom`` edge chains ((n, 2)
    each, same direction), as consecutive edges: the two chains and the straight ends between
    them, each corner cut at 45 degrees by ``snipe`` mm along both edges when ``snipe`` > 0
    and the edges are long enough for it (:data:`SNIPE_ROOM`)."""
    top, bottom = drop_duplicates(top, closed=False), drop_duplicates(bottom, closed=False)
    ends = [np.array([top[-1], bottom[-1]]), np.array([bottom[0], top[0]])]
    shortest = min(_length(c) for c in (top, bottom, *ends))
    if snipe <= 0 or shortest < SNIPE_ROOM * snipe:
        return [top, ends[0], bottom[::-1], ends[1]]
    sides = [
        _cut(top, snipe),
        _cut(ends[0], snipe),
        _cut(bottom[::-1], snipe),
        _cut(ends[1], snipe),
    ]
    edges = []
    for here, after in zip(sides, sides[1:] + sides[:1]):
        edges += [here, np.array([here[-1], after[0]])]
    return edges


def _length(chain: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(chain, axis=0), axis=1).sum())


def _cut(chain: np.ndarray, leg: float) -> np.ndarray:
    """The chain without ``leg`` mm of arc length at both ends."""
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(chain, axis=0), axis=1))]
    keep = (lengths > leg) & (lengths < lengths[-1] - leg)
    ends = [
        np.array([np.interp(at, lengths, chain[:, i]) for i in range(chain.shape[1])])
        for at in (leg, lengths[-1] - leg)
    ]
    return np.vstack([ends[0], chain[keep], ends[1]])


def plate(
    name: str,
    kind: str,
    edges: list[np.ndarray],
    frame: np.ndarray,
    thickness: float,
    plane: np.ndarray,
    holes: list,
) -> dict:
    """A plate part record: the closed outline ``edges`` (consecutive (n, 2) chains in the
    frame's x, y) extruded by ``thickness`` along the frame's z, with round ``holes``
    ((centre, diameter) pairs); its flatness measured on the solid."""
    outline = drop_duplicates(np.vstack([edge[:-1] for edge in edges]))
    solid = occ.prism(edges, frame, thickness, name, holes)
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
    volume, centroid = occ.mass_properties(solid, adaptive=False)
    return {
        "id": name,
        "kind": kind,
        "thickness": thickness,
        "volume": volume,
        "centroid": centroid,
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


def section_edge(
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


def trim_chains(
    chains: list[np.ndarray],
    frame: np.ndarray,
    plane: np.ndarray,
    inset: float,
    thickness: float,
    name: str,
    other: str,
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
            f"outline of {name} vanished when trimmed at {other}; the panel "
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


def drop_duplicates(points: np.ndarray, closed: bool = True, eps: float = 1e-6) -> np.ndarray:
    """Points without consecutive repeats (within ``eps`` mm)."""
    if closed:
        keep = np.linalg.norm(points - np.roll(points, -1, axis=0), axis=1) > eps
        return points[keep]
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > eps]
    return points[keep]
