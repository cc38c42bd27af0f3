"""Per panel: weight, centre of gravity, lifting points, coating area and erection sequence.

Erection sequence: the shell goes up from its supports. The panels standing on the support level
(boundary panels whose lowest corner is within 1 % of the span of the lowest point) can be set
first; every next panel is the lowest of those standing on the supports or sharing a side with a
panel already up, so each panel is set on a support or bolted onto the erected shell, and both
sides of a vault rise together.

A panel with error-level issues (on it or one of its parts: a clash, an unreachable bolt, a part
that was not built) is marked ``HOLD`` with their count: it must not be built as drawn.

Lifting points: one lug on each corner stiffener (the panel's stiffest points, where ribs meet),
at the stiffener's centre. A panel whose centre of gravity lies outside the lugs' outline seen
from above tips as it is lifted; the schedule says so.
"""

from __future__ import annotations

import heapq

import numpy as np

from .schedules import Schedule, panel_types
from .source import DocSource, PartDoc

#: panels whose lowest corner is within this share of the span above the lowest point stand on
#: the support level
SUPPORT_LEVEL = 0.01


def erection_sequence(source: DocSource) -> dict[str, int]:
    """Panel id -> its place in the erection order, 1 for the first (module docstring)."""
    lowest = {p.id: float(p.corners[:, 2].min()) for p in source.panels}
    neighbours = {p.id: [n for n in p.neighbours if n in lowest] for p in source.panels}
    ground = min(lowest.values(), default=0.0)
    span = max(lowest.values(), default=0.0) - ground
    queue = [(lowest[pid], pid) for pid in support_panels(source, ground, span)]
    heapq.heapify(queue)
    order: dict[str, int] = {}
    while len(order) < len(lowest):
        if not queue:  # a piece not standing on the support level: its lowest panel
            start = min((z, pid) for pid, z in lowest.items() if pid not in order)
            heapq.heappush(queue, start)
        _, pid = heapq.heappop(queue)
        if pid in order:
            continue
        order[pid] = len(order) + 1
        for other in neighbours[pid]:
            if other not in order:
                heapq.heappush(queue, (lowest[other], other))
    return order


def support_panels(source: DocSource, ground: float, span: float) -> list[str]:
    """Boundary panels standing on the support level (their lowest corner within
    ``SUPPORT_LEVEL`` of the span above the lowest point): each is set on its support."""
    return [
        p.id
        for p in source.panels
        if None in p.neighbours and float(p.corners[:, 2].min()) <= ground + SUPPORT_LEVEL * span
    ]


def centre_of_gravity(parts: list[PartDoc]) -> np.ndarray | None:
    """Mass-weighted centre of the parts' centroids, mm (None when one was not measured)."""
    if not parts or any(p.centroid is None for p in parts):
        return None
    mass = np.array([p.mass for p in parts])
    centres = np.array([p.centroid for p in parts])
    return (mass[:, None] * centres).sum(axis=0) / mass.sum()


def lifting_points(parts: list[PartDoc]) -> np.ndarray:
    """(n, 3) lug positions: the corner stiffeners' centres, in stiffener order."""
    points = [p.centroid for p in parts if p.kind == "stiffener" and p.centroid is not None]
    return np.array(points).reshape(-1, 3)


def inside_in_plan(point: np.ndarray, polygon: np.ndarray) -> bool:
    """Whether ``point`` lies inside the convex hull of ``polygon`` seen from above (x, y)."""
    from shapely.geometry import MultiPoint, Point

    if len(polygon) < 3:
        return False
    return bool(MultiPoint(polygon[:, :2].tolist()).convex_hull.covers(Point(point[:2])))


def panel_schedule(source: DocSource) -> Schedule:
    """One row per built panel (see the module docstring)."""
    sequence = erection_sequence(source)
    type_of = {pid: name for name, ids in panel_types(source) for pid in ids}
    rows = []
    for panel in sorted(source.panels, key=lambda p: sequence[p.id]):
        parts = source.parts_of(panel.id)
        if not parts:
            continue
        cog = centre_of_gravity(parts)
        lugs = lifting_points(parts)
        lug_cells = [" ".join(f"{v:.1f}" for v in point) for point in lugs[:4]]
        lug_cells += [""] * (4 - len(lug_cells))
        balanced = "" if cog is None or not len(lugs) else str(inside_in_plan(cog, lugs)).lower()
        cog_cells = [f"{v:.1f}" for v in cog] if cog is not None else ["", "", ""]
        rows.append(
            (
                panel.id,
                str(sequence[panel.id]),
                type_of.get(panel.id, ""),
                panel.panel_class,
                str(len(parts)),
                f"{sum(p.mass for p in parts):.1f}",
                *cog_cells,
                *lug_cells,
                balanced,
                f"{sum(p.coating_area for p in parts) / 1e6:.2f}",
                " ".join(n or "-" for n in panel.neighbours),
                str(len(source.errors.get(panel.id, ()))),
                "HOLD" if panel.id in source.errors else "",
            )
        )
    return Schedule(
        "panels.csv",
        "Panels",
        (
            "panel",
            "sequence",
            "type",
            "class",
            "parts",
            "mass_kg",
            "cog_x_mm",
            "cog_y_mm",
            "cog_z_mm",
            "lift_1_mm",
            "lift_2_mm",
            "lift_3_mm",
            "lift_4_mm",
            "cog_inside_lifting_points",
            "coating_area_m2",
            "neighbours",
            "errors",
            "status",
        ),
        tuple(rows),
    )
