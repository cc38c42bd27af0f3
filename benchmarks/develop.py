"""Developability methods side by side on the examples: global optimisation against the loft
baseline (and the plain projection onto the design surface).

    .venv/bin/python benchmarks/develop.py [--methods global,loft,project] [--max-iterations N]
                                          [NAME ...]

Panelises each example job in examples/ and fabpanel/examples/ (or the names given), then
develops it by each method.
Prints one line per run and, last, one JSON object: panels, time, peak memory (resident, MB),
max/mean unroll strain, the rib measures (sheet edge from its rib plane, mm; largest angle of the
normals to it and its variation along a side, degrees), max/mean deviation, the largest gap
between neighbours, and per example the ratios of the global method's deviations to the loft's.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path

import fabpanel as fp
from fabpanel.develop import develop
from fabpanel.surface import SurfaceQuery

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*")
    parser.add_argument("--methods", default="global,loft,project")
    parser.add_argument("--max-iterations", type=int, default=None)
    args = parser.parse_args()
    jobs = [JOBS[name] for name in sorted(JOBS)]
    if args.names:
        jobs = [j for j in jobs if j.stem in args.names]
    runs, ratios = [], {}
    for path in jobs:
        base = fp.Job.from_toml(path)
        surface = fp.load_surface(base.input_path, base.input.units)
        query = SurfaceQuery(surface)
        layout = fp.panelize(surface, base, query)
        by_method = {}
        for method in args.methods.split(","):
            settings = {"method": method}
            if args.max_iterations:
                settings["max_iterations"] = args.max_iterations
            job = base.replace(develop=settings)
            started = time.perf_counter()
            developed = develop(layout, surface, job, query)
            seconds = time.perf_counter() - started
            m = developed.metrics
            record = {
                "example": path.stem,
                "method": method,
                "panels": len(layout.quads),
                "seconds": round(seconds, 2),
                "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
                "strain_max": m["unroll_strain"]["max"],
                "strain_mean": m["unroll_strain"]["mean"],
                "rib_plane_residual_mm_max": m["rib_plane_residual_mm_max"],
                "rib_plane_residual_mm_max_interior": m["rib_plane_residual_mm_max_interior"],
                "rib_normal_angle_deg_max": m["rib_normal_angle_deg_max"],
                "rib_bevel_twist_deg_max": m["rib_bevel_twist_deg_max"],
                "classes": m["classes"],
                "deviation_mm_max": m["deviation_mm"]["max"],
                "deviation_mm_mean": m["deviation_mm"]["mean"],
                "gap_mm_max": m.get("gap_mm_max", 0.0),
                "kink_deg_max": m.get("kink_deg", {}).get("max"),
                "not_developable": m["panels_not_developable"],
                "solver": m.get("solver"),
            }
            by_method[method] = record
            runs.append(record)
            print(
                f"{path.stem:>14} {method:>8}: {record['panels']} panels {seconds:7.1f} s, "
                f"strain max {record['strain_max']:.2e}, rib {record['rib_plane_residual_mm_max']}"
                f" mm, deviation max/mean {record['deviation_mm_max']}/"
                f"{record['deviation_mm_mean']} mm, gap {record['gap_mm_max']} mm",
                file=sys.stderr,
            )
        if "global" in by_method and "loft" in by_method:
            ratios[path.stem] = {
                key: (
                    round(by_method["global"][key] / by_method["loft"][key], 4)
                    if by_method["loft"][key]
                    else None
                )
                for key in ("deviation_mm_mean", "deviation_mm_max")
            }
    print(json.dumps({"benchmark": "develop", "runs": runs, "global_over_loft": ratios}))


if __name__ == "__main__":
    main()
