"""Quality gates of a panel layout, for every method: what a shop needs from the layout.

Measured on every layout (``metrics["gates"]``) and turned into issues that name the panels:

================================  =================================  =========  =============
measure                           threshold                          severity   code
================================  =================================  =========  =============
panels / (area / panel_size²)     ≤ 1.3                              warning    layout-panel-count
edges in 0.5-1.25 x panel_size    ≥ 90 %                             warning    layout-edge-band
shortest edge                     ≥ 0.3 x panel_size                 warning    layout-short-edge
corner angles                     all in 45-135°, ≥ 95 % in 60-120°  warning    layout-corner-angle
  (at a design tip under 45°)     (the design's own: no layout helps)  warning    outline-sharp-corner
narrowest panel (mid-line)        ≥ ``[panelize] min_panel_width``   error      layout-narrow-panel
quads form a manifold surface     Euler characteristic = surface's   error      layout-topology
================================  =================================  =========  =============

A panel narrower than ``min_panel_width`` (default 0.3 x panel_size) cannot be built: the ribs
and corner stiffeners of its two long sides meet. The score that ``method = "auto"`` uses to
choose between layouts is :func:`layout_score`.

A tip of the design outline sharper than 45° (a crescent's horns) forces a panel corner under
45° whatever the layout: the panel that covers the tip has the tip's angle. Such corners are
told apart (``outline_tip_corners``) and reported as ``outline-sharp-corner``, which names the
tip and its angle and asks for the design to change, not the layout; they count in the corner
measures all the same.
"""

from __future__ import annotations

import numpy as np

from ..data import PanelLayout, Surface
from ..errors import Issue
from ..job import Job
from ..surface.design_boundary import DesignBoundary
from .folds import panels_across_folds
from .quality import corner_angles, vertex_valences

#: thresholds (fractions of the panel size, degrees, shares)
MAX_COUNT_RATIO = 1.3
EDGE_BAND = (0.5, 1.25)
MIN_BAND_SHARE = 0.90
MIN_EDGE = 0.3
CORNER_LIMITS = (45.0, 135.0)
CORNER_GOOD = (60.0, 120.0)
MIN_GOOD_CORNERS = 0.95
#: default narrowest panel, fraction of the panel size
MIN_WIDTH = 0.3
#: bins of edge length / panel size in the histogram
HISTOGRAM_BINS = (0.0, 0.3, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, np.inf)
#: panels named in one message
NAMED = 8
#: the outline's own angle at a tip is measured between chords this long (x panel size)
TIP_REACH = 0.15
#: slack on the tip's measured angle: chords across a curved outline read a little off
TIP_SLACK_DEG = 3.0


def euler_characteristic(vertices: int, faces: np.ndarray) -> int:
    """V - E + F of a polygon mesh given its vertex count and faces (rows of vertex indices)."""
    sides = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    edges = len(np.unique(np.sort(sides, axis=1), axis=0))
    used = len(np.unique(faces)) if len(faces) else vertices
    return int(used - edges + len(faces))


def panel_widths(corners: np.ndarray) -> np.ndarray:
    """(m,) float: each quad's narrower mid-line (between the midpoints of opposite sides)."""
    mids = 0.5 * (corners + np.roll(corners, -1, axis=1))
    across = np.linalg.norm(mids[:, 2] - mids[:, 0], axis=1)
    along = np.linalg.norm(mids[:, 3] - mids[:, 1], axis=1)
    return np.minimum(across, along)


def gate_measures(layout: PanelLayout, surface: Surface, target: float) -> dict:
    """Every measure of the table above, JSON-ready."""
    corners = layout.vertices[layout.quads]
    edges = layout.edges
    lengths = np.linalg.norm(layout.vertices[edges[:, 1]] - layout.vertices[edges[:, 0]], axis=1)
    relative = lengths / target
    angles = corner_angles(corners)
    widths = panel_widths(corners)
    counts, _ = np.histogram(relative, bins=np.asarray(HISTOGRAM_BINS))
    sides = np.sort(np.stack([layout.quads, np.roll(layout.quads, -1, 1)], 2).reshape(-1, 2), 1)
    _, side_uses = np.unique(sides, axis=0, return_counts=True)
    expected = surface.area / target**2
    across = panels_across_folds(layout, surface, target)
    return {
        "surface_area_m2": round(surface.area / 1e6, 3),
        "panels": len(layout.quads),
        "panels_for_area": round(float(expected), 1),
        "count_ratio": round(len(layout.quads) / max(expected, 1e-9), 4),
        "edge_histogram": {
            "bins_vs_panel_size": [float(b) if np.isfinite(b) else None for b in HISTOGRAM_BINS],
            "counts": [int(c) for c in counts],
        },
        "edges_in_band": round(
            float(np.mean((relative >= EDGE_BAND[0]) & (relative <= EDGE_BAND[1]))), 4
        ),
        "shortest_edge_mm": round(float(lengths.min()), 1),
        "shortest_edge_vs_panel_size": round(float(relative.min()), 4),
        "narrowest_panel_mm": round(float(widths.min()), 1),
        "narrowest_panel": layout.panel_ids[int(np.argmin(widths))],
        "corner_angle_deg": [round(float(angles.min()), 2), round(float(angles.max()), 2)],
        "corners_in_60_120": round(float(np.mean(_within(angles, CORNER_GOOD))), 4),
        "corners_in_45_135": round(float(np.mean(_within(angles, CORNER_LIMITS))), 4),
        "corners_outside_45_135": int(np.sum(~_within(angles, CORNER_LIMITS))),
        "euler_characteristic": euler_characteristic(len(layout.vertices), layout.quads),
        "surface_euler_characteristic": euler_characteristic(len(surface.vertices), surface.faces),
        "manifold": bool(side_uses.max() <= 2) if len(side_uses) else True,
        "fold_lines": len(surface.folds),
        "panels_across_folds": [layout.panel_ids[i] for i in across],
        **_outline_tips(layout, surface, angles, target),
    }


def _outline_tips(
    layout: PanelLayout, surface: Surface, angles: np.ndarray, target: float
) -> dict[str, list]:
    """The panel corners under 45° that the design outline forces: a boundary vertex that only
    one panel touches, where the outline itself turns to less than 45° (+ slack), measured
    between chords of ``TIP_REACH x target`` along the design boundary. JSON-ready: the
    (panel, corner) pairs and the outline's angle at each."""
    sharp = np.argwhere(angles < CORNER_LIMITS[0])
    if not len(sharp) or not surface.boundary_loops:
        return _no_tips()
    vertex = layout.quads[sharp[:, 0], sharp[:, 1]]
    _, on_boundary = vertex_valences(layout.quads, len(layout.vertices))
    panels_at = np.bincount(layout.quads.ravel(), minlength=len(layout.vertices))
    alone = on_boundary[vertex] & (panels_at[vertex] == 1)
    sharp, vertex = sharp[alone], vertex[alone]
    if not len(sharp):
        return _no_tips()
    design = DesignBoundary(surface)
    tip = layout.vertices[vertex]
    _, _, loop, s = design.locate(tip)
    reach = TIP_REACH * target
    outline = np.array(
        [
            _angle_between(
                design.at(int(k), np.array([(at - reach) % design.loop_length[k]]))[0] - point,
                design.at(int(k), np.array([(at + reach) % design.loop_length[k]]))[0] - point,
            )
            for k, at, point in zip(loop, s, tip, strict=True)
        ]
    )
    forced = outline < CORNER_LIMITS[0] + TIP_SLACK_DEG
    return {
        "outline_tip_corners": sharp[forced].tolist(),
        "outline_tip_angles_deg": [round(float(a), 1) for a in outline[forced]],
        "outline_tip_points_mm": np.round(tip[forced] + surface.origin, 1).tolist(),
    }


def _no_tips() -> dict[str, list]:
    return {"outline_tip_corners": [], "outline_tip_angles_deg": [], "outline_tip_points_mm": []}


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    cosine = np.dot(a, b) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-300)
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def _within(values: np.ndarray, limits: tuple[float, float]) -> np.ndarray:
    return (values >= limits[0]) & (values <= limits[1])


def min_panel_width(job: Job) -> float:
    """The narrowest panel the gates allow, mm: ``[panelize] min_panel_width``, by default
    ``MIN_WIDTH x panel_size``."""
    return job.panelize.min_panel_width or MIN_WIDTH * job.panelize.panel_size


def meets_every_gate(measures: dict, min_width: float, tips_apart: bool = False) -> bool:
    """Whether the measures of :func:`gate_measures` pass every gate of the table above. A
    design tip's corner counts as failing (callers use this to stop looking further), unless
    ``tips_apart``: then the corner gates are taken over the other corners, as
    :func:`gate_issues` takes them."""
    corners = 4 * measures["panels"]
    tips = len(measures["outline_tip_corners"]) if tips_apart else 0
    outside_limits = measures["corners_outside_45_135"] - tips
    good_share = measures["corners_in_60_120"] * corners / max(corners - tips, 1)
    return bool(
        measures["count_ratio"] <= MAX_COUNT_RATIO
        and measures["edges_in_band"] >= MIN_BAND_SHARE
        and measures["shortest_edge_vs_panel_size"] >= MIN_EDGE
        and outside_limits <= 0
        and good_share >= MIN_GOOD_CORNERS
        and measures["narrowest_panel_mm"] >= min_width
        and measures["manifold"]
        and measures["euler_characteristic"] == measures["surface_euler_characteristic"]
        and not measures.get("panels_across_folds")
    )


def layout_score(measures: dict, min_width: float) -> float:
    """One number to compare layouts of one surface (higher is better).

    The share of edges in the band plus the share of good corners, less a penalty for each
    gate failed: too many panels (0.5, and by how much), an edge shorter than 0.3 x
    panel_size, corners outside 45-135°, a panel narrower than ``min_width`` mm (1: an error,
    which no share of good corners makes up for), a wrong topology. Documented in the README
    (Panel layouts).
    """
    score = measures["edges_in_band"] + measures["corners_in_60_120"]
    score -= 2.0 * max(0.0, measures["count_ratio"] - MAX_COUNT_RATIO)
    score -= 0.5 * (measures["count_ratio"] > MAX_COUNT_RATIO)
    score -= 0.5 * (measures["shortest_edge_vs_panel_size"] < MIN_EDGE)
    score -= 0.5 * (measures["corners_outside_45_135"] > 0)
    score -= 1.0 * (measures["narrowest_panel_mm"] < min_width)
    score -= 0.5 * bool(measures.get("panels_across_folds"))
    score -= 10.0 * (
        not measures["manifold"]
        or measures["euler_characteristic"] != measures["surface_euler_characteristic"]
    )
    return round(float(score), 4)


def _names(layout: PanelLayout, panels: np.ndarray) -> str:
    ids = [layout.panel_ids[i] for i in panels[:NAMED]]
    more = f" and {len(panels) - NAMED} more" if len(panels) > NAMED else ""
    return ", ".join(ids) + more


def failed_gates(issues) -> list[str]:
    """The layout gates that ``issues`` say failed, by code: the ``layout-...`` ones (a design
    tip's ``outline-sharp-corner`` is the design's, not the layout's)."""
    return sorted({issue.code for issue in issues if issue.code.startswith("layout-")})


def gate_issues(layout: PanelLayout, measures: dict, job: Job) -> tuple[Issue, ...]:
    """Issues for every gate the layout fails, naming the panels and the likely fix."""
    target = job.panelize.panel_size
    if layout.method == "field":  # the skeleton is rarely better where the field fails
        fix = 'try a smaller panel_size, or draw the layout (method = "layout")'
    else:
        fix = 'try [panelize] method = "field" or another panel_size'
    corners = layout.vertices[layout.quads]
    issues: list[Issue] = []
    min_width = min_panel_width(job)
    widths = panel_widths(corners)
    narrow = np.flatnonzero(widths < min_width)
    if len(narrow):
        issues.append(
            Issue(
                "layout-narrow-panel",
                f"{len(narrow)} panel(s) narrower than {min_width:.0f} mm (narrowest "
                f"{widths.min():.0f} mm): {_names(layout, narrow[np.argsort(widths[narrow])])}; "
                f"their ribs and stiffeners would meet; {fix}, or lower [panelize] "
                f"min_panel_width if such panels can be built",
                layout.panel_ids[int(narrow[np.argmin(widths[narrow])])],
                "error",
            )
        )
    if not measures["manifold"] or (
        measures["euler_characteristic"] != measures["surface_euler_characteristic"]
    ):
        issues.append(
            Issue(
                "layout-topology",
                f"the layout's Euler characteristic is {measures['euler_characteristic']}, the "
                f"surface's {measures['surface_euler_characteristic']} (manifold: "
                f"{measures['manifold']}): panels are missing or overlap; {fix}",
                "",
                "error",
            )
        )
    if measures["count_ratio"] > MAX_COUNT_RATIO:
        issues.append(
            Issue(
                "layout-panel-count",
                f"{measures['panels']} panels where the area needs about "
                f"{measures['panels_for_area']:.0f} ({measures['count_ratio']:.2f} x, more than "
                f"{MAX_COUNT_RATIO} x): panels are smaller than the {target:.0f} mm asked; "
                f"{_count_fix(layout.method)}",
            )
        )
    issues += _edge_issues(layout, measures, target, fix)
    issues += _corner_issues(layout, corners, measures, fix)
    issues += _fold_issues(layout, measures)
    return tuple(issues)


def _fold_issues(layout: PanelLayout, measures: dict) -> list[Issue]:
    across = measures.get("panels_across_folds") or []
    if not across:
        return []
    more = f" and {len(across) - NAMED} more" if len(across) > NAMED else ""
    fix = (
        'use [panelize] method = "field", which puts panel sides along the folds'
        if layout.method != "field"
        else "try another panel_size, or draw the layout with sides along the folds"
    )
    return [
        Issue(
            "layout-crosses-fold",
            f"{len(across)} panel(s) span a fold line of the surface (a seam between two "
            f"faces that kinks): {', '.join(across[:NAMED])}{more}; a developable sheet "
            f"cannot follow both sides of the kink; {fix}",
            across[0],
        )
    ]


def _count_fix(method: str) -> str:
    """The fix for too many panels: larger ones asked for, or the other method (not the
    smaller panel_size the other gates suggest to the field method)."""
    other = "skeleton" if method == "field" else "field"
    return f'try a larger panel_size, or [panelize] method = "{other}"'


def _edge_issues(layout: PanelLayout, measures: dict, target: float, fix: str) -> list[Issue]:
    corners = layout.vertices[layout.quads]
    side = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=2) / target
    issues = []
    if measures["edges_in_band"] < MIN_BAND_SHARE:
        outside = np.flatnonzero(((side < EDGE_BAND[0]) | (side > EDGE_BAND[1])).any(axis=1))
        issues.append(
            Issue(
                "layout-edge-band",
                f"{measures['edges_in_band']:.0%} of panel edges lie within "
                f"{EDGE_BAND[0]}-{EDGE_BAND[1]} x panel_size (wanted {MIN_BAND_SHARE:.0%}); "
                f"panels with edges outside: {_names(layout, outside)}; {fix}",
            )
        )
    short = np.flatnonzero((side < MIN_EDGE).any(axis=1))
    if len(short):
        issues.append(
            Issue(
                "layout-short-edge",
                f"{len(short)} panel(s) have an edge shorter than {MIN_EDGE} x panel_size "
                f"(shortest {measures['shortest_edge_mm']:.0f} mm): {_names(layout, short)}; {fix}",
                layout.panel_ids[int(short[0])],
            )
        )
    return issues


def _corner_issues(
    layout: PanelLayout, corners: np.ndarray, measures: dict, fix: str
) -> list[Issue]:
    angles = corner_angles(corners)
    outside = ~_within(angles, CORNER_LIMITS)
    tips = np.asarray(measures.get("outline_tip_corners", []), dtype=int).reshape(-1, 2)
    issues = _tip_issues(layout, tips, measures)
    outside[tips[:, 0], tips[:, 1]] = False  # the design's, reported above
    bad = np.flatnonzero(outside.any(axis=1))
    # the tips' corners cannot be in 60-120° either: the share is taken over the others
    counted = np.ones(angles.shape, dtype=bool)
    counted[tips[:, 0], tips[:, 1]] = False
    good_share = float(np.mean(_within(angles, CORNER_GOOD)[counted])) if counted.any() else 1.0
    if not len(bad) and good_share >= MIN_GOOD_CORNERS:
        return issues
    return issues + [
        Issue(
            "layout-corner-angle",
            f"corner angles {angles.min():.0f}-{angles.max():.0f}°, {good_share:.0%} within "
            f"60-120° (wanted all within 45-135° and {MIN_GOOD_CORNERS:.0%} within 60-120°)"
            + (f"; panels beyond 45-135°: {_names(layout, bad)}" if len(bad) else "")
            + (" (the outline's sharp tips apart)" if len(tips) else "")
            + f"; {fix}",
            layout.panel_ids[int(bad[0])] if len(bad) else "",
        )
    ]


def _tip_issues(layout: PanelLayout, tips: np.ndarray, measures: dict) -> list[Issue]:
    if not len(tips):
        return []
    where = "; ".join(
        f"{layout.panel_ids[panel]} at ({', '.join(f'{c:.0f}' for c in point)}) mm, {angle:.0f}°"
        for panel, angle, point in zip(
            tips[:NAMED, 0],
            measures["outline_tip_angles_deg"],
            measures["outline_tip_points_mm"],
            strict=False,
        )
    )
    return [
        Issue(
            "outline-sharp-corner",
            f"the design outline comes to {len(tips)} tip(s) sharper than 45°, so the panel "
            f"covering each has a corner as sharp, whatever the layout or panel size: {where}; "
            f"round the tip off or cut it square in the design (or accept the tip panel: check "
            f"that its ribs and stiffeners fit)",
            layout.panel_ids[int(tips[0, 0])],
        )
    ]
