"""How the panels' boundary sides meet the design boundary, on the examples and the hard shapes.

    .venv/bin/python benchmarks/boundary.py [--size "1 m"] [NAME ...]

Panelises each example job and each shape of benchmarks/hard_shapes.py (``auto``, at the size
given) and samples the panels on the design surface (the ``project`` develop method: the
boundary sides are decided there, the other methods hold them). A boundary side follows the
design boundary where a planar rib can; where the boundary curves in the sheet's own plane
so much that a rib through it would lie within ``rib_tangent_deg`` of the sheet it cuts the
chord (``boundary-chord``). Prints one line per shape: panels, boundary sides, chorded sides
and how far the chords lie inside the boundary, and the deviation (both ways, mm) of the
followed sides; last, one JSON object with every figure.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import fabpanel as fp
from fabpanel.develop import develop

sys.path.insert(0, str(Path(__file__).resolve().parent))
from panelize import jobs_to_run


def measure(job: fp.Job, size: str) -> dict:
    job = job.replace(panelize={"panel_size": size}, develop={"method": "project"})
    surface = fp.load_surface(job.input_path, job.input.units)
    start = time.perf_counter()
    layout = fp.panelize(surface, job)
    developed = develop(layout, surface, job)
    metrics = developed.metrics
    deviation = metrics.get("boundary_deviation_mm") or {}
    followed = deviation.get("followed", deviation)
    return {
        "panels": len(layout.quads),
        "boundary_sides": int((layout.side_neighbours < 0).sum()),
        "chords": metrics["boundary_chords"]["sides"],
        "chord_offset_mm_max": metrics["boundary_chords"]["offset_mm_max"],
        "followed_mm": max(followed.values(), default=0.0),
        "all_mm": max(deviation.values(), default=0.0)
        if "followed" not in deviation
        else max(deviation["design_to_panels"], deviation["panels_to_design"]),
        "seconds": round(time.perf_counter() - start, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*")
    parser.add_argument("--size", default="1 m")
    args = parser.parse_args()
    records = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, job in jobs_to_run(args.names, Path(folder)).items():
            record = measure(job, args.size)
            records[name] = record
            print(
                f"{name:16s} {record['panels']:5d} panels, {record['boundary_sides']:4d} boundary "
                f"sides, {record['chords']:3d} chords (up to {record['chord_offset_mm_max']:6.1f} "
                f"mm inside), followed sides within {record['followed_mm']:.2f} mm "
                f"({record['seconds']} s)",
                flush=True,
            )
    print(json.dumps({"size": args.size, "shapes": records}))


if __name__ == "__main__":
    main()
