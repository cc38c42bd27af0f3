"""Nesting on the examples: fabpanel's spyrrow nest against a naive bounding-box packing.

    .venv/bin/python benchmarks/nest.py [NAME ...] [--nest-time SECONDS ...] [--develop METHOD]

Runs each example job (default: barrel-vault and one-opening) up to the cut stage, then nests
its flat parts once per time budget given (default: 0 s, the job's reproducible default) and
packs the same parts' bounding rectangles with rectpack (MaxRects, best-fit bins, quarter turns
when the job allows them: the nest's own first assignment), both with the job's plate, margin
and part spacing. Prints
one line per run and, last, one JSON object: per example and material/thickness group the parts,
the area lower bound on plates, plates and utilisation of both methods, and the time spent.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import fabpanel as fp
from fabpanel.flat.nest import bounding_box_plates, nest, validate_nests

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*", default=["barrel-vault", "one-opening"])
    parser.add_argument(
        "--nest-time",
        type=float,
        nargs="+",
        default=[0.0],
        help="time budgets per material/thickness group, seconds",
    )
    parser.add_argument(
        "--develop",
        default=None,
        help="develop method for the build ('project' is the fastest way to "
        "parts; the nest does not need developable sheets)",
    )
    args = parser.parse_args()
    runs = []
    for name in args.names:
        job = fp.Job.from_toml(JOBS.get(name, EXAMPLES / f"{name}.toml"))
        if args.develop:
            job = job.replace(develop={"method": args.develop})
        started = time.perf_counter()
        flat = fp.run(job, until="cut", write=False).flat
        pipeline_seconds = time.perf_counter() - started
        started = time.perf_counter()
        baseline = bounding_box_plates(flat, job)
        baseline_seconds = time.perf_counter() - started
        plate_area = job.cutting.plate_length * job.cutting.plate_width
        for budget in args.nest_time:
            timed = job.replace(cutting={"nest_time": f"{budget:g} s"})
            started = time.perf_counter()
            nests = nest(flat, timed)
            seconds = time.perf_counter() - started
            problems = validate_nests(nests, flat, timed)
            if problems:
                raise RuntimeError(f"{name}: invalid nest: {problems[:3]}")
            groups = []
            for g in nests.metrics["groups"]:
                key = (g["material"], float(g["thickness_mm"]))
                area = sum(p.area for p in flat.parts if (p.material, float(p.thickness)) == key)
                groups.append(
                    {
                        "material": key[0],
                        "thickness_mm": key[1],
                        "parts": g["parts"],
                        "plates_lower_bound": math.ceil(area / plate_area - 1e-9),
                        "plates": g["plates"],
                        "utilisation": round(area / (g["plates"] * plate_area), 4),
                        "time_s": g["time_s"],
                        "bounding_box_plates": baseline[key],
                        "bounding_box_utilisation": round(area / (baseline[key] * plate_area), 4),
                    }
                )
            record = {
                "example": name,
                "nest_time_s": budget,
                "parts": len(flat.parts),
                "plates": nests.metrics["plates"],
                "plates_lower_bound": nests.metrics["plates_lower_bound"],
                "utilisation": round(nests.metrics["utilisation"], 4),
                "time_s": round(seconds, 2),
                "bounding_box_plates": sum(baseline.values()),
                "bounding_box_time_s": round(baseline_seconds, 2),
                "pipeline_to_cut_s": round(pipeline_seconds, 1),
                "groups": groups,
            }
            runs.append(record)
            print(
                f"{name:>14} ({budget:g} s): {record['parts']} parts on {record['plates']} "
                f"plates (lower bound {record['plates_lower_bound']}, bounding boxes "
                f"{record['bounding_box_plates']}), utilisation {record['utilisation']:.1%}, "
                f"{record['time_s']} s",
                file=sys.stderr,
            )
            for g in groups:
                print(
                    f"{'':>16}{g['material']} {g['thickness_mm']:g} mm: {g['parts']} parts, "
                    f"{g['plates']} plates (bound {g['plates_lower_bound']}, bounding boxes "
                    f"{g['bounding_box_plates']}), {g['time_s']} s",
                    file=sys.stderr,
                )
    print(json.dumps({"benchmark": "nest", "runs": runs}))


if __name__ == "__main__":
    main()
