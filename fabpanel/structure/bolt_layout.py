"""The joints' bolt layout against EN 1993-1-8 Table 3.3, measured on the built ribs.

Minimum end distance e_1 = 1.2 d_0 and spacing p_1 = 2.2 d_0 are checked (an error below them).
The maximum spacing min(14 t, 200 mm) that Table 3.3 sets for compression members is reported
but not enforced: it guards against the plates buckling apart between the bolts (and crevice
corrosion outdoors), and each rib of a joint is welded along both long edges to its panel's
sheets, so it cannot buckle out of its plane between bolts as a free strip does, and the joint
lies inside the closed sandwich. Set ``[sandwich.bolts] spacing`` to 14 t or less to meet it
literally (112 mm for 8 mm ribs: about twice the bolts).
"""

from __future__ import annotations

import numpy as np

from ..errors import Issue

#: EN 1993-1-8 Table 3.3 minimums, times d_0
MIN_END = 1.2
MIN_PITCH = 2.2


def bolt_layout(parts, t_rib: float) -> tuple[dict, list[Issue]]:
    """``(summary, issues)``: the smallest end distance and the range of spacings along the
    built ribs (``parts``: the model's parts), against Table 3.3."""
    ends, pitches, d0, short = [], [], 0.0, []
    for part in parts:
        if part.kind != "rib" or not part.holes or part.outline is None:
            continue
        along = np.sort([h.centre[0] for h in part.holes])
        d0 = max(d0, max(h.diameter for h in part.holes))
        low, high = float(np.min(part.outline[:, 0])), float(np.max(part.outline[:, 0]))
        end = min(along[0] - low, high - along[-1])
        ends.append(end)
        if len(along) > 1:
            pitches.append(np.diff(along))
        if end < MIN_END * d0 - 1e-6:
            short.append((part.id, end))
    if not ends:
        return {"checked": False}, []
    every = np.concatenate(pitches) if pitches else np.zeros(0)
    limit = min(14 * t_rib, 200.0)
    summary = {
        "checked": True,
        "hole_mm": round(d0, 2),
        "end_distance_min_mm": round(min(ends), 1),
        "end_distance_required_mm": round(MIN_END * d0, 1),
        "spacing_min_mm": round(float(every.min()), 1) if len(every) else None,
        "spacing_max_mm": round(float(every.max()), 1) if len(every) else None,
        "spacing_required_mm": round(MIN_PITCH * d0, 1),
        "compression_spacing_limit_mm": round(limit, 1),
        "compression_limit_applied": False,
        "why": (
            "Table 3.3's min(14 t, 200 mm) for compression members guards against the plates "
            "buckling apart between bolts: each rib is welded to its sheets along both long "
            "edges and the joint lies inside the closed sandwich, so it is not enforced"
        ),
    }
    issues = [
        Issue(
            "bolt-spacing",
            f"{pid}: end distance {end:.1f} mm is below EN 1993-1-8 Table 3.3's 1.2 d_0 = "
            f"{MIN_END * d0:.1f} mm; raise [sandwich.bolts] edge_distance",
            pid,
            "error",
        )
        for pid, end in short
    ]
    if len(every) and every.min() < MIN_PITCH * d0 - 1e-6:
        issues.append(
            Issue(
                "bolt-spacing",
                f"bolt spacing {every.min():.1f} mm is below Table 3.3's 2.2 d_0 = "
                f"{MIN_PITCH * d0:.1f} mm; raise [sandwich.bolts] spacing",
                severity="error",
            )
        )
    return summary, issues
