"""Clash check: no two parts may interpenetrate, measured on tessellations with manifold3d.

Parts that touch (a rib on a sheet, back-to-back ribs) share faces; on exact geometry their common
volume is zero, on tessellations it is a sliver of about the chord error times the contact area.
To keep those slivers out, every clash solid is shrunk by ``TOLERANCES.clash_depth`` on all
sides (plates: outline offset inward, thickness reduced on both faces; sheets: faces moved towards
each other, edges pulled in along the surface), so touching parts leave a gap, and a pair clashes
when its common volume still exceeds ``TOLERANCES.clash_volume`` of the smaller part: an overlap
deeper than the shrink over more than that share of the part.

The tessellations come from the parts' own data, not from meshing the B-reps (which costs about
2 s per drilled sheet): a plate is its outline (the points its B-spline edges interpolate)
extruded by its thickness, a sheet is the closed mesh of its two faces' dense sample grids and
the strips between their edges (chord error about 0.04 mm on a 1.2 m panel of 4 m radius).
Holes are left out: they only remove material, so a clash found without them is checked on
more material than the part has, never less.

To keep this linear in the number of panels, every panel's parts are first united (the overlap
inside a panel is the sum of the part volumes minus the union's volume), and neighbouring panels'
unions are intersected; only a group over the tolerance is checked part by part, to name the
parts. manifold3d's booleans are exact on its input meshes (Lévy's robust predicates), so touching
coplanar faces do not create spurious volume.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping

import manifold3d as m3d
import numpy as np

from ..errors import KernelError
from ..tolerances import TOLERANCES

#: two parts that interpenetrate: their ids, the volume they share (mm3) and its centre (mm)
Clash = tuple[str, str, float, np.ndarray]


def plate_solid(
    outline: np.ndarray, frame: np.ndarray, thickness: float, shrink: float = 0.0
) -> m3d.Manifold:
    """A flat plate: ``outline (n, 2)`` in the frame's (x, y) extruded along its z, mm, shrunk
    by ``shrink`` mm on every side."""
    section = m3d.CrossSection([np.asarray(outline, dtype=float).tolist()])
    if shrink:
        section = section.offset(-shrink, m3d.JoinType.Miter)
    solid = section.extrude(float(thickness) - 2 * shrink).translate((0.0, 0.0, shrink))
    return solid.transform(np.asarray(frame, dtype=float)[:3])


def shrink_slab(
    outer: np.ndarray, inner: np.ndarray, shrink: float
) -> tuple[np.ndarray, np.ndarray]:
    """Two corresponding (a, b, 3) face grids moved ``shrink`` mm towards each other, their
    boundary rows ``shrink`` mm into the sheet along the grid."""
    across = inner - outer
    unit = across / np.maximum(np.linalg.norm(across, axis=2, keepdims=True), 1e-12)
    grids = [outer + shrink * unit, inner - shrink * unit]
    for grid in grids:
        for rows, inward in (((0,), (1,)), ((-1,), (-2,))):
            for axis in (0, 1):
                edge = np.take(grid, rows, axis=axis)
                step = np.take(grid, inward, axis=axis) - edge
                moved = edge + shrink * step / np.maximum(
                    np.linalg.norm(step, axis=2, keepdims=True), 1e-12
                )
                index: list[slice | int] = [slice(None), slice(None)]
                index[axis] = rows[0]
                grid[tuple(index)] = np.squeeze(moved, axis=axis)
    return grids[0], grids[1]


def slab_mesh(outer: np.ndarray, inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle mesh between two (a, b, 3) grids with corresponding points: both grids
    as two triangles per cell and the four strips between their boundaries; outward."""
    a, b = outer.shape[:2]
    index = np.arange(a * b).reshape(a, b)
    cells = np.stack([index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]], -1)
    cells = cells.reshape(-1, 4)
    top = np.r_[cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]]
    ring = np.concatenate([index[:, 0], index[-1, 1:], index[-2::-1, -1], index[0, -2:0:-1]])
    nxt = np.roll(ring, -1)
    n = a * b
    strips = np.r_[np.c_[ring, nxt, nxt + n], np.c_[ring, nxt + n, ring + n]]
    triangles = np.r_[top, top[:, ::-1] + n, strips[:, ::-1]]
    vertices = np.r_[outer.reshape(-1, 3), inner.reshape(-1, 3)]
    if _signed_volume(vertices, triangles) < 0:
        triangles = triangles[:, ::-1]
    return vertices, triangles


def _signed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    tri = vertices[triangles]
    return float(np.einsum("nd,nd->n", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def part_solid(shape: tuple, name: str, shrink: float | None = None) -> m3d.Manifold:
    """The clash solid of a part from its ``clash_shape`` record: ``("plate", outline, frame,
    thickness)`` or ``("slab", outer grid, inner grid)``, shrunk by ``shrink`` mm (default
    ``TOLERANCES.clash_depth``)."""
    shrink = TOLERANCES.clash_depth if shrink is None else shrink
    if shape[0] == "plate":
        _, outline, frame, thickness = shape
        solid = plate_solid(outline, frame, thickness, shrink=shrink)
        if solid.status() != m3d.Error.NoError or solid.volume() <= 0:
            raise KernelError(f"clash solid of {name} could not be made ({solid.status()})")
        return solid
    return to_manifold(*slab_mesh(*shrink_slab(shape[1], shape[2], shrink)), name)


def to_manifold(vertices: np.ndarray, triangles: np.ndarray, name: str) -> m3d.Manifold:
    """A manifold3d solid from a closed, outward-oriented triangle mesh."""
    mesh = m3d.Mesh(
        vert_properties=np.asarray(vertices, dtype=np.float32),
        tri_verts=np.asarray(triangles, dtype=np.uint32),
    )
    solid = m3d.Manifold(mesh)
    if solid.status() != m3d.Error.NoError:
        raise KernelError(f"tessellation of {name} is not a closed solid ({solid.status()})")
    return solid


def common_volume(a: m3d.Manifold, b: m3d.Manifold) -> float:
    """Volume two solids share, mm3."""
    return float((a ^ b).volume())


def find_clashes(
    solids: Mapping[str, m3d.Manifold],
    groups: dict[str, list[str]],
    neighbours: Iterable[tuple[str, str]],
    fraction: float | None = None,
) -> tuple[list[Clash], dict]:
    """Pairs of parts that interpenetrate beyond the tolerance.

    solids : part id -> its clash solid (:func:`part_solid`, :func:`to_manifold`); a mapping
        that makes each solid when asked (:class:`SolidsOnDemand`) keeps only a few panels'
        solids alive at a time.
    groups : group (panel) id -> its part ids.
    neighbours : pairs of group ids whose parts can touch (panels sharing a side or a corner).
    fraction : tolerance as a share of the smaller part's volume (default
        ``TOLERANCES.clash_volume``).
    Returns ``[(part a, part b, common volume mm3, its centre (3,) mm)]`` (sorted by the
    parts' ids) and measures (largest common volume relative to the smaller part, pairs
    checked).

    The groups are visited in an order that keeps neighbours close (reverse Cuthill-McKee on
    the neighbour graph), and a group's union is dropped once its last neighbour is checked:
    holding every part's solid and every union at once took 1.3 GB of the main process at 252
    panels, growing with the count.
    """
    fraction = TOLERANCES.clash_volume if fraction is None else fraction
    neighbours = list(neighbours)
    order, partners, last = _visiting_order(list(groups), neighbours)
    volumes: dict[str, float] = {}
    unions: dict[str, m3d.Manifold] = {}
    clashes, checked, worst = [], 0, 0.0
    for position, group in enumerate(order):
        ids = groups[group]
        members = [solids[i] for i in ids]
        volumes.update((i, float(s.volume())) for i, s in zip(ids, members))
        unions[group] = m3d.Manifold.batch_boolean(members, m3d.OpType.Add)
        del members
        overlap = sum(volumes[i] for i in ids) - float(unions[group].volume())
        if overlap > fraction * min(volumes[i] for i in ids):
            found, relative = _pairwise(ids, ids, solids, volumes, fraction)
            clashes += found
            worst = max(worst, relative)
            checked += len(ids) * (len(ids) - 1) // 2
        for other in partners[group]:
            if other not in unions:
                continue  # not visited yet: checked when it is
            shared = common_volume(unions[other], unions[group])
            smallest = min(volumes[i] for i in groups[other] + groups[group])
            if shared > fraction * smallest:
                first, second = sorted((other, group))
                found, relative = _pairwise(
                    groups[first], groups[second], solids, volumes, fraction
                )
                clashes += found
                worst = max(worst, relative)
                checked += len(groups[first]) * len(groups[second])
        for done in [g for g in unions if last[g] <= position]:
            del unions[done]
    measures = {
        "groups": len(groups),
        "group_pairs": len(neighbours),
        "part_pairs_checked": checked,
        "clashes": len(clashes),
        "max_relative_overlap": worst,
        "tolerance_fraction": fraction,
    }
    return sorted(clashes, key=lambda clash: (clash[0], clash[1])), measures


def _visiting_order(
    groups: list[str], neighbours: list[tuple[str, str]]
) -> tuple[list[str], dict[str, list[str]], dict[str, int]]:
    """The groups in reverse Cuthill-McKee order of the neighbour graph, each group's
    neighbours, and the position after which each group's union is no longer needed."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    index = {group: k for k, group in enumerate(groups)}
    partners: dict[str, list[str]] = {group: [] for group in groups}
    for a, b in neighbours:
        partners[a].append(b)
        partners[b].append(a)
    if neighbours:
        rows = np.array([index[a] for a, _ in neighbours] + [index[b] for _, b in neighbours])
        cols = np.array([index[b] for _, b in neighbours] + [index[a] for a, _ in neighbours])
        graph = coo_matrix(
            (np.ones(len(rows)), (rows, cols)), shape=(len(groups), len(groups))
        ).tocsr()
        order = [groups[k] for k in reverse_cuthill_mckee(graph, symmetric_mode=True)]
    else:
        order = list(groups)
    position = {group: k for k, group in enumerate(order)}
    last = {
        group: max([position[group], *(position[p] for p in partners[group])]) for group in order
    }
    return order, partners, last


class SolidsOnDemand(Mapping[str, m3d.Manifold]):
    """Part id -> clash solid, each made from its ``clash_shape`` record when asked and not
    kept (:func:`find_clashes` asks for a part's solid once, or again only to name the parts
    of a clash)."""

    def __init__(self, shapes: dict[str, tuple]):
        self._shapes = shapes

    def __getitem__(self, part_id: str) -> m3d.Manifold:
        return part_solid(self._shapes[part_id], part_id)

    def __iter__(self) -> Iterator[str]:
        return iter(self._shapes)

    def __len__(self) -> int:
        return len(self._shapes)


def _pairwise(
    first: list[str],
    second: list[str],
    made: Mapping[str, m3d.Manifold],
    volumes: dict,
    fraction: float,
) -> tuple[list[Clash], float]:
    """The clashing pairs of one part of ``first`` and one of ``second`` (each pair once
    where they are the same list), and the largest relative overlap of any pair."""
    solids = {i: made[i] for i in dict.fromkeys(first + second)}  # each made once here
    found, worst = [], 0.0
    for a in first:
        for b in second:
            if a >= b and first is second:
                continue
            common = solids[a] ^ solids[b]
            shared = float(common.volume())
            relative = shared / min(volumes[a], volumes[b])
            worst = max(worst, relative)
            if relative > fraction:
                box = np.asarray(common.bounding_box(), dtype=float)
                found.append((a, b, shared, 0.5 * (box[:3] + box[3:])))
    return found, worst
