"""Strips of overlong panels split in two: local density for field layouts.

A strip is the row of quads crossed by walking from an edge to the opposite edge of each quad
(:func:`fabpanel.panelize.densify.collect_strips`); every edge it crosses spans its width.
gmsh's quasi-structured mesher gives every curve an even number of edges and calibrates one
size for the whole domain, so a region can come out a row short: on a slab 4.7 m deep, three
rows of 1.45 m on one side of an opening and five on the other; on an 8 m triangle with two
small openings, 1.4-1.7 m panels down one side. Smoothing cannot help (the rows are there in
the topology), nor can a smaller size everywhere (it adds panels where they were right).

Splitting the strip that holds most of the overlong edges adds one row of panels along it
and halves every edge it crosses; the smoothing that follows spreads the new row over its
neighbours (three rows of 1.45 m and one new become four of about 1.1 m). Where the strip also
runs through a region of right-sized panels, those get one row more than they need: a strip
is chosen by the overlong edges it halves less the edges it would halve below the band
(:func:`strips_to_split`), and the caller keeps a split only where the gates' score rises.
A strip that crosses one of its quads twice (it turns round a singular vertex back into
itself) is never split: that quad would need four parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .densify import Strip, collect_strips, quad_edges


@dataclass(frozen=True)
class SplitMesh:
    """A flat quad mesh with one strip split: ``nodes`` (n, 2), ``quads`` (m, 4),
    ``on_curve`` (n,) bool, and the strip's quads before (``split`` their ids) ."""

    nodes: np.ndarray
    quads: np.ndarray
    on_curve: np.ndarray
    split: np.ndarray


def strips_to_split(
    quads: np.ndarray, lengths: np.ndarray, target: float, band: tuple[float, float]
) -> list[Strip]:
    """The strips worth splitting, best first: those whose crossing edges hold more edges over
    the band's top (``band[1] x target``) than edges that halved would fall under its bottom
    (shorter than ``2 x band[0] x target``), ranked by that difference, the longest mean
    crossing edge first on a tie. ``lengths`` (e,) are the edges' lengths on the surface, in the
    order of :func:`~fabpanel.panelize.densify.quad_edges`. Strips that cross a quad twice are
    left out."""
    edges, _ = quad_edges(quads)
    index = {(int(a), int(b)): i for i, (a, b) in enumerate(edges)}
    _, strips = collect_strips(quads)
    ranked: list[tuple[int, float, int]] = []
    for number, strip in enumerate(strips):
        if len(set(strip.quads)) < len(strip.quads):
            continue
        crossing = lengths[[index[edge] for edge in strip.edges]]
        overlong = int(np.count_nonzero(crossing > band[1] * target))
        gain = overlong - int(np.count_nonzero(crossing < 2 * band[0] * target))
        if gain > 0:
            ranked.append((gain, float(crossing.mean()), number))
    ranked.sort(key=lambda item: (-item[0], -item[1], item[2]))
    return [strips[number] for _, _, number in ranked]


def split_strip(
    nodes: np.ndarray,
    quads: np.ndarray,
    on_curve: np.ndarray,
    strip: Strip,
    on_track=None,
) -> SplitMesh:
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
    return SplitMesh(
        nodes=np.vstack([nodes, middles]),
        quads=np.vstack([kept, np.asarray(added, np.int64).reshape(-1, 4)]),
        on_curve=np.concatenate([np.asarray(on_curve, bool), boundary]),
        split=np.asarray(strip.quads, np.int64),
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
