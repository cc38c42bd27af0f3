"""run(job) -> Result: the stages in order, their outputs, metrics and the atomic output folder.

Only this module sequences the stages. Outputs are written into a temporary folder next to the
target and renamed into place only when the whole run succeeds, so a failed run leaves nothing
half-written and an existing folder is never partly overwritten.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import os
import platform
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from . import __version__
from .data import DevelopedPanels, FlatPart, FlatParts, Model, Nests, PanelLayout, Surface
from .errors import InputError, Issue
from .job import STAGES, Job, Stage
from .outdir import check_target, discard_staging, make_staging, move_into_place, sweep_stale
from .panelize.estimate import check_panel_count
from .parallel import executor

if TYPE_CHECKING:
    from .structure import Structure

log = logging.getLogger(__name__)


class Progress(Protocol):
    """What the pipeline tells its caller while it runs (the CLI draws bars from it)."""

    def start(self, stage: str, total: int | None) -> None: ...

    def advance(self, steps: int = 1) -> None: ...

    def finish(self, stage: str, seconds: float, note: str) -> None: ...

    def note(self, text: str) -> None: ...


class _Silent:
    def start(self, stage: str, total: int | None) -> None:
        pass

    def advance(self, steps: int = 1) -> None:
        pass

    def finish(self, stage: str, seconds: float, note: str) -> None:
        log.info("%s done in %.1f s: %s", stage, seconds, note)

    def note(self, text: str) -> None:
        log.info("%s", text)


#: above this many estimated panels the run says so before it starts the layout
MANY_PANELS = 1000


@dataclass(frozen=True)
class Result:
    """Everything a run produced. Stages that did not run (``--until``) are ``None``."""

    job: Job
    out_dir: Path | None
    surface: Surface
    layout: PanelLayout | None = None
    developed: DevelopedPanels | None = None
    model: Model | None = None
    flat: FlatParts | None = None
    nests: Nests | None = None
    structure: Structure | None = None
    summary: dict = field(default_factory=dict)
    issues: tuple[Issue, ...] = ()
    stages_run: tuple[Stage, ...] = ()


def load(job: Job):
    """Read the job's design surface (a stage of its own so bad input fails before any work)."""
    from .surface import load_surface

    if job.input_path is None:
        raise InputError("the job names no input surface; set [input] path or pass INPUT")
    if not Path(job.input_path).exists():
        raise InputError(
            f"{Path(job.input_path).name}: file not found ({job.input_path}); check [input] path "
            "in the job (relative to the job file) or the INPUT argument"
        )
    return load_surface(job.input_path, job.input.units, crease_angle=job.input.crease_angle)


def run(
    job: Job,
    out_dir: str | Path | None = None,
    until: Stage = "structure",
    jobs: int | None = None,
    force: bool = False,
    progress: Progress | None = None,
    write: bool = True,
) -> Result:
    """Run the pipeline up to and including stage ``until``; write the outputs when ``write``.

    out_dir : output folder (default: the job's ``[output] dir``). The working folder, folders
        holding the inputs and folders that are not fabpanel output are refused; an earlier
        fabpanel output is refused unless ``force``, then replaced only once the new run has
        succeeded (see :mod:`fabpanel.outdir`).
    jobs : worker processes for per-panel work (default: all cores).
    """
    if until not in STAGES:
        raise InputError(f"unknown stage {until!r}; use one of {', '.join(STAGES)}")
    progress = progress or _Silent()
    target = Path(out_dir).resolve() if out_dir else job.output_dir
    settings = job.run
    on = executor(
        settings.executor,
        settings.address,
        jobs or os.cpu_count() or 1,
        settings.worker_tasks,
        settings.retries,
    )
    if not write:
        with on:
            return _run_stages(job, _checked_surface(job, progress), None, until, jobs, progress)
    check_target(target, job_inputs(job), force)
    swept = sweep_stale(target)
    if swept:
        log.info("removed %d folder(s) left by earlier runs that were killed", len(swept))
    staging = make_staging(target)  # before any work: an unwritable target stops at once
    try:
        surface = _checked_surface(job, progress)
        with on:
            result = _run_stages(job, surface, staging, until, jobs, progress)
    except BaseException:
        discard_staging(staging)
        raise
    move_into_place(staging, target, force)
    return Result(**{**result.__dict__, "out_dir": target})


def _checked_surface(job: Job, progress: Progress) -> Surface:
    """The job's surface, loaded, with the panel count estimated (a unit mistake stops here)."""
    surface = load(job)
    estimate = check_panel_count(surface, job)
    if estimate > MANY_PANELS:
        progress.note(
            f"{surface.source.name} asks for about {estimate:.0f} panels of "
            f"{job.panelize.panel_size / 1000:g} m; a larger panel size runs faster"
        )
    return surface


def job_inputs(job: Job) -> list[Path]:
    """The files a run of ``job`` reads: the design surface, the job file, a user layout."""
    paths = [p for p in (job.input_path, job.source) if p is not None]
    if job.panelize.layout:
        paths.append(job.base_dir / job.panelize.layout)
    return [Path(p).resolve() for p in paths]


def _timed(progress: Progress, stage: str, total: int | None, work, issues: list[Issue]):
    """Run one stage: its time, and the library warnings it raised as issues (not stderr)."""
    progress.start(stage, total)
    started = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = work()
    issues += warning_issues(stage, caught)
    return value, time.perf_counter() - started


def warning_issues(stage: str, caught: list[warnings.WarningMessage]) -> list[Issue]:
    """One ``library-warning`` issue per distinct warning (category, text) a stage raised."""
    seen: dict[tuple[str, str], int] = {}
    for item in caught:
        key = (item.category.__name__, " ".join(str(item.message).split())[:200])
        seen[key] = seen.get(key, 0) + 1
    return [
        Issue(
            "library-warning",
            f"{stage}: {category}: {text}" + (f" ({count} times)" if count > 1 else ""),
            severity="warning",
        )
        for (category, text), count in seen.items()
    ]


def _run_stages(
    job: Job,
    surface: Surface,
    folder: Path | None,
    until: Stage,
    jobs: int | None,
    progress: Progress,
) -> Result:
    from .develop import develop
    from .panelize import panelize
    from .surface import SurfaceQuery

    stop = STAGES.index(until)
    timings: dict[str, float] = {}
    issues: list[Issue] = []
    query = SurfaceQuery(surface)
    state: dict = {"surface": surface}

    layout, timings["panelize"] = _timed(
        progress, "panelize", None, lambda: panelize(surface, job, query), issues
    )
    issues += layout.issues
    progress.finish(
        "panelize", timings["panelize"], f"{len(layout.quads)} panels ({layout.method})"
    )
    state["layout"] = layout
    ran: list[Stage] = ["panelize"]

    if stop >= STAGES.index("develop"):
        developed, timings["develop"] = _timed(
            progress, "develop", None, lambda: develop(layout, surface, job, query), issues
        )
        issues += developed.issues
        state["developed"] = developed
        ran.append("develop")
        progress.finish(
            "develop",
            timings["develop"],
            ", ".join(f"{n} {c}" for c, n in developed.metrics["classes"].items()),
        )

    if stop >= STAGES.index("build"):
        from .model import build

        model, timings["build"] = _timed(
            progress,
            "build",
            len(layout.quads),
            lambda: build(state["developed"], job, jobs=jobs, progress=progress.advance),
            issues,
        )
        issues += model.issues
        state["model"] = model
        ran.append("build")
        not_built = model.metrics.get("panels_not_built", 0)
        progress.finish(
            "build",
            timings["build"],
            f"{len(model.parts)} parts, {model.mass:.1f} kg"
            + (f", {not_built} panel(s) not built" if not_built else ""),
        )

    if stop >= STAGES.index("cut"):
        from .flat import cut
        from .flat.nest import nest

        def cut_and_nest():
            flat = cut(state["model"], job, jobs=jobs)
            nests = nest(flat, job, progress=lambda fraction, message: None)
            if job.cutting.suggest_stock:
                from .flat.stock import suggest_stock

                suggestion = suggest_stock(flat, job, jobs, nests)
                nests = dataclasses.replace(
                    nests, metrics={**nests.metrics, "stock_suggestion": suggestion}
                )
            return flat, nests

        (flat, nests), timings["cut"] = _timed(progress, "cut", None, cut_and_nest, issues)
        issues += flat.issues + nests.issues
        state["flat"], state["nests"] = flat, nests
        ran.append("cut")
        progress.finish(
            "cut", timings["cut"], f"{len(flat.parts)} flat parts on {len(nests.plates)} plates"
        )

    structure = {
        "analysed": False,
        "reason": f"not run (--until {until})",
        "ccx_found": shutil.which("ccx") is not None,
    }
    if stop >= STAGES.index("structure"):
        from .structure import analyse, describe

        analysis, timings["structure"] = _timed(
            progress,
            "structure",
            None,
            lambda: analyse(
                state["model"],
                job,
                folder=folder / "structure" if folder is not None else None,
                flat=state.get("flat"),
            ),
            issues,
        )
        issues += analysis.issues
        state["structure"] = analysis
        structure = analysis.summary
        ran.append("structure")
        progress.finish("structure", timings["structure"], describe(analysis))

    result = Result(
        job=job,
        out_dir=folder,
        issues=tuple(issues),
        stages_run=tuple(ran),
        **{k: v for k, v in state.items()},
    )
    from .report import summarise

    summary = summarise(result, timings, structure)
    result = Result(**{**result.__dict__, "summary": summary})
    if folder is not None:
        # the manifest is written first, so warnings of the writers (matplotlib's in the
        # report) are logged for --debug rather than lost on stderr
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            _write_outputs(result, folder, progress, jobs)
        for issue in warning_issues("write", caught):
            log.info("%s", issue.message)
    return result


def _written(write, *args) -> tuple[dict, dict[str, bytes]]:
    """``write(*args, folder)`` run into a scratch folder of the worker's own; its result and
    the files it wrote, by name, so that no file is written on a remote node (Ray)."""
    with tempfile.TemporaryDirectory(prefix="fabpanel-files-") as scratch:
        result = write(*args, Path(scratch))
        files = {path.name: path.read_bytes() for path in Path(scratch).iterdir()}
    return result, files


def _write_part_chunk(flat: FlatParts) -> tuple[dict, dict[str, bytes]]:
    from .flat.dxf import write_parts

    return _written(write_parts, flat)


def _write_plate_chunk(nests: Nests, flat: FlatParts) -> tuple[dict, dict[str, bytes]]:
    from .flat.nest_output import write_nests

    return _written(write_nests, nests, flat)


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

    def chunks(items):
        size = max(1, -(-len(items) // (4 * workers)))
        return [items[i : i + size] for i in range(0, len(items), size)]

    # one file per mark: only each mark's first part goes to the writers
    drawn: dict[str, FlatPart] = {}
    for part in flat.parts:
        drawn.setdefault(part.mark or part.id, part)
    part_chunks = [FlatParts(parts=tuple(c)) for c in chunks(list(drawn.values()))]
    plate_chunks = [Nests(plates=tuple(c)) for c in chunks(list(nests.plates))]
    if workers == 1:
        part_maps = [_saved(_write_part_chunk(c), folder / "parts") for c in part_chunks]
        plate_maps = [_saved(_write_plate_chunk(c, flat), folder / "nests") for c in plate_chunks]
    else:
        with worker_pool(workers, fresh=True) as pool:  # this process has run spyrrow's nests
            part_futures = [pool.submit(_write_part_chunk, c) for c in part_chunks]
            plate_futures = [pool.submit(_write_plate_chunk, c, flat) for c in plate_chunks]
            part_maps = [_saved(f.result(), folder / "parts") for f in part_futures]
            plate_maps = [_saved(f.result(), folder / "nests") for f in plate_futures]
    drawn_files = {k: v for m in part_maps for k, v in m.items()}
    part_files = {p.id: drawn_files[drawn[p.mark or p.id].id] for p in flat.parts}
    plate_files = {k: v for m in plate_maps for k, v in m.items()}
    return part_files, plate_files


def _write_outputs(
    result: Result, folder: Path, progress: Progress, jobs: int | None = None
) -> None:
    from .parallel import shared_pool

    workers = jobs or os.cpu_count() or 1
    with shared_pool(workers):  # one start of the workers for every file
        _write_files(result, folder, progress, workers)


def _write_files(result: Result, folder: Path, progress: Progress, workers: int) -> None:
    job = result.job
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
    laps: dict[str, float] = {}
    lap = time.perf_counter()

    def done(part: str) -> None:
        nonlocal lap
        now = time.perf_counter()
        laps[part] = now - lap
        lap = now

    writes_docs = job.docs.write and result.model is not None and result.flat is not None
    solids = None
    if result.model is not None:
        from .model import write_glb, write_panel_steps, write_step_assembly

        if job.output.step:
            write_step_assembly(
                result.model, folder / "model" / "assembly.step", job.material.density, workers
            )
        if job.output.step and job.output.step_per_panel:
            (folder / "model" / "panels").mkdir(parents=True)
            note(write_panel_steps(result.model, folder / "model" / "panels"), "model/panels")
        if job.output.glb:
            write_glb(result.model, folder / "model" / "preview.glb", workers)
        if job.output.rhino or writes_docs:
            from .docs.ifc import solid_geometries

            # the IFC's and the 3DM's solids: made once, here, for both
            solids = solid_geometries(
                [(p.id, p.brep, p.thickness, p.kind) for p in result.model.parts], workers
            )
        if job.output.rhino:
            from .model.rhino import write_3dm

            write_3dm(result.model, folder / "model" / "design.3dm", solids)
        done("model")
    if result.flat is not None and result.nests is not None and job.output.dxf:
        (folder / "cut" / "parts").mkdir(parents=True)
        (folder / "cut" / "nests").mkdir(parents=True)
        part_files, plate_files = _write_cut_files(
            result.flat, result.nests, folder / "cut", workers
        )
        note(part_files, "cut/parts")
        note(plate_files, "cut/nests")
        done("cut")

    manifest = build_manifest(result, files)
    source = None
    if writes_docs and result.model is not None:
        from .docs import DocSource, write_docs

        source = DocSource.from_manifest(manifest)
        documents = write_docs(
            source, folder, {p.id: p.brep for p in result.model.parts}, workers, solids
        )
        manifest["documents"] = sorted(str(p.relative_to(folder)) for p in documents)
        done("docs")
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=1, default=_json_default))
    _write_bom(result, folder / "bom.csv", files)
    if result.flat is not None and result.model is not None:
        _write_marks(result, folder / "marks.csv", files)
    if job.output.report:
        from .report import write_report

        (folder / "report").mkdir()
        write_report(result, folder / "report", source)
        done("report")
    written = sum(1 for path in folder.rglob("*") if path.is_file())
    split = ", ".join(f"{k} {v:.0f} s" for k, v in laps.items())
    progress.finish("write", time.perf_counter() - started, f"{written} files ({split})")


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
