"""Fold lines: the seams between two faces of a B-rep where the surface kinks.

A designer's surface of several faces sewn together (a STEP of a vault drawn as three patches)
can meet at a seam with a kink in it: on the new user's vault, 5 degrees at the crown fading
to none at the springing. A panel across such a fold cannot be one developable sheet close to
both sides: the global optimiser bends it across the fold, and the sheet the build fits
through its samples unrolled with 2.5 % strain where 0.05 % is allowed. So the layout puts
panel sides along the fold (:mod:`fabpanel.panelize.field`) and measures the panels any fold
still crosses (:func:`fabpanel.panelize.folds.panels_across_folds`).

A seam is a fold where the tessellation's neighbouring triangles across it differ by more than
``FOLD_DEG`` somewhere along it (median of three neighbouring seam edges, so one triangle's
chord error does not make a fold): on the vault its smooth seam reads 0.07 degrees (median,
0.46 at most) and the fold 3.5 (5.2 at most), the faces' own edges 0.4 (1.3 for the top
percent). Seams sharper than ``[input] crease_angle`` are refused as creases before this.
Meshes carry no faces, so no folds are found on them (a sharp fold of a mesh is its
crease check's).
"""

from __future__ import annotations

import numpy as np

#: a seam folding more than this (degrees) somewhere along it is a fold line the layout follows
FOLD_DEG = 2.0


def fold_lines(
    vertices: np.ndarray, triangles: np.ndarray, face_ids: np.ndarray
) -> tuple[np.ndarray, ...]:
    """Vertex chains (ordered, open or closed) along the seams between two B-rep faces that
    fold by more than ``FOLD_DEG`` (module docstring). ``face_ids (m,)``: the B-rep face of
    each triangle."""
    edges, left, right = _interior_edges(triangles)
    seam = face_ids[left] != face_ids[right]
    if not seam.any():
        return ()
    fold = _fold_angles(vertices, triangles, left, right)
    found = []
    for chain, along in _chains(edges[seam], fold[seam]):
        smoothed = _median_of_three(along)
        if smoothed.max() > FOLD_DEG:
            found.append(chain)
    return tuple(found)


def fold_summary(
    vertices: np.ndarray, triangles: np.ndarray, folds: tuple[np.ndarray, ...], origin: np.ndarray
) -> list[dict]:
    """Per fold line: its length and largest fold (degrees) and its two ends in the design's
    own frame (mm), JSON-ready, for ``fabpanel inspect``."""
    if not folds:
        return []
    edges, left, right = _interior_edges(triangles)
    fold = _fold_angles(vertices, triangles, left, right)
    index = {(int(a), int(b)): i for i, (a, b) in enumerate(edges.tolist())}
    summary = []
    for chain in folds:
        pairs = np.sort(np.column_stack([chain[:-1], chain[1:]]), axis=1)
        along = fold[[index[(int(a), int(b))] for a, b in pairs]]
        points = vertices[chain]
        summary.append(
            {
                "length_mm": round(float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()), 1),
                "largest_fold_deg": round(float(_median_of_three(along).max()), 2),
                "from_mm": np.round(points[0] + origin, 1).tolist(),
                "to_mm": np.round(points[-1] + origin, 1).tolist(),
            }
        )
    return summary


def fold_ends(folds: tuple[np.ndarray, ...]) -> np.ndarray:
    """The vertex ids where fold lines end (on the boundary, or where three faces meet)."""
    if not folds:
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.concatenate([[chain[0], chain[-1]] for chain in folds]))


def _interior_edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(e, 2) sorted vertex pairs used by two triangles, and the two triangles of each."""
    edges = np.sort(np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2), axis=2)
    edges = edges.reshape(-1, 2)
    owner = np.repeat(np.arange(len(triangles)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    twin = np.flatnonzero((edges[1:] == edges[:-1]).all(axis=1))
    return edges[twin], owner[twin], owner[twin + 1]


def _fold_angles(
    vertices: np.ndarray, triangles: np.ndarray, left: np.ndarray, right: np.ndarray
) -> np.ndarray:
    """Degrees between the normals of the triangles ``left`` and ``right`` of each edge."""
    corners = vertices[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    cosine = np.einsum("ij,ij->i", normals[left], normals[right])
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def _chains(edges: np.ndarray, values: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The seam edges walked into chains between vertices of other than two seam edges (a
    seam's ends on the boundary, three faces meeting), or round closed loops: each chain's
    vertices in order and its edges' values in the same order."""
    links: dict[int, list[tuple[int, int]]] = {}
    for index, (a, b) in enumerate(edges.tolist()):
        links.setdefault(a, []).append((b, index))
        links.setdefault(b, []).append((a, index))
    used = np.zeros(len(edges), dtype=bool)
    starts = [v for v, around in links.items() if len(around) != 2]
    chains = []
    for start in [*sorted(starts), *sorted(links)]:
        for _ in links[start]:
            chain, along = _walk(start, links, used)
            if len(chain) > 1:
                chains.append((np.array(chain), values[along]))
    return chains


def _walk(start: int, links: dict, used: np.ndarray) -> tuple[list[int], list[int]]:
    """From ``start`` along unused seam edges until a vertex of other than two seam edges
    (or back at the start)."""
    chain, along, here = [start], [], start
    while True:
        step = next(((v, e) for v, e in links[here] if not used[e]), None)
        if step is None:
            break
        here, edge = step
        used[edge] = True
        chain.append(here)
        along.append(edge)
        if here == start or len(links[here]) != 2:
            break
    return chain, along


def _median_of_three(values: np.ndarray) -> np.ndarray:
    if len(values) < 3:
        return np.full(len(values), np.median(values))
    padded = np.concatenate([values[:1], values, values[-1:]])
    return np.median(np.stack([padded[:-2], padded[1:-1], padded[2:]]), axis=0)
