"""Time and peak memory of the whole pipeline on the barrel vault at two panel sizes.

    .venv/bin/python benchmarks/pipeline.py [--jobs N]

Prints one line per run and, last, one JSON object with all figures.
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

DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument("--sizes", default="1.2 m,0.8 m")
    args = parser.parse_args()
    figures = []
    for size in args.sizes.split(","):
        job = fp.Job.from_toml(DEMO / "barrel-vault.toml").replace(
            panelize={"panel_size": size.strip()}
        )
        with tempfile.TemporaryDirectory() as folder:
            started = time.perf_counter()
            result = fp.run(job, out_dir=Path(folder) / "out", jobs=args.jobs)
            seconds = time.perf_counter() - started
        record = {
            "panel_size": size.strip(),
            "panels": result.summary["panels"]["count"],
            "parts": result.summary["parts"]["count"],
            "plates": len(result.nests.plates),
            "utilisation": result.nests.metrics.get("utilisation"),
            "seconds_total": round(seconds, 2),
            "seconds_by_stage": result.summary["timings_s"],
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "peak_rss_children_mb": round(
                resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024, 1
            ),
        }
        print(
            f"{record['panel_size']:>8}: {record['panels']} panels, {record['parts']} parts, "
            f"{record['plates']} plates, {record['seconds_total']} s, "
            f"{record['peak_rss_mb']} MB",
            file=sys.stderr,
        )
        figures.append(record)
    print(json.dumps({"benchmark": "pipeline-barrel-vault", "runs": figures}))


if __name__ == "__main__":
    main()
