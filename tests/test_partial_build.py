"""One panel that cannot be built: the others are built, checked, cut, nested and analysed.

A 3 x 3 cylinder patch whose centre panel P005 has its developed samples folded back over
themselves (as a user's P263 was: its sheet solid came out with a non-positive volume): the
build refuses the folded grid before any OCCT work, and the build stage reports P005 as an error issue and carries on; the joints and corners P005
shares are left out of the checks that need both panels; cut, nest and the exports work on
the parts there are; the structure stage keeps P005's shell (the panel exists in the design)
and compares the mass of the built panels only.
"""

from __future__ import annotations

import dataclasses
import shutil
import sys
from concurrent.futures.process import BrokenProcessPool

import numpy as np
import pytest
from conftest import cylinder_developed

from fabpanel.errors import KernelError, WorkerError
from fabpanel.flat import cut, nest, validate_nests
from fabpanel.job import Job
from fabpanel.model import build, write_panel_steps
from fabpanel.model.rhino import write_3dm

BAD = "P005"
PER_PANEL = 10  # TOP, BOT, RIB-0..3, STF-0..3

build_module = sys.modules["fabpanel.model.build"]  # the name is shadowed by the function


def _layout() -> tuple:
    return cylinder_developed(n_arc=3, n_len=3, length=3000.0, arc=np.pi / 3 * 1.2)


def _folded(developed):
    """The developed panels with BAD's samples folded back at its middle column."""
    p = developed.panel_ids.index(BAD)
    samples = np.array(developed.samples, copy=True)
    samples[p, :, 5:] = samples[p, :, 3:4][:, ::-1]
    return dataclasses.replace(developed, samples=samples)


@pytest.fixture(scope="module")
def job():
    return Job.from_dict({})


@pytest.fixture(scope="module")
def good():
    return _layout()


@pytest.fixture(scope="module")
def broken(good):
    return _folded(good)


@pytest.fixture(scope="module")
def partial(broken, job):
    return build(broken, job, jobs=1)


def _not_built(model):
    return [i for i in model.issues if i.code == "panel-not-built"]


def test_the_bad_panel_is_an_error_issue_and_the_others_are_built(partial, broken):
    others = [pid for pid in broken.panel_ids if pid != BAD]
    assert sorted({p.panel_id for p in partial.parts}) == others
    assert len(partial.parts) == PER_PANEL * len(others)
    (issue,) = _not_built(partial)
    assert issue.severity == "error" and issue.item == BAD
    # names the panel, the part and the reason
    assert BAD in issue.message and "fold back over themselves" in issue.message
    # the fold is the columns from the middle one on (cells 4-8 of 8)
    assert "columns 4-8" in issue.message
    # nothing else is wrong: the joints and corners with P005 were skipped, not mismeasured
    assert [i.code for i in partial.issues if i.severity != "info"] == ["panel-not-built"]
    metrics = partial.metrics
    assert metrics["panels_built"] == 8 and metrics["panels_not_built"] == 1
    assert list(metrics["not_built"]) == [BAD] and "fold" in metrics["not_built"][BAD]
    assert BAD not in metrics["panels"]
    assert metrics["all_valid"] is True
    assert metrics["clash"]["groups"] == 8 and metrics["clash"]["clashes"] == 0
    # 3 x 3 panels share 20 corner pairs (12 sides, 8 diagonals); P005 is in 8 of them
    assert metrics["clash"]["group_pairs"] == 20 - 8
    assert metrics["max_bolt_coaxial_error_mm"] < 1e-6
    assert metrics["max_sheet_edge_mismatch_mm"] < 0.05
    assert metrics["max_rib_contact_gap_mm"] < 0.01


def test_through_worker_processes_the_same(partial, broken, job):
    calls = []
    parallel = build(broken, job, jobs=2, progress=calls.append)
    assert calls == [1] * 9
    assert [p.id for p in parallel.parts] == [p.id for p in partial.parts]
    assert parallel.issues == partial.issues
    assert parallel.metrics["not_built"] == partial.metrics["not_built"]


def test_cut_nest_and_exports_work_on_the_parts_there_are(partial, broken, job, tmp_path):
    flat = cut(partial, job, jobs=2)
    assert len(flat.parts) == len(partial.parts)
    assert all(p.panel_id != BAD for p in flat.parts)
    assert not [i for i in flat.issues if i.severity == "error"]
    nests = nest(flat, job)
    assert validate_nests(nests, flat, job) == []
    assert nests.metrics["parts_left_out"] == 0 and not nests.issues
    steps = write_panel_steps(partial, tmp_path / "panels")
    assert BAD not in steps and len(steps) == 8
    # the design file draws every panel of the layout, the one not built too
    write_3dm(partial, tmp_path / "design.3dm")
    nan = np.array(broken.samples, copy=True)
    nan[broken.panel_ids.index(BAD), 4, 4] = np.nan  # no B-spline through it
    write_3dm(
        dataclasses.replace(partial, developed=dataclasses.replace(broken, samples=nan)),
        tmp_path / "nan.3dm",
    )
    import rhino3dm

    for name, surfaces in (("design.3dm", 9), ("nan.3dm", 8)):
        doc = rhino3dm.File3dm.Read(str(tmp_path / name))
        layers = [layer.Name for layer in doc.Layers]
        on = [layers[obj.Attributes.LayerIndex] for obj in doc.Objects]
        assert on.count("panels") == surfaces and on.count("labels") == 9


def test_a_layout_whose_every_panel_fails_still_stops(job):
    one = cylinder_developed(n_arc=1, n_len=1)
    samples = np.array(one.samples, copy=True)
    samples[0, :, 5:] = samples[0, :, 3:4][:, ::-1]
    with pytest.raises(
        KernelError, match="no panel could be built; P001: developed samples of P001 fold"
    ):
        build(dataclasses.replace(one, samples=samples), job, jobs=1)


def _die_on_bad(payload):
    import os

    if payload.panel_id == BAD:
        os._exit(3)  # a worker killed (out of memory, a segfault in OCCT)
    return _real_build_or_failure(payload)


# the build's workers are fresh (forkserver): a patch of this process does not reach them, but
# the task's function is pickled by name, so a worker running this one imports this module
_real_build_or_failure = build_module._build_or_failure


def test_a_dead_worker_is_not_a_bad_panel(good, job, monkeypatch):
    monkeypatch.setattr(build_module, "_build_or_failure", _die_on_bad)
    with pytest.raises(WorkerError) as stopped:
        build(good, job, jobs=2)
    assert isinstance(stopped.value.__cause__, BrokenProcessPool)
    assert "worker process stopped" in str(stopped.value)


def test_keyboard_interrupt_is_not_a_bad_panel(good, job, monkeypatch):
    def interrupted(payload, where=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(build_module, "build_panel", interrupted)
    with pytest.raises(KeyboardInterrupt):
        build(good, job, jobs=1)


# --------------------------------------------------------------------------------------------
# structure: the panel exists in the design, its parts do not
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def design_partial(partial, good):
    """The partial model on the unfolded layout: an OCCT failure on a sane panel."""
    return dataclasses.replace(partial, developed=good)


def test_shell_model_keeps_the_panel_and_compares_the_built_mass(design_partial, job):
    from fabpanel.structure.analysis import panels_built, shell_of
    from fabpanel.structure.mesh import built_share

    built = panels_built(design_partial)
    p = design_partial.developed.panel_ids.index(BAD)
    assert not built[p] and built.sum() == 8
    shell = shell_of(design_partial, job)
    sheets = (shell.panel[:, 0] == p) & (shell.side < 0)
    assert sheets.sum() > 0  # its sheets are meshed (and it has no stiffener plates)
    element_mass = shell.density * shell.thickness * shell.element_areas()
    share = built_share(shell, built)
    assert np.all(share[sheets] == 0) and np.all(share[shell.panel[:, 0] != p] > 0)
    # the stiffeners are plates of the built panels (nothing lumped)
    assert shell.lumped_mass is None and "STF" in [g.name for g in shell.groups]
    built_mass = float((element_mass * share).sum())
    # the built panels' part of the shell model against their parts (the 0.5 % of the check)
    assert abs(built_mass / design_partial.mass - 1) < 5e-3
    whole = float(element_mass.sum())
    assert whole / design_partial.mass - 1 > 0.05  # the exclusion matters


@pytest.mark.parametrize("joints", ["bolted", "rigid"])
def test_the_rib_shells_carry_the_rib_plates_mass_and_the_sheets_theirs(
    design_partial, job, joints
):
    """Kind by kind, the built panels' share of the shell model carries their parts' mass: the
    rib shells (each panel's own where bolted; one of twice the thickness on a shared plane
    where rigid) the rib plates', every trim, node cut and hole included; the sheet shells,
    which meet at the rib planes, the sheets'. The panel not built gets the same rates."""
    from fabpanel.structure.analysis import panels_built, shell_of
    from fabpanel.structure.mesh import built_share

    shell = shell_of(design_partial, job.replace(structure={"joints": joints}))
    share = built_share(shell, panels_built(design_partial))
    element_mass = shell.density * shell.thickness * shell.element_areas() * share
    names = np.array([g.name for g in shell.groups])[shell.group]
    parts = design_partial.parts

    def kg(kind):
        return sum(p.mass for p in parts if p.kind == kind)

    ribs = float(element_mass[np.isin(names, ["RIB", "RIB2"])].sum())
    assert ("RIB2" in set(names)) == (joints == "rigid")
    assert ribs == pytest.approx(kg("rib"), rel=1e-9)
    for group, kind in (("TOP", "sheet-top"), ("BOT", "sheet-bottom")):
        assert float(element_mass[names == group].sum()) == pytest.approx(kg(kind), rel=1e-9)
    # the rates: plates a little smaller than their shells (gaps, trims, holes)
    factors = {g.name: g.density_factor for g in shell.groups}
    assert 0.85 < factors["TOP"] < 1.0 and 0.85 < factors["RIB"] < 1.0


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
def test_structure_analyses_the_design_and_checks_the_mass_of_the_built_panels(
    design_partial, job, tmp_path
):
    from fabpanel.structure import analyse

    # the stiffeners as masses: their plates' ties cost CalculiX half as much again, and the
    # plates' mass is tested on its own (tests/test_structure.py)
    structure = analyse(
        design_partial, job.replace(structure={"stiffeners": "mass"}), folder=tmp_path
    )
    s = structure.summary
    assert structure.analysed, s.get("reason")
    assert s["mass"]["ok"] and abs(s["mass"]["error"]) < 5e-3
    assert s["mass"]["panels_not_built"] == [BAD]
    assert s["mass"]["not_built_kg"] > 0
    assert "mass-mismatch" not in [i.code for i in structure.issues]
    assert BAD in s["panels"]


def test_folded_cells_are_those_that_face_back_or_collapse(good):
    from fabpanel.model.panel import folded_cells

    samples, normals = good.samples[0], good.normals[0]
    assert not folded_cells(samples, normals).any()
    # the grid's own turning sense does not matter: read backwards it is still whole
    assert not folded_cells(samples[:, ::-1], normals[:, ::-1]).any()
    folded = np.array(samples, copy=True)
    folded[:, 5] = samples[:, 3]  # column 5 back onto column 3: cells 4 face back
    cells = folded_cells(folded, normals)
    assert cells[:, 4].all() and not np.delete(cells, 4, axis=1).any()
    collapsed = np.array(samples, copy=True)
    collapsed[:, 6] = samples[:, 5]
    cells = folded_cells(collapsed, normals)
    assert cells[:, 5].all() and cells.sum() == cells.shape[0]
