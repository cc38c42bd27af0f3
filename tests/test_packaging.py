"""Packaging: the wheel built from this checkout installs and runs outside the checkout.

The wheel is built without network (``pip wheel --no-deps --no-build-isolation --no-index``)
from a copy of the sources it is made of (pyproject.toml, README.md, fabpanel/; building in the
checkout would leave build/ and an egg-info there) and installed with ``--no-deps --no-index``
into a fresh venv in a temporary folder outside the checkout. The dependencies (build123d/OCP,
numpy, ...) come from the running interpreter's site-packages through a ``.pth`` file in the new
venv: a directory added that way is not a site dir, so its own ``.pth`` files (among them the
editable install of fabpanel) are not processed and the wheel's fabpanel is the one imported,
which is asserted. Every command runs the new venv's ``fabpanel`` from a folder outside the
checkout. About 60 s of CPU: each of the four fresh processes pays the OCP import (~8 s), the
export ~13 s more.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import zipfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ("barrel-vault", "cladding", "sandwich-pavilion")
DEMO_FILES = ("barrel-vault.toml", "barrel-vault.step")


def _setuptools_version() -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in version("setuptools").split(".")[:2])
    except (PackageNotFoundError, ValueError):
        return (0,)


pytestmark = pytest.mark.skipif(
    _setuptools_version() < (68,),
    reason="building the wheel without network needs the build requirement setuptools>=68 in "
    "the test environment (pip install 'setuptools>=68')",
)


def _env(venv: Path) -> dict[str, str]:
    """The environment of a user of the new venv: nothing pointing back at the checkout."""
    drop = {"PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "VIRTUAL_ENV", "PYTHONSAFEPATH"}
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _run(args: list, cwd: Path, env: dict | None = None, check: bool = True):
    done = subprocess.run(
        [str(a) for a in args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if check:
        assert done.returncode == 0, (
            f"{' '.join(map(str, args))} exited {done.returncode}\n"
            f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
        )
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> SimpleNamespace:
    base = tmp_path_factory.mktemp("packaging").resolve()
    assert not base.is_relative_to(ROOT), "the venv must live outside the checkout"
    source = base / "src"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, source / name)
    shutil.copytree(
        ROOT / "fabpanel",
        source / "fabpanel",
        ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info"),
    )
    wheels = base / "wheels"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    _run(
        [
            *pip,
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-w",
            wheels,
            source,
        ],
        cwd=base,
    )
    (wheel,) = wheels.glob("fabpanel-*.whl")

    venv = base / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=base)
    python = venv / "bin" / "python"
    _run([*pip, "--python", python, "install", "-q", "--no-deps", "--no-index", wheel], cwd=base)
    purelib = Path(
        _run(
            [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], cwd=base
        ).stdout.strip()
    )
    # the dependencies, from the running interpreter's site-packages (not copied)
    (purelib / "_fabpanel_test_dependencies.pth").write_text(
        "".join(f"{folder}\n" for folder in site.getsitepackages())
    )
    work = base / "work"  # the user's folder
    work.mkdir()
    return SimpleNamespace(
        wheel=wheel,
        venv=venv,
        python=python,
        purelib=purelib,
        fabpanel=venv / "bin" / "fabpanel",
        work=work,
        env=_env(venv),
    )


def test_wheel_ships_the_templates_and_the_demo(installed):
    names = set(zipfile.ZipFile(installed.wheel).namelist())
    for name in TEMPLATES:
        assert f"fabpanel/templates/{name}.toml" in names
    for name in (*DEMO_FILES, "barrel_vault.py", "__init__.py"):
        assert f"fabpanel/examples/{name}" in names
    # only the package: not the tests, not the top-level example shapes (test fixtures)
    assert all(n.startswith("fabpanel/") or n.split("/")[0].endswith(".dist-info") for n in names)
    assert not [n for n in names if n.endswith((".obj", ".png", ".html"))]
    assert (
        "fabpanel = fabpanel.cli:main"
        in zipfile.ZipFile(installed.wheel)
        .read(next(n for n in names if n.endswith(".dist-info/entry_points.txt")))
        .decode()
    )


_PROBE = """
import json, sys, tomllib
from importlib.resources import files
from pathlib import Path

from click.testing import CliRunner

import fabpanel
from fabpanel import Job, load_surface
from fabpanel.cli import EXAMPLE_DIR, TEMPLATE_DIR, main

demo = files("fabpanel.examples")
job = Job.from_toml(Path(str(demo / "barrel-vault.toml")))
for written in sys.argv[1:]:                     # the files fabpanel init wrote: valid jobs
    Job.from_dict(tomllib.loads(Path(written).read_text(encoding="utf-8")))
print(json.dumps({
    "fabpanel": fabpanel.__file__,
    "template_dir": str(TEMPLATE_DIR), "example_dir": str(EXAMPLE_DIR),
    "templates": sorted(p.name for p in (files("fabpanel") / "templates").iterdir()),
    "demo_files": sorted(p.name for p in demo.iterdir() if p.is_file()),
    "demo_input": str(job.input_path),
    "demo_area_mm2": load_surface(job.input_path, job.input.units).area,
    "demo_help": CliRunner().invoke(main, ["demo", "--help"]).exit_code,
    "unknown_template": CliRunner().invoke(main, ["init", "--template", "nope", "n.toml"]).output,
}))
"""


def _grid_obj(path: Path, nx: int = 9, ny: int = 5) -> Path:
    """A gently curved 2 x 1 m patch (a dome of radius ~12 m), quads, in metres: 2 panels of
    1 m, 20 parts, ~20 s to the cut stage (a 3 x 2 m patch takes ~55 s)."""
    x, y = np.meshgrid(np.linspace(0.0, 2.0, nx), np.linspace(0.0, 1.0, ny), indexing="ij")
    z = 0.3 - ((x - 1.0) ** 2 + (y - 0.5) ** 2) / 24.0
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    quads = np.stack([a, a + ny, a + ny + 1, a + 1], axis=1)
    path.write_text(
        "".join(f"v {px:.6f} {py:.6f} {pz:.6f}\n" for px, py, pz in vertices)
        + "".join("f " + " ".join(str(k + 1) for k in q) + "\n" for q in quads)
    )
    return path


def test_installed_fabpanel_runs_outside_the_checkout(installed):
    work, env, fabpanel = installed.work, installed.env, installed.fabpanel
    assert not work.is_relative_to(ROOT)

    _run([fabpanel, "init"], cwd=work, env=env)
    template = ROOT / "fabpanel" / "templates" / "sandwich-pavilion.toml"
    assert (work / "fabpanel.toml").read_text() == template.read_text()
    _run([fabpanel, "init", "--template", "cladding", "x.toml"], cwd=work, env=env)
    assert (work / "x.toml").read_text().startswith("# fabpanel job")

    probe = _run([installed.python, "-c", _PROBE, "fabpanel.toml", "x.toml"], cwd=work, env=env)
    found = json.loads(probe.stdout.strip().splitlines()[-1])
    package = installed.purelib.resolve() / "fabpanel"
    # the wheel's fabpanel, not the checkout's (editable) one
    assert Path(found["fabpanel"]).resolve() == package / "__init__.py"
    assert Path(found["template_dir"]) == package / "templates"
    assert Path(found["example_dir"]) == package / "examples"
    assert found["templates"] == sorted(f"{name}.toml" for name in TEMPLATES)
    assert set(DEMO_FILES) <= set(found["demo_files"])
    # the demo job's [input] path is relative to the job: its STEP next to it, in the package
    assert Path(found["demo_input"]) == package / "examples" / "barrel-vault.step"
    assert found["demo_area_mm2"] == pytest.approx(np.pi * 4000 * 12000, rel=1e-3)
    assert found["demo_help"] == 0
    assert "cladding" in found["unknown_template"]  # the installed templates are listed

    _grid_obj(work / "patch.obj")
    before = sorted(
        p.relative_to(package) for p in package.rglob("*") if "__pycache__" not in p.parts
    )
    _run(
        [
            fabpanel,
            "export",
            "patch.obj",
            "--units",
            "m",
            "--panel-size",
            "1 m",
            "--until",
            "cut",
            "--jobs",
            "1",
            "--out",
            "out",
        ],
        cwd=work,
        env=env,
    )
    assert (work / "out" / "manifest.json").is_file()
    after = sorted(
        p.relative_to(package) for p in package.rglob("*") if "__pycache__" not in p.parts
    )
    assert after == before  # nothing written into the package
