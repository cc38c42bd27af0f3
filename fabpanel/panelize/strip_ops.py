"""Strip operations on field layouts: a strip of overlong panels split in two, a strip of
panels too small collapsed (the local density of issue 15; compas_quad's strip operations).

A strip is the row of quads crossed by walking from an edge to the opposite edge of each quad
(:func:`fabpanel.panelize.densify.collect_strips`); every edge it crosses spans its width.
gmsh's quasi-structured mesher gives every curve an even number of edges and calibrates one
size for the whole domain, so a region can come out a row short: on a slab 4.7 m deep, three
rows of 1.45 m on one side of an opening and five on the other; on an 8 m triangle with two
small openings, 1.4-1.7 m panels down one side. Or a row too many: between two openings
closer than a panel, a row of 0.3-0.45 m panels. Smoothing cannot help (the rows are there in
the topology), nor can another size everywhere (it changes panels where they were right).

**Split**: the strip that holds most of the overlong edges gets one row of panels more along
it, every edge it crosses halved; the smoothing that follows spreads the new row over its
neighbours (three rows of 1.45 m and one new become four of about 1.1 m). Where the strip also
runs through a region of right-sized panels, those get one row more than they need: a strip
is chosen by the overlong edges it halves less the edges it would halve below the band
(:func:`strips_to_split`), and the caller keeps a split only where the gates' score rises.

**Collapse**: the strip that holds most of the short edges is taken out, each edge it
crosses shrunk to one node (scipy's union-find joins them where the strip passes a node
twice), so its two sides become one line; the neighbours take its width in the smoothing.
It is refused (:func:`collapse_strip` returns None) where that would change the layout's
topology or leave a bad node: an edge across the domain between two boundary loops, two
fixed nodes (outline corners, singular points) made one, a quad left with a repeated node,
a side used three times, an inner node of fewer than three panels, another Euler
characteristic.

A strip that crosses one of its quads twice (it turns round a singular vertex back into
itself) is neither split nor collapsed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import DisjointSet

from .densify import Strip, collect_strips, quad_edges
from .gates import euler_characteristic


@dataclass(frozen=True)
class EditedMesh:
    """A flat quad mesh with one strip split or collapsed: ``nodes`` (n, 2), ``quads`` (m, 4),
    ``on_curve`` (n,) bool."""

    nodes: np.ndarray
    quads: np.ndarray
    on_curve: np.ndarray


def strips_to_split(
    quads: np.ndarray, lengths: np.ndarray, target: float, band: tuple[float, float]
) -> list[Strip]:
    """The strips worth splitting, best first: those whose crossing edges hold more edges over
    the band's top (``band[1] x target``) than edges that halved would fall under its bottom
    (shorter than ``2 x band[0] x target``), ranked by that difference, the longest mean
    crossing edge first on a tie. ``lengths`` (e,) are the edges' lengths on the surface, in the
    order of :func:`~fabpanel.panelize.densify.quad_edges`. Strips that cross a quad twice are
    left out."""
    top, halved_short = band[1] * target, 2 * band[0] * target
    return _ranked(
        quads,
        lengths,
        lambda crossing: (
            np.count_nonzero(crossing > top) - np.count_nonzero(crossing < halved_short)
        ),
        longest_first=True,
    )


def _ranked(
    quads: np.ndarray,
    lengths: np.ndarray,
    gain: Callable[[np.ndarray], int | np.integer],
    longest_first: bool,
) -> list[Strip]:
    """The strips of ``quads`` with a positive ``gain`` of their crossing edges' lengths, the
    largest gain first, then by the mean crossing edge (longest or shortest first), then in
    :func:`~fabpanel.panelize.densify.collect_strips`' order; strips that cross a quad twice
    left out."""
    edges, _ = quad_edges(quads)
    index = {(int(a), int(b)): i for i, (a, b) in enumerate(edges)}
    _, strips = collect_strips(quads)
    ranked: list[tuple[int, float, int]] = []
    sign = -1.0 if longest_first else 1.0
    for number, strip in enumerate(strips):
        if len(set(strip.quads)) < len(strip.quads):
            continue
        crossing = lengths[[index[edge] for edge in strip.edges]]
        value = int(gain(crossing))
        if value > 0:
            ranked.append((-value, sign * float(crossing.mean()), number))
    ranked.sort()
    return [strips[number] for _, _, number in ranked]


def split_strip(
    nodes: np.ndarray,
    quads: np.ndarray,
    on_curve: np.ndarray,
    strip: Strip,
    on_track=None,
) -> EditedMesh:
    """``strip`` of the flat mesh split along its length: a node in the middle of every edge it
    crosses, each of its quads cut in two between the middles of its two crossed sides. A new
    node on a boundary edge (the two ends of an open strip) is on the curve, moved onto it by
    ``on_track`` ((k, 2) points -> (k, 2) points on the outline) where given; the others lie
    on their edge's chord, where the smoothing takes them from. The quads keep their turning
    sense; the split quads' halves replace them in place and in order, the second halves
    appended."""
    nodes = np.asarray(nodes, float)
    quads = np.asarray(quads, np.int64)
    edges = np.asarray(strip.edges, np.int64)
    middles = 0.5 * (nodes[edges[:, 0]] + nodes[edges[:, 1]])
    boundary = np.zeros(len(edges), dtype=bool)
    if not strip.closed:
        boundary[[0, -1]] = True
    if on_track is not None and boundary.any():
        middles[boundary] = on_track(middles[boundary])
    first_new = len(nodes)
    middle_of = {(int(a), int(b)): first_new + k for k, (a, b) in enumerate(edges)}
    kept = np.array(quads, copy=True)
    added = []
    for quad in strip.quads:
        corners = quads[quad]
        halves = _halves(corners, middle_of)
        kept[quad] = halves[0]
        added.append(halves[1])
    return EditedMesh(
        nodes=np.vstack([nodes, middles]),
        quads=np.vstack([kept, np.asarray(added, np.int64).reshape(-1, 4)]),
        on_curve=np.concatenate([np.asarray(on_curve, bool), boundary]),
    )


def _halves(corners: np.ndarray, middle_of: dict[tuple[int, int], int]) -> np.ndarray:
    """(2, 4): a quad ``corners`` (4,) cut between the middles of its two sides in
    ``middle_of`` (opposite sides: ``s`` and ``s + 2``), both halves in its turning sense."""
    for s in range(2):
        a, b, c, d = (int(corners[(s + k) % 4]) for k in range(4))
        near, far = middle_of.get(_key(a, b)), middle_of.get(_key(c, d))
        if near is not None and far is not None:
            # side a-b holds `near`, the opposite side c-d (running back) holds `far`
            return np.array([[a, near, far, d], [near, b, c, far]], np.int64)
    raise ValueError(f"quad {corners.tolist()} does not cross its strip")


def _key(a: int, b: int) -> tuple[int, int]:
    return (a, b) if a < b else (b, a)


def strips_to_collapse(
    quads: np.ndarray, lengths: np.ndarray, target: float, band: tuple[float, float]
) -> list[Strip]:
    """The strips worth collapsing, best first: those whose crossing edges hold more edges under
    the band's bottom (``band[0] x target``) than edges of at least ``band[0] x target``
    (whose width the neighbours would take on), ranked by that difference, the shortest mean
    crossing edge first on a tie. ``lengths`` as :func:`strips_to_split` takes them."""
    bottom = band[0] * target
    return _ranked(
        quads,
        lengths,
        lambda crossing: 2 * np.count_nonzero(crossing < bottom) - len(crossing),
        longest_first=False,
    )


def collapse_strip(
    nodes: np.ndarray,
    quads: np.ndarray,
    on_curve: np.ndarray,
    strip: Strip,
    fixed: np.ndarray,
    loop_of: Callable[[np.ndarray], np.ndarray] | None = None,
) -> EditedMesh | None:
    """The flat mesh with ``strip`` taken out (module docstring), or None where that is
    refused. Each edge the strip crosses becomes one node: at a ``fixed`` (n,) bool node where
    it has one, else on the curve at its on-curve node, else at its middle (both ends on the
    curve only for the strip's two end edges, which lie on the outline). ``loop_of`` gives the
    boundary loop of on-curve nodes ((k,) ids -> (k,) loop numbers); where given, an edge
    whose two ends lie on different loops is refused even at a strip's end. Nodes are
    renumbered (the unused dropped, order kept)."""
    nodes = np.asarray(nodes, float)
    quads = np.asarray(quads, np.int64)
    on_curve = np.asarray(on_curve, bool)
    edges = np.asarray(strip.edges, np.int64)
    ends = np.zeros(len(edges), dtype=bool)
    if not strip.closed:
        ends[[0, -1]] = True
    both_on_curve = on_curve[edges].all(axis=1)
    if (both_on_curve & ~ends).any() or (fixed[edges].all(axis=1)).any():
        return None  # an edge across the domain, or two fixed nodes made one
    if loop_of is not None and both_on_curve.any():
        loops = loop_of(edges[both_on_curve].ravel()).reshape(-1, 2)
        if (loops[:, 0] != loops[:, 1]).any():
            return None
    joined = DisjointSet(range(len(nodes)))
    for a, b in edges:
        joined.merge(int(a), int(b))
    merged = np.array(nodes, copy=True)
    merged_on_curve = np.array(on_curve, copy=True)
    end_pairs = {tuple(sorted(map(int, edge))) for edge in edges[ends]}
    for group in joined.subsets():
        if len(group) == 1:
            continue
        ids = np.array(sorted(group))
        if fixed[ids].sum() > 1:
            return None
        if on_curve[ids].sum() > 1 and not (len(ids) == 2 and tuple(ids.tolist()) in end_pairs):
            return None  # the outline pinched: two of its nodes joined through the inside
        anchor = ids[fixed[ids]] if fixed[ids].any() else ids[on_curve[ids]]
        point = nodes[anchor].mean(axis=0) if len(anchor) else nodes[ids].mean(axis=0)
        merged[ids] = point
        merged_on_curve[ids] = on_curve[ids].any()
    root = np.array([joined[i] for i in range(len(nodes))])
    keep = np.ones(len(quads), dtype=bool)
    keep[strip.quads] = False
    remaining = root[quads[keep]]
    return _checked(merged, remaining, merged_on_curve, quads)


def _checked(
    nodes: np.ndarray, quads: np.ndarray, on_curve: np.ndarray, before: np.ndarray
) -> EditedMesh | None:
    """The collapsed mesh renumbered, or None where it is not a valid quad layout of the same
    topology as ``before`` (the quads before the collapse)."""
    if len(quads) == 0:
        return None
    if (np.sort(quads, axis=1)[:, 1:] == np.sort(quads, axis=1)[:, :-1]).any():
        return None  # a quad with a repeated node
    sides = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    _, uses = np.unique(sides, axis=0, return_counts=True)
    if uses.max() > 2 or len(np.unique(np.sort(quads, axis=1), axis=0)) < len(quads):
        return None
    used = np.unique(quads)
    renumber = np.full(len(nodes), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    quads = renumber[quads]
    nodes, on_curve = nodes[used], on_curve[used]
    valence = np.bincount(quads.ravel(), minlength=len(nodes))
    if (valence[~on_curve] < 3).any():
        return None
    if euler_characteristic(len(nodes), quads) != euler_characteristic(
        len(np.unique(before)), before
    ):
        return None
    return EditedMesh(nodes, quads, on_curve)
