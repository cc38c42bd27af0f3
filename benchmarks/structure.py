"""The structure stage on the examples, and the shell benchmarks it is validated with.

    .venv/bin/python benchmarks/structure.py [NAME ...] [--element-size LENGTH]
                                             [--max-elements N] [--threads N]
                                             [--develop METHOD] [--no-validation]

Runs each example job (default: barrel-vault and pavilion) up to the build stage, then the
structural check with the job's default element size (or the one given). Prints one line per
run and, last, one JSON object: per example the panels, elements, equations, CalculiX wall time
(static cases and buckling), stage time, peak memory of the CalculiX runs (resident, MB), and the
results (utilisation, deflection, buckling factors, mass and reaction errors); and the validation
benchmarks (Scordelis-Lo, pinched hemisphere, plate buckling) with their errors.
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
from fabpanel.structure import analyse, validation

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*", default=["barrel-vault", "pavilion"])
    parser.add_argument("--element-size", default=None)
    parser.add_argument("--max-elements", type=int, default=None)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument(
        "--develop",
        default=None,
        help="develop method for the build (the structure model does not "
        "depend on it; 'project' is the fastest way to a model)",
    )
    parser.add_argument("--no-validation", action="store_true")
    args = parser.parse_args()
    runs = []
    for name in args.names:
        job = fp.Job.from_toml(JOBS.get(name, EXAMPLES / f"{name}.toml"))
        settings = {}
        if args.element_size:
            settings["element_size"] = args.element_size
        if args.max_elements:
            settings["max_elements"] = args.max_elements
        if args.threads:
            settings["threads"] = args.threads
        if settings:
            job = job.replace(structure=settings)
        if args.develop:
            job = job.replace(develop={"method": args.develop})
        started = time.perf_counter()
        result = fp.run(job, until="build", write=False)
        build_seconds = time.perf_counter() - started
        with tempfile.TemporaryDirectory() as tmp:
            started = time.perf_counter()
            structure = analyse(result.model, job, folder=tmp)
            seconds = time.perf_counter() - started
        s = structure.summary
        if not structure.analysed:
            print(f"{name}: not analysed: {s['reason']}", file=sys.stderr)
            continue
        record = {
            "example": name,
            "develop": job.develop.method,
            "panels": len(result.model.developed.panel_ids),
            "elements": s["mesh"]["elements"],
            "nodes": s["mesh"]["nodes"],
            "elements_per_side": s["mesh"]["elements_per_side"],
            "knots": s["mesh"]["knots"],
            "equations": structure.metrics["equations"],
            "threads": s["solver"]["threads"],
            "ccx_static_s": s["seconds"]["static"],
            "ccx_buckling_s": s["seconds"]["buckling"],
            "stage_s": round(seconds, 2),
            "pipeline_to_build_s": round(build_seconds, 2),
            "ccx_peak_rss_mb": round(structure.metrics["peak_memory_mb"], 1),
            "python_peak_rss_mb": round(
                resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1
            ),
            "mass_error": s["mass"]["error"],
            "reaction_error_max": max(c["error"] for c in s["load_cases"].values()),
            "utilisation": s["stress"]["utilisation"],
            "utilisation_at": s["stress"]["part"],
            "deflection_mm": s["deflection"]["max_mm"],
            "deflection_ratio": s["deflection"]["ratio"],
            "buckling_combination": s["buckling"]["combination"],
            "buckling_factors": s["buckling"]["factors"],
            "checks": s["checks"],
        }
        runs.append(record)
        print(
            f"{name:>14}: {record['panels']} panels, {record['elements']} S8R "
            f"({record['equations']} equations), ccx {record['ccx_static_s']} + "
            f"{record['ccx_buckling_s']} s, stage {record['stage_s']} s, "
            f"{record['ccx_peak_rss_mb']} MB; utilisation {record['utilisation']}, "
            f"{record['deflection_ratio']}, buckling {record['buckling_factors'][:3]}",
            file=sys.stderr,
        )
    checks = {}
    if not args.no_validation:
        with tempfile.TemporaryDirectory() as tmp:
            for label, run in (
                ("scordelis_lo", validation.scordelis_lo),
                ("pinched_hemisphere", validation.pinched_hemisphere),
                ("plate_buckling", validation.plate_buckling),
                ("shallow_arch", validation.shallow_arch),
                ("lap_joint", validation.lap_joint),
            ):
                found = run(Path(tmp) / label)
                checks[label] = {
                    k: found[k] for k in ("value", "reference", "error", "elements", "seconds")
                }
                print(
                    f"{label:>20}: {found['value']:.5g} against {found['reference']:.5g} "
                    f"({found['error']:+.2%})",
                    file=sys.stderr,
                )
    print(json.dumps({"benchmark": "structure", "runs": runs, "validation": checks}))


if __name__ == "__main__":
    main()
