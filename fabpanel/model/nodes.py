"""Nodes: where the ribs of every panel round a layout vertex end.

Each panel's ribs end at its own neighbouring rib planes. Those planes all pass through the
vertex at the top sheet, but below it they share one line (a node axis) only where the layout
allows it: on a doubly curved shell the rib planes of a node twist against each other by a
degree or two (the median on the one-opening roof after ``global``: 1.2 degrees, up to 2.7 at
one node in ten). Then two panels that meet only at the node overlap below the top sheet, by
``depth x tan(twist)`` across each of the two planes between them: 2.6-3.7 cm3 of rib in rib,
150 mm deep. A rib's end is therefore also cut, for each panel that meets its panel only at
that node, at one of that panel's two rib planes there (either keeps the rib out of the wedge
between them: the one that takes less off and crosses the rib), on the side of the rib's middle,
as far from the plane as the rib standing on it keeps from it (half the erection gap at a
joint). Where the planes do share an axis, these cuts coincide with the panel's own and remove
nothing; where they do not, they take a sliver, growing with depth, off the rib's end.
"""

from __future__ import annotations

import numpy as np

from ..data import PanelLayout

#: the panels that meet one panel only at one of its corners: (n, 2, 5) float, per panel its two
#: rib planes at that vertex, rows (unit normal, offset, how far a rib on that plane stands
#: from it), mm
NodePlanes = np.ndarray


def node_planes(
    layout: PanelLayout, side_planes: np.ndarray, erection_gap: float
) -> list[tuple[NodePlanes, NodePlanes, NodePlanes, NodePlanes]]:
    """For every panel and each of its four corners, the two rib contact planes at that
    corner's vertex of each panel that meets this one only there (two panels sharing a side
    are parted by its plane, which both panels' parts keep to; a valence-3 node or a boundary
    vertex with two panels has none).

    side_planes : (m, 4, 4) float, every panel side's contact plane (normal, offset), mm.
    Returns per panel a 4-tuple (one per corner) of (n, 2, 5) arrays, one (2, 5) pair per such
    panel: unit normal (into that panel), offset, and the rib's stand-off from the plane (half
    ``erection_gap`` at a joint, 0 on the boundary).
    """
    planes = side_planes / np.linalg.norm(side_planes[..., :3], axis=-1, keepdims=True)
    stand_off = np.where(layout.side_neighbours >= 0, erection_gap / 2, 0.0)
    # (m, 4, 5): each side's plane, normal into its own panel, and the stand-off
    rows = np.concatenate([planes, stand_off[..., None]], axis=-1)
    # (panel, corner) pairs at every vertex
    at_vertex: dict[int, list[tuple[int, int]]] = {}
    for panel, corner in np.ndindex(*layout.quads.shape):
        at_vertex.setdefault(int(layout.quads[panel, corner]), []).append((panel, corner))
    neighbours = layout.side_neighbours
    result = []
    for panel, quad in enumerate(layout.quads):
        corners = []
        for corner in range(4):
            pairs = [
                rows[other, [(at - 1) % 4, at]]
                for other, at in at_vertex[int(quad[corner])]
                if other != panel and other not in neighbours[panel]
            ]
            corners.append(np.array(pairs) if pairs else np.empty((0, 2, 5)))
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
