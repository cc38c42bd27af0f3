"""Nodes: where the ribs of every panel round a layout vertex end.

Each panel's ribs end at its own neighbouring rib planes. Those planes all pass through the
vertex at the top sheet, but below it they share one line (a node axis) only where the layout
allows it: on a doubly curved shell the rib planes of a node twist against each other by a
degree or two (the median on the one-opening roof after ``global``: 1.2 degrees, up to 2.7 at
one node in ten). Then two panels that meet only at the node overlap below the top sheet, by
``depth x tan(twist)`` across each of the two planes between them: 2.6-3.7 cm3 of rib in rib,
150 mm deep. A rib's end is therefore also cut at every other rib plane of its node that
crosses it, on the side of the rib's middle, as far from that plane as the rib standing on it
keeps from it (half the erection gap at a joint). Where the planes do share an axis, these
cuts coincide with the panel's own and remove nothing; where they do not, they take a sliver,
growing with depth, off the rib's end.
"""

from __future__ import annotations

import numpy as np

from ..data import PanelLayout

#: the planes of the other rib planes at one corner: (n, 5) float, rows (unit normal, offset,
#: how far a rib on that plane stands from it), mm
NodePlanes = np.ndarray


def node_planes(
    layout: PanelLayout, side_planes: np.ndarray, erection_gap: float
) -> list[tuple[NodePlanes, NodePlanes, NodePlanes, NodePlanes]]:
    """For every panel and each of its four corners, the rib contact planes of the other layout
    edges at that corner's vertex (not the panel's own two sides there).

    side_planes : (m, 4, 4) float, every panel side's contact plane (normal, offset), mm.
    Returns per panel a 4-tuple (one per corner) of (n, 5) arrays: unit normal, offset, and the
    rib's stand-off from the plane (half ``erection_gap`` at a joint, 0 on the boundary).
    """
    edges = layout.side_edges
    planes = side_planes / np.linalg.norm(side_planes[..., :3], axis=-1, keepdims=True)
    stand_off = np.where(layout.side_neighbours >= 0, erection_gap / 2, 0.0)
    by_edge = np.empty((len(layout.edges), 5))
    by_edge[edges.ravel()] = np.concatenate([planes, stand_off[..., None]], axis=-1).reshape(-1, 5)
    at_vertex: dict[int, set[int]] = {}
    for vertex, edge in zip(layout.quads.ravel(), edges.ravel(), strict=True):
        at_vertex.setdefault(int(vertex), set()).add(int(edge))
    for vertex, edge in zip(np.roll(layout.quads, -1, axis=1).ravel(), edges.ravel(), strict=True):
        at_vertex.setdefault(int(vertex), set()).add(int(edge))
    result = []
    for quad, own in zip(layout.quads, edges, strict=True):
        corners = []
        for corner in range(4):
            mine = {int(own[corner - 1]), int(own[corner])}
            others = sorted(at_vertex[int(quad[corner])] - mine)
            corners.append(by_edge[others] if others else np.empty((0, 5)))
        result.append((corners[0], corners[1], corners[2], corners[3]))
    return result


def facing(plane: np.ndarray, middle: np.ndarray) -> np.ndarray:
    """(4,) float: a node plane (normal, offset, stand-off) as a trimming plane whose normal
    points towards ``middle`` (the middle of the rib it cuts), moved that way by its
    stand-off."""
    normal, offset, stand_off = plane[:3], plane[3], plane[4]
    if normal @ middle - offset < 0:
        normal, offset = -normal, -offset
    return np.r_[normal, offset + stand_off]
