"""Panelisation of the example shapes at several densities: time, peak memory and quality.

    .venv/bin/python benchmarks/panelize.py [--sizes "1.5 m,1.2 m,0.9 m"] [NAME ...]

Runs only the panelize stage for each example job in examples/ and fabpanel/examples/ (or the
names given). Prints one line per run and, last, one JSON object with every figure.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tracemalloc
from pathlib import Path

import fabpanel as fp

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*")
    parser.add_argument("--sizes", default="1.5 m,1.2 m,0.9 m")
    args = parser.parse_args()
    jobs = [JOBS[name] for name in sorted(JOBS)]
    if args.names:
        jobs = [j for j in jobs if j.stem in args.names]
    runs = []
    for path in jobs:
        base = fp.Job.from_toml(path)
        surface = fp.load_surface(base.input_path, base.input.units)
        for size in args.sizes.split(","):
            job = base.replace(panelize={"panel_size": size.strip()})
            tracemalloc.start()
            started = time.perf_counter()
            try:
                layout = fp.panelize(surface, job)
            except fp.FabpanelError as err:
                tracemalloc.stop()
                runs.append({"example": path.stem, "panel_size": size.strip(), "error": str(err)})
                print(f"{path.stem:>14} {size:>7}: {err}", file=sys.stderr)
                continue
            seconds = time.perf_counter() - started
            peak = tracemalloc.get_traced_memory()[1] / 2**20
            tracemalloc.stop()
            m = layout.metrics
            record = {
                "example": path.stem,
                "panel_size": size.strip(),
                "method": layout.method,
                "seconds": round(seconds, 3),
                "peak_python_mb": round(peak, 1),
                **{
                    k: m[k]
                    for k in (
                        "panels",
                        "singular_valences",
                        "edge_length_mm",
                        "edge_lengths_within_band",
                        "corner_angle_deg",
                        "aspect_ratio_max",
                        "panels_exceeding_plate",
                        "boundary_coverage_mm",
                    )
                    if k in m
                },
            }
            runs.append(record)
            print(
                f"{path.stem:>14} {size:>7}: {record['panels']} panels in {seconds:.2f} s, "
                f"edges {m['edge_length_mm']}, singular {m.get('singular_valences')}",
                file=sys.stderr,
            )
    print(json.dumps({"benchmark": "panelize", "runs": runs}))


if __name__ == "__main__":
    main()
