"""Quality measures of a panel layout (edge lengths, corner angles, aspect, plate fit)."""

from __future__ import annotations

import numpy as np

from ..data import PanelLayout
from ..errors import Issue
from ..geom.polygon import point_segment_distances
from ..surface import SurfaceQuery


def corner_angles(corners: np.ndarray) -> np.ndarray:
    """(m, 4) float: interior angle at each quad corner, degrees. corners: (m, 4, 3)."""
    to_next = np.roll(corners, -1, axis=1) - corners
    to_prev = np.roll(corners, 1, axis=1) - corners
    cos = np.einsum("mci,mci->mc", to_next, to_prev) / (
        np.linalg.norm(to_next, axis=2) * np.linalg.norm(to_prev, axis=2)
    )
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def panel_extents(corners: np.ndarray) -> np.ndarray:
    """(m, 2) float: panel length along side 0 and across it, in the panel's mean plane, mm.

    The bounding rectangle of the corners, aligned with side 0: a close estimate of the flat
    blank's size before unrolling (the unrolled size is measured exactly by the cutting stage).
    """
    normal = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    x_axis = corners[:, 1] - corners[:, 0]
    x_axis -= np.einsum("mi,mi->m", x_axis, normal)[:, None] * normal
    x_axis /= np.linalg.norm(x_axis, axis=1, keepdims=True)
    y_axis = np.cross(normal, x_axis)
    local = corners - corners[:, :1]
    xs = np.einsum("mci,mi->mc", local, x_axis)
    ys = np.einsum("mci,mi->mc", local, y_axis)
    return np.stack([xs.max(1) - xs.min(1), ys.max(1) - ys.min(1)], axis=1)


def vertex_valences(quads: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge valence of every vertex and whether it lies on the layout's boundary.

    Returns ``valence (n,) int`` and ``on_boundary (n,) bool``.
    """
    sides = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges, counts = np.unique(sides, axis=0, return_counts=True)
    valence = np.bincount(edges.ravel(), minlength=n_vertices)
    on_boundary = np.zeros(n_vertices, dtype=bool)
    on_boundary[edges[counts == 1].ravel()] = True
    return valence, on_boundary


def singular_vertices(layout: PanelLayout) -> list[dict]:
    """Interior vertices whose valence is not 4 (the singular points of the quad layout)."""
    valence, on_boundary = vertex_valences(layout.quads, len(layout.vertices))
    used = np.zeros(len(layout.vertices), dtype=bool)
    used[layout.quads.ravel()] = True
    singular = np.flatnonzero(used & ~on_boundary & (valence != 4))
    return [
        {
            "vertex": int(v),
            "valence": int(valence[v]),
            "position_mm": [round(float(c), 3) for c in layout.vertices[v]],
        }
        for v in singular
    ]


def boundary_coverage(layout: PanelLayout, design_loops: list[np.ndarray]) -> float:
    """Largest distance between the layout's boundary and the design boundary, mm.

    Both ways: design boundary points to the layout's boundary edges (straight panel sides), and
    layout boundary vertices to the design boundary polylines.
    """
    sides = np.stack([layout.quads, np.roll(layout.quads, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(sides, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    boundary_sides = sides[counts[inverse.ravel()] == 1]
    if len(boundary_sides) == 0 or not design_loops:
        return 0.0
    starts, ends = layout.vertices[boundary_sides[:, 0]], layout.vertices[boundary_sides[:, 1]]
    design_points = np.concatenate(design_loops)
    design_starts = np.concatenate(design_loops)
    design_ends = np.concatenate([np.roll(loop, -1, axis=0) for loop in design_loops])
    to_layout = point_segment_distances(design_points, starts, ends)
    to_design = point_segment_distances(
        layout.vertices[np.unique(boundary_sides)], design_starts, design_ends
    )
    return float(max(to_layout.max(), to_design.max()))


def layout_metrics(
    layout: PanelLayout,
    query: SurfaceQuery,
    target: float,
    cutting,
    design_loops: list[np.ndarray] | None = None,
) -> tuple[dict, tuple[Issue, ...]]:
    """Measures of a layout against the target panel size and the stock plate."""
    corners = layout.vertices[layout.quads]
    edges = layout.edges
    lengths = np.linalg.norm(layout.vertices[edges[:, 1]] - layout.vertices[edges[:, 0]], axis=1)
    angles = corner_angles(corners)
    side_lengths = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=2)
    aspect = np.maximum(
        side_lengths[:, 0] + side_lengths[:, 2], side_lengths[:, 1] + side_lengths[:, 3]
    ) / np.minimum(side_lengths[:, 0] + side_lengths[:, 2], side_lengths[:, 1] + side_lengths[:, 3])
    extents = np.sort(panel_extents(corners), axis=1)[:, ::-1]
    usable = np.array(cutting.usable)  # (long, short) inside the margins
    fits = np.all(extents <= usable, axis=1)
    _, _, distances = query.closest(layout.vertices)
    issues = tuple(
        Issue(
            "panel-exceeds-plate",
            f"panel {layout.panel_ids[i]} is about {extents[i, 0]:.0f} x {extents[i, 1]:.0f} mm, "
            f"larger than the usable plate {usable[0]:.0f} x {usable[1]:.0f} mm; lower "
            f"[panelize] panel_size",
            layout.panel_ids[i],
            "error",
        )
        for i in np.flatnonzero(~fits)
    )
    singular = singular_vertices(layout)
    metrics = {
        "panels": len(layout.quads),
        "singular_vertices": singular,
        "singular_valences": {
            str(v): sum(s["valence"] == v for s in singular)
            for v in sorted({s["valence"] for s in singular})
        },
        "vertices": len(layout.vertices),
        "target_edge_mm": round(float(target), 3),
        "edge_length_mm": {
            "min": round(float(lengths.min()), 3),
            "median": round(float(np.median(lengths)), 3),
            "max": round(float(lengths.max()), 3),
        },
        "edge_length_vs_target": {
            "min": round(float(lengths.min() / target), 4),
            "max": round(float(lengths.max() / target), 4),
        },
        "corner_angle_deg": {
            "min": round(float(angles.min()), 3),
            "max": round(float(angles.max()), 3),
        },
        "aspect_ratio_max": round(float(aspect.max()), 4),
        "largest_panel_mm": [round(float(v), 1) for v in extents[np.argmax(extents[:, 0])]],
        "usable_plate_mm": [round(float(v), 1) for v in usable],
        "panels_exceeding_plate": int((~fits).sum()),
        "vertex_distance_to_surface_mm": {
            "max": round(float(distances.max()), 6),
            "mean": round(float(distances.mean()), 6),
        },
        "edge_lengths_within_band": _band_share(lengths, target),
    }
    if design_loops is not None:
        metrics["boundary_coverage_mm"] = round(boundary_coverage(layout, design_loops), 3)
    return metrics, issues


#: the band around the target panel size that edges should stay in (fraction of the target)
EDGE_BAND = (0.5, 1.25)


def _band_share(lengths: np.ndarray, target: float) -> dict:
    low, high = EDGE_BAND
    inside = (lengths >= low * target) & (lengths <= high * target)
    return {"band": [low, high], "share": round(float(inside.mean()), 4)}
