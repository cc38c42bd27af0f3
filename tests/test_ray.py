"""Per-panel work on Ray (issue 18): a small job run on a local Ray instance that the test
starts (2 CPUs) writes the same files, bit for bit, as the local worker processes; a task's
worker is replaced after ``[run] worker_tasks`` tasks; without Ray the run says how to get it."""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import pytest

import fabpanel as fp
from fabpanel.parallel import executor, worker_pool

DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"


@pytest.fixture(scope="module")
def vault(tmp_path_factory) -> fp.Job:
    from fabpanel.examples.barrel_vault import write_barrel_vault_step

    path = write_barrel_vault_step(
        tmp_path_factory.mktemp("input") / "vault.step", radius=2000.0, length=2400.0
    )
    job = fp.Job.from_toml(DEMO / "barrel-vault.toml")
    job = fp.Job.from_dict({**job.to_dict(), "input": {"path": str(path)}}, base_dir=path.parent)
    return job.replace(panelize={"grid_u": 2, "grid_v": 1}, cutting={"nest_time": "0 s"})


#: files that carry the time they were written (STEP's header, Rhino's file) or timings
STAMPED = (".3dm", ".json", ".html")


def _untimed(value):
    """A summary or manifest without its timings."""
    if isinstance(value, dict):
        return {
            k: _untimed(v)
            for k, v in value.items()
            if k not in ("timings_s", "time_s", "seconds", "versions")
        }
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def _digests(folder: Path) -> dict[str, str]:
    """Every output file's digest: the STEP file's without its header's time stamp and its
    entity numbers, the summary's and manifest's without timings; Rhino's file and the report
    page by name."""
    found = {}
    for path in sorted(folder.rglob("*")):
        if not path.is_file():
            continue
        data = path.read_bytes()
        if path.suffix == ".step":
            # OCCT's writer numbers some entities in an order of memory addresses (colours,
            # assembly usages): the entities, renumbered away, compare as a sorted list
            data = re.sub(rb"FILE_NAME\([^;]*;", b"", data)
            entities = re.sub(rb"#\d+", b"#", re.sub(rb"\s+", b"", data)).split(b";")
            data = b";".join(sorted(entities))
        elif path.suffix == ".json":
            found_json = _untimed(json.loads(data))
            found_json.get("job", {}).pop("run", None)  # the executor: the one change asked
            data = json.dumps(found_json, sort_keys=True).encode()
        elif path.suffix in STAMPED or path.name == "report.pdf":
            # the report (page and PDF) prints the stages' timings
            data = b""
        found[str(path.relative_to(folder))] = hashlib.sha256(data).hexdigest()
    return found


def test_a_ray_run_writes_the_same_files_as_a_local_run(vault, tmp_path):
    pytest.importorskip("ray")
    local = fp.run(vault, out_dir=tmp_path / "local", until="cut", jobs=2)
    remote = fp.run(
        vault.replace(run={"executor": "ray"}),
        out_dir=tmp_path / "ray",
        until="cut",
        jobs=2,
    )
    assert [p.id for p in remote.model.parts] == [p.id for p in local.model.parts]
    assert [p.brep for p in remote.model.parts] == [p.brep for p in local.model.parts]
    ours, theirs = _digests(local.out_dir), _digests(remote.out_dir)
    assert sorted(ours) == sorted(theirs) and len(ours) > 10
    assert ours == theirs


def test_ray_workers_are_replaced_after_their_tasks():
    ray = pytest.importorskip("ray")
    with executor("ray", None, 2, worker_tasks=1, retries=0):
        assert ray.is_initialized()
        with worker_pool(2) as pool:
            pids = [f.result() for f in [pool.submit(os.getpid) for _ in range(4)]]
    assert not ray.is_initialized()  # the instance the run started is shut down
    assert len(set(pids)) == 4  # one task per worker process


def test_without_ray_the_run_says_how_to_install_it(monkeypatch, vault, tmp_path):
    import builtins

    real_import = builtins.__import__

    def no_ray(name, *args, **kwargs):
        if name == "ray":
            raise ImportError("no ray")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ray)
    with pytest.raises(fp.InputError, match=r"fabpanel\[ray\]"):
        fp.run(vault.replace(run={"executor": "ray"}), out_dir=tmp_path / "x", until="panelize")
