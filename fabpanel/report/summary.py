"""The run's summary: counts, masses, the key figure of every stage, the issues."""

from __future__ import annotations

from collections import Counter, defaultdict


def summarise(result, timings: dict[str, float], structure: dict) -> dict:
    """JSON-ready summary of a :class:`fabpanel.pipeline.Result`."""
    summary: dict = {
        "input": result.surface.to_dict(),
        "stages_run": list(result.stages_run),
        "timings_s": {k: round(v, 3) for k, v in timings.items()},
        "structure": structure,
        "issues": {
            "errors": sum(i.severity == "error" for i in result.issues),
            "warnings": sum(i.severity == "warning" for i in result.issues),
        },
    }
    if result.layout is not None:
        m = result.layout.metrics
        summary["panels"] = {
            "count": m["panels"],
            "method": result.layout.method,
            "singular_valences": m.get("singular_valences", {}),
            "boundary_coverage_mm": m.get("boundary_coverage_mm"),
            "edge_length_mm": m["edge_length_mm"],
            "corner_angle_deg": m["corner_angle_deg"],
            "largest_panel_mm": m["largest_panel_mm"],
            # the layout gates' measures (count, edge band and histogram, shortest edge,
            # narrowest panel, corners, topology, score) and why ``auto`` chose the method
            "gates": m.get("gates"),
            "chosen_because": _chosen_because(result),
        }
    if result.developed is not None:
        m = result.developed.metrics
        summary["developability"] = {
            "method": result.developed.method,
            "classes": m["classes"],
            "unroll_strain_max": m["unroll_strain"]["max"],
            "deviation_mm": m["deviation_mm"],
            "bending_radius_mm_min": m["bending_radius_mm_min"],
            # against the design boundary, and the sides that cut its chord (boundary-chord)
            "boundary_deviation_mm": m.get("boundary_deviation_mm"),
            "boundary_chords": m.get("boundary_chords"),
            "boundary_sides": int((result.developed.layout.side_neighbours < 0).sum()),
        }
    if result.model is not None:
        parts = result.model.parts
        kinds = Counter(p.kind for p in parts)
        mass_by_kind: defaultdict[str, float] = defaultdict(float)
        for p in parts:
            mass_by_kind[p.kind] += p.mass
        summary["parts"] = {
            "count": len(parts),
            "by_kind": dict(kinds),
            "mass_kg": round(result.model.mass, 2),
            "mass_by_kind_kg": {k: round(v, 2) for k, v in mass_by_kind.items()},
            "mass_per_m2_kg": round(result.model.mass / (result.surface.area / 1e6), 2),
            "checks": {k: v for k, v in result.model.metrics.items() if k != "panels"},
        }
    if result.flat is not None:
        # per-part strains stay in the manifest
        summary["flat"] = {
            k: v for k, v in result.flat.metrics.items() if k not in ("per_part", "strain_by_part")
        }
    if result.nests is not None:
        summary["nests"] = {
            k: v
            for k, v in result.nests.metrics.items()
            if not isinstance(v, (list, dict)) or k in ("utilisation", "groups", "stock_suggestion")
        }
        summary["nests"]["plates"] = len(result.nests.plates)
    return summary


def _chosen_because(result) -> str:
    """Why the layout has its method: ``auto``'s reason, or the job's own asking."""
    reason = result.layout.metrics.get("auto", {}).get("reason")
    if reason:
        return reason
    asked = result.job.panelize.method
    if asked == "auto":  # a four-sided outline with grid counts given: the grid, as asked
        return "auto on a four-sided outline with grid_u or grid_v given: the grid"
    return f'asked in the job ([panelize] method = "{asked}")'
