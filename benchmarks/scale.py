"""How the cost grows with the panel count: a generated shell end to end at several sizes.

    .venv/bin/python benchmarks/scale.py [--panels 250,500,1000,2000] [--structure-up-to 500]
                                         [--jobs N] [--keep FOLDER]

The shell is a shallow doubly curved roof (an elliptic paraboloid with a twist, rise 1/10 of
the span) on a rectangle sized so that a grid of 1.1 m panels covers it with the asked count
(aspect about 5:4); every panel differs from its neighbours, so no two sheets share a part
mark across the roof's quarters only by symmetry. Each size runs ``fabpanel export`` in its own
process through ``cut`` (all outputs written), and through ``structure`` up to
``--structure-up-to`` panels. Printed per size: the stages' times (the summary's
``timings_s``; the write stage and start-up are the rest of the run), the peak memory of the largest process (the run or one of its
workers, ``getrusage`` of the children), the output folder's size and its largest files; last,
one JSON object with every figure.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: panel edge of the generated grid, m (a 1.1 m sheet unrolls onto a 3000 x 1500 plate)
PANEL = 1.1
#: triangles per panel side in the generated mesh
MESH_PER_PANEL = 3


def grid_for(panels: int) -> tuple[int, int]:
    """Panel counts (u, v) of about ``panels`` panels at an aspect of about 5:4."""
    v = max(2, round(math.sqrt(panels * 4 / 5)))
    return max(2, round(panels / v)), v


def shell_mesh(u: int, v: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (m) and triangles of the roof over a (u x v) x PANEL rectangle."""
    a, b = u * PANEL / 2, v * PANEL / 2
    nx, ny = u * MESH_PER_PANEL, v * MESH_PER_PANEL
    x, y = np.meshgrid(np.linspace(-a, a, nx + 1), np.linspace(-b, b, ny + 1), indexing="ij")
    rise = 0.1 * max(a, b)
    z = rise * (1 - 0.6 * (x / a) ** 2 - 0.4 * (y / b) ** 2) + 0.15 * rise * (x / a) * (y / b)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    return vertices, _shapes().grid_triangles(nx, ny)


def _shapes():
    """examples/shapes.py (the examples' generators), loaded from its file."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("example_shapes", ROOT / "examples" / "shapes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_case(folder: Path, panels: int) -> tuple[Path, int]:
    """The mesh and a job for ``panels`` panels in ``folder``; the job path and the count."""
    u, v = grid_for(panels)
    vertices, triangles = shell_mesh(u, v)
    mesh = folder / f"shell-{u * v}.obj"
    with mesh.open("w") as handle:
        handle.write(f"# benchmarks/scale.py: {u} x {v} panels of {PANEL} m, metres\n")
        np.savetxt(handle, vertices, fmt="v %.6f %.6f %.6f")
        np.savetxt(handle, triangles + 1, fmt="f %d %d %d")
    job = folder / f"shell-{u * v}.toml"
    job.write_text(
        f'[input]\npath = "{mesh.name}"\nunits = "m"\n\n'
        f'[panelize]\nmethod = "grid"\npanel_size = "{PANEL} m"\ngrid_u = {u}\ngrid_v = {v}\n\n'
        '[cutting]\nnest_time = "0 s"\n'
    )
    return job, u * v


def folder_size(folder: Path) -> tuple[int, dict[str, int]]:
    """Bytes in the folder, and the five largest files' sizes by relative path."""
    sizes = {str(p.relative_to(folder)): p.stat().st_size for p in folder.rglob("*") if p.is_file()}
    largest = dict(sorted(sizes.items(), key=lambda kv: -kv[1])[:5])
    return sum(sizes.values()), largest


def run_case(job: Path, out: Path, until: str, jobs: int | None) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    command = [sys.executable, "-m", "fabpanel", "export", str(job), "--out", str(out)]
    command += ["--until", until, "--force", "--allow-issues", "--quiet"]
    if jobs:
        command += ["--jobs", str(jobs)]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if done.returncode not in (0, 3):
        return {"error": (done.stderr.strip().splitlines() or ["?"])[-1], "seconds": seconds}
    summary = json.loads((out / "report" / "summary.json").read_text())
    total, largest = folder_size(out)
    timings = summary.get("timings_s", {})
    return {
        "seconds": round(seconds, 1),
        "timings_s": timings,
        # the summary is written during the write stage: the rest of the run is that stage
        # and the start-up (reading the surface, about a second)
        "write_s": round(seconds - sum(timings.values()), 1),
        # the largest process's peak, the run's or a worker's (a later size only raises it)
        "peak_rss_mb": round(max(peak, before) / 1024.0),
        "output_mb": round(total / 1e6, 1),
        "largest_files_mb": {k: round(v / 1e6, 1) for k, v in largest.items()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--panels", default="250,500,1000,2000")
    parser.add_argument("--structure-up-to", type=int, default=500)
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument("--keep", type=Path, default=None, help="keep the outputs here")
    args = parser.parse_args()
    counts = [int(n) for n in args.panels.split(",")]
    runs = []
    with tempfile.TemporaryDirectory(prefix="fabpanel-scale-") as scratch:
        base = args.keep or Path(scratch)
        base.mkdir(parents=True, exist_ok=True)
        for asked in counts:
            job, panels = write_case(base, asked)
            until = "structure" if asked <= args.structure_up_to else "cut"
            result = run_case(job, base / f"out-{panels}", until, args.jobs)
            runs.append({"panels": panels, "until": until, **result})
            print(json.dumps(runs[-1]), file=sys.stderr, flush=True)
    stages = ("panelize", "develop", "build", "cut", "structure", "write")
    print("| panels | until | " + " | ".join(stages) + " | total | peak memory | output |")
    print("|---" * (len(stages) + 5) + "|")
    for run in runs:
        if "error" in run:
            print(f"| {run['panels']} | {run['until']} | failed: {run['error']} |")
            continue
        seconds = {**run["timings_s"], "write": run["write_s"]}
        times = [f"{seconds[s]:.0f} s" if s in seconds else "-" for s in stages]
        print(
            f"| {run['panels']} | {run['until']} | "
            + " | ".join(times)
            + f" | {run['seconds']:.0f} s"
            f" | {run['peak_rss_mb'] / 1024:.1f} GB | {run['output_mb']:.0f} MB |"
        )
    print(json.dumps({"benchmark": "scale", "runs": runs}))


if __name__ == "__main__":
    main()
