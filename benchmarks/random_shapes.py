"""Panel layouts of seeded random shapes: how often the layout gates pass on shapes nobody drew.

    .venv/bin/python benchmarks/random_shapes.py [--size "1 m"] [--method auto] [--seeds 1-24]

Each seed makes one shape (metres), in the spirit of what a designer might send:

- ``fourier``: a smooth blob 8-20 m across (radius with harmonics 2-5, aspect 0.45-1);
- ``polygon``: 4-7 random vertices (half of them made convex), corners of any angle, tips as
  sharp as the polygon makes them;
- ``rounded``: a rectangle 8-20 m by 0.4-1 of that, corners rounded at 0.3 m to a third of
  its depth;

with 0-3 openings (round, 0.8-3 m across, or rotated rectangles) kept 0.5 m inside the outline,
lifted by a bump up to 2.5 m plus a gentle saddle. The shapes are meshed like those of
``hard_shapes.py`` (0.2 m triangles). Prints one line per shape (method kept, time, panels,
the gate measures and the gates failed) and, last, the share that passes every layout gate
(a design tip under 45°, ``outline-sharp-corner``, is the design's and not counted).
"""

from __future__ import annotations

import argparse
import importlib.util
import tempfile
import time
from pathlib import Path

import numpy as np
from shapely import affinity
from shapely.geometry import Point, Polygon, box

import fabpanel as fp

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "hard_shapes", ROOT / "benchmarks" / "hard_shapes.py"
)
hard_shapes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hard_shapes)


def _outline(rng: np.random.Generator) -> tuple[str, Polygon]:
    kind = str(rng.choice(["fourier", "polygon", "rounded"]))
    size = rng.uniform(8, 20)
    if kind == "fourier":
        t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
        radius = np.ones_like(t)
        for k in range(2, 6):
            radius += rng.uniform(0, 0.5 / k) * np.cos(k * t + rng.uniform(0, 2 * np.pi))
        aspect = rng.uniform(0.45, 1.0)
        ring = np.column_stack(
            [size / 2 * radius * np.cos(t), size / 2 * aspect * radius * np.sin(t)]
        )
        return kind, Polygon(ring).buffer(0)
    if kind == "polygon":
        n = int(rng.integers(4, 8))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = rng.uniform(0.6, 1.0, n) * size / 2
        polygon = Polygon(np.column_stack([radii * np.cos(angles), radii * np.sin(angles)]))
        return kind, polygon.convex_hull if rng.random() < 0.5 else polygon.buffer(0)
    width, depth = size, size * rng.uniform(0.4, 1)
    round_off = rng.uniform(0.3, min(width, depth) / 3)
    core = box(
        -width / 2 + round_off, -depth / 2 + round_off, width / 2 - round_off, depth / 2 - round_off
    )
    return kind, core.buffer(round_off, quad_segs=16)


def _with_openings(domain: Polygon, rng: np.random.Generator) -> Polygon:
    for _ in range(int(rng.integers(0, 4))):
        for _attempt in range(20):
            low_x, low_y, high_x, high_y = domain.bounds
            centre = Point(rng.uniform(low_x, high_x), rng.uniform(low_y, high_y))
            radius = rng.uniform(0.4, 1.5)
            if rng.random() < 0.6:
                hole = centre.buffer(radius, 24)
            else:
                rectangle = box(
                    centre.x - radius,
                    centre.y - 0.6 * radius,
                    centre.x + radius,
                    centre.y + 0.6 * radius,
                )
                hole = affinity.rotate(rectangle, rng.uniform(0, 90))
            if domain.buffer(-0.5).contains(hole):
                domain = domain.difference(hole)
                break
    return domain


def random_shape(seed: int) -> tuple[str, np.ndarray, np.ndarray]:
    """(kind, vertices (n, 3) m, triangles) of the shape of one seed."""
    rng = np.random.default_rng(seed)
    kind, domain = _outline(rng)
    domain = _with_openings(domain, rng)
    saddle = rng.uniform(-0.06, 0.06, 3)
    bump = rng.uniform(0, 2.5)
    spread = (domain.bounds[2] - domain.bounds[0]) ** 2 / 4

    def height(x, y):
        return (
            bump * np.exp(-(x**2 + y**2) / spread)
            + saddle[0] * x * y / 2
            + saddle[1] * x**2 / 3
            + saddle[2] * y**2 / 3
        )

    vertices, faces = hard_shapes._mesh(domain, height)
    return kind, vertices, faces


def _seeds(text: str) -> list[int]:
    if "-" in text:
        first, last = text.split("-")
        return list(range(int(first), int(last) + 1))
    return [int(s) for s in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1 m")
    parser.add_argument("--method", default="auto")
    parser.add_argument("--seeds", default="1-24")
    args = parser.parse_args()
    template = fp.Job.from_toml(ROOT / "examples" / "one-opening.toml")
    passed = 0
    seeds = _seeds(args.seeds)
    with tempfile.TemporaryDirectory() as folder:
        for seed in seeds:
            kind, vertices, faces = random_shape(seed)
            path = hard_shapes.write_obj(Path(folder) / f"random{seed}.obj", vertices, faces)
            job = template.replace(input={"path": str(path), "units": "m"}).replace(
                panelize={"panel_size": args.size, "method": args.method}
            )
            surface = fp.load_surface(job.input_path, job.input.units)
            started = time.perf_counter()
            try:
                layout = fp.panelize(surface, job)
            except fp.FabpanelError as err:
                print(f"{seed:3d} {kind:8s} refused: {err}")
                continue
            seconds = time.perf_counter() - started
            gates = layout.metrics["gates"]
            failed = sorted({i.code for i in layout.issues if i.code.startswith("layout-")})
            passed += not failed
            tips = " (design tips under 45°)" if gates["outline_tip_corners"] else ""
            way = layout.metrics.get("field", {}).get("small_openings", "plain")
            tips += "" if way == "plain" else f" (small openings {way})"
            print(
                f"{seed:3d} {kind:8s} {layout.method:6s} {seconds:5.1f} s {gates['panels']:4d} "
                f"panels, count {gates['count_ratio']:.2f}, band {gates['edges_in_band']:.0%}, "
                f"shortest {gates['shortest_edge_vs_panel_size']:.2f}, corners "
                f"{gates['corner_angle_deg'][0]:.0f}-{gates['corner_angle_deg'][1]:.0f}° "
                f"({gates['corners_in_60_120']:.0%} in 60-120°): "
                f"{', '.join(failed) or 'pass'}{tips}",
                flush=True,
            )
    print(f"{passed} of {len(seeds)} pass every layout gate at {args.size}")


if __name__ == "__main__":
    main()
