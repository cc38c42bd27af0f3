"""Load-time checks: refuse geometry the later stages cannot handle, saying where it is.

Run on the welded triangle mesh of every input (a mesh file, or the tessellation of a B-rep) by
:func:`check_surface`, in this order, each raising one :class:`~fabpanel.errors.InputError` line
that names the file, says what is wrong, where (world coordinates in the input's declared unit),
and how to fix it:

1. unwelded seams: boundary edges that lie on other boundary edges (two patches exported without
   merging their common vertices, or with different divisions along the common edge). A seam
   that is also a crease (see 3) is reported as the crease, since welding would not help there;
2. separate pieces: more than one part connected through shared vertices;
3. creases: neighbouring triangles whose normals differ by more than ``crease_angle`` degrees.
   The panelizer and the developer smooth across a crease (panels about 25 mm off a 90-degree
   fold of 1.2 m panels), so a crease splits the job. Closed surfaces are not checked here, as
   panelize refuses them anyway (they have no boundary) and a box or a drum has creases by
   design, which ``fabpanel inspect`` must still describe;
4. self-intersections: two triangles without a common vertex whose interiors cross. The
   developer fails on them with numerical noise instead of a message.

The self-intersection test is the edge-through-triangle form of the triangle-triangle test of
T. Möller, "A fast triangle-triangle intersection test", J. Graphics Tools 2(2), 1997: two
non-coplanar triangles cross exactly when an edge of one passes through the other. Candidate
pairs come from a k-d tree on triangle centres, bucketed by triangle size (a factor of two per
bucket), so that a few large triangles (planar faces of a B-rep) do not widen the search for
all the small ones. Triangles lying flat on each other (coplanar overlap) are not seen by this
test; a sheet folded back onto itself is caught as a 180-degree crease, a copy lying on top as a
second piece.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from ..errors import InputError
from ..units import UNITS
from .boundary import directed_edges, edge_use

log = logging.getLogger(__name__)

#: default of ``[input] crease_angle``, degrees. The largest angle between neighbouring triangle
#: normals on the examples is 20 degrees (pavilion.obj, on the canopy; 23 on its coarse test
#: version), 8 on the form-found shell and under 2.5 on the vaults, the saddle patch (mesh and
#: STEP tessellation) and the one-opening roof: 45 leaves twice that margin and still stops a
#: right-angled fold.
CREASE_ANGLE = 45.0

#: boundary edges closer than this fraction of the bounding-box diagonal count as lying on each
#: other (an unwelded seam). 1e-6 is 0.03 mm on a 28 m shell: a thousand times the vertex welding
#: grid (``mesh.WELD_RELATIVE``), far above the float32 noise of STL and GLB coordinates
#: (1e-7 relative) and far below any gap that is meant (a joint between steel panels is several
#: millimetres)
SEAM_RELATIVE = 1e-6
#: ... or than this fraction of the longer edge's length: where two patches divide a curved
#: common edge differently, a vertex of one lies off the other's chord by up to about an eighth
#: of the turning angle per segment times the chord (1.2 % for 0.1 rad, the B-rep tessellation
#: angle; 4 % for 20 degrees); 0.05 covers that and is still a slit far too narrow to be an
#: opening at the mesh's own resolution
SEAM_EDGE_RELATIVE = 0.05
#: two boundary edges on a seam run nearly parallel: |cos| of the angle between them at least this
#: (25 degrees)
SEAM_PARALLEL = 0.9
#: an edge must pass through a triangle's plane by more than this fraction of the bounding-box
#: diagonal, and through its interior, to count as crossing it: touching is not crossing. 1e-9
#: (3e-5 mm on a 28 m shell) is the weld grid and far above the rounding of the arithmetic
CROSSING_RELATIVE = 1e-9

#: decimals of reported coordinates per unit: 10 mm in metres, 1 mm otherwise
_DECIMALS = {"m": 2, "cm": 1, "mm": 0}


# --------------------------------------------------------------------------------------------
# reporting
# --------------------------------------------------------------------------------------------
def format_point(point: Sequence[float] | np.ndarray, units: str) -> str:
    """``"(3.20, 1.05, 0.40) m"``: a point given in millimetres, in the input's declared unit.

    units : the declared unit (``"m"``, ``"cm"``, ``"mm"``); any other (an inch STEP) reports mm.
    """
    return f"{_coordinates(point, units)} {_unit(units)}"


def format_span(low: np.ndarray, high: np.ndarray, units: str) -> str:
    """``"(0.00, 0.00, 0.00)–(2.00, 1.00, 0.50) m"``: two points in mm, in the declared unit."""
    return f"{_coordinates(low, units)}–{_coordinates(high, units)} {_unit(units)}"


def _unit(units: str) -> str:
    return units if units in UNITS["length"] else "mm"


def _coordinates(point: Sequence[float] | np.ndarray, units: str) -> str:
    unit = _unit(units)
    decimals = _DECIMALS.get(unit, 0)
    # + 0.0 turns a rounded -0.0 into 0.0
    values = [round(float(x) / UNITS["length"][unit], decimals) + 0.0 for x in point]
    return "(" + ", ".join(f"{x:.{decimals}f}" for x in values) + ")"


# --------------------------------------------------------------------------------------------
# the checks
# --------------------------------------------------------------------------------------------
def check_surface(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    name: str,
    units: str,
    crease_angle: float = CREASE_ANGLE,
    brep: bool = False,
) -> None:
    """Refuse a welded triangle mesh that the later stages cannot handle (see module docstring).

    vertices : (n, 3) float, millimetres, world frame; faces : (m, 3) int, welded.
    name : file name put in front of the message; units : the input's declared length unit,
    used for the coordinates in messages; crease_angle : degrees; brep : the mesh tessellates a
    B-rep (changes the advice for seams).
    Raises :class:`InputError`; returns nothing when the surface passes.
    """
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return
    if not 0.0 < crease_angle <= 180.0:
        raise InputError(
            f"[input] crease_angle = {crease_angle:g} is not an angle in degrees "
            f"between 0 (excluded) and 180"
        )
    diagonal = float(np.linalg.norm(np.ptp(vertices[faces.ravel()], axis=0)))
    edges, counts, inverse = edge_use(faces)
    normals = _unit_normals(vertices, faces)
    _check_seams(
        vertices, faces, edges, counts, inverse, normals, diagonal, name, units, crease_angle, brep
    )
    _check_pieces(vertices, faces, name, units)
    if np.any(counts == 1):  # closed surfaces: see the module docstring
        _check_creases(vertices, faces, counts, inverse, normals, name, units, crease_angle)
    _check_self_intersections(vertices, faces, diagonal, name, units)


def _unit_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def _fold_angles(
    normals_a: np.ndarray, normals_b: np.ndarray, direction_a: np.ndarray, direction_b: np.ndarray
) -> np.ndarray:
    """Angle between the normals of triangles on either side of an edge, degrees.

    direction_a/b : (k, 3) the edge as each triangle runs it. Neighbours wound consistently run
    a common edge in opposite directions; where they run it the same way one normal is turned
    first, so the angle does not depend on the winding (a Moebius strip, an unwelded patch
    oriented on its own).
    """
    same = np.einsum("ij,ij->i", direction_a, direction_b) > 0
    cosine = np.einsum("ij,ij->i", normals_a, normals_b)
    cosine = np.where(same, -cosine, cosine)
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def _check_seams(
    vertices, faces, edges, counts, inverse, normals, diagonal, name, units, crease_angle, brep
) -> None:
    pairs, boundary = seam_pairs(vertices, edges, counts, diagonal)
    if len(pairs) == 0:
        return
    directed = directed_edges(faces)
    # the triangle and direction of each boundary edge
    owner = np.empty(len(edges), dtype=np.int64)
    owner[inverse] = np.arange(len(inverse))
    use_a, use_b = owner[boundary[pairs[:, 0]]], owner[boundary[pairs[:, 1]]]
    direction = vertices[directed[:, 1]] - vertices[directed[:, 0]]
    angles = _fold_angles(
        normals[use_a // 3], normals[use_b // 3], direction[use_a], direction[use_b]
    )
    seam_edges = edges[boundary[np.unique(pairs)]]
    sharp = angles > crease_angle
    if sharp.any():
        crease = edges[boundary[np.unique(pairs[sharp])]]
        links = np.stack(
            [edges[boundary[pairs[sharp, 0]], 0], edges[boundary[pairs[sharp, 1]], 0]], axis=1
        )
        _raise_crease(vertices, crease, float(angles.max()), name, units, crease_angle, links)
    first = vertices[seam_edges[0]].mean(axis=0)
    fix = (
        "join (sew) the faces in the modeller so that they share their edges"
        if brep
        else "weld the mesh (merge vertices) in the modeller"
    )
    raise InputError(
        f"{name}: unwelded seam: {len(seam_edges)} boundary edges near "
        f"{format_point(first, units)} coincide with other boundary edges; {fix}"
    )


def seam_pairs(
    vertices: np.ndarray, edges: np.ndarray, counts: np.ndarray, diagonal: float
) -> tuple[np.ndarray, np.ndarray]:
    """Boundary edges lying on other boundary edges (an unwelded seam).

    vertices : (n, 3) float; edges, counts : as :func:`~.boundary.edge_use` returns them;
    diagonal : of the bounding box, same unit as ``vertices``.
    A boundary edge ``e`` lies on the boundary edge ``f`` when they run nearly parallel
    (``SEAM_PARALLEL``) and the midpoint of ``e`` projects into ``f`` within ``max(SEAM_RELATIVE
    x diagonal, SEAM_EDGE_RELATIVE x longer edge)`` of it. Edges with a common vertex (a seam
    welded at its ends only, the neighbours along a boundary) must lie on each other within
    ``SEAM_RELATIVE x diagonal``: the relative term would take a cusp of the boundary for a seam.
    Returns ``pairs (k, 2) int`` (positions in ``boundary``, each pair once, first < second) and
    ``boundary (b,) int``: the indices into ``edges`` of all boundary edges.
    """
    boundary = np.flatnonzero(counts == 1)
    none = np.zeros((0, 2), dtype=np.int64)
    if len(boundary) < 2:
        return none, boundary
    ends = edges[boundary]
    start, end = vertices[ends[:, 0]], vertices[ends[:, 1]]
    middle = 0.5 * (start + end)
    length = np.linalg.norm(end - start, axis=1)
    absolute = SEAM_RELATIVE * diagonal
    # a midpoint within tol of segment f is within |f| / 2 + tol of f's midpoint
    reach = 0.5 * length + np.maximum(absolute, SEAM_EDGE_RELATIVE * length.max())
    near = cKDTree(middle).query_ball_point(middle, reach, return_sorted=False)
    sizes = np.fromiter((len(x) for x in near), dtype=np.int64, count=len(near))
    f = np.repeat(np.arange(len(boundary)), sizes)  # the segment
    e = np.fromiter((i for x in near for i in x), dtype=np.int64, count=int(sizes.sum()))
    e, f = e[e != f], f[e != f]
    if len(e) == 0:
        return none, boundary
    shared = (
        (ends[e, 0] == ends[f, 0])
        | (ends[e, 0] == ends[f, 1])
        | (ends[e, 1] == ends[f, 0])
        | (ends[e, 1] == ends[f, 1])
    )
    tiny = np.finfo(float).tiny
    axis = end[f] - start[f]
    cosine = np.abs(np.einsum("ij,ij->i", end[e] - start[e], axis)) / (
        np.maximum(length[e], tiny) * np.maximum(length[f], tiny)
    )
    t = np.einsum("ij,ij->i", middle[e] - start[f], axis) / np.maximum(length[f], tiny) ** 2
    distance = np.linalg.norm(middle[e] - (start[f] + t[:, None] * axis), axis=1)
    tolerance = np.where(
        shared,
        absolute,
        np.maximum(absolute, SEAM_EDGE_RELATIVE * np.maximum(length[e], length[f])),
    )
    hit = (cosine >= SEAM_PARALLEL) & (t >= 0.0) & (t <= 1.0) & (distance <= tolerance)
    if not hit.any():
        return none, boundary
    pairs = np.unique(np.sort(np.stack([e[hit], f[hit]], axis=1), axis=1), axis=0)
    return pairs, boundary


def _check_pieces(vertices, faces, name, units) -> None:
    labels = connected_pieces(faces, len(vertices))
    count = int(labels.max()) + 1
    if count == 1:
        return
    # order the pieces by area, largest first
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    order = np.argsort(-np.bincount(labels, weights=area, minlength=count), kind="stable")
    second = vertices[np.unique(faces[labels == order[1]])]
    which = "second" if count == 2 else "second largest"
    raise InputError(
        f"{name}: the surface is {count} separate pieces (the {which} spans "
        f"{format_span(second.min(axis=0), second.max(axis=0), units)}); join "
        f"them into one surface or run them as separate jobs"
    )


def connected_pieces(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """(m,) int: the piece of each triangle; triangles sharing a vertex are in one piece."""
    faces = np.asarray(faces, dtype=np.int64)
    ring = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    graph = sparse.coo_matrix(
        (np.ones(len(ring)), (ring[:, 0], ring[:, 1])), shape=(n_vertices, n_vertices)
    )
    _, vertex_labels = csgraph.connected_components(graph, directed=False)
    # number the pieces in order of their first triangle
    _, labels = np.unique(vertex_labels[faces[:, 0]], return_inverse=True)
    first = np.unique(labels, return_index=True)[1]
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[labels.ravel()]


def fold_angles(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle between the normals of the two triangles on each interior edge, degrees.

    Returns ``edges (k, 2) int`` (vertex pairs of the edges used by exactly two triangles) and
    ``angles (k,) float``: 0 where the surface is flat across the edge, 90 at a right-angled
    fold, 180 where it folds back onto itself. Independent of the triangles' winding.
    """
    faces = np.asarray(faces, dtype=np.int64)
    edges, counts, inverse = edge_use(faces)
    pair, first, second = _interior_uses(counts, inverse)
    angles = _interior_angles(vertices, faces, first, second, _unit_normals(vertices, faces))
    return edges[pair], angles


def _interior_uses(
    counts: np.ndarray, inverse: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edges used twice and their two uses (indices into the directed edges)."""
    shared = np.flatnonzero(counts[inverse] == 2)
    order = shared[np.argsort(inverse[shared], kind="stable")]
    first, second = order[0::2], order[1::2]
    return inverse[first], first, second


def _interior_angles(vertices, faces, first, second, normals) -> np.ndarray:
    directed = directed_edges(faces)
    direction = vertices[directed[:, 1]] - vertices[directed[:, 0]]
    return _fold_angles(
        normals[first // 3], normals[second // 3], direction[first], direction[second]
    )


def _check_creases(vertices, faces, counts, inverse, normals, name, units, crease_angle) -> None:
    _, first, second = _interior_uses(counts, inverse)
    angles = _interior_angles(vertices, faces, first, second, normals)
    sharp = angles > crease_angle
    if not sharp.any():
        return
    directed = directed_edges(faces)
    crease = np.sort(directed[first[sharp]], axis=1)
    _raise_crease(vertices, crease, float(angles.max()), name, units, crease_angle)


def _raise_crease(
    vertices,
    crease: np.ndarray,
    angle: float,
    name: str,
    units: str,
    crease_angle: float,
    links: np.ndarray | None = None,
) -> None:
    """Raise the crease message for the crease edges ``crease (k, 2) int`` (vertex pairs).

    links : (j, 2) int vertex pairs that join crease edges across an unwelded seam (then the
    crease edges are the boundary edges on both sides of the seam).
    """
    joined = crease if links is None else np.vstack([crease, links])
    graph = sparse.coo_matrix(
        (np.ones(len(joined)), (joined[:, 0], joined[:, 1])), shape=(len(vertices), len(vertices))
    )
    _, labels = csgraph.connected_components(graph, directed=False)
    # the crease line through the first crease edge: the crease edges connected to it
    on_line = labels[crease[:, 0]] == labels[crease[0, 0]]
    points = vertices[np.unique(crease[on_line])]
    # its two most distant points, approximately: farthest from any point, then from that one
    a = points[np.argmax(np.linalg.norm(points - points[0], axis=1))]
    b = points[np.argmax(np.linalg.norm(points - a, axis=1))]
    a, b = sorted([a, b], key=tuple)
    lines = len(np.unique(labels[crease[:, 0]]))
    more = f", one of {lines} creases" if lines > 1 else ""
    count = int(on_line.sum())
    plural = "s" if count > 1 else ""
    where = (
        f"{count} edge{plural}"
        if links is None
        else f"an unwelded seam of {count} boundary edge{plural}"
    )
    raise InputError(
        f"{name}: the surface has a crease: triangles meet at up to {angle:.0f} degrees (more "
        f"than [input] crease_angle = {crease_angle:g}) along {where} from "
        f"{_coordinates(a, units)} to {format_point(b, units)}{more}; split the surface into "
        f"separate jobs along the crease, or raise [input] crease_angle if the fold is intended "
        f"and smooth"
    )


def _check_self_intersections(vertices, faces, diagonal, name, units) -> None:
    pairs, points = self_intersections(vertices, faces, CROSSING_RELATIVE * diagonal)
    if len(pairs) == 0:
        return
    raise InputError(
        f"{name}: the surface passes through itself: {len(pairs)} pairs of triangles cross, "
        f"the first near {format_point(points[0], units)}; remove the fold or overlap in the "
        f"modeller (the panels cannot be developed through it)"
    )


# --------------------------------------------------------------------------------------------
# self-intersection
# --------------------------------------------------------------------------------------------
def self_intersections(
    vertices: np.ndarray, faces: np.ndarray, tolerance: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of triangles without a common vertex that cross each other.

    vertices : (n, 3) float; faces : (m, 3) int.
    tolerance : an edge must pass this far through a triangle's plane, and that far inside it,
        to cross it (same unit as ``vertices``).
    Returns ``pairs (k, 2) int`` (first < second, sorted) and ``points (k, 3) float``: a point
    where an edge of one triangle of each pair passes through the other.
    """
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    none = np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3))
    if len(faces) < 2:
        return none
    tri = vertices[faces]
    centre = tri.mean(axis=1)
    radius = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1) + tolerance
    pairs = _overlapping_spheres(centre, radius)
    if len(pairs) == 0:
        return none
    # neighbours (a common vertex or edge) do not count. Most sphere pairs are neighbours, so
    # this test comes first; nine column comparisons are several times faster than one
    # broadcast (k, 3, 3) comparison
    face_a, face_b = faces[pairs[:, 0]], faces[pairs[:, 1]]
    neighbours = np.zeros(len(pairs), dtype=bool)
    for i in range(3):
        for j in range(3):
            neighbours |= face_a[:, i] == face_b[:, j]
    pairs = pairs[~neighbours]
    low, high = tri.min(axis=1), tri.max(axis=1)
    a, b = pairs[:, 0], pairs[:, 1]
    pairs = pairs[((low[a] <= high[b] + tolerance) & (low[b] <= high[a] + tolerance)).all(axis=1)]
    if len(pairs) == 0:
        return none
    normals = _unit_normals(vertices, faces)
    a, b = pairs[:, 0], pairs[:, 1]
    # signed distances of each triangle's corners from the other's plane. Möller's rejection: a
    # triangle wholly on one side of the other's plane does not meet it; and an edge can only
    # cross a plane that its triangle straddles
    dist_b = np.einsum("kij,kj->ki", tri[b] - tri[a][:, None, 0], normals[a])
    dist_a = np.einsum("kij,kj->ki", tri[a] - tri[b][:, None, 0], normals[b])
    keep = (
        (_straddles(dist_b, tolerance) | _straddles(dist_a, tolerance))
        & ~_one_side(dist_a, tolerance)
        & ~_one_side(dist_b, tolerance)
    )
    pairs, dist_a, dist_b = pairs[keep], dist_a[keep], dist_b[keep]
    a, b = pairs[:, 0], pairs[:, 1]
    hit_ba, point_ba = _edges_through(tri[b], dist_b, tri[a], normals[a], tolerance)
    hit_ab, point_ab = _edges_through(tri[a], dist_a, tri[b], normals[b], tolerance)
    hit = hit_ba | hit_ab
    points = np.where(hit_ba[:, None], point_ba, point_ab)[hit]
    pairs = pairs[hit]
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order], points[order]


def _straddles(distance: np.ndarray, tolerance: float) -> np.ndarray:
    """(k,) bool: some corner lies beyond ``tolerance`` on each side of the plane."""
    return np.asarray((distance > tolerance).any(axis=1) & (distance < -tolerance).any(axis=1))


def _one_side(distance: np.ndarray, tolerance: float) -> np.ndarray:
    """(k,) bool: every corner lies beyond ``tolerance`` on the same side of the plane."""
    return np.asarray((distance > tolerance).all(axis=1) | (distance < -tolerance).all(axis=1))


def _edges_through(
    edge_tri: np.ndarray,
    distance: np.ndarray,
    target: np.ndarray,
    normal: np.ndarray,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Does an edge of ``edge_tri`` pass through the interior of ``target``? (per pair)

    edge_tri, target : (k, 3, 3) triangles; distance : (k, 3) signed distances of the corners
    of ``edge_tri`` from the plane of ``target``, whose unit normal is ``normal (k, 3)``.
    Returns ``hit (k,) bool`` and ``point (k, 3)``: where the first such edge passes.
    """
    following = np.roll(distance, -1, axis=1)
    crosses = ((distance > tolerance) & (following < -tolerance)) | (
        (distance < -tolerance) & (following > tolerance)
    )  # (k, 3)
    denominator = np.where(crosses, distance - following, 1.0)
    t = np.where(crosses, distance / denominator, 0.0)
    start = edge_tri
    point = start + t[:, :, None] * (np.roll(edge_tri, -1, axis=1) - start)  # (k, 3, 3)
    # inside the target: on the inner side of each of its edges by more than the tolerance
    inside = crosses.copy()
    for i in range(3):
        u, v = target[:, i], target[:, (i + 1) % 3]
        side = v - u
        inward = np.cross(normal, side)  # in the plane, into the triangle
        length = np.linalg.norm(inward, axis=1, keepdims=True)
        inward = np.divide(inward, length, out=np.zeros_like(inward), where=length > 0)
        depth = np.einsum("kij,kj->ki", point - u[:, None], inward)
        inside &= depth > tolerance
    hit = np.asarray(inside.any(axis=1))
    which = np.argmax(inside, axis=1)
    return hit, point[np.arange(len(point)), which]


def _overlapping_spheres(centre: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(k, 2) int pairs ``i < j`` of spheres that overlap, through k-d trees per size bucket."""
    positive = radius[radius > 0]
    if len(positive) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    level = np.floor(np.log2(np.maximum(radius, positive.min()) / positive.min())).astype(int)
    groups = [np.flatnonzero(level == value) for value in np.unique(level)]
    trees = [cKDTree(centre[group]) for group in groups]
    largest = [float(radius[group].max()) for group in groups]
    found = []
    for i, (group_i, tree_i) in enumerate(zip(groups, trees, strict=True)):
        found.append(group_i[tree_i.query_pairs(2.0 * largest[i], output_type="ndarray")])
        for j in range(i + 1, len(groups)):
            near = tree_i.sparse_distance_matrix(
                trees[j], largest[i] + largest[j], output_type="ndarray"
            )
            found.append(np.stack([group_i[near["i"]], groups[j][near["j"]]], axis=1))
    pairs = np.concatenate(found).astype(np.int64).reshape(-1, 2)
    first, second = pairs[:, 0], pairs[:, 1]
    offset = centre[first] - centre[second]
    reach = radius[first] + radius[second]
    close = np.einsum("ij,ij->i", offset, offset) <= reach * reach
    first, second = first[close], second[close]
    return np.stack([np.minimum(first, second), np.maximum(first, second)], axis=1)
