"""The reliability probes of issue 14, run as a new user would, from a shell, on generated shapes.

    .venv/bin/python benchmarks/reliability.py [--only NAME]

Prints one row per probe: exit code, seconds, stderr lines, the first (or last) stderr line, and
whether the folder is as it was (files of the user kept, no debris). The README's reliability
table is this script's output.
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def vault(
    path: Path,
    scale: float = 1.0,
    shift: float = 0.0,
    n: int = 24,
    length: float = 6.0,
    width: float = 4.0,
    rise: float = 0.8,
) -> Path:
    """A shallow barrel vault as an OBJ quad mesh, metres x ``scale``, moved by ``shift``."""
    x, y = np.meshgrid(
        np.linspace(0, length, n + 1), np.linspace(-width / 2, width / 2, n + 1), indexing="ij"
    )
    radius = (rise**2 + (width / 2) ** 2) / (2 * rise)
    z = np.sqrt(radius**2 - y**2) - (radius - rise)
    points = (np.stack([x, y, z], axis=-1).reshape(-1, 3) + shift) * scale
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v = (i * (n + 1) + j).ravel()
    quads = np.stack([v, v + n + 1, v + n + 2, v + 1], axis=1)
    path.write_text(
        "\n".join(f"v {a:.15g} {b:.15g} {c:.15g}" for a, b, c in points)
        + "\n"
        + "\n".join("f " + " ".join(str(q + 1) for q in quad) for quad in quads)
        + "\n"
    )
    return path


def _grid_obj(path: Path, points: np.ndarray) -> Path:
    a, b = points.shape[:2]
    i, j = np.meshgrid(np.arange(a - 1), np.arange(b - 1), indexing="ij")
    v = (i * b + j).ravel()
    quads = np.stack([v, v + b, v + b + 1, v + 1], axis=1)
    path.write_text(
        "\n".join(f"v {x:.15g} {y:.15g} {z:.15g}" for x, y, z in points.reshape(-1, 3))
        + "\n"
        + "\n".join("f " + " ".join(str(q + 1) for q in quad) for quad in quads)
    )
    return path


def looped(path: Path) -> Path:
    """One connected sheet crossing itself: an alpha-shaped section (x = t² - 1, y = t³ - t,
    metres, crossing itself at the origin) swept 2 m along z."""
    # an even count: no two grid points fall on the crossing (they would weld into one vertex)
    t, z = np.meshgrid(np.linspace(-1.5, 1.5, 30), np.linspace(0, 2, 5), indexing="ij")
    return _grid_obj(path, np.stack([t**2 - 1, t**3 - t, z], axis=-1))


def unwelded(path: Path) -> Path:
    """The vault as two halves whose seam vertices are written twice, 1 µm apart (a seam
    left unwelded by the exporter; exact duplicates are welded on reading)."""
    full = vault(path.with_suffix(".full.obj"))
    lines = full.read_text().splitlines()
    vertices = [line for line in lines if line.startswith("v ")]
    faces = [list(map(int, line.split()[1:])) for line in lines if line.startswith("f ")]
    n = 25
    extra = []
    remap = {}
    for face in faces[len(faces) // 2 :]:
        for q in face:
            row = (q - 1) // n
            if row == 12 and q not in remap:
                x, y, z = (float(c) for c in vertices[q - 1].split()[1:])
                extra.append(f"v {x:.15g} {y + 1e-6:.15g} {z:.15g}")
                remap[q] = len(vertices) + len(extra)
    out = faces[: len(faces) // 2] + [
        [remap.get(q, q) for q in face] for face in faces[len(faces) // 2 :]
    ]
    path.write_text(
        "\n".join(vertices + extra)
        + "\n"
        + "\n".join("f " + " ".join(map(str, f)) for f in out)
        + "\n"
    )
    full.unlink()
    return path


def two_pieces(path: Path) -> Path:
    a = vault(path.with_suffix(".a.obj"), n=8).read_text().splitlines()
    b = vault(path.with_suffix(".b.obj"), n=8, shift=10.0).read_text().splitlines()
    nv = sum(1 for line in a if line.startswith("v "))
    b = [
        line
        if not line.startswith("f ")
        else "f " + " ".join(str(int(q) + nv) for q in line.split()[1:])
        for line in b
    ]
    path.write_text(
        "\n".join(
            [x for x in a if x.startswith("v ")]
            + [x for x in b if x.startswith("v ")]
            + [x for x in a if x.startswith("f ")]
            + [x for x in b if x.startswith("f ")]
        )
        + "\n"
    )
    return path


def creased_step(path: Path) -> Path:
    """Two 3 x 2 m planar faces meeting at a 90 degree crease, one STEP shell (mm)."""
    from build123d import Face, Shell, Vector, Wire, export_step

    a = Face(
        Wire.make_polygon(
            [Vector(0, 0, 0), Vector(3000, 0, 0), Vector(3000, 2000, 0), Vector(0, 2000, 0)],
            close=True,
        )
    )
    b = Face(
        Wire.make_polygon(
            [
                Vector(0, 2000, 0),
                Vector(3000, 2000, 0),
                Vector(3000, 2000, 2000),
                Vector(0, 2000, 2000),
            ],
            close=True,
        )
    )
    export_step(Shell([a, b]), str(path))
    return path


def tiny_step(path: Path) -> Path:
    """A 10 x 6 mm curved face: a 10 x 6 m design written 1000x too small."""
    from build123d import Face, Vector, export_step

    points = [
        [
            Vector(10 * i / 3, 6 * j / 3, 0.8 * np.sin(np.pi * i / 3) * np.sin(np.pi * j / 3))
            for j in range(4)
        ]
        for i in range(4)
    ]
    export_step(Face.make_surface_from_array_of_points(points), str(path))
    return path


def job(path: Path, body: str, mesh: str = "vault.obj") -> Path:
    path.write_text(f'[input]\npath = "{mesh}"\nunits = "m"\n' + body)
    return path


Probe = tuple[str, Callable[[Path], list[str]]]


def _probes() -> list[Probe]:
    def export(*extra: str, mesh: str = "vault.obj", units: str = "m"):
        return ["export", mesh, "--units", units, "--out", "out", *extra]

    def setup_vault(d: Path, *args: str) -> list[str]:
        vault(d / "vault.obj")
        (d / "job.toml").write_text('[input]\npath = "vault.obj"\nunits = "m"\n')
        (d / "notes.txt").write_text("the user's notes")
        return list(args)

    def job_probe(body: str) -> Callable[[Path], list[str]]:
        def setup(d: Path) -> list[str]:
            vault(d / "vault.obj")
            job(d / "job.toml", body)
            return ["export", "job.toml", "--out", "out"]

        return setup

    return [
        (
            "--out . --force",
            lambda d: setup_vault(d, "export", "job.toml", "--out", ".", "--force"),
        ),
        (
            "--out vault.obj --force",
            lambda d: setup_vault(
                d, "export", "vault.obj", "--units", "m", "--out", "vault.obj", "--force"
            ),
        ),
        (
            "--out a folder of the user's",
            lambda d: (
                d.joinpath("mine").mkdir(),
                d.joinpath("mine", "plan.dwg").write_text("the user's drawing"),
                setup_vault(d, "export", "job.toml", "--out", "mine", "--force"),
            )[2],
        ),
        (
            "mesh in mm declared --units m",
            lambda d: (vault(d / "vault.obj", scale=1000.0), export())[1],
        ),
        (
            "mesh in m declared --units mm",
            lambda d: (vault(d / "vault.obj"), export(units="mm"))[1],
        ),
        (
            "STEP 1000x too small",
            lambda d: (tiny_step(d / "tiny.step"), ["export", "tiny.step", "--out", "out"])[1],
        ),
        (
            '--panel-size "0.05 m" (9600 panels)',
            lambda d: (vault(d / "vault.obj"), export("--panel-size", "0.05 m"))[1],
        ),
        (
            "--panel-size 1 (bare number)",
            lambda d: (vault(d / "vault.obj"), export("--panel-size", "1", "--until", "panelize"))[
                1
            ],
        ),
        (
            '--panel-size "0.2 m" on a 12 x 8 m vault',
            lambda d: (
                vault(d / "vault.obj", length=12.0, width=8.0, rise=2.0),
                export("--panel-size", "0.2 m", "--until", "panelize"),
            )[1],
        ),
        (
            "grid panels larger than the plate (2 m)",
            lambda d: (
                vault(d / "vault.obj"),
                export("--panel-size", "2 m", "--until", "panelize"),
            )[1],
        ),
        ('rib_height = "5 m"', job_probe('[sandwich]\nrib_height = "5 m"\n')),
        ('sheet_thickness = "500 mm"', job_probe('[sandwich]\nsheet_thickness = "500 mm"\n')),
        ('bolt diameter "500 mm"', job_probe('[sandwich.bolts]\ndiameter = "500 mm"\n')),
        ("wind_direction = [0, 0]", job_probe("[loads]\nwind_direction = [0, 0]\n")),
        ("wind_direction = [nan, 0]", job_probe("[loads]\nwind_direction = [nan, 0]\n")),
        ("NaN singular point", job_probe("[panelize]\nsingular_points = [[nan, 0, 0]]\n")),
        ('panel_size = "1e308 m"', job_probe('[panelize]\npanel_size = "1e308 m"\n')),
        ("self-intersecting mesh", lambda d: (looped(d / "loop.obj"), export(mesh="loop.obj"))[1]),
        (
            "STEP with a 90° crease",
            lambda d: (creased_step(d / "crease.step"), ["export", "crease.step", "--out", "out"])[
                1
            ],
        ),
        ("unwelded seam", lambda d: (unwelded(d / "seam.obj"), export(mesh="seam.obj"))[1]),
        ("two separate pieces", lambda d: (two_pieces(d / "two.obj"), export(mesh="two.obj"))[1]),
    ]


def run_probe(name: str, setup: Callable[[Path], list[str]]) -> dict:
    with TemporaryDirectory() as tmp:
        folder = Path(tmp)
        args = setup(folder)
        before = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
        started = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "fabpanel", *args],
            cwd=folder,
            capture_output=True,
            text=True,
            check=False,
            timeout=1800,
        )
        seconds = time.perf_counter() - started
        after = {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}
        kept = all(after.get(k) == v for k, v in before.items())
        debris = [p.name for p in folder.iterdir() if ".partial-" in p.name]
        lines = [line for line in proc.stderr.splitlines() if line.strip()]
    message = next(
        (line for line in lines if line.startswith(("error:", "internal"))),
        next((line for line in lines if line.startswith("note:")), lines[-1] if lines else ""),
    )
    return {
        "probe": name,
        "exit": proc.returncode,
        "seconds": round(seconds, 1),
        "stderr_lines": len(lines),
        "files_kept": kept and not debris,
        "message": message[:300],
    }


def signal_probe(sig: signal.Signals) -> dict:
    """SIGTERM/SIGINT/SIGKILL in the build: time to exit, workers left, debris left."""
    with TemporaryDirectory() as tmp:
        folder = Path(tmp)
        vault(folder / "vault.obj")
        job(
            folder / "job.toml", '[panelize]\npanel_size = "0.5 m"\n[develop]\nmethod = "project"\n'
        )
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "fabpanel",
                "export",
                "job.toml",
                "--out",
                "out",
                "--until",
                "build",
                "--jobs",
                "2",
            ],
            cwd=folder,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        while not workers_up(proc.pid):
            time.sleep(0.1)
        time.sleep(2.0)
        workers = descendants(proc.pid)
        sent = time.perf_counter()
        proc.send_signal(sig)
        _, stderr = proc.communicate()
        seconds = time.perf_counter() - sent
        time.sleep(2.0)
        alive = [w for w in workers if alive(w)]
        debris = [p.name for p in folder.iterdir() if ".partial-" in p.name]
        swept = None
        if debris:
            rerun = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "fabpanel",
                    "export",
                    "job.toml",
                    "--out",
                    "out",
                    "--until",
                    "panelize",
                ],
                cwd=folder,
                capture_output=True,
                text=True,
                check=False,
            )
            swept = rerun.returncode == 0 and not [
                p for p in folder.iterdir() if ".partial-" in p.name
            ]
    lines = [line for line in stderr.splitlines() if line.strip()]
    return {
        "probe": f"{sig.name} during the build",
        "exit": proc.returncode,
        "seconds": round(seconds, 2),
        "workers_left": len(alive),
        "debris": debris,
        "swept_by_next_run": swept,
        "message": lines[-1] if lines else "",
    }


def moved_probe() -> dict:
    """The same vault at the origin and moved by +1e6 m: deviation and rib angles compared."""
    import fabpanel as fp

    figures = {}
    with TemporaryDirectory() as tmp:
        for name, shift in (("origin", 0.0), ("moved", 1e6)):
            path = vault(Path(tmp) / f"{name}.obj", shift=shift)
            job_ = fp.Job.for_input(path, units="m", panelize={"panel_size": "1 m"})
            result = fp.run(job_, write=False, until="develop", jobs=1)
            metrics = result.developed.metrics
            figures[name] = {
                "panels": len(result.layout.quads),
                "deviation_mm_max": metrics["deviation_mm"]["max"],
                "rib_normal_angle_deg_max": metrics["rib_normal_angle_deg_max"],
                "unroll_strain_max": metrics["unroll_strain"]["max"],
            }
    return {"probe": "vault moved by +1e6 m (develop)", **figures}


def children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        children = task / "children"
        found += [int(c) for c in children.read_text().split()] if children.exists() else []
    return found


def descendants(pid: int) -> list[int]:
    """Every process below ``pid``: fresh workers are children of a fork server, itself a
    child of the run."""
    found, queue = [], children(pid)
    while queue:
        found.append(queue.pop())
        queue += children(found[-1])
    return found


def workers_up(pid: int) -> bool:
    """Whether the run's worker processes (grandchildren, under the fork server) are up."""
    return sum(len(children(c)) for c in children(pid)) >= 2


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", default=None, help="run the probes whose name contains this")
    args = parser.parse_args()
    rows = []
    for name, setup in _probes():
        if args.only and args.only not in name:
            continue
        rows.append(run_probe(name, setup))
        print(json.dumps(rows[-1]), flush=True)
    if not args.only or "signal" in args.only:
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            rows.append(signal_probe(sig))
            print(json.dumps(rows[-1]), flush=True)
    if not args.only or "moved" in args.only:
        rows.append(moved_probe())
        print(json.dumps(rows[-1]), flush=True)


if __name__ == "__main__":
    main()
