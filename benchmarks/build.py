"""Time and peak memory of the build stage (OCCT solids, checks) and its model files (STEP
assembly, per-panel STEP, GLB, 3DM) on example shells at two panel densities.

    .venv/bin/python benchmarks/build.py [--jobs N] [--runs barrel-vault:1.2 m,one-opening:1.8 m]

Each run first panelises and develops the example (not timed), then builds and writes the model
files. Prints one line per run and, last, one JSON object with all figures.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
import time
from pathlib import Path

import fabpanel as fp
from fabpanel.model import build, write_3dm, write_glb, write_panel_steps, write_step_assembly

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def _peak_mb() -> tuple[float, float]:
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return round(own, 1), round(children, 1)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument(
        "--runs",
        default="barrel-vault:1.2 m,one-opening:1.8 m",
        help="example:panel size, comma separated",
    )
    args = parser.parse_args()
    figures = []
    for run in args.runs.split(","):
        example, size = (part.strip() for part in run.split(":"))
        job = fp.Job.from_toml(JOBS.get(example, EXAMPLES / f"{example}.toml")).replace(
            panelize={"panel_size": size}
        )
        developed = fp.run(job, until="develop", write=False).developed
        started = time.perf_counter()
        model = build(developed, job, jobs=args.jobs)
        built = time.perf_counter() - started
        with tempfile.TemporaryDirectory() as folder:
            out = Path(folder)
            started = time.perf_counter()
            write_step_assembly(model, out / "assembly.step", job.material.density)
            write_panel_steps(model, out / "panels")
            write_glb(model, out / "preview.glb")
            write_3dm(model, out / "design.3dm")
            written = time.perf_counter() - started
            step_mb = (out / "assembly.step").stat().st_size / 1e6
        own, children = _peak_mb()
        m = model.metrics
        record = {
            "example": example,
            "panel_size": size,
            "panels": len(developed.panel_ids),
            "parts": m["parts"],
            "bolt_holes": m["bolt_holes"],
            "access_openings": m["access_openings"],
            "seconds_build": round(built, 2),
            "seconds_files": round(written, 2),
            "step_mb": round(step_mb, 1),
            "peak_rss_mb": own,
            "peak_rss_workers_mb": children,
            "all_valid": m["all_valid"],
            "clashes": m["clash"]["clashes"],
            "max_plate_planarity_mm": m["max_plate_planarity_mm"],
            "max_rib_contact_gap_mm": m["max_rib_contact_gap_mm"],
            "max_bolt_coaxial_error_mm": m["max_bolt_coaxial_error_mm"],
            "max_sheet_fit_error_mm": m["max_sheet_fit_error_mm"],
            "max_sheet_trim_slide_mm": m["max_sheet_trim_slide_mm"],
            "max_sheet_edge_mismatch_mm": m["max_sheet_edge_mismatch_mm"],
            "issues": {
                code: sum(1 for i in model.issues if i.code == code)
                for code in sorted({i.code for i in model.issues})
            },
        }
        print(
            f"{example} {size}: {record['panels']} panels, {record['parts']} parts, build "
            f"{record['seconds_build']} s, files {record['seconds_files']} s, peak "
            f"{own} MB (workers {children} MB)",
            file=sys.stderr,
        )
        figures.append(record)
    print(json.dumps({"benchmark": "build", "runs": figures}))


if __name__ == "__main__":
    main()
