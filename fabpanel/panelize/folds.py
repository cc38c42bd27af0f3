"""Panels across the surface's fold lines (:mod:`fabpanel.surface.folds`), and the layout
vertices on them.

A panel that a fold runs through, farther than ``CLEAR_OF_FOLD`` x panel_size from its sides,
spans the fold: its sheet would be bent across the kink. The field method meshes along the
folds so that none does; a skeleton or grid layout does not know them, and the gates report
what spans one (``layout-crosses-fold``). A fold that fades out inside the surface (ending
where three faces meet, the other seams smooth) is measured as far as it runs.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

from ..data import PanelLayout, Surface
from ..geom.polygon import closest_on_polylines

#: a fold farther than this inside a panel (x panel_size) from its sides runs through it
CLEAR_OF_FOLD = 0.05
#: a layout vertex this close to a fold (mm) lies on it and stays there when polished
ON_FOLD_MM = 1.0


def distance_to_folds(points: np.ndarray, surface: Surface) -> np.ndarray:
    """(n,) mm from each point to the nearest fold line (inf without folds)."""
    distance = np.full(len(points), np.inf)
    for chain in surface.folds:
        foot = closest_on_polylines(points, surface.vertices[chain], closed=False)
        distance = np.minimum(distance, np.linalg.norm(points - foot, axis=1))
    return distance


def on_folds(vertices: np.ndarray, surface: Surface) -> np.ndarray:
    """(n,) bool: the layout vertices lying on a fold line."""
    return distance_to_folds(vertices, surface) <= ON_FOLD_MM


def panels_across_folds(layout: PanelLayout, surface: Surface, target: float) -> np.ndarray:
    """Indices of the panels a fold line runs through: points of a fold inside a panel (in
    the plane of its diagonals), farther than ``CLEAR_OF_FOLD`` x ``target`` from its sides."""
    if not surface.folds or not len(layout.quads):
        return np.zeros(0, dtype=np.int64)
    points = np.concatenate(
        [_resampled(surface.vertices[chain], CLEAR_OF_FOLD * target) for chain in surface.folds]
    )
    corners = layout.vertices[layout.quads]
    centres = corners.mean(axis=1)
    reach = np.linalg.norm(corners - centres[:, None], axis=2).max()
    near = cKDTree(centres).query_ball_point(points, reach)
    crossed = set()
    for point, panels in zip(points, near):
        for panel in panels:
            if panel not in crossed and _inside_clear(
                point, corners[panel], CLEAR_OF_FOLD * target
            ):
                crossed.add(panel)
    return np.array(sorted(crossed), dtype=np.int64)


def _resampled(polyline: np.ndarray, step: float) -> np.ndarray:
    """Points along an open polyline at most ``step`` apart (its vertices kept)."""
    out = [polyline[:1]]
    for a, b in itertools.pairwise(polyline):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.concatenate(out)


def _inside_clear(point: np.ndarray, corners: np.ndarray, clear: float) -> bool:
    """Whether ``point`` lies inside the quad ``corners (4, 3)`` seen along the normal of its
    diagonals, and farther than ``clear`` from each of its sides."""
    normal = np.cross(corners[2] - corners[0], corners[3] - corners[1])
    normal /= max(float(np.linalg.norm(normal)), 1e-300)
    u = corners[1] - corners[0]
    u -= normal * (u @ normal)
    u /= max(float(np.linalg.norm(u)), 1e-300)
    v = np.cross(normal, u)
    flat = (corners - corners[0]) @ np.column_stack([u, v])
    p = (point - corners[0]) @ np.column_stack([u, v])
    if abs((point - corners.mean(axis=0)) @ normal) > np.ptp(flat, axis=0).max():
        return False  # far off the panel's plane: another part of the surface
    starts, ends = flat, np.roll(flat, -1, axis=0)
    edge = ends - starts
    cross = edge[:, 0] * (p - starts)[:, 1] - edge[:, 1] * (p - starts)[:, 0]
    if not ((cross > 0).all() or (cross < 0).all()):
        return False
    t = np.clip(np.einsum("ij,ij->i", p - starts, edge) / np.einsum("ij,ij->i", edge, edge), 0, 1)
    gap = np.linalg.norm(p - (starts + t[:, None] * edge), axis=1)
    return bool(gap.min() > clear)
