"""Small openings as missing panels: meshed over, then the quad over each punched out.

gmsh's quasi-structured mesher splits triangles into quads, so every boundary curve it meshes
gets an even number of edges, at least two. An opening about a panel across (a 0.9 m round
hole or a 0.8 x 0.5 m rectangle at 1 m panels) then gets eight edges of 0.25-0.4 m round it, or
its short sides merged away, and a ring of narrow panels with singular vertices round that.
What a panel layer would do by hand is run the grid past it as past a missing panel: four
sides round the opening, one panel on each, three panels at each of its corners.

So the mesher gets the domain with the small openings filled in; afterwards the quad that
best covers each opening is taken out, its four nodes moved onto the opening's four corners
(:class:`.corners.SmallOpenings`), matched round in the same turning sense with the least
movement, and the smoothing that follows squares the panels round it. The panel sides on the
opening are chords of it in the flat domain; the layout's boundary sides follow the design
boundary on the surface (the develop stage samples them along it).
"""

from __future__ import annotations

import numpy as np

#: quads whose centre lies within this many opening diameters (or quad diagonals, where
#: longer) of the opening's centre are tried; the one whose corners move least is punched
SEARCH_DIAMETERS = 1.5


class PunchFailed(ValueError):
    """No quad near a small opening could be punched (each touches the boundary, another
    opening or a singular point)."""


def punched(
    nodes: np.ndarray,
    quads: np.ndarray,
    on_curve: np.ndarray,
    openings: tuple[np.ndarray, ...],
    fixed: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nodes, quads, on_curve) with one quad per opening taken out and its nodes moved onto
    the opening's corners. ``openings``: per opening its four corners (4, 2), flat, in loop
    order; ``fixed`` (q,) bool: nodes that must stay (singular points). Raises
    :class:`PunchFailed` where an opening finds no quad whose nodes are all free."""
    nodes, on_curve = nodes.copy(), on_curve.copy()
    if any(np.shape(corners) != (4, 2) for corners in openings):
        raise PunchFailed("a punched opening needs exactly four corners")
    taken = np.zeros(len(quads), dtype=bool)
    busy = on_curve | fixed
    for corners in openings:
        quad, order = _best_quad(nodes, quads, busy, taken, corners)
        ids = quads[quad]
        nodes[ids] = corners[order]
        on_curve[ids] = True
        busy[ids] = True
        taken[quad] = True
    return nodes, quads[~taken], on_curve


def _best_quad(
    nodes: np.ndarray,
    quads: np.ndarray,
    busy: np.ndarray,
    taken: np.ndarray,
    corners: np.ndarray,
) -> tuple[int, np.ndarray]:
    """The quad to punch for one opening and, per quad corner, the opening corner it moves to:
    among the free quads near the opening, the least summed squared movement over the four
    cyclic matchings that keep the turning sense."""
    centre = corners.mean(axis=0)
    centres = nodes[quads].mean(axis=1)
    # at least a quad's size: an opening smaller than a quad may sit on a node of the mesh
    diameter = 2.0 * np.linalg.norm(corners - centre, axis=1).max()
    across = np.median(np.linalg.norm(nodes[quads[:, 2]] - nodes[quads[:, 0]], axis=1))
    near = np.linalg.norm(centres - centre, axis=1) <= SEARCH_DIAMETERS * max(diameter, across)
    candidates = np.flatnonzero(near & ~taken & ~busy[quads].any(axis=1))
    if not len(candidates):
        raise PunchFailed(f"no free quad near the small opening at {centre.round(1)}")
    if _signed_area(corners) < 0:
        corners_ccw, back = corners[::-1], np.arange(4)[::-1]
    else:
        corners_ccw, back = corners, np.arange(4)
    points = nodes[quads[candidates]]  # (c, 4, 2)
    clockwise = _signed_areas(points) < 0
    points[clockwise] = points[clockwise][:, ::-1]
    shifts = (np.arange(4)[:, None] + np.arange(4)[None, :]) % 4  # (shift, k)
    cost = ((points[:, None, :, :] - corners_ccw[shifts][None]) ** 2).sum(axis=(2, 3))
    best, shift = np.unravel_index(int(np.argmin(cost)), cost.shape)
    order = back[shifts[shift]]  # corner index for each ccw-ordered quad corner
    if clockwise[best]:
        order = order[::-1]
    return int(candidates[best]), order


def _signed_area(points: np.ndarray) -> float:
    return float(_signed_areas(points[None])[0])


def _signed_areas(points: np.ndarray) -> np.ndarray:
    """(c,) signed area of each closed flat polygon in (c, k, 2), positive counter-clockwise."""
    x, y = points[..., 0], points[..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=-1) - y * np.roll(x, -1, axis=-1)).sum(axis=-1)
