"""Panel corners that the quad mesher put on a smooth stretch of the outline, taken out.

A boundary vertex of one panel is a corner of the layout: its panel turns through about 90°
there. Where the outline has a corner, that is right. Where the mesher puts one on a smooth,
gently curved stretch (a lobe of 2.5 m radius, the blunt end of an ellipse), the outline
turns by only the chords' angle there, 20-40° at a 1 m panel, so the panel's corner opens to
140-165°, and sliding the nodes along the outline cannot close it: the outline's turning
over one or two panel edges is all there is.

The fix moves the layout's corner off the outline into the panels: the panel ``(v, a, c, b)``
at such a vertex ``v`` (``a`` and ``b`` its neighbours on the outline, ``c`` the inner
corner) is removed and ``a`` and ``b`` become one node, where ``v`` was. The outline gains no
corner, and ``c`` loses one panel: a regular inner vertex of four becomes one of three, whose
three corners of about 120° lie in the gates' band (at 120°) rather than one of 160°. The
outline has two nodes fewer there; the smoothing that follows spaces the rest evenly.
"""

from __future__ import annotations

import numpy as np


def one_panel_nodes(quads: np.ndarray, on_curve: np.ndarray) -> np.ndarray:
    """Ids of the boundary nodes used by one quad only: the layout's corners."""
    count = np.bincount(quads.ravel(), minlength=len(on_curve))
    return np.flatnonzero(on_curve & (count == 1))


def dissolve_corners(
    nodes: np.ndarray,
    quads: np.ndarray,
    on_curve: np.ndarray,
    corners: np.ndarray,
    movable: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The flat quad mesh (``nodes`` (n, 2), ``quads`` (m, 4), ``on_curve`` (n,) bool) with
    the layout corners ``corners`` (node ids, each in one quad) dissolved as the module
    docstring says, where that is possible: the corner and both its outline neighbours are
    ``movable`` (n,) bool (not a corner of the outline, not a singular point), the inner
    corner is not on the outline and has four panels or more, and no other panel joins the
    two neighbours. Returns the new nodes, quads and ``on_curve`` (unused nodes dropped) and
    how many corners were dissolved."""
    nodes, quads, movable = nodes.copy(), quads.copy(), movable.copy()
    keep_quad = np.ones(len(quads), dtype=bool)
    keep_node = np.ones(len(nodes), dtype=bool)
    valence = np.bincount(quads.ravel(), minlength=len(nodes))
    done = 0
    for corner in corners:
        hit = np.argwhere((quads == corner) & keep_quad[:, None])
        if len(hit) != 1:
            continue
        quad, at = hit[0]
        nxt, inner, prev = (quads[quad, (at + k) % 4] for k in (1, 2, 3))
        joint = keep_quad & (quads == nxt).any(axis=1) & (quads == prev).any(axis=1)
        if not (
            movable[[corner, nxt, prev]].all()
            and on_curve[nxt]
            and on_curve[prev]
            and not on_curve[inner]
            and valence[inner] >= 4
            and joint.sum() == 1
        ):
            continue
        nodes[nxt] = nodes[corner]
        quads[quads == prev] = nxt
        keep_quad[quad] = False
        keep_node[[corner, prev]] = False
        valence[inner] -= 1
        movable[[nxt]] = False  # edited once: its neighbourhood is no longer the one tested
        done += 1
    new_id = np.cumsum(keep_node) - 1
    return nodes[keep_node], new_id[quads[keep_quad]], on_curve[keep_node], done
