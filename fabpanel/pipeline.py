"""run(job) -> Result: the stages in order, their outputs, metrics and the atomic output folder.

Only this module sequences the stages. Outputs are written into a temporary folder next to the
target and renamed into place only when the whole run succeeds, so a failed run leaves nothing
half-written and an existing folder is never partly overwritten.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import shutil
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from .data import DevelopedPanels, FlatParts, Model, Nests, PanelLayout, Surface
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


def _units_not_applied(job: Job, surface: Surface) -> list[Issue]:
    """A warning where the job declares a length unit for a B-rep that declares another: the
    file's own unit is used for the surface (a roof in mm under ``units = "m"`` ran silently in
    mm), the job's for the points and layouts the job gives."""
    units = job.input.units
    if units is None or surface.format not in ("step", "iges", "brep") or units == surface.units:
        return []
    return [
        Issue(
            "input-units-not-applied",
            f"{surface.source.name} is read in the unit its {surface.format.upper()} file "
            f'declares ({surface.units}), not in [input] units = "{units}", which applies only '
            "to what the job gives as coordinates (singular and support points, a drawn "
            "layout): if the file's numbers are in "
            f"{units}, export it again with {units} as its unit",
            "",
            "warning",
        )
    ]


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
    issues: list[Issue] = _units_not_applied(job, surface)
    query = SurfaceQuery(surface)
    state: dict = {"surface": surface}

    layout, timings["panelize"] = _timed(
        progress, "panelize", None, lambda: panelize(surface, job, query), issues
    )
    issues += layout.issues
    progress.finish("panelize", timings["panelize"], _layout_verdict(layout))
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
    from .write import write_outputs

    summary = summarise(result, timings, structure)
    result = Result(**{**result.__dict__, "summary": summary})
    if folder is not None:
        # the manifest is written first, so warnings of the writers (matplotlib's in the
        # report) are logged for --debug rather than lost on stderr
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            write_outputs(result, folder, progress, jobs)
        for issue in warning_issues("write", caught):
            log.info("%s", issue.message)
    return result


def _layout_verdict(layout: PanelLayout) -> str:
    """The panelize stage's progress line: panels, method and the layout gates' verdict."""
    gates = layout.metrics.get("gates", {})
    head = f"{len(layout.quads)} panels ({layout.method})"
    if "passed" not in gates:
        return head
    if gates["passed"]:
        return f"{head}, every layout gate passed"
    return f"{head}, layout gates failed: {', '.join(gates['failed'])}"
