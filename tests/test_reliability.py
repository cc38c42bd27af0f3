"""Reliability: the user's files are never lost, unit mistakes are refused before any work, a
run stops cleanly on SIGINT/SIGTERM (and its workers die even on SIGKILL), error-level issues
exit 3, stderr holds one line per error.

Each test reproduces a failure a user met (issue 14) with a small generated shape.
"""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import fabpanel as fp
from fabpanel.errors import InputError
from fabpanel.outdir import STAGING_MARK, make_staging, move_into_place, sweep_stale

# the probes' shape generator and process helpers (benchmarks/reliability.py runs the same
# probes as a report)
_spec = importlib.util.spec_from_file_location(
    "reliability_probes", Path(__file__).resolve().parents[1] / "benchmarks" / "reliability.py"
)
probes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(probes)
_vault_obj = probes.vault
_descendants = probes.descendants
_workers_up = probes.workers_up
_alive = probes.alive


def _cli(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "fabpanel", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip()]


def _tree(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


# ---------------------------------------------------------------------------------------------
# output safety
# ---------------------------------------------------------------------------------------------
@pytest.fixture
def workdir(tmp_path) -> Path:
    work = tmp_path / "work"
    work.mkdir()
    _vault_obj(work / "base.obj")
    (work / "job.toml").write_text('[input]\npath = "base.obj"\nunits = "m"\n')
    (work / "notes.txt").write_text("the client's notes")
    return work


@pytest.mark.parametrize("out", [".", "..", "base.obj", "job.toml"])
def test_output_never_replaces_the_working_folder_or_an_input(workdir, out):
    before = _tree(workdir.parent)
    result = _cli("export", "job.toml", "--out", out, "--force", "--until", "panelize", cwd=workdir)
    assert result.returncode == 2, result.stderr
    assert len(_lines(result.stderr)) == 1 and "error:" in result.stderr
    assert _tree(workdir.parent) == before


def test_output_folder_holding_the_input_is_refused(workdir):
    sub = workdir / "design"
    sub.mkdir()
    (workdir / "base.obj").rename(sub / "base.obj")
    result = _cli(
        "export", "design/base.obj", "--units", "m", "--out", "design", "--force", cwd=workdir
    )
    assert result.returncode == 2 and "base.obj" in result.stderr
    assert (sub / "base.obj").is_file()


def test_a_folder_that_is_not_fabpanel_output_is_never_replaced(workdir):
    mine = workdir / "mine"
    mine.mkdir()
    (mine / "drawing.dwg").write_text("precious")
    result = _cli(
        "export", "job.toml", "--out", "mine", "--force", "--until", "panelize", cwd=workdir
    )
    assert result.returncode == 2 and "not a fabpanel output" in result.stderr
    assert "--force" not in result.stderr.split(";")[-1]  # the fix is another folder
    assert (mine / "drawing.dwg").read_text() == "precious"


def test_an_earlier_output_is_replaced_with_force_and_an_empty_folder_is_used(workdir):
    (workdir / "out").mkdir()
    first = _cli("export", "job.toml", "--out", "out", "--until", "panelize", cwd=workdir)
    assert first.returncode == 0, first.stderr
    again = _cli("export", "job.toml", "--out", "out", "--until", "panelize", cwd=workdir)
    assert again.returncode == 2 and "--force" in again.stderr
    forced = _cli(
        "export", "job.toml", "--out", "out", "--until", "panelize", "--force", cwd=workdir
    )
    assert forced.returncode == 0, forced.stderr
    assert json.loads((workdir / "out" / "manifest.json").read_text())["stages_run"] == ["panelize"]
    assert sorted(p.name for p in workdir.iterdir()) == ["base.obj", "job.toml", "notes.txt", "out"]


def test_stale_staging_folders_of_dead_runs_are_swept(tmp_path):
    target = tmp_path / "out"
    dead = _dead_pid()
    stale = tmp_path / f".out.partial-{dead}"
    stale.mkdir()
    (stale / STAGING_MARK).write_text(str(dead))
    live = tmp_path / f".out.partial-{os.getpid()}"
    live.mkdir()
    (live / STAGING_MARK).write_text(str(os.getpid()))
    foreign = tmp_path / f".out.partial-{dead + 1}"  # no mark: not ours
    foreign.mkdir()
    assert sweep_stale(target) == [stale]
    assert not stale.exists() and live.exists() and foreign.exists()


def _finished_staging(target: Path) -> Path:
    staging = make_staging(target)
    (staging / "manifest.json").write_text('{"fabpanel": "x", "stages_run": []}')
    return staging


@pytest.mark.parametrize("force", [False, True])
def test_a_folder_filled_during_the_run_is_never_replaced(tmp_path, force):
    target = tmp_path / "out"
    staging = _finished_staging(target)
    target.mkdir()  # another program writes there while the run works
    (target / "drawing.dwg").write_text("precious")
    with pytest.raises(InputError, match="out-1"):
        move_into_place(staging, target, force)
    assert (target / "drawing.dwg").read_text() == "precious"
    assert (tmp_path / "out-1" / "manifest.json").is_file() and not staging.exists()


def test_another_runs_output_written_meanwhile_needs_force(tmp_path):
    target = tmp_path / "out"
    other = _finished_staging(target)
    move_into_place(other, target, False)  # a second run finished first
    staging = _finished_staging(tmp_path / "out")
    with pytest.raises(InputError):
        move_into_place(staging, target, False)
    staging = _finished_staging(tmp_path / "out")
    (staging / "mine").write_text("new")
    move_into_place(staging, target, True)
    assert (target / "mine").is_file()


@pytest.mark.parametrize("below", ["a-file/sub", "/proc/fabpanel-out"])
def test_an_output_folder_that_cannot_be_made_is_refused(workdir, below):
    target = below if below.startswith("/") else str(workdir / below)
    (workdir / "a-file").write_text("not a folder")
    result = _cli("export", "job.toml", "--out", target, "--until", "panelize", cwd=workdir)
    assert result.returncode == 2, result.stderr
    assert len(_lines(result.stderr)) == 1 and "--out" in result.stderr


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# ---------------------------------------------------------------------------------------------
# unit and size mistakes, before any work
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("scale", "units", "size", "hint"),
    [
        (1000.0, "m", None, "--units mm"),  # mm coordinates declared as metres
        (100.0, "m", None, "--units cm"),  # cm coordinates declared as metres
        (1.0, "mm", None, "--units m"),  # metre coordinates declared as mm
        (10.0, "m", "0.5 m", "--panel-size"),  # 10600 panels on a 60 x 40 m vault
    ],
)
def test_unit_and_size_mistakes_are_refused_at_once(tmp_path, scale, units, size, hint):
    mesh = _vault_obj(tmp_path / "vault.obj", scale=scale)
    args = ["export", "vault.obj", "--units", units, "--out", "out"]
    if size:
        args += ["--panel-size", size]
    started = time.perf_counter()
    result = _cli(*args, cwd=tmp_path, timeout=120)
    assert result.returncode == 2, result.stderr
    assert time.perf_counter() - started < 60
    (line,) = _lines(result.stderr)
    assert hint in line and mesh.name in line and "panel" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["vault.obj"]


def test_max_panels_is_a_job_setting(tmp_path):
    surface = fp.load_surface(_vault_obj(tmp_path / "vault.obj"), "m")
    from fabpanel.panelize.estimate import check_panel_count

    job = fp.Job(panelize={"panel_size": "0.5 m", "max_panels": 50})
    with pytest.raises(fp.InputError, match="max_panels = 50"):
        check_panel_count(surface, job)
    assert check_panel_count(surface, job.replace(panelize={"max_panels": 500})) == pytest.approx(
        surface.area / 500.0**2
    )


def test_a_bare_panel_size_takes_the_input_units(tmp_path):
    _vault_obj(tmp_path / "vault.obj")
    result = _cli(
        "export",
        "vault.obj",
        "--units",
        "m",
        "--panel-size",
        "1",
        "--until",
        "panelize",
        "--out",
        "out",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert "1 m" in result.stderr.splitlines()[0]  # the note says how it read
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["job"]["panelize"]["panel_size"] == "1000 mm"


def test_error_level_issues_exit_3_unless_allowed(tmp_path):
    # 2 m grid panels on a 4 m wide vault: their sheets do not fit the 1500 mm plate
    _vault_obj(tmp_path / "vault.obj")
    args = ["export", "vault.obj", "--units", "m", "--panel-size", "2 m", "--until", "panelize"]
    result = _cli(*args, "--out", "a", cwd=tmp_path)
    assert result.returncode == 3, result.stderr
    assert "panel-exceeds-plate" in (tmp_path / "a" / "manifest.json").read_text()
    assert _lines(result.stderr)[-1].startswith("error: finished with")
    allowed = _cli(*args, "--out", "b", "--allow-issues", cwd=tmp_path)
    assert allowed.returncode == 0, allowed.stderr
    assert "issue:" in allowed.stderr


# ---------------------------------------------------------------------------------------------
# signals
# ---------------------------------------------------------------------------------------------
def _start_build(tmp_path: Path) -> tuple[subprocess.Popen, Path]:
    """An export that spends its time in the build's worker processes (~100 panels), in
    ``tmp_path/run`` with its temporary files in ``tmp_path/tmp``."""
    (tmp_path / "tmp").mkdir()
    tmp_path = tmp_path / "run"
    tmp_path.mkdir()
    _vault_obj(tmp_path / "vault.obj")
    (tmp_path / "job.toml").write_text(
        '[input]\npath = "vault.obj"\nunits = "m"\n[panelize]\npanel_size = "0.5 m"\n'
        '[develop]\nmethod = "project"\n'
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
        cwd=tmp_path,
        env={**os.environ, "TMPDIR": str(tmp_path.parent / "tmp")},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while not _workers_up(proc.pid):  # the build's workers are up
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the build never started"
        time.sleep(0.1)
    time.sleep(1.0)
    return proc, tmp_path


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_stops_the_run_cleanly_within_5_s(tmp_path, sig, code):
    proc, folder = _start_build(tmp_path)
    workers = _descendants(proc.pid)
    sent = time.monotonic()
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 5.0
    assert proc.returncode == code, stderr
    assert _lines(stderr)[-1].startswith(f"stopped by {sig.name}")
    assert "Traceback" not in stderr
    time.sleep(0.5)
    assert not [w for w in workers if _alive(w)]
    assert sorted(p.name for p in folder.iterdir()) == ["job.toml", "vault.obj"]
    assert not list((folder.parent / "tmp").iterdir())  # multiprocessing's pymp-* folder too


def test_workers_die_with_a_killed_run_and_its_debris_is_swept(tmp_path):
    proc, folder = _start_build(tmp_path)
    workers = _descendants(proc.pid)
    proc.kill()
    proc.communicate(timeout=30)
    deadline = time.monotonic() + 5
    while [w for w in workers if _alive(w)] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if _alive(w)]
    partial = [p.name for p in folder.iterdir() if ".partial-" in p.name]
    assert partial == [f".out.partial-{proc.pid}"]
    rerun = _cli("export", "job.toml", "--out", "out", "--until", "panelize", cwd=folder)
    assert rerun.returncode == 0, rerun.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["job.toml", "out", "vault.obj"]


# ---------------------------------------------------------------------------------------------
# exit codes and stderr
# ---------------------------------------------------------------------------------------------
def test_a_script_without_a_main_guard_is_told_to_add_one(tmp_path):
    # fresh (forkserver) workers import the script that started the run; without the guard
    # each runs it again and dies starting workers of its own: a bare BrokenProcessPool before
    script = tmp_path / "no_guard.py"
    script.write_text(
        "from fabpanel.parallel import map_chunks\n"
        "def double(chunk):\n"
        "    return [2 * x for x in chunk]\n"
        "print(sum(map_chunks(double, list(range(40)), 2)))\n"
    )
    run = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        check=False,
    )
    assert run.returncode != 0
    # the traceback ends in the WorkerError line; the interpreter's resource tracker may add a
    # leaked-semaphore warning after it at shutdown (the dead workers' pool), so find the line
    errors = [
        line for line in run.stderr.splitlines() if line.startswith("fabpanel.errors.WorkerError")
    ]
    assert len(errors) == 1, run.stderr[-2000:]
    assert "no_guard.py calls fabpanel at its top level" in errors[0]
    assert 'if __name__ == "__main__":' in errors[0]


def test_library_warnings_become_issues_not_stderr():
    import warnings

    from fabpanel.pipeline import warning_issues

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):
            np.divide(np.zeros(2), np.zeros(2))
    issues = warning_issues("develop", caught)
    assert len(issues) == 1 and issues[0].code == "library-warning"
    assert "3 times" in issues[0].message and "develop" in issues[0].message


def test_writers_side_by_side_share_the_pool_and_stop_together_when_one_fails():
    import threading

    from fabpanel.parallel import shared_pool, side_by_side, worker_pool

    def pool_of_a_writer():
        with worker_pool(2, fresh=True) as pool:
            return pool

    def waits_on_a_worker():
        with worker_pool(2, fresh=True) as pool:
            return pool.submit(time.sleep, 120).result()

    def fails():
        raise RuntimeError("a writer failed")

    with shared_pool(2), side_by_side(2) as lanes, worker_pool(2, fresh=True) as shared:
        assert lanes.start(pool_of_a_writer).result() is shared  # not a pool of its own
    begun = time.monotonic()
    with (
        pytest.raises(RuntimeError, match="a writer failed"),
        shared_pool(2),
        side_by_side(2) as lanes,
    ):
        waiting = lanes.start(waits_on_a_worker)
        time.sleep(0.5)
        lanes.start(fails).result()
    # the waiting writer's worker was stopped, not waited for (it sleeps 120 s)
    assert time.monotonic() - begun < 30
    assert waiting.done()
    assert not [t for t in threading.enumerate() if t.name.startswith("fabpanel-write")]


def test_writers_run_inline_in_order_with_one_worker():
    from fabpanel.parallel import side_by_side

    order: list[int] = []
    with side_by_side(1) as lanes:
        first = lanes.start(order.append, 1)
        assert first.done() and order == [1]
        lanes.start(order.append, 2)
        order.append(3)
    assert order == [1, 2, 3]
