"""Patch graph of the skeleton decomposition and its conversion into a coarse quad layout.

Helper of :mod:`fabpanel.panelize.skeleton`. The kept graph (boundary segments, live skeleton
chords, grafts) lives on a refinement of the Delaunay clusters whose small faces and their
adjacency are known by construction: around every cluster node, one face per boundary edge of its
polygon and two half-kites per chord. Patches are the classes of small faces merged across every
edge that is not kept, so no angle sorting or coordinate matching is needed.

Graph nodes ("P-nodes") are integers: boundary sample ``v`` is ``v``, skeleton cluster ``c`` is
``n + c`` (``n`` samples).
"""

from __future__ import annotations

import logging
from collections import Counter, defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from shapely.geometry import Polygon

from ..errors import GeometryError
from .coarse import CoarseLayout

if TYPE_CHECKING:
    from .skeleton import _Decomposition, _Skeleton

log = logging.getLogger(__name__)

#: a small face: ("B", cluster, polygon side) for a boundary side of a cluster polygon, or
#: ("H", chord key, chord end vertex) for the half-kite of a chord at one of its ends
FaceKey = tuple[str, int, int]
#: a patch side as used by a patch: (side id, traversed in the side's own direction?)
PatchSide = tuple[int, bool]


def smallest_member_labels(count: int, pairs: Iterable[tuple[int, int]]) -> list[int]:
    """Label every element 0..count-1 with the smallest element of its connected component.

    Replaces the hand-written union-finds (their root was always the smallest member, and
    clusters and patches are numbered and ordered by it, so the label must stay that).
    """
    if count == 0:
        return []
    edges = np.asarray(list(pairs), dtype=np.int64).reshape(-1, 2)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(count, count))
    component_count, component = connected_components(graph, directed=False)
    # do not rely on how connected_components numbers its components: take the minimum
    smallest = np.full(component_count, count, dtype=np.int64)
    np.minimum.at(smallest, component, np.arange(count))
    return [int(label) for label in smallest[component]]


def _area(pl):
    x, y = pl[:, 0], pl[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _join(parts):
    out = [parts[0]]
    for p in parts[1:]:
        out.append(p[1:])
    return np.vstack(out)


def _halves(pl):
    seg = np.linalg.norm(np.diff(pl, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    half = cum[-1] / 2.0
    i = int(np.searchsorted(cum, half, side="right") - 1)
    i = min(max(i, 0), len(pl) - 2)
    t = (half - cum[i]) / max(seg[i], 1e-300)
    m = pl[i] + t * (pl[i + 1] - pl[i])
    first = [pl[j] for j in range(i + 1)]
    second = [pl[j] for j in range(i + 1, len(pl))]
    eps = 1e-9 * max(cum[-1], 1e-300)
    if np.linalg.norm(first[-1] - m) < eps and len(first) > 1:
        first.pop()
    if np.linalg.norm(second[0] - m) < eps and len(second) > 1:
        second.pop(0)
    return np.array(first + [m]), m, np.array([m] + second)


def _side_polyline(geoms: list, nodes: tuple, n: int) -> np.ndarray:
    """Polyline of a patch side from its half-edge geometries.

    Along a skeleton branch the circumcentres of the sleeve triangles zig-zag back and forth
    when the two boundaries are sampled out of phase (nearly parallel sides: the circumcentres
    all lie near the axis, but not in order), which folds every patch built on the branch. The
    chord midpoints (Prasad's chordal axis) advance monotonically along the sleeve, so the
    interior skeleton nodes (cluster ids >= n) are dropped and only the chord midpoints and the
    side's two end nodes are kept; boundary samples (ids < n) are all kept.
    """
    points = [geoms[0][0]]
    for k, g in enumerate(geoms):
        points.extend(g[1:-1])
        if k == len(geoms) - 1 or nodes[k + 1] < n:
            points.append(g[-1])
    return np.asarray(points, dtype=float)


def _quad_ok(poly):
    if _area(poly) <= 0:
        return False
    try:
        return Polygon(poly).is_valid
    except Exception:  # noqa: BLE001 - shapely raises several types on degenerate rings
        return False


class _HalfEdge(NamedTuple):
    """A directed edge of the kept graph with the patch on its left."""

    start: int  # P-node
    end: int  # P-node
    patch: int
    geometry: np.ndarray | None  # polyline start -> end; None for a straight graft


class _SmallFaces:
    """The small faces around every cluster node, numbered in a fixed order, and their patches."""

    def __init__(self, dec: _Decomposition):
        self.skeleton = dec.sk
        self.ids: dict[FaceKey, int] = {}
        for cluster in range(self.skeleton.ncl):
            polygon = self.skeleton.poly[cluster]
            for side in range(len(polygon)):
                for vertex in (polygon[side], polygon[(side + 1) % len(polygon)]):
                    self.ids.setdefault(self.key(cluster, side, vertex), len(self.ids))
        # patch of every face: the smallest face id of its class (patches are ordered by it)
        self.patch_of = smallest_member_labels(len(self.ids), self._merged_pairs(dec))

    def key(self, cluster: int, side: int, vertex: int) -> FaceKey:
        """The small face at ``vertex`` on side ``side`` (mod its length) of a cluster polygon."""
        side %= len(self.skeleton.poly[cluster])
        chord = self.skeleton.eside[cluster][side]
        return ("B", cluster, side) if chord == -1 else ("H", chord, vertex)

    def patch(self, cluster: int, side: int, vertex: int) -> int:
        """The patch of the small face at ``vertex`` on side ``side`` of a cluster polygon."""
        return self.patch_of[self.ids[self.key(cluster, side, vertex)]]

    def patch_of_face(self, face: FaceKey) -> int:
        """The patch of a small face given by its key."""
        return self.patch_of[self.ids[face]]

    def _merged_pairs(self, dec: _Decomposition) -> Iterator[tuple[int, int]]:
        """Pairs of small faces on the two sides of every graph edge that is not kept."""
        skeleton = self.skeleton
        for cluster in range(skeleton.ncl):
            polygon = skeleton.poly[cluster]
            # spokes (node to polygon vertex) separate the faces of sides i - 1 and i at vertex
            # i; only the grafts of live nodes are kept
            kept = dec.spokes[cluster] if cluster in dec.live_nodes else set()
            for side, vertex in enumerate(polygon):
                if side not in kept:
                    yield (
                        self.ids[self.key(cluster, side, vertex)],
                        self.ids[self.key(cluster, side - 1, vertex)],
                    )
        for chord in sorted(skeleton.chord):
            if chord not in dec.live_chords:
                # a dead chord's skeleton edge (node to node) separates its two half-kites
                yield (
                    self.ids[("H", chord, chord // skeleton.n)],
                    self.ids[("H", chord, chord % skeleton.n)],
                )


def _node_point(skeleton: _Skeleton, node: int) -> np.ndarray:
    """Plane position of a P-node (a boundary sample or a skeleton cluster's node)."""
    return skeleton.P[node] if node < skeleton.n else skeleton.pos[node - skeleton.n]


def _halfedge_geometry(skeleton: _Skeleton, halfedge: _HalfEdge) -> np.ndarray:
    """Polyline of a half-edge (a straight segment for a graft)."""
    if halfedge.geometry is not None:
        return halfedge.geometry
    return np.array([_node_point(skeleton, halfedge.start), _node_point(skeleton, halfedge.end)])


def _boundary_halfedges(dec: _Decomposition, bnd_dir, faces: _SmallFaces) -> list[_HalfEdge]:
    """One half-edge per boundary segment (the domain inside), following the input loop."""
    skeleton, samples = dec.sk, dec.smp
    sample_count = skeleton.n
    halfedges = []
    for start, end in bnd_dir:
        cluster, side = skeleton.bnd_owner[min(start, end) * sample_count + max(start, end)]
        # the input loop between the two samples (its own vertices kept), ends exactly at them
        loop_curve = dec.curves[int(samples.loop[start])]
        geometry = loop_curve.between(float(samples.s[start]), float(samples.s[end]))
        geometry[0], geometry[-1] = skeleton.P[start], skeleton.P[end]
        patch = faces.patch_of_face(("B", cluster, side))
        halfedges.append(_HalfEdge(start, end, patch, geometry))
    return halfedges


def _chord_halfedges(dec: _Decomposition, faces: _SmallFaces) -> list[_HalfEdge]:
    """Both half-edges of every live skeleton edge: node, chord midpoint, node."""
    skeleton = dec.sk
    sample_count = skeleton.n
    halfedges = []
    for chord in sorted(dec.live_chords):
        cluster, neighbour = skeleton.chord[chord]
        side = skeleton.eside[cluster].index(chord)
        polygon = skeleton.poly[cluster]
        first, second = polygon[side], polygon[(side + 1) % len(polygon)]
        middle = 0.5 * (skeleton.P[first] + skeleton.P[second])
        geometry = np.array([skeleton.pos[cluster], middle, skeleton.pos[neighbour]])
        forward_patch = faces.patch_of_face(("H", chord, second))
        backward_patch = faces.patch_of_face(("H", chord, first))
        halfedges.append(
            _HalfEdge(sample_count + cluster, sample_count + neighbour, forward_patch, geometry)
        )
        halfedges.append(
            _HalfEdge(
                sample_count + neighbour, sample_count + cluster, backward_patch, geometry[::-1]
            )
        )
    return halfedges


def _graft_halfedges(dec: _Decomposition, faces: _SmallFaces) -> list[_HalfEdge]:
    """Both half-edges of every graft (live node to boundary sample, straight)."""
    skeleton = dec.sk
    halfedges = []
    for cluster in sorted(dec.live_nodes):
        polygon = skeleton.poly[cluster]
        for side in sorted(dec.spokes[cluster]):
            sample = polygon[side]
            left = faces.patch(cluster, side, sample)
            right = faces.patch(cluster, side - 1, sample)
            if left == right:
                point = skeleton.P[sample]
                raise GeometryError(
                    "a graft ends inside one patch (dangling branch) near "
                    f"({point[0]:.6g}, {point[1]:.6g}); try another sample_spacing"
                )
            halfedges.append(_HalfEdge(skeleton.n + cluster, sample, left, None))
            halfedges.append(_HalfEdge(sample, skeleton.n + cluster, right, None))
    return halfedges


def _coarse_nodes(dec: _Decomposition, halfedges: list[_HalfEdge], bnd_dir) -> set[int]:
    """P-nodes that become coarse vertices: graph degree other than 2, and boundary corners."""
    half_degree: Counter[int] = Counter()
    for halfedge in halfedges:
        half_degree[halfedge.start] += 1
        half_degree[halfedge.end] += 1
    for start, end in bnd_dir:  # boundary edges were added once, count their other direction
        half_degree[start] += 1
        half_degree[end] += 1
    degree = {node: count // 2 for node, count in half_degree.items()}
    coarse_nodes = {node for node, node_degree in degree.items() if node_degree != 2}
    coarse_nodes |= {int(sample) for sample in np.flatnonzero(dec.smp.corner)}
    return coarse_nodes


def _patch_cycles(skeleton: _Skeleton, halfedges: list[_HalfEdge]) -> dict[int, list[_HalfEdge]]:
    """Outline of every patch (by patch id, ascending): its half-edges in order from its
    smallest node. Raises if a patch touches itself or is not a disk."""
    by_patch: defaultdict[int, dict[int, _HalfEdge]] = defaultdict(dict)  # patch -> start -> he
    for halfedge in halfedges:
        outgoing = by_patch[halfedge.patch]
        if halfedge.start in outgoing:
            point = _node_point(skeleton, halfedge.start)
            raise GeometryError(
                f"a patch touches itself at ({point[0]:.6g}, {point[1]:.6g}); the skeleton "
                "decomposition failed here - try another sample_spacing"
            )
        outgoing[halfedge.start] = halfedge
    cycles = {}
    for patch in sorted(by_patch):
        outgoing = by_patch[patch]
        start = min(outgoing)
        cycle = [outgoing[start]]
        while cycle[-1].end != start:
            cycle.append(outgoing[cycle[-1].end])
            if len(cycle) > len(outgoing):
                raise GeometryError(
                    "patch outline does not close; internal error of the decomposition"
                )
        if len(cycle) != len(outgoing):
            point = _node_point(skeleton, start)
            raise GeometryError(
                f"a patch near ({point[0]:.6g}, {point[1]:.6g}) is not a disk (it surrounds "
                "an opening); the skeleton decomposition failed - try another "
                "sample_spacing"
            )
        cycles[patch] = cycle
    return cycles


@dataclass
class _CoarseVertices:
    """The coarse vertices as they are made, in id order."""

    points: list[np.ndarray] = field(default_factory=list)
    loop_of: list[int] = field(default_factory=list)  # boundary loop, -1 inside
    corner: list[bool] = field(default_factory=list)

    def add(self, point: np.ndarray, loop: int, corner: bool = False) -> int:
        """Append a vertex; its id."""
        self.points.append(point)
        self.loop_of.append(loop)
        self.corner.append(corner)
        return len(self.points) - 1


def _coarse_vertices(
    dec: _Decomposition, coarse_nodes: set[int]
) -> tuple[dict[int, int], _CoarseVertices]:
    """Coarse vertex ids (boundary samples in loop order, then skeleton nodes) and vertices."""
    skeleton, samples = dec.sk, dec.smp
    sample_count = skeleton.n
    order_key = {}
    for loop, loop_order in enumerate(samples.order):
        for position, sample in enumerate(loop_order):
            order_key[sample] = (0, loop, position)
    ordered = sorted(coarse_nodes, key=lambda node: order_key.get(node, (1, node, 0)))
    vertices = _CoarseVertices()
    for node in ordered:
        loop = int(samples.loop[node]) if node < sample_count else -1
        vertices.add(
            _node_point(skeleton, node), loop, bool(node < sample_count and samples.corner[node])
        )
    return {node: vertex for vertex, node in enumerate(ordered)}, vertices


@dataclass
class _Sides:
    """The patch sides (graph paths between coarse nodes), each stored once."""

    ids: dict[tuple[int, ...], int] = field(default_factory=dict)  # canonical P-nodes -> side id
    geometry: list[np.ndarray] = field(default_factory=list)  # polyline, canonical direction
    ends: list[tuple[int, int]] = field(default_factory=list)  # coarse vertex ids
    loop: list[int] = field(default_factory=list)  # boundary loop of a boundary side, else -1
    nodes: list[tuple[int, ...]] = field(default_factory=list)  # canonical P-nodes

    def corners(self, patch_sides: list[PatchSide]) -> list[int]:
        """Coarse vertex ids of a patch's corners, corner i at the start of side i."""
        return [
            self.ends[side][0] if forward else self.ends[side][1] for side, forward in patch_sides
        ]


def _patch_sides(
    dec: _Decomposition,
    cycles: list[list[_HalfEdge]],
    coarse_nodes: set[int],
    vertex_of_node: dict[int, int],
) -> tuple[_Sides, list[list[PatchSide]]]:
    """Cut every patch outline at its coarse nodes into sides; the sides once (the first patch
    to reach a side sets its direction) and every patch as its list of sides."""
    skeleton, samples = dec.sk, dec.smp
    sample_count = skeleton.n
    sides = _Sides()
    patches = []
    for cycle in cycles:
        first = next(
            (index for index, halfedge in enumerate(cycle) if halfedge.start in coarse_nodes), None
        )
        if first is None:
            point = _node_point(skeleton, cycle[0].start)
            raise GeometryError(
                f"a boundary loop near ({point[0]:.6g}, {point[1]:.6g}) has no split point; "
                "internal error of the decomposition"
            )
        cycle = cycle[first:] + cycle[:first]
        run_nodes, run_geometries = [cycle[0].start], []
        patch_sides: list[PatchSide] = []
        for halfedge in cycle:
            run_nodes.append(halfedge.end)
            run_geometries.append(_halfedge_geometry(skeleton, halfedge))
            if halfedge.end not in coarse_nodes:
                continue
            nodes = tuple(run_nodes)
            if nodes in sides.ids:
                patch_sides.append((sides.ids[nodes], True))
            elif nodes[::-1] in sides.ids:
                patch_sides.append((sides.ids[nodes[::-1]], False))
            else:
                sides.ids[nodes] = len(sides.geometry)
                sides.geometry.append(_side_polyline(run_geometries, nodes, sample_count))
                sides.ends.append((vertex_of_node[nodes[0]], vertex_of_node[nodes[-1]]))
                on_boundary = all(node < sample_count for node in nodes)
                sides.loop.append(int(samples.loop[nodes[0]]) if on_boundary else -1)
                sides.nodes.append(nodes)
                patch_sides.append((sides.ids[nodes], True))
            run_nodes, run_geometries = [halfedge.end], []
        patches.append(patch_sides)
    return sides, patches


def _patches_are_quads(sides: _Sides, patches: list[list[PatchSide]], info: dict) -> bool:
    """Whether the patches are a quad layout as they are (four distinct corners each, no two
    sides on one vertex pair, no two patches on one vertex set); recorded in ``info``."""
    sides_per_patch = Counter(len(patch) for patch in patches)
    info["patches"] = len(patches)
    info["patches_by_sides"] = {
        str(sides): int(count) for sides, count in sorted(sides_per_patch.items())
    }
    vertex_pairs = Counter(tuple(sorted(ends)) for ends in sides.ends)
    vertex_sets = Counter(frozenset(sides.corners(patch)) for patch in patches)
    all_quads = (
        all(len(patch) == 4 and len(set(sides.corners(patch))) == 4 for patch in patches)
        and max(vertex_pairs.values()) == 1
        and max(vertex_sets.values()) == 1
    )
    info["midpoint_subdivision"] = not all_quads
    return all_quads


def _store_edge(edge_curves: dict, start: int, end: int, geometry: np.ndarray) -> None:
    """Store an edge polyline under its sorted vertex pair, running from the smaller id."""
    if start < end:
        edge_curves[(start, end)] = geometry
    else:
        edge_curves[(end, start)] = geometry[::-1]


def _patch_quads(
    sides: _Sides, patches: list[list[PatchSide]]
) -> tuple[list[list[int]], dict[tuple[int, int], np.ndarray]]:
    """The patches themselves as the quads, their sides as the edge curves."""
    edge_curves: dict[tuple[int, int], np.ndarray] = {}
    for side, (start, end) in enumerate(sides.ends):
        _store_edge(edge_curves, start, end, sides.geometry[side])
    return [sides.corners(patch) for patch in patches], edge_curves


def _split_side(dec: _Decomposition, sides: _Sides, side: int) -> tuple:
    """A side's two halves and its midpoint (on the input loop for a boundary side)."""
    geometry = sides.geometry[side]
    loop = sides.loop[side]
    if loop >= 0 and len(geometry) >= 3:
        # split a boundary side at its sample nearest to the middle: stays on the input
        segment_lengths = np.linalg.norm(np.diff(geometry, axis=0), axis=1)
        cumulative = np.concatenate([[0.0], np.cumsum(segment_lengths)])
        nearest = int(np.argmin(np.abs(cumulative[1:-1] - cumulative[-1] / 2.0))) + 1
        return geometry[: nearest + 1], geometry[nearest].copy(), geometry[nearest:]
    if loop >= 0:
        # one sample segment: take the middle along the input loop
        start, end = sides.nodes[side][0], sides.nodes[side][-1]
        loop_curve = dec.curves[loop]
        s_start, s_end = float(dec.smp.s[start]), float(dec.smp.s[end])
        if s_end <= s_start:  # the segment runs across the loop's start
            s_end += loop_curve.length
        middle = loop_curve.at(0.5 * (s_start + s_end))
        return np.array([geometry[0], middle]), middle, np.array([middle, geometry[-1]])
    return _halves(geometry)


def _dead_nodes_inside_patches(dec: _Decomposition, faces: _SmallFaces) -> dict[int, list[int]]:
    """Dead skeleton nodes whose small faces all lie in one patch, by patch."""
    skeleton = dec.sk
    inside_nodes = defaultdict(list)
    for cluster in range(skeleton.ncl):
        if cluster in dec.live_nodes:
            continue
        polygon = skeleton.poly[cluster]
        patches = {faces.patch(cluster, side, polygon[side]) for side in range(len(polygon))}
        patches |= {faces.patch(cluster, side - 1, polygon[side]) for side in range(len(polygon))}
        if len(patches) == 1:
            inside_nodes[patches.pop()].append(cluster)
    return inside_nodes


def _oriented_halves(
    patch_sides: list[PatchSide], halves: list[tuple[np.ndarray, np.ndarray]]
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Half polylines along the patch: outs[i] corner i -> mid of side i, ins[i] that mid ->
    corner i + 1."""
    outs, ins = [], []
    for side, forward in patch_sides:
        first, second = halves[side]
        if forward:
            outs.append(first)
            ins.append(second)
        else:
            outs.append(second[::-1])
            ins.append(first[::-1])
    return outs, ins


def _patch_centre(
    skeleton: _Skeleton,
    outs: list[np.ndarray],
    ins: list[np.ndarray],
    mid_points: list[np.ndarray],
    inside_nodes: list[int],
) -> tuple[int, np.ndarray]:
    """Centre of a patch's midpoint subdivision and how many of its k quads are valid with it:
    the first candidate that makes all k valid, else the first with the most valid."""
    side_count = len(outs)
    outline = _join([_join([outs[side], ins[side]]) for side in range(side_count)])
    outline_polygon = Polygon(outline)
    candidates = []
    if outline_polygon.is_valid and outline_polygon.area > 0:
        candidates.append(np.array(outline_polygon.centroid.coords[0]))
        candidates.append(np.array(outline_polygon.representative_point().coords[0]))
    mean_point = outline.mean(0)
    # when neither makes all k quads valid (a bent or invalid outline), the dead skeleton
    # nodes inside the patch are tried: they lie on the medial axis, far from every side
    nearest_nodes = sorted(
        inside_nodes,
        key=lambda cluster: (float(np.linalg.norm(skeleton.pos[cluster] - mean_point)), cluster),
    )
    candidates += [skeleton.pos[cluster] for cluster in nearest_nodes[:40]]
    if not candidates:
        candidates.append(mean_point)
    best = None
    for candidate in candidates:
        valid = 0
        for corner in range(side_count):
            # the quad at corner i: out of corner i, mid i, centre, mid i - 1, back into corner i
            quad = _join(
                [
                    outs[corner],
                    np.array([mid_points[corner], candidate]),
                    np.array([candidate, mid_points[corner - 1]]),
                    ins[corner - 1],
                ]
            )
            valid += _quad_ok(quad[:-1])
        if best is None or valid > best[0]:
            best = (valid, candidate)
        if valid == side_count:
            break
    if best is None:  # candidates is never empty
        raise GeometryError("a patch has no centre candidate; internal error of the decomposition")
    return best


def _midpoint_subdivision(
    dec: _Decomposition,
    faces: _SmallFaces,
    sides: _Sides,
    patches: list[list[PatchSide]],
    patch_ids: list[int],
    vertices: _CoarseVertices,
) -> tuple[list[list[int]], dict[tuple[int, int], np.ndarray], int]:
    """Every k-sided patch as k quads (corner, side mid, centre, previous side mid); adds the
    mids and centres to ``vertices``. Quads, edge curves, patches without a valid centre."""
    side_mids = []
    halves = []
    for side in range(len(sides.geometry)):
        first, middle, second = _split_side(dec, sides, side)
        side_mids.append(vertices.add(middle, sides.loop[side]))
        halves.append((first, second))
    inside_nodes = _dead_nodes_inside_patches(dec, faces)
    quads = []
    edge_curves: dict[tuple[int, int], np.ndarray] = {}
    bad_centres = 0
    for patch, patch_sides in zip(patch_ids, patches):
        side_count = len(patch_sides)
        corners = sides.corners(patch_sides)
        mids = [side_mids[side] for side, _ in patch_sides]
        outs, ins = _oriented_halves(patch_sides, halves)
        valid, centre_point = _patch_centre(
            dec.sk, outs, ins, [vertices.points[mid] for mid in mids], inside_nodes.get(patch, [])
        )
        if valid < side_count:
            bad_centres += 1
        centre = vertices.add(centre_point, -1)
        for corner in range(side_count):
            previous = (corner - 1) % side_count
            quads.append([corners[corner], mids[corner], centre, mids[previous]])
            _store_edge(edge_curves, corners[corner], mids[corner], outs[corner])
            _store_edge(edge_curves, mids[previous], corners[corner], ins[previous])
            spoke = np.array([vertices.points[mids[corner]], centre_point])
            _store_edge(edge_curves, mids[corner], centre, spoke)
    return quads, edge_curves, bad_centres


def _edge_polygon(edge_curves: dict, quad: np.ndarray) -> np.ndarray:
    """Outline of a quad along its edge polylines (last point not repeated)."""
    parts = []
    for corner in range(4):
        start, end = int(quad[corner]), int(quad[(corner + 1) % 4])
        parts.append(edge_curves[(start, end)] if start < end else edge_curves[(end, start)][::-1])
    return _join(parts)[:-1]


def _report_validity(
    vertices: np.ndarray, quads: np.ndarray, edge_curves: dict, info: dict
) -> None:
    """Count (in ``info``) quads with non-positive straight-edge area or whose edge polylines
    do not form a simple CCW polygon; warn about the latter."""
    nonpositive_straight = 0
    invalid = []
    for quad_index, quad in enumerate(quads):
        if _area(vertices[quad]) <= 0:
            nonpositive_straight += 1
        if not _quad_ok(_edge_polygon(edge_curves, quad)):
            invalid.append(quad_index)
    info["quads_nonpositive_straight"] = nonpositive_straight
    info["quads_invalid_polyline"] = len(invalid)
    if invalid:
        log.warning(
            "skeleton layout: %d quads whose edge polylines do not form a simple CCW polygon: %s",
            len(invalid),
            invalid[:10],
        )


def _singular_vertices(
    edge_curves: dict, loop_of_vertex: np.ndarray, vertex_count: int, info: dict
) -> np.ndarray:
    """Interior vertices whose valence is not 4 (their valences counted in ``info``)."""
    valence: Counter[int] = Counter()
    for start, end in edge_curves:
        valence[start] += 1
        valence[end] += 1
    singular = np.array(
        sorted(
            vertex
            for vertex in range(vertex_count)
            if loop_of_vertex[vertex] == -1 and valence[vertex] != 4
        ),
        dtype=np.int64,
    )
    info["singular_valences"] = {
        str(degree): int(count)
        for degree, count in sorted(Counter(valence[vertex] for vertex in singular).items())
    }
    return singular


def _match_point_features(vertices: np.ndarray, point_features, diag: float, info: dict) -> None:
    """Count (in ``info``) the point features that are layout vertices; warn about the others
    (not supported by the skeleton method yet)."""
    if point_features is None or not len(point_features):
        return
    features = np.asarray(point_features, float).reshape(-1, 2)
    matched = 0
    for point in features:
        distance = np.linalg.norm(vertices - point, axis=1)
        if distance.min() <= 1e-6 * diag:
            matched += 1
        else:
            log.warning(
                "point feature (%.6g, %.6g) is not a vertex of the skeleton layout; "
                "point features are not supported by the skeleton method yet, ignored",
                point[0],
                point[1],
            )
    info["point_features_matched"] = matched
    info["point_features_ignored"] = int(len(features) - matched)


def build_layout(dec, bnd_dir, point_features, diag) -> CoarseLayout:
    """Coarse quad layout of the decomposition's kept graph: its patches, as they are if all are
    quads, else after one global midpoint subdivision."""
    skeleton, samples, info = dec.sk, dec.smp, dec.info
    faces = _SmallFaces(dec)
    halfedges = (
        _boundary_halfedges(dec, bnd_dir, faces)
        + _chord_halfedges(dec, faces)
        + _graft_halfedges(dec, faces)
    )
    coarse_nodes = _coarse_nodes(dec, halfedges, bnd_dir)
    cycles = _patch_cycles(skeleton, halfedges)
    vertex_of_node, vertices = _coarse_vertices(dec, coarse_nodes)
    patch_ids = sorted(cycles)
    sides, patches = _patch_sides(
        dec, [cycles[patch] for patch in patch_ids], coarse_nodes, vertex_of_node
    )
    if _patches_are_quads(sides, patches, info):
        quads, edge_curves = _patch_quads(sides, patches)
        bad_centres = 0
    else:
        quads, edge_curves, bad_centres = _midpoint_subdivision(
            dec, faces, sides, patches, patch_ids, vertices
        )
    vertex_array = np.array(vertices.points, float)
    quad_array = np.array(quads, dtype=np.int64).reshape(-1, 4)
    info["quads"] = len(quad_array)
    info["patches_without_valid_centre"] = bad_centres
    _report_validity(vertex_array, quad_array, edge_curves, info)
    loop_of_vertex = np.array(vertices.loop_of, dtype=np.int64)
    singular = _singular_vertices(edge_curves, loop_of_vertex, len(vertex_array), info)
    _match_point_features(vertex_array, point_features, diag, info)
    return CoarseLayout(
        vertices=vertex_array,
        quads=quad_array,
        edge_curves=edge_curves,
        loop_of_vertex=loop_of_vertex,
        corner=np.array(vertices.corner, bool),
        singular=singular,
        loops=tuple(skeleton.P[np.array(loop_order)] for loop_order in samples.order),
        info=info,
    )
