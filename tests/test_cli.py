"""Command line: bad input exits 2 with one line and writes nothing; init; inspect."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fabpanel.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(*args: str):
    return CliRunner().invoke(main, list(args))


def _write_obj(path: Path, vertices, faces) -> Path:
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def _square(path: Path) -> Path:
    return _write_obj(path, [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [(0, 1, 2, 3)])


def _no_surface_step(path: Path) -> Path:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(BRepBuilderAPI_MakeVertex(gp_Pnt(1, 2, 3)).Vertex(), STEPControl_AsIs)
    writer.Write(str(path))
    return path


BAD_INPUTS = {
    "missing file": lambda d: d / "nothing.obj",
    "unknown extension": lambda d: (d / "surface.xyz").write_text("1 2 3") and d / "surface.xyz",
    "empty file": lambda d: (d / "empty.obj").write_text("") or d / "empty.obj",
    "no faces": lambda d: _write_obj(d / "points.obj", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], []),
    "nan coordinates": lambda d: _write_obj(
        d / "nan.obj", [(0, 0, 0), (1, "nan", 0), (0, 1, 0)], [(0, 1, 2)]
    ),
    "infinite coordinates": lambda d: _write_obj(
        d / "inf.obj", [(0, 0, 0), (1, "inf", 0), (0, 1, 0)], [(0, 1, 2)]
    ),
    "face index out of range": lambda d: _write_obj(
        d / "range.obj", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 98)]
    ),
    "binary junk": lambda d: (
        (d / "junk.stl").write_bytes(np.random.default_rng(1).bytes(3000)) and d / "junk.stl"
    ),
    "step without surface": lambda d: _no_surface_step(d / "point.step"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_exits_2_with_one_line_and_writes_nothing(case, tmp_path):
    source = BAD_INPUTS[case](tmp_path)
    out = tmp_path / "out"
    before = set(tmp_path.iterdir())
    result = _run("export", str(source), "--units", "m", "--out", str(out))
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    assert "Traceback" not in result.output
    assert set(tmp_path.iterdir()) == before  # nothing written, no staging left


BAD_JOBS = {
    "unknown key": ('[sandwich]\nrib_heigth = "150 mm"\n', "rib_heigth"),
    "wrong unit": ('[sandwich]\nrib_height = "150 kg"\n', "not a length unit"),
    "missing unit": ("[sandwich]\nrib_height = 150\n", "has no unit"),
    "zero thickness": ('[sandwich]\nsheet_thickness = "0 mm"\n', "sheet_thickness"),
    "negative size": ('[panelize]\npanel_size = "-1 m"\n', "panel_size"),
    "negative plate": ('[cutting]\nplate_length = "-3000 mm"\n', "plate_length"),
}


@pytest.mark.parametrize("case", sorted(BAD_JOBS))
def test_bad_job_exits_2_naming_the_key(case, tmp_path):
    body, fragment = BAD_JOBS[case]
    surface = _square(tmp_path / "square.obj")
    job = tmp_path / "job.toml"
    job.write_text(f'[input]\npath = "{surface.name}"\nunits = "m"\n' + body)
    before = set(tmp_path.iterdir())
    result = _run("export", str(job), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and fragment in lines[0], result.stderr
    assert set(tmp_path.iterdir()) == before


def test_existing_folder_that_is_not_fabpanel_output_is_refused_even_with_force(tmp_path):
    surface = _square(tmp_path / "square.obj")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    for extra in ([], ["--force"]):
        result = _run("export", str(surface), "--units", "m", "--out", str(out), *extra)
        assert result.exit_code == 2 and "not a fabpanel output" in result.stderr
    assert (out / "keep.txt").read_text() == "mine"


def test_mesh_without_units_is_refused(tmp_path):
    surface = _square(tmp_path / "square.obj")
    result = _run("export", str(surface), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2 and "units" in result.stderr


def test_init_writes_each_template(tmp_path):
    for name in ("sandwich-pavilion", "cladding", "barrel-vault"):
        path = tmp_path / f"{name}.toml"
        result = _run("init", "--template", name, str(path))
        assert result.exit_code == 0, result.output
        assert path.read_text().startswith("# fabpanel job")
    assert _run("init", "--template", "nope", str(tmp_path / "x.toml")).exit_code == 2
    assert _run("init", str(tmp_path / "cladding.toml")).exit_code == 2  # exists


def test_inspect_reports_the_barrel_vault(tmp_path):
    result = _run("inspect", str(EXAMPLES / "barrel-vault.obj"), "--units", "m", "--json")
    assert result.exit_code == 0, result.output
    import json

    info = json.loads(result.stdout)
    assert info["openings"] == 0
    assert info["area_m2"] == pytest.approx(np.pi * 4 * 12, rel=2e-3)


def test_python_dash_m_runs():
    result = subprocess.run(
        [sys.executable, "-m", "fabpanel", "--help"], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0 and "export" in result.stdout


def test_a_job_whose_surface_is_missing_names_the_key(tmp_path):
    job = tmp_path / "job.toml"
    job.write_text('[input]\npath = "no_such_file.obj"\nunits = "m"\n')
    result = _run("export", str(job), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "no_such_file.obj: file not found" in lines[0]
    assert "[input] path" in lines[0] and not (tmp_path / "out").exists()


def test_an_issue_line_names_its_item_once():
    from fabpanel.cli import issue_line
    from fabpanel.errors import Issue

    named = Issue("bolt-overloaded", "P001-RIB-0 bolt 0: shear 1.2", "P001-RIB-0", "error")
    assert issue_line(named) == "  issue: P001-RIB-0 bolt 0: shear 1.2"
    bare = Issue("panel-not-built", "not built: OCCT failed", "P002", "error")
    assert issue_line(bare) == "  issue: P002: not built: OCCT failed"


def test_help_and_the_job_load_no_kernel_and_the_stage_names_stay_functions():
    # `fabpanel --help` and `fp.Job` need neither OCCT nor gmsh (their imports took 3-6 s of
    # every --help); the stage functions load on first use, and `fp.panelize` and
    # `fp.develop` stay the functions when their packages are imported by other modules
    script = (
        "import sys, fabpanel as fp, fabpanel.cli\n"
        "heavy = {'OCP', 'build123d', 'gmsh', 'ezdxf', 'trimesh'} & set(sys.modules)\n"
        "assert not heavy, heavy\n"
        "import fabpanel.pipeline\n"
        "assert fp.panelize.__module__ == 'fabpanel.panelize', fp.panelize\n"
        "from fabpanel import develop, run, Model\n"
        "assert not isinstance(develop, type(sys)) and not isinstance(fp.panelize, type(sys))\n"
        "assert run is fp.run and Model.__name__ == 'Model'\n"
        "try:\n    fp.no_such_name\nexcept AttributeError:\n    pass\nelse:\n    raise SystemExit(1)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], check=False, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
