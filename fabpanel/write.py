"""The write stage: every output file of a run, from the stages' results.

The files are independent of each other, so their writers start together
(:func:`fabpanel.parallel.side_by_side`), each in a thread of this process over the one shared
worker pool: the exchange solids first (the 3DM, the IFC and the GLB's plates are made from
them), then the STEP, the GLB, the 3DM, the cut files and the report, which waits for the
cut files (it shows the plate images). Meanwhile this thread writes the documents (the IFC in
this process while the workers are busy, then the drawings in the workers). Only the
manifest, the bill of materials and the marks, which name the files, wait for all of them.
With one worker everything runs in this order, one after another.
"""

from __future__ import annotations

import csv
import json
import os
import platform
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import Future
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from . import __version__
from .data import FlatPart, FlatParts, Model, Nests
from .parallel import side_by_side

if TYPE_CHECKING:
    from .flat.dxf import ContourArcs
    from .job import Job
    from .pipeline import Progress, Result

T = TypeVar("T")

#: the write stage's writers, in the order the progress line gives their times
WRITERS = ("solids", "step", "glb", "rhino", "cut", "report", "docs")


def _written(write, *args) -> tuple[dict, dict[str, bytes]]:
    """``write(*args, folder)`` run into a scratch folder of the worker's own; its result and
    the files it wrote, by name, so that no file is written on a remote node (Ray)."""
    with tempfile.TemporaryDirectory(prefix="fabpanel-files-") as scratch:
        result = write(*args, Path(scratch))
        files = {path.name: path.read_bytes() for path in Path(scratch).iterdir()}
    return result, files


def _write_part_chunk(
    flat: FlatParts,
) -> tuple[tuple[dict, dict[str, bytes]], dict[str, ContourArcs]]:
    """The part DXFs of ``flat`` (:func:`_written`), and the arcs fitted to their contours by
    part mark."""
    from .flat.dxf import contour_arcs, write_parts

    written = _written(write_parts, flat)
    return written, {p.mark or p.id: contour_arcs([p]) for p in flat.parts}


def _write_plate_chunk(
    nests: Nests, flat: FlatParts, arcs: ContourArcs
) -> tuple[dict, dict[str, bytes]]:
    """The plate DXFs and previews of ``nests`` (:func:`_written`), the parts' contours
    taking their arcs from ``arcs`` where the part DXFs fitted them."""
    from .flat.dxf import given_arcs
    from .flat.nest_output import write_nests

    with given_arcs(arcs):
        return _written(write_nests, nests, flat)


def _inline(work: Callable[..., T], *args) -> Future[T]:
    """``work(*args)`` run here, as a finished future (the one-worker path of a pool)."""
    future: Future[T] = Future()
    future.set_result(work(*args))
    return future


def _saved(written: tuple[dict, dict[str, bytes]], folder: Path) -> dict:
    """The files of one chunk (:func:`_written`) saved into ``folder``; the chunk's result."""
    result, files = written
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return result


def _write_cut_files(
    flat: FlatParts, nests: Nests, folder: Path, workers: int
) -> tuple[dict, dict]:
    """Part DXFs and plate DXF/PNGs, in worker processes (each file is independent)."""
    from .parallel import worker_pool

    (folder / "parts").mkdir(parents=True)
    (folder / "nests").mkdir(parents=True)

    def chunks(items):
        size = max(1, -(-len(items) // (4 * workers)))
        return [items[i : i + size] for i in range(0, len(items), size)]

    # one file per mark: only each mark's first part goes to the writers
    drawn: dict[str, FlatPart] = {}
    for part in flat.parts:
        drawn.setdefault(part.mark or part.id, part)
    part_chunks = [FlatParts(parts=tuple(c)) for c in chunks(list(drawn.values()))]
    plate_chunks = [Nests(plates=tuple(c)) for c in chunks(list(nests.plates))]
    marks = {p.id: p.mark or p.id for p in flat.parts}

    def arcs_of(plates: Nests, fitted: dict[str, ContourArcs]) -> ContourArcs:
        """The fits a chunk of plates needs: those of its parts' marks."""
        needed = sorted({marks[p.part_id] for plate in plates.plates for p in plate.placements})
        return {k: v for m in needed for k, v in fitted.get(m, {}).items()}

    # the plates wait for the parts: the parts' fits go with them, each contour fitted once
    with ExitStack() as stack:
        submit: Callable[..., Future] = _inline
        if workers > 1:  # this process has run spyrrow's nests: fresh workers
            submit = stack.enter_context(worker_pool(workers, fresh=True)).submit
        done = [f.result() for f in [submit(_write_part_chunk, c) for c in part_chunks]]
        fitted = {k: v for _, arcs in done for k, v in arcs.items()}
        plate_futures = [
            submit(_write_plate_chunk, c, flat, arcs_of(c, fitted)) for c in plate_chunks
        ]
        part_maps = [_saved(written, folder / "parts") for written, _ in done]
        plate_maps = [_saved(f.result(), folder / "nests") for f in plate_futures]
    drawn_files = {k: v for m in part_maps for k, v in m.items()}
    part_files = {p.id: drawn_files[drawn[p.mark or p.id].id] for p in flat.parts}
    plate_files = {k: v for m in plate_maps for k, v in m.items()}
    return part_files, plate_files


def _solids_of(model: Model, workers: int) -> dict[str, object]:
    from .docs.ifc import solid_geometries

    return solid_geometries([(p.id, p.brep, p.thickness, p.kind) for p in model.parts], workers)


def _write_steps(model: Model, job: Job, folder: Path, workers: int) -> dict:
    """The STEP assembly and, when asked, the per-panel STEPs (their names by panel id)."""
    from .model import write_panel_steps, write_step_assembly

    (folder / "model").mkdir(exist_ok=True)
    write_step_assembly(model, folder / "model" / "assembly.step", job.material.density, workers)
    if not job.output.step_per_panel:
        return {}
    (folder / "model" / "panels").mkdir(parents=True)
    return write_panel_steps(model, folder / "model" / "panels")


def _write_glb(model: Model, folder: Path, workers: int, solids: Future | None) -> None:
    from .model import write_glb

    (folder / "model").mkdir(exist_ok=True)
    geometry = solids.result() if solids is not None else None
    write_glb(model, folder / "model" / "preview.glb", workers, geometry)


def _write_rhino(model: Model, folder: Path, solids: dict[str, object]) -> None:
    from .model.rhino import write_3dm

    write_3dm(model, folder / "model" / "design.3dm", solids)


def _write_side_by_side(
    result: Result,
    folder: Path,
    workers: int,
    timed: dict[str, float],
    note: Callable[[dict, str], None],
) -> list[Path]:
    """Every file but the manifest and the CSVs that name the files, side by side (module
    docstring); each writer's time into ``timed``, the files named by part or panel through
    ``note``; the documents written."""
    job = result.job

    def timing(part: str, work: Callable[[], T]) -> T:
        begun = time.perf_counter()
        value = work()
        timed[part] = time.perf_counter() - begun
        return value

    writes_docs = job.docs.write and result.model is not None and result.flat is not None
    model, flat, nests = result.model, result.flat, result.nests
    with side_by_side(workers) as lanes:
        solids = None
        if model is not None and (job.output.rhino or writes_docs):
            # the IFC's and the 3DM's solids: made once, first, for both
            solids = lanes.start(timing, "solids", lambda: _solids_of(model, workers))
        steps = None
        if model is not None and job.output.step:
            steps = lanes.start(timing, "step", lambda: _write_steps(model, job, folder, workers))
        if model is not None and job.output.glb:
            lanes.start(timing, "glb", lambda: _write_glb(model, folder, workers, solids))
        if model is not None and job.output.rhino and solids is not None:
            lanes.start(timing, "rhino", lambda: _write_rhino(model, folder, solids.result()))
        cut_files = None
        if flat is not None and nests is not None and job.output.dxf:
            cut_files = lanes.start(
                timing, "cut", lambda: _write_cut_files(flat, nests, folder / "cut", workers)
            )
        # the documents (in this thread) and the report (a lane of its own) need no file of
        # the others' (their source is the manifest's content, whose file names come last)
        # but the plate images the report shows: it waits for the cut files
        source = None
        if writes_docs and model is not None:
            from .docs import DocSource

            source = DocSource.from_manifest(build_manifest(result, {}))
        report = None
        if job.output.report:
            from .raster import PYPLOT
            from .report import write_report

            (folder / "report").mkdir()

            def write_the_report() -> None:
                if cut_files is not None:
                    cut_files.result()
                with PYPLOT:  # its figures, beside the documents' key plan and drawings
                    timing("report", lambda: write_report(result, folder / "report", source))

            report = lanes.start(write_the_report)
        documents: list[Path] = []
        if source is not None and model is not None and solids is not None:
            from .docs import write_docs

            breps = {p.id: p.brep for p in model.parts}
            documents = timing(
                "docs", lambda: write_docs(source, folder, breps, workers, solids.result())
            )
        if steps is not None:
            note(steps.result(), "model/panels")
        if cut_files is not None:
            part_files, plate_files = cut_files.result()
            note(part_files, "cut/parts")
            note(plate_files, "cut/nests")
        if report is not None:
            report.result()
    return documents


def write_outputs(
    result: Result, folder: Path, progress: Progress, jobs: int | None = None
) -> None:
    from .parallel import shared_pool

    workers = jobs or os.cpu_count() or 1
    with shared_pool(workers):  # one start of the workers for every file
        _write_files(result, folder, progress, workers)


def _write_files(result: Result, folder: Path, progress: Progress, workers: int) -> None:
    started = time.perf_counter()
    progress.start("write", None)
    files: dict[str, list[str]] = {}

    def note(mapping: dict, prefix: str) -> None:
        for key, names in mapping.items():
            names = [names] if isinstance(names, (str, Path)) else names
            files.setdefault(key, []).extend(f"{prefix}/{Path(n).name}" for n in names)

    if result.layout is not None:
        from .panelize.export import write_layout_obj

        (folder / "model").mkdir(exist_ok=True)
        write_layout_obj(result.layout, folder / "model" / "panels.obj")
    if result.developed is not None:
        from .develop.export import write_developed_obj

        write_developed_obj(result.developed, folder / "model" / "developed.obj")
    timed: dict[str, float] = {}
    documents = _write_side_by_side(result, folder, workers, timed, note)
    manifest = build_manifest(result, files)
    if documents:
        manifest["documents"] = sorted(str(p.relative_to(folder)) for p in documents)
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=1, default=_json_default))
    _write_bom(result, folder / "bom.csv", files)
    if result.flat is not None and result.model is not None:
        _write_marks(result, folder / "marks.csv", files)
    written = sum(1 for path in folder.rglob("*") if path.is_file())
    # side by side: each writer's own time, which overlap
    split = ", ".join(f"{k} {timed[k]:.0f} s" for k in WRITERS if k in timed)
    progress.finish(
        "write", time.perf_counter() - started, f"{written} files (side by side: {split})"
    )


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def versions() -> dict[str, str | None]:
    from importlib.metadata import PackageNotFoundError, version

    found: dict[str, str | None] = {"fabpanel": __version__, "python": platform.python_version()}
    for name in (
        "build123d",
        "cadquery-ocp-novtk",
        "numpy",
        "scipy",
        "trimesh",
        "ezdxf",
        "spyrrow",
        "manifold3d",
        "ifcopenshell",
    ):
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = None
    return found


def _flat_and_plate_of(result: Result) -> tuple[dict, dict]:
    """Each part's flat record and the name of the plate it is nested on, by part id."""
    flat_by_id = {p.id: p for p in result.flat.parts} if result.flat is not None else {}
    plate_of = {
        placement.part_id: plate.name
        for plate in (result.nests.plates if result.nests is not None else ())
        for placement in plate.placements
    }
    return flat_by_id, plate_of


def build_manifest(result: Result, files: dict[str, list[str]]) -> dict:
    """The manifest: job as run, versions, units, panels, parts, nests and stage metrics."""
    panels = []
    if result.layout is not None:
        layout_record = result.layout.to_dict()
        classes = (
            dict(zip(result.developed.panel_ids, result.developed.classes))
            if result.developed is not None
            else {}
        )
        for record in layout_record["panels"]:
            # the design's own frame, as the model files (the stages work in the local frame)
            record["corners_mm"] = np.round(
                np.asarray(record["corners_mm"]) + result.surface.origin, 3
            ).tolist()
            record["class"] = classes.get(record["id"])
            record["files"] = files.get(record["id"], [])
            panels.append(record)
    flat_by_id, plate_of = _flat_and_plate_of(result)
    parts = []
    if result.model is not None:
        from .flat.nest import cut_length

        origin = result.surface.origin
        for part in result.model.parts:
            record = part.to_dict()
            record["files"] = files.get(part.id, [])
            # the design's own frame, as the panel corners
            if "centroid_mm" in record:
                record["centroid_mm"] = np.round(part.centroid + origin, 3).tolist()
            for hole in record.get("bolt_holes", ()):
                hole["centre_mm"] = np.round(np.add(hole["centre_mm"], origin), 3).tolist()
            if part.id in flat_by_id:
                flat = flat_by_id[part.id]
                record["flat"] = {**flat.to_dict(), "cut_length_mm": round(cut_length(flat), 1)}
                record["plate"] = plate_of.get(part.id)
            parts.append(record)
    stages = {"surface": result.surface.to_dict()}
    for name, value in (
        ("panelize", result.layout),
        ("develop", result.developed),
        ("build", result.model),
        ("cut", result.flat),
        ("nest", result.nests),
    ):
        if value is not None:
            stages[name] = value.metrics
    return {
        "fabpanel": __version__,
        "versions": versions(),
        "units": {"length": "mm", "mass": "kg", "area": "mm2", "volume": "mm3"},
        # model files and panel corners are in the design's own frame; the stages, the
        # CalculiX decks and the report's figures work in the local frame, whose origin this is
        "origin_mm": np.round(result.surface.origin, 3).tolist(),
        "job": result.job.to_dict(),
        "stages_run": list(result.stages_run),
        "panels": panels,
        "parts": parts,
        "marks": [m.to_dict() for m in result.flat.marks] if result.flat is not None else [],
        "nests": (
            [{**p.to_dict(), "files": files.get(p.name, [])} for p in result.nests.plates]
            if result.nests is not None
            else []
        ),
        "metrics": stages,
        "structure": result.summary.get("structure", {}),
        "issues": [i.to_dict() for i in result.issues],
    }


#: the columns of bom.csv (one row per part) and marks.csv (one row per part mark): an output
#: contract other tools read
BOM_COLUMNS = (
    "part", "mark", "quantity", "kind", "panel", "material", "thickness_mm", "flat_area_mm2",
    "volume_mm3", "mass_kg", "flat_length_mm", "flat_width_mm", "max_strain", "forming",
    "cut_length_mm", "pierces", "plate", "files", "stock",
)  # fmt: skip
MARK_COLUMNS = (
    "mark", "quantity", "kind", "material", "thickness_mm", "flat_length_mm", "flat_width_mm",
    "flat_area_mm2", "mass_kg_each", "mass_kg_total", "forming", "file", "parts",
)  # fmt: skip


def _write_csv(path: Path, columns: tuple[str, ...], rows) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        writer.writerows(rows)


def _write_bom(result: Result, path: Path, files: dict[str, list[str]]) -> None:
    _write_csv(path, BOM_COLUMNS, _bom_rows(result, files))


def _bom_rows(result: Result, files: dict[str, list[str]]):
    from .flat.nest import cut_length, pierces

    if result.model is None:
        return
    flat_by_id, plate_of = _flat_and_plate_of(result)
    quantity = {m.mark: m.quantity for m in result.flat.marks} if result.flat is not None else {}
    for part in result.model.parts:
        flat = flat_by_id.get(part.id)
        size = np.ptp(flat.outline, axis=0) if flat is not None else (None, None)
        yield [
            part.id,
            flat.mark if flat is not None else "",
            quantity.get(flat.mark, "") if flat is not None else "",
            part.kind,
            part.panel_id,
            part.material,
            f"{part.thickness:g}",
            f"{flat.area:.1f}" if flat is not None else f"{part.area:.1f}",
            f"{part.volume:.1f}",
            f"{part.mass:.4f}",
            f"{size[0]:.1f}" if flat is not None else "",
            f"{size[1]:.1f}" if flat is not None else "",
            f"{flat.max_strain:.2e}" if flat is not None else "",
            flat.forming if flat is not None else "",
            f"{cut_length(flat):.1f}" if flat is not None else "",
            pierces(flat) if flat is not None else "",
            plate_of.get(part.id, ""),
            " ".join(files.get(part.id, [])),
            _stock_of(flat),
        ]


def _stock_of(flat: FlatPart | None) -> str:
    """What a part is cut from: ``plate``, ``flat bar 150 x 8`` (sawn), "" (not laid flat)."""
    from .flat.flatbar import bar_size

    if flat is None:
        return ""
    size = bar_size(flat) if flat.stock_form == "flat-bar" else None
    return f"flat bar {size[0]:g} x {flat.thickness:g}" if size else "plate"


def _write_marks(result: Result, path: Path, files: dict[str, list[str]]) -> None:
    """One row per part mark: what the shop cuts, how many, what it weighs, where they go."""
    _write_csv(path, MARK_COLUMNS, _mark_rows(result, files))


def _mark_rows(result: Result, files: dict[str, list[str]]):
    assert result.flat is not None and result.model is not None
    flat_by_id = {p.id: p for p in result.flat.parts}
    model_by_id = {p.id: p for p in result.model.parts}
    for group in result.flat.marks:
        first = flat_by_id[group.part_ids[0]]
        mass = [model_by_id[i].mass for i in group.part_ids if i in model_by_id]
        size = np.ptp(first.outline, axis=0)
        yield [
            group.mark,
            group.quantity,
            first.kind,
            first.material,
            f"{first.thickness:g}",
            f"{size[0]:.1f}",
            f"{size[1]:.1f}",
            f"{first.area:.1f}",
            f"{np.mean(mass):.4f}" if mass else "",
            f"{np.sum(mass):.4f}" if mass else "",
            first.forming or first.face,
            " ".join(files.get(first.id, [])),
            " ".join(group.part_ids),
        ]
