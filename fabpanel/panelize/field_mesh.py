"""gmsh's quasi-structured quads of the flat domain, run in a child process
(:mod:`.gmsh_quads`, which can abort the whole process on some inputs), and what it returns."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..data import Surface
from ..errors import GeometryError
from ..job import Job
from .corners import OutlineCorners

#: a gmsh run longer than this is stopped (it never takes more than seconds on 5000 panels)
GMSH_TIMEOUT = 300.0


@dataclass(frozen=True)
class Meshed:
    """One of gmsh's meshes of the flat domain as it came (before punching and placing), the
    panel size it was made for and the report of its making."""

    nodes: np.ndarray
    quads: np.ndarray
    on_curve: np.ndarray
    size: float
    info: dict


def gmsh_quads(
    surface: Surface,
    flat: np.ndarray,
    scale: np.ndarray,
    outline: OutlineCorners,
    points: np.ndarray,
    job: Job,
    size: float,
    topology: int,
    folds: tuple[np.ndarray, ...] = (),
) -> list[Meshed]:
    """Run :mod:`.gmsh_quads` on the flat domain in a child process with QQS's ``topology``
    steps, split along the flat ``folds`` (polylines); the mesh it chose, then the finer ones
    it returned beside it."""
    from ..parallel import child_preexec

    cross: dict = {}
    if job.panelize.align == "curvature":
        from .cross_field import curvature_cross_field

        cross["cross"], _ = curvature_cross_field(
            surface.vertices, surface.faces, flat, surface.boundary_loops
        )
    loops = list(outline.loops)
    starts = np.cumsum([0, *[len(loop) for loop in loops[:-1]]])
    with tempfile.TemporaryDirectory(prefix="fabpanel-gmsh-") as folder:
        source, target = Path(folder) / "in.npz", Path(folder) / "out.npz"
        np.savez(
            source,
            flat=flat,
            faces=surface.faces,
            scale=scale,
            loops=np.concatenate(loops),
            loop_starts=starts,
            corners=np.concatenate(outline.corners),
            points=points,
            h=float(size),
            area=surface.area,
            topology=topology,
            folds=np.concatenate(folds) if folds else np.zeros((0, 2)),
            fold_starts=np.cumsum([0, *[len(f) for f in folds[:-1]]]),
            **cross,
        )
        script = Path(__file__).with_name("gmsh_quads.py")
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        try:
            run = subprocess.run(
                [sys.executable, str(script), str(source), str(target)],
                capture_output=True,
                text=True,
                timeout=GMSH_TIMEOUT,
                preexec_fn=child_preexec,
                env=env,
                check=False,
            )
        except subprocess.TimeoutExpired:
            raise GeometryError(
                f"{surface.source.name}: gmsh's quad mesher took longer than "
                f'{GMSH_TIMEOUT:.0f} s; use [panelize] method = "skeleton"'
            ) from None
        if run.returncode != 0 or not target.is_file():
            reason = (run.stderr.strip().splitlines() or [f"exit {run.returncode}"])[-1]
            raise GeometryError(
                f"{surface.source.name}: gmsh's quad mesher failed ({reason}); use "
                f'[panelize] method = "skeleton"'
            )
        out = np.load(target)
        info = {
            "size_factor": round(float(out["factor"]), 4),
            "flat_score": round(float(out["score"]), 4),
            "gmsh_meshes": int(out["meshes"]),
            "gmsh_topology": topology,
            "gmsh_seconds": round(float(out["seconds"]), 2),
        }
        chosen = Meshed(out["nodes"], out["quads"].astype(np.int64), out["on_curve"], size, info)
        return [chosen, *_finer_meshes(out, size, info)]


def _finer_meshes(out, size: float, info: dict) -> list[Meshed]:
    """The finer meshes :mod:`.gmsh_quads` returned beside the chosen one, fewest quads first."""
    if not len(out["finer_factors"]):
        return []
    node_ends = np.cumsum(out["finer_node_counts"])
    quad_ends = np.cumsum(out["finer_quad_counts"])
    nodes = np.split(out["finer_nodes"], node_ends[:-1])
    quads = np.split(out["finer_quads"].astype(np.int64), quad_ends[:-1])
    on_curve = np.split(out["finer_on_curve"], node_ends[:-1])
    return [
        Meshed(
            n,
            q,
            c,
            size,
            {**info, "size_factor": round(float(f), 4), "flat_score": round(float(sc), 4)},
        )
        for n, q, c, f, sc in zip(
            nodes, quads, on_curve, out["finer_factors"], out["finer_scores"], strict=True
        )
    ]
