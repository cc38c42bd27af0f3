"""Part marks: flat parts equal within 0.1 mm share one mark, one DXF and a quantity.

A shell of 100 panels has 400 corner stiffeners of one shape, and on a regular grid most ribs
and sheets repeat too. The shop cuts by mark: one drawing, a quantity, any of the pieces fits
any of its places (the manifest and ``bom.csv`` keep every instance with its panel).

Two flat parts are equal when a rotation and a translation in the plane (no mirror: a plate
turned over shows its other face, which the etched face and the bevels tell apart) put every
outline vertex, hole centre and every bend line end of one within ``tolerance`` of the other's,
every inner contour (the access slots) within ``tolerance`` of one of the other's (Hausdorff
distance: a merged slot's vertices fall where float noise puts them), with hole diameters equal
within ``tolerance`` and the same material, thickness, kind, forming and etched face. Outlines
sampled differently (another vertex count) count as different: marks never merge parts that are
not the same.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from ..data import FlatPart, Hole, MarkGroup
from ..geom.polygon import polygon_area

#: parts equal within this (mm) share a mark
TOLERANCE = 0.1
#: mark prefix per part kind
PREFIX = {"sheet-top": "T", "sheet-bottom": "B", "rib": "R", "stiffener": "S", "packing": "K"}


def mark_groups(parts: Sequence[FlatPart], tolerance: float = TOLERANCE) -> tuple[MarkGroup, ...]:
    """The parts grouped by equality (see the module docstring), marks numbered per kind in
    the order of each group's first part.

    Each part is compared with every group of its coarse key at once through its shape
    signature (:func:`_signature`), which equal parts share within ``2 tolerance``; only the
    groups that pass are matched vertex by vertex (:func:`rigid_match`). Without it, a roof of
    2500 parts spent a minute here, most of it fitting rotations to parts that differ.
    """
    members: list[list[int]] = []
    transforms: list[list[np.ndarray]] = []
    buckets: dict[tuple, _Bucket] = {}
    for index, part in enumerate(parts):
        bucket = buckets.setdefault(_coarse_key(part), _Bucket())
        signature = _signature(part.outline)
        for group in bucket.near(signature, tolerance):
            found = rigid_match(parts[members[group][0]], part, tolerance)
            if found is not None:
                members[group].append(index)
                transforms[group].append(found)
                break
        else:
            bucket.add(signature, len(members))
            members.append([index])
            transforms.append([np.eye(3)])
    counters: dict[str, int] = {}
    groups = []
    for indices, moves in zip(members, transforms):
        prefix = PREFIX.get(parts[indices[0]].kind, "X")
        counters[prefix] = counters.get(prefix, 0) + 1
        groups.append(
            MarkGroup(
                mark=f"{prefix}{counters[prefix]:03d}",
                part_ids=tuple(parts[i].id for i in indices),
                transforms=tuple(moves),
            )
        )
    return tuple(groups)


class _Bucket:
    """The groups of one coarse key: their first parts' signatures, stacked for one
    comparison with a new part."""

    def __init__(self) -> None:
        self.signatures: list[np.ndarray] = []
        self.groups: list[int] = []
        self._stacked: np.ndarray | None = None

    def add(self, signature: np.ndarray, group: int) -> None:
        self.signatures.append(signature)
        self.groups.append(group)
        self._stacked = None

    def near(self, signature: np.ndarray, tolerance: float) -> list[int]:
        """The groups whose signature is within ``2 tolerance`` of ``signature``, in order."""
        if not self.groups:
            return []
        if self._stacked is None:
            self._stacked = np.stack(self.signatures)
        close = np.abs(self._stacked - signature).max(axis=1) <= 2 * tolerance
        return [self.groups[k] for k in np.flatnonzero(close)]


def _signature(outline: np.ndarray) -> np.ndarray:
    """What a rotation and translation leave unchanged: the outline's edge lengths and its
    vertices' distances from their mean, each sorted. Every vertex of an equal part lies
    within ``tolerance`` of its partner, so both lists agree within ``2 tolerance``."""
    return np.concatenate([np.sort(_edge_lengths(outline)), np.sort(_radii(outline))])


def _edge_lengths(outline: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.roll(outline, -1, axis=0) - outline, axis=1)


def _radii(outline: np.ndarray) -> np.ndarray:
    return np.linalg.norm(outline - outline.mean(axis=0), axis=1)


def _coarse_key(part: FlatPart) -> tuple:
    """What equal parts share exactly: material, thickness, kind, forming, face and counts."""
    return (
        part.kind,
        part.material,
        float(part.thickness),
        part.forming,
        part.face,
        len(part.outline),
        len(part.holes),
        len(part.round_holes),
        len(part.drill_holes),
        len(part.bend_lines),
    )


def rigid_match(a: FlatPart, b: FlatPart, tolerance: float = TOLERANCE) -> np.ndarray | None:
    """The (3, 3) rotation and translation that puts part ``a`` on part ``b`` within
    ``tolerance`` (outline, holes, contours, bend lines), or None if there is none."""
    if _coarse_key(a) != _coarse_key(b):
        return None
    area, perimeter = _area_and_perimeter(a.outline)
    if abs(area - _area_and_perimeter(b.outline)[0]) > tolerance * perimeter:
        return None
    for shift in _matching_shifts(a.outline, b.outline, tolerance):
        target = np.roll(b.outline, -shift, axis=0)
        transform = _best_rotation(a.outline, target)
        moved = _apply(transform, a.outline)
        if np.abs(moved - target).max() > tolerance * np.sqrt(2):
            continue
        if _features_match(a, b, transform, tolerance):
            return transform
    return None


def _area_and_perimeter(outline: np.ndarray) -> tuple[float, float]:
    return abs(polygon_area(outline)), float(_edge_lengths(outline).sum())


def _matching_shifts(a: np.ndarray, b: np.ndarray, tolerance: float) -> np.ndarray:
    """Cyclic shifts k for which b's edge lengths and centre distances, from vertex k on,
    equal a's (within ``2 tolerance``): the only vertex pairings a rigid motion can make."""
    ours = np.stack([_edge_lengths(a), _radii(a)], axis=1)
    theirs = np.stack([_edge_lengths(b), _radii(b)], axis=1)
    if np.abs(np.sort(ours, axis=0) - np.sort(theirs, axis=0)).max() > 2 * tolerance:
        return np.zeros(0, dtype=int)  # not even the same edges
    n = len(a)
    index = (np.arange(n)[:, None] + np.arange(n)[None, :]) % n
    gaps = np.abs(theirs[index] - ours[None, :, :]).max(axis=(1, 2))
    return np.flatnonzero(gaps <= 2 * tolerance)


def _best_rotation(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(3, 3) proper rigid transform that best maps ``source`` points onto ``target`` (Kabsch,
    without reflection)."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - cs).T @ (target - ct))
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, d]) @ u.T
    transform = np.eye(3)
    transform[:2, :2] = rotation
    transform[:2, 2] = ct - rotation @ cs
    return transform


def _apply(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ transform[:2, :2].T + transform[:2, 2]


def _features_match(a: FlatPart, b: FlatPart, transform: np.ndarray, tolerance: float) -> bool:
    """Holes, inner contours and bend lines of ``a``, moved, land on ``b``'s."""
    for mine, theirs in ((a.round_holes, b.round_holes), (a.drill_holes, b.drill_holes)):
        if not _holes_match(mine, theirs, transform, tolerance):
            return False
    for contour in a.holes:
        moved = _apply(transform, np.asarray(contour, dtype=float))
        if not any(_contours_match(moved, np.asarray(c), tolerance) for c in b.holes):
            return False
    if len(a.bend_lines):
        ends = _apply(transform, np.asarray(a.bend_lines).reshape(-1, 2)).reshape(-1, 2, 2)
        others = np.asarray(b.bend_lines)
        for start, end in ends:
            forward = np.maximum(
                np.linalg.norm(others[:, 0] - start, axis=1),
                np.linalg.norm(others[:, 1] - end, axis=1),
            )
            backward = np.maximum(
                np.linalg.norm(others[:, 1] - start, axis=1),
                np.linalg.norm(others[:, 0] - end, axis=1),
            )
            if min(forward.min(), backward.min()) > tolerance:
                return False
    return True


def _holes_match(
    mine: tuple[Hole, ...], theirs: tuple[Hole, ...], transform: np.ndarray, tolerance: float
) -> bool:
    if not mine:
        return not theirs
    centres = _apply(transform, np.array([h.centre for h in mine], dtype=float))
    others = np.array([h.centre for h in theirs], dtype=float)
    sizes = np.array([h.diameter for h in theirs])
    for centre, hole in zip(centres, mine):
        near = (np.linalg.norm(others - centre, axis=1) <= tolerance) & (
            np.abs(sizes - hole.diameter) <= tolerance
        )
        if not near.any():
            return False
    return True


def _contours_match(a: np.ndarray, b: np.ndarray, tolerance: float) -> bool:
    """Two closed contours lie within ``tolerance`` of each other (Hausdorff distance of the
    closed polylines, whatever their vertex counts: a shapely union places its vertices by
    float noise)."""
    if np.linalg.norm(a.mean(axis=0) - b.mean(axis=0)) > 10 * tolerance + 1.0:
        return False
    first, second = shapely.LinearRing(a), shapely.LinearRing(b)
    return bool(shapely.hausdorff_distance(first, second, densify=0.25) <= tolerance)
