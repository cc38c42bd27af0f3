"""Edge topology of triangle meshes: edge use counts, boundary loops, consistent winding.

A boundary edge is an edge used by exactly one triangle; the boundary edges of a surface whose
vertices are manifold form closed loops. The loops are ordered as fabpanel needs them: the loop
enclosing the largest area, projected onto the plane that best fits all boundary points, is the
outer boundary and comes first; the others are openings.
"""

from __future__ import annotations

import logging

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from ..errors import InputError
from ..geom.fitting import bestfit_planes
from ..geom.polygon import polygon_area

log = logging.getLogger(__name__)


def directed_edges(faces: np.ndarray) -> np.ndarray:
    """(3 m, 2) int: the directed edges of each triangle, ``faces[f, i] -> faces[f, i + 1]``.

    Edge ``3 f + i`` belongs to face ``f``.
    """
    faces = np.asarray(faces, dtype=np.int64)
    return np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)


def edge_use(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique undirected edges and how many triangles use each.

    faces : (m, 3) int
    Returns ``edges (e, 2) int`` (sorted vertex pairs), ``counts (e,) int`` and
    ``inverse (3 m,) int``: the unique edge of each directed edge of :func:`directed_edges`.
    """
    directed = directed_edges(faces)
    if len(directed) == 0:
        return (
            np.zeros((0, 2), dtype=np.int64),
            np.zeros(0, dtype=np.int64),
            np.zeros(0, dtype=np.int64),
        )
    low = np.minimum(directed[:, 0], directed[:, 1])
    high = np.maximum(directed[:, 0], directed[:, 1])
    # one int64 key per edge orders like the sorted pairs and makes np.unique 1-d, several
    # times faster than np.unique(axis=0) (fine below 3e9 vertices)
    n = int(high.max()) + 1
    keys, inverse, counts = np.unique(low * n + high, return_inverse=True, return_counts=True)
    edges = np.stack([keys // n, keys % n], axis=1)
    return edges, counts, inverse.ravel()


def boundary_loops(
    faces: np.ndarray, vertices: np.ndarray | None = None, where: str = ""
) -> tuple[np.ndarray, ...]:
    """Closed loops of boundary vertices, outer boundary first.

    faces : (m, 3) int
        triangles; loops run in the direction of the boundary edges of their triangles, so for a
        consistently oriented surface they turn counter-clockwise seen from the normal side.
    vertices : (n, 3) float or None
        needed to sort the loops by projected area (mm); without it the loops keep the order in
        which they were found (the loop through the lowest vertex index first).
    where : str
        file name put in front of error messages.

    Returns a tuple of ``(k,) int`` arrays, first vertex not repeated; empty for a closed surface.
    Raises :class:`InputError` when a vertex lies on more than two boundary edges (two loops
    touching in one vertex, a "bow-tie"), since the loops are then ambiguous.
    """
    prefix = f"{where}: " if where else ""
    directed = directed_edges(faces)
    _, counts, inverse = edge_use(faces)
    boundary = directed[counts[inverse] == 1]
    if len(boundary) == 0:
        return ()
    degree = np.bincount(boundary.ravel())
    bad = np.flatnonzero(degree > 2)
    if len(bad):
        raise InputError(
            f"{prefix}boundary vertex {int(bad[0])} is shared by {int(degree[bad[0]]) // 2} "
            f"boundary loops (a bow-tie vertex); split that vertex or close the gap between the "
            f"loops in the modeller"
        )
    ends = np.flatnonzero(degree == 1)
    if len(ends):
        raise InputError(
            f"{prefix}the boundary ends at vertex {int(ends[0])} instead of closing into a loop "
            f"(an edge there is shared by three or more faces); remove the non-manifold faces"
        )
    # walk the undirected boundary graph: every boundary vertex has exactly two boundary edges
    # here, so each vertex has a "next" neighbour. Not a hot path (boundary vertices only).
    neighbours: dict[int, list[int]] = {}
    for a, b in boundary.tolist():
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    successor = {int(a): int(b) for a, b in boundary.tolist()}
    visited: set[int] = set()
    loops = []
    for start in sorted(neighbours):
        if start in visited:
            continue
        loop = [start]
        visited.add(start)
        previous, current = start, neighbours[start][0]
        while current != start:
            if current in visited:
                raise InputError(
                    f"{prefix}the boundary through vertex {current} does not close "
                    f"into a loop; repair the mesh (merge its open edges)"
                )
            loop.append(current)
            visited.add(current)
            options = neighbours[current]
            nxt = options[1] if options[0] == previous else options[0]
            previous, current = current, nxt
        loop_arr = np.array(loop, dtype=np.int64)
        # run the loop like its triangles' boundary edges (they agree for oriented surfaces)
        if successor.get(loop[0]) != loop[1 % len(loop)]:
            loop_arr = np.roll(loop_arr[::-1], 1)
        loops.append(loop_arr)
    if vertices is not None and len(loops) > 1:
        loops = _sort_by_projected_area(loops, np.asarray(vertices, dtype=float))
    return tuple(loops)


def _sort_by_projected_area(loops: list[np.ndarray], vertices: np.ndarray) -> list[np.ndarray]:
    """Largest loop (area projected onto the best-fit plane of all boundary points) first."""
    points = vertices[np.concatenate(loops)]
    normal = bestfit_planes(points[None])[0][0]
    # any two unit vectors spanning the plane; the area's sign does not matter here
    helper = np.eye(3)[np.argmin(np.abs(normal))]
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    areas = [abs(polygon_area(vertices[loop] @ np.stack([e1, e2], axis=1))) for loop in loops]
    order = np.argsort(-np.asarray(areas), kind="stable")
    return [loops[i] for i in order]


def loop_lengths(vertices: np.ndarray, loops: tuple[np.ndarray, ...]) -> list[float]:
    """Length of each closed loop, mm."""
    out = []
    for loop in loops:
        pts = vertices[loop]
        out.append(float(np.linalg.norm(pts - np.roll(pts, -1, axis=0), axis=1).sum()))
    return out


def orient_consistently(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """Flip triangles so that neighbours cross every shared edge in opposite directions.

    faces : (m, 3) int
    Returns ``faces (m, 3) int`` (a new array; unchanged faces keep their vertex order) and the
    number of shared edges still inconsistent afterwards (non-zero only for non-orientable
    surfaces such as a Moebius strip, or at non-manifold edges, which are skipped).

    Vectorised replacement of ``trimesh.repair.fix_winding`` (which needs networkx and walks face
    pairs in Python): a breadth-first spanning forest of the face adjacency over manifold edges
    fixes each face's flip relative to its component's root; the parity along each tree path is
    accumulated by pointer jumping in ``log2(depth)`` numpy steps.
    """
    faces = np.asarray(faces, dtype=np.int64)
    m = len(faces)
    if m == 0:
        return faces.copy(), 0
    directed = directed_edges(faces)
    _, counts, inverse = edge_use(faces)
    # pairs of directed edges on the same manifold edge
    shared = np.flatnonzero(counts[inverse] == 2)
    order = shared[np.argsort(inverse[shared], kind="stable")]
    first, second = order[0::2], order[1::2]
    face_a, face_b = first // 3, second // 3
    # the pair is consistent when the two faces run the edge in opposite directions
    flip_needed = (directed[first, 0] == directed[second, 0]).astype(np.int8)
    # two faces can share more than one edge (folded slivers): keep one relation per face pair
    _, unique_pairs = np.unique(
        np.sort(np.stack([face_a, face_b], axis=1), axis=1), axis=0, return_index=True
    )
    face_a, face_b = face_a[unique_pairs], face_b[unique_pairs]
    flip_needed = flip_needed[unique_pairs]
    graph = sparse.coo_matrix((np.ones(len(face_a)), (face_a, face_b)), shape=(m, m)).tocsr()
    _, labels = csgraph.connected_components(graph, directed=False)
    predecessors = np.full(m, -9999, dtype=np.int64)
    roots = np.unique(labels, return_index=True)[1]
    for root in roots:  # one BFS per connected component (usually one)
        _, pred = csgraph.breadth_first_order(graph, root, directed=False, return_predecessors=True)
        reached = pred >= 0
        predecessors[reached] = pred[reached]
    predecessors[roots] = roots
    # relation of each tree edge (face -> its predecessor): 1 when the two must differ
    relation = sparse.coo_matrix(
        (
            np.concatenate([flip_needed, flip_needed]) + 1,
            (np.concatenate([face_a, face_b]), np.concatenate([face_b, face_a])),
        ),
        shape=(m, m),
    ).tocsr()
    parity = np.asarray(relation[np.arange(m), predecessors]).ravel().astype(np.int64)
    # stored as flip + 1 so that "no flip" is not an implicit zero; roots have no relation
    parity = np.where(parity > 0, parity - 1, 0)
    parity[roots] = 0
    pointer = predecessors.copy()
    while True:
        nxt = pointer[pointer]
        parity = parity ^ parity[pointer]
        done = np.array_equal(nxt, pointer)
        pointer = nxt
        if done:
            break
    out = faces.copy()
    flip = parity.astype(bool)
    out[flip] = out[flip][:, ::-1]
    remaining = inconsistent_edges(out)
    if remaining:
        log.warning(
            "%d shared edges cannot be oriented consistently (non-orientable surface)", remaining
        )
    return out, remaining


def inconsistent_edges(faces: np.ndarray) -> int:
    """Number of manifold edges whose two triangles run them in the same direction."""
    directed = directed_edges(faces)
    _, counts, inverse = edge_use(faces)
    shared = np.flatnonzero(counts[inverse] == 2)
    order = shared[np.argsort(inverse[shared], kind="stable")]
    return int(np.count_nonzero(directed[order[0::2], 0] == directed[order[1::2], 0]))
