"""Command line: ``fabpanel export | init | inspect | docs | serve | demo``.

Exit codes: 0 success, 2 bad input or job (one line on stderr: what, where, how to fix),
1 internal error. ``--debug`` shows tracebacks.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, cast

import click

from .errors import FabpanelError, InputError, Stopped
from .job import STAGES, Job, Stage

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"  # package data: fabpanel init
EXAMPLE_DIR = Path(__file__).resolve().parent / "examples"  # package data: fabpanel demo
JOB_SUFFIXES = {".toml"}
#: exit code of a run that finished but left error-level issues (without --allow-issues)
EXIT_ISSUES = 3


class _Reporter:
    """Progress for the pipeline: a rich bar per stage on a terminal, plain lines otherwise."""

    def __init__(self, quiet: bool):
        self.quiet = quiet
        self.interactive = sys.stderr.isatty() and not quiet
        self._progress: Any = None  # rich.progress.Progress on a terminal
        self._task: Any = None
        if self.interactive:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self._progress = Progress(
                TextColumn("{task.description:<10}"),
                BarColumn(),
                TextColumn("{task.completed}/{task.total}"),
                TimeElapsedColumn(),
                console=Console(stderr=True),
                transient=True,
            )
            self._progress.start()

    def start(self, stage: str, total: int | None) -> None:
        if self._progress is not None:
            self._task = self._progress.add_task(stage, total=total)
        self._started = time.perf_counter()

    def advance(self, steps: int = 1) -> None:
        if self._progress is not None and self._task is not None:
            self._progress.advance(self._task, steps)

    def finish(self, stage: str, seconds: float, note: str) -> None:
        if self._progress is not None and self._task is not None:
            self._progress.remove_task(self._task)
            self._task = None
        if not self.quiet:
            click.echo(f"{stage:<10} {seconds:6.1f} s  {note}", err=True)

    def note(self, text: str) -> None:
        if not self.quiet:
            click.echo(f"note: {text}", err=True)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()


def issue_line(issue) -> str:
    """An error-level issue's line on stderr: the item it concerns, then the message (most
    messages begin with the item already: its id once, not twice)."""
    named = not issue.item or issue.message.startswith(issue.item)
    return f"  issue: {'' if named else issue.item + ': '}{issue.message}"


def _fail(err: BaseException, debug: bool) -> None:
    if isinstance(err, KeyboardInterrupt):
        signum = getattr(err, "signum", signal.SIGINT)
        click.echo(
            f"stopped by {signal.Signals(signum).name}: queued work cancelled, workers "
            f"stopped, nothing written",
            err=True,
        )
        # the run has cleaned up (workers, staging folder); skip the interpreter's teardown,
        # which spends seconds collecting the run's geometry, but not its temporary folder
        from .parallel import remove_temp_dir

        remove_temp_dir()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(128 + signum)
    if debug:
        raise err
    if isinstance(err, FabpanelError):
        click.echo(f"error: {err}", err=True)
        sys.exit(err.exit_code)
    click.echo(
        f"internal error: {type(err).__name__}: {err} (run with --debug for the "
        f"traceback and report it)",
        err=True,
    )
    sys.exit(1)


@contextmanager
def _stop_on_signals() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Stopped` in the main thread, so the run unwinds:
    workers terminated, the staging folder removed (see :mod:`fabpanel.parallel`)."""

    def stop(signum: int, frame: object) -> None:
        raise Stopped(signum)

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _quiet_logging(debug: bool) -> None:
    """Library log lines reach stderr only with --debug: findings are issues, errors one line."""
    logging.basicConfig(
        level=logging.INFO if debug else logging.CRITICAL + 1,
        format="%(levelname)s %(name)s: %(message)s",
        force=True,
    )
    logging.captureWarnings(True)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="fabpanel")
def main() -> None:
    """fabpanel: free-form steel shells to panels, STEP solids, DXF cutting files and nests."""


def _job_for(source: Path, units: str | None, panel_size: str | None, quiet: bool) -> Job:
    if source.suffix.lower() in JOB_SUFFIXES:
        job = Job.from_toml(source)
        if units is not None:
            job = job.replace(input={"units": units})
    else:
        if not source.exists():
            raise InputError(f"input file {source} does not exist; check the path")
        job = Job.for_input(source, units=units)
    if panel_size is not None:
        from .units import length_option

        quantity, note = length_option(panel_size, job.input.units, "--panel-size")
        if note and not quiet:
            click.echo(f"note: {note}", err=True)
        job = job.replace(panelize={"panel_size": quantity})
    return job


def export_run(
    source: Path,
    out: Path | None,
    units: str | None,
    panel_size: str | None,
    until: str,
    jobs: int | None,
    force: bool,
    quiet: bool,
    require_fem: bool = False,
    allow_issues: bool = False,
    debug: bool = False,
    run_settings: dict | None = None,
):
    """The ``export`` command: run, report, and exit 3 when error-level issues remain."""
    from .pipeline import run

    _quiet_logging(debug)
    job = _job_for(source, units, panel_size, quiet)
    if run_settings:
        job = job.replace(run=run_settings)
    if require_fem:
        job = job.replace(structure={"required": True})
    reporter = _Reporter(quiet)
    try:
        result = run(
            job, out_dir=out, until=cast(Stage, until), jobs=jobs, force=force, progress=reporter
        )
    finally:
        reporter.close()
    errors = [i for i in result.issues if i.severity == "error"]
    if not quiet:
        _print_summary(result)
    for issue in errors[:10]:
        click.echo(issue_line(issue), err=True)
    if errors and not allow_issues:
        more = f" ({len(errors) - 10} more)" if len(errors) > 10 else ""
        click.echo(
            f"error: finished with {len(errors)} error-level issue(s){more}, written to "
            f"{result.out_dir}/manifest.json; fix them or pass --allow-issues to accept "
            f"them (exit 3)",
            err=True,
        )
        sys.exit(EXIT_ISSUES)
    return result


def _print_summary(result) -> None:
    summary = result.summary
    parts = summary.get("parts", {})
    click.echo(f"wrote {result.out_dir}", err=True)
    if parts:
        click.echo(
            f"  {summary['panels']['count']} panels, {parts['count']} parts, {parts['mass_kg']} kg",
            err=True,
        )
    if result.flat is not None and result.flat.marks:
        click.echo(f"  {len(result.flat.marks)} part marks (cut/parts, marks.csv)", err=True)
    if result.nests is not None:
        _echo_stock(result.nests.metrics)
    if "nests" in summary:
        click.echo(f"  {summary['nests']['plates']} plates", err=True)
    if "structure" in result.stages_run and result.structure is not None:
        from .structure import describe

        click.echo(f"  structure: {describe(result.structure)}", err=True)
    warnings = Counter(i.code for i in result.issues if i.severity == "warning")
    if warnings:
        listed = ", ".join(f"{code} x{n}" if n > 1 else code for code, n in warnings.items())
        click.echo(f"  {sum(warnings.values())} warning(s): {listed} (in manifest.json)", err=True)


_export_options = [
    click.option(
        "--out",
        "out",
        type=click.Path(path_type=Path),
        default=None,
        help="Output folder (default: from the job, or <input>-fabpanel).",
    ),
    click.option(
        "--units",
        type=click.Choice(["m", "cm", "mm"]),
        default=None,
        help="Length unit of the input coordinates (meshes carry none).",
    ),
    click.option(
        "--panel-size",
        default=None,
        metavar="LENGTH",
        help='Target panel size, with a unit: "1.2 m".',
    ),
    click.option(
        "--until",
        type=click.Choice(STAGES),
        default="structure",
        help="Stop after this stage; its outputs and those before are written.",
    ),
    click.option(
        "--jobs",
        type=click.IntRange(min=1),
        default=None,
        help="Worker processes for per-panel work (default: all cores).",
    ),
    click.option(
        "--executor",
        type=click.Choice(["local", "ray"]),
        default=None,
        help="Where per-panel work runs: worker processes here, or tasks on a Ray cluster "
        "(default: the job's [run] executor, local).",
    ),
    click.option(
        "--address",
        default=None,
        help='The Ray cluster to join ("auto", "ray://head:10001"); without it --executor '
        "ray starts a local Ray instance.",
    ),
    click.option("--force", is_flag=True, help="Replace an existing output folder."),
    click.option(
        "--require-fem",
        "require_fem",
        is_flag=True,
        help="Fail (exit 2) when CalculiX is missing instead of skipping the structural check.",
    ),
    click.option(
        "--allow-issues",
        "allow_issues",
        is_flag=True,
        help="Exit 0 even when error-level issues remain (default: exit 3).",
    ),
    click.option("--quiet", is_flag=True, help="Print nothing but errors."),
    click.option("--debug", is_flag=True, help="Show tracebacks and library log lines."),
]


def _with_export_options(func):
    for option in reversed(_export_options):
        func = option(func)
    return func


@main.command()
@click.argument("source", type=click.Path(path_type=Path))
@_with_export_options
def export(
    source,
    out,
    units,
    panel_size,
    until,
    jobs,
    executor,
    address,
    force,
    require_fem,
    allow_issues,
    quiet,
    debug,
):
    """Run the pipeline on INPUT (a surface file) or JOB.toml and write the output folder."""
    run_settings = {
        key: value for key, value in (("executor", executor), ("address", address)) if value
    }
    try:
        with _stop_on_signals():
            export_run(
                source,
                out,
                units,
                panel_size,
                until,
                jobs,
                force,
                quiet,
                require_fem,
                allow_issues,
                debug,
                run_settings,
            )
    except (Exception, KeyboardInterrupt) as err:  # noqa: BLE001 - every error is an exit code
        _fail(err, debug)


@main.command()
@click.argument("path", type=click.Path(path_type=Path), default=Path("fabpanel.toml"))
@click.option(
    "--template",
    default="sandwich-pavilion",
    show_default=True,
    help="Template name: " + ", ".join(sorted(p.stem for p in TEMPLATE_DIR.glob("*.toml"))),
)
@click.option("--force", is_flag=True, help="Overwrite an existing file.")
@click.option("--debug", is_flag=True, help="Show tracebacks.")
def init(path, template, force, debug):
    """Write a commented job file from a template."""
    try:
        source = TEMPLATE_DIR / f"{template}.toml"
        if not source.is_file():
            names = ", ".join(sorted(p.stem for p in TEMPLATE_DIR.glob("*.toml")))
            raise InputError(f"unknown template {template!r}; choose one of {names}")
        if path.exists() and not force:
            raise InputError(f"{path} exists; pass --force to overwrite it or choose another path")
        text = source.read_text(encoding="utf-8")
        Job.from_dict(__import__("tomllib").loads(text))  # templates must stay valid
        path.write_text(text, encoding="utf-8")
        click.echo(f"wrote {path} (template {template})", err=True)
    except Exception as err:  # noqa: BLE001
        _fail(err, debug)


@main.command()
@click.argument("source", type=click.Path(path_type=Path))
@click.option(
    "--units",
    type=click.Choice(["m", "cm", "mm"]),
    default=None,
    help="Length unit of the input coordinates (meshes carry none).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("--debug", is_flag=True, help="Show tracebacks.")
def inspect(source, units, as_json, debug):
    """Show what is read from INPUT: format, units, bounds, area, boundary loops, openings."""
    try:
        from .surface import describe_surface, load_surface

        if source.suffix.lower() in JOB_SUFFIXES:
            job = Job.from_toml(source)
            source, units = job.input_path, units or job.input.units
        surface = load_surface(source, units)
        info = describe_surface(surface)
        if as_json:
            import json

            click.echo(json.dumps(info, indent=1, default=str))
        else:
            for key, value in info.items():
                click.echo(f"{key:>22}: {value}")
    except Exception as err:  # noqa: BLE001
        _fail(err, debug)


@main.command()
@click.argument("folder", type=click.Path(path_type=Path))
@click.option("--jobs", type=click.IntRange(min=1), default=None)
@click.option("--debug", is_flag=True, help="Show tracebacks.")
def docs(folder, jobs, debug):
    """Make the shop documents again from the output FOLDER of a run: docs/*.csv (panels,
    rolling, fasteners, welds), docs/keyplan.pdf and model/assembly.ifc."""
    try:
        import os

        from .docs import docs_from_folder

        _quiet_logging(debug)
        with _stop_on_signals():
            written = docs_from_folder(folder, jobs or os.cpu_count() or 1)
        for path in written:
            click.echo(f"wrote {path}", err=True)
    except (Exception, KeyboardInterrupt) as err:  # noqa: BLE001
        _fail(err, debug)


@main.command()
@click.option("--host", default="localhost", show_default=True, help="Address to listen on.")
@click.option("--port", type=click.IntRange(1, 65535), default=5000, show_default=True)
@click.option("--debug", is_flag=True, help="Show tracebacks.")
def serve(host, port, debug):
    """Run the Grasshopper Hops endpoint: inspect, panelize, develop and export as Hops
    components (point a Hops component at http://HOST:PORT/panelize, ...)."""
    try:
        from .serve import server

        _quiet_logging(debug)
        httpd = server(host, port)
        click.echo(
            f"fabpanel Hops endpoint on http://{host}:{port}/ (components /inspect, /panelize, "
            "/develop, /export); Ctrl-C stops it",
            err=True,
        )
        try:
            httpd.serve_forever()
        except KeyboardInterrupt:
            click.echo("stopped", err=True)
        finally:
            httpd.server_close()
    except Exception as err:  # noqa: BLE001
        _fail(err, debug)


@main.command()
@click.argument("folder", type=click.Path(path_type=Path), default=Path("fabpanel-demo"))
@click.option("--force", is_flag=True, help="Replace an existing output folder.")
@click.option("--jobs", type=click.IntRange(min=1), default=None)
@click.option("--quiet", is_flag=True)
@click.option("--debug", is_flag=True)
def demo(folder, force, jobs, quiet, debug):
    """Run the barrel-vault example shipped with fabpanel; write the outputs into FOLDER
    (default: fabpanel-demo in the current folder)."""
    try:
        # job and STEP are package data (fabpanel/examples); outputs go to FOLDER only
        job_path = EXAMPLE_DIR / "barrel-vault.toml"
        if not (EXAMPLE_DIR / "barrel-vault.step").is_file():
            raise InputError(
                f"the demo surface {EXAMPLE_DIR / 'barrel-vault.step'} is missing; "
                "reinstall fabpanel (in a checkout: python -m "
                "fabpanel.examples.barrel_vault)"
            )
        with _stop_on_signals():
            export_run(job_path, folder, None, None, "structure", jobs, force, quiet, debug=debug)
        if not quiet:
            click.echo(f"open {folder / 'report' / 'index.html'}", err=True)
    except (Exception, KeyboardInterrupt) as err:  # noqa: BLE001
        _fail(err, debug)


def _echo_stock(metrics: dict) -> None:
    """Steel bought against net, and the stock suggestion where it buys less."""
    if metrics.get("net_kg"):
        click.echo(
            f"  steel bought {metrics['bought_kg'] / 1000:.2f} t for {metrics['net_kg'] / 1000:.2f} t "
            f"of parts ({metrics['bought_to_net']:.2f} x)",
            err=True,
        )
    for bar in metrics.get("flat_bars", []):
        click.echo(
            f"  flat bar: {bar['pieces']} ribs sawn from {bar['bars']} bars of "
            f"{bar['bar_length_mm'] / 1000:g} m, {bar['width_mm']:g} x {bar['thickness_mm']:g} mm",
            err=True,
        )
    now = {(g["material"], g["thickness_mm"]): g for g in metrics.get("groups", [])}
    better = [
        s
        for s in metrics.get("stock_suggestion", [])
        if (s["material"], s["thickness_mm"]) in now
        and s["bought_kg"] < now[(s["material"], s["thickness_mm"])]["bought_kg"] - 1e-6
    ]
    for s in better:
        was = now[(s["material"], s["thickness_mm"])]
        click.echo(
            f"  stock: {s['material']} {s['thickness_mm']:g} mm on {s['length_mm']:g} x "
            f"{s['width_mm']:g} mm plates{' cut from coil' if s.get('from_coil') else ''} "
            f"would buy {s['bought_to_net']:.2f} x net "
            f"(now {was['bought_kg'] / was['net_kg']:.2f} x)",
            err=True,
        )
    if better:
        from .flat.stock import stock_toml

        click.echo("  to use it, add to the job:\n" + stock_toml(better), err=True)


if __name__ == "__main__":
    main()
