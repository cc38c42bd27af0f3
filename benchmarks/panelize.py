"""Panel layouts of the examples and the hard test shapes, skeleton and field side by side.

    .venv/bin/python benchmarks/panelize.py [--sizes "1 m"] [--methods skeleton,field] [NAME ...]

Runs only the panelize stage for each example job in examples/ and fabpanel/examples/ and for
each shape of benchmarks/hard_shapes.py (written to a temporary folder, metres), at each size
and with each method. Prints a Markdown table (the one in the README's "Panel layouts"
section) and, last, one JSON object with every figure. The gates are those of
:mod:`fabpanel.panelize.gates`: panels <= 1.3 x area / size², >= 90 % of edges in
0.5-1.25 x size, shortest edge >= 0.3 x size, corners within 45-135° and >= 95 % in 60-120°.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import fabpanel as fp
from fabpanel.panelize.gates import MIN_WIDTH, meets_every_gate

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DEMO = ROOT / "fabpanel" / "examples"  # barrel-vault, shipped
# example jobs by name: the shipped demo and the shapes in examples/
JOBS = {p.stem: p for p in sorted([*DEMO.glob("*.toml"), *EXAMPLES.glob("*.toml")])}


def hard_shapes(folder: Path) -> dict[str, Path]:
    """The shapes of benchmarks/hard_shapes.py written as OBJ (metres) into ``folder``."""
    path = Path(__file__).with_name("hard_shapes.py")
    if not path.is_file():
        return {}
    spec = importlib.util.spec_from_file_location("hard_shapes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    written = {}
    for name, make in module.SHAPES.items():
        vertices, faces = make()
        target = folder / f"{name}.obj"
        module.write_obj(target, vertices, faces)
        written[name] = target
    return written


def jobs_to_run(names: list[str], folder: Path) -> dict[str, fp.Job]:
    jobs = {name: fp.Job.from_toml(path) for name, path in JOBS.items()}
    template = fp.Job.from_toml(JOBS["one-opening"])
    for name, path in hard_shapes(folder).items():
        jobs[name] = template.replace(input={"path": str(path), "units": "m"})
    return {n: j for n, j in jobs.items() if not names or n in names}


def measure(name: str, job: fp.Job, surface, method: str, size: str) -> dict:
    job = job.replace(panelize={"panel_size": size, "method": method})
    tracemalloc.start()
    started = time.perf_counter()
    try:
        layout = fp.panelize(surface, job)
    except fp.FabpanelError as err:
        tracemalloc.stop()
        return {"shape": name, "method": method, "panel_size": size, "error": str(err)}
    seconds = time.perf_counter() - started
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    gates = layout.metrics["gates"]
    return {
        "shape": name,
        "method": layout.method,
        "asked": method,
        "panel_size": size,
        "seconds": round(seconds, 2),
        "peak_python_mb": round(peak, 1),
        **gates,
        "singular_valences": layout.metrics.get("singular_valences"),
        "errors": sum(i.severity == "error" for i in layout.issues),
        "auto": layout.metrics.get("auto", {}).get("reason"),
    }


def passes(record: dict) -> bool:
    """Every layout gate, with the default narrowest panel (0.3 x panel_size)."""
    size = record["shortest_edge_mm"] / record["shortest_edge_vs_panel_size"]
    return meets_every_gate(record, MIN_WIDTH * size)


def _tips(record: dict) -> str:
    """A note where the design outline has tips under 45° (no layout can meet the corner
    target there: ``outline-sharp-corner``)."""
    tips = record.get("outline_tip_angles_deg") or []
    return f" (design tips {', '.join(f'{a:.0f}°' for a in tips)})" if tips else ""


def table(runs: list[dict]) -> str:
    lines = [
        (
            "| shape | method | panels | area / size² | shortest edge | corners | in 60-120° "
            "| edges in 0.5-1.25 | time | gates |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        if "error" in r:
            lines.append(f"| {r['shape']} | {r['method']} | failed: {r['error'][:60]} |||||||")
            continue
        low, high = r["corner_angle_deg"]
        lines.append(
            f"| {r['shape']} | {r['method']} | {r['panels']} | {r['panels_for_area']:.0f} | "
            f"{r['shortest_edge_mm']:.0f} mm | {low:.0f}°-{high:.0f}° | "
            f"{r['corners_in_60_120']:.0%} | {r['edges_in_band']:.0%} | {r['seconds']:.1f} s | "
            f"{'pass' if passes(r) else 'fail'}{_tips(r)} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("names", nargs="*")
    parser.add_argument("--sizes", default="1 m")
    parser.add_argument("--methods", default="skeleton,field,auto")
    args = parser.parse_args()
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        for name, job in jobs_to_run(args.names, Path(folder)).items():
            surface = fp.load_surface(job.input_path, job.input.units)
            for size in args.sizes.split(","):
                for method in args.methods.split(","):
                    record = measure(name, job, surface, method.strip(), size.strip())
                    runs.append(record)
                    print(table([record]).splitlines()[-1], file=sys.stderr, flush=True)
    print(table(runs))
    print(json.dumps({"benchmark": "panelize", "runs": runs}))


if __name__ == "__main__":
    main()
