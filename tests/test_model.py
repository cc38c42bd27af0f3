"""Build stage on analytic cylinder panels: ids, validity, volumes, rib planes, STEP round trip."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import cylinder_developed

from fabpanel.errors import KernelError
from fabpanel.geom.polygon import polygon_area
from fabpanel.job import Job
from fabpanel.model import (
    build,
    occ,
    read_step_parts,
    write_glb,
    write_panel_steps,
    write_step_assembly,
)
from fabpanel.model.build import buildup_offsets, clip_polyline

R, LENGTH, ARC = 4000.0, 2400.0, np.pi / 3


@pytest.fixture(scope="module")
def developed():
    return cylinder_developed(radius=R, length=LENGTH, arc=ARC)


@pytest.fixture(scope="module")
def job():
    return Job.from_dict({})


@pytest.fixture(scope="module")
def model(developed, job):
    return build(developed, job, jobs=1)


def _world(part):
    pts = part.outline
    return (np.c_[pts, np.zeros(len(pts)), np.ones(len(pts))] @ part.frame.T)[:, :3]


def test_parts_ids_kinds_and_order(model):
    ids = [p.id for p in model.parts]
    expected = [f"P00{i}-{s}" for i in range(1, 5)
                for s in ("TOP", "BOT", "RIB-0", "RIB-1", "RIB-2", "RIB-3")]
    assert ids == expected
    kinds = {p.id: p.kind for p in model.parts}
    assert kinds["P001-TOP"] == "sheet-top" and kinds["P003-BOT"] == "sheet-bottom"
    assert kinds["P004-RIB-2"] == "rib"
    assert model.metrics["counts"] == {"sheet-top": 4, "sheet-bottom": 4, "rib": 16}
    assert model.issues == ()


def test_every_solid_valid(model):
    assert model.metrics["all_valid"] is True
    for part in model.parts:
        assert occ.is_valid(occ.from_brep(part.brep)), part.id


def test_top_sheet_volume_is_cylindrical_shell(model, job):
    t = job.sandwich.sheet_thickness
    angle, length = ARC / 2, LENGTH / 2
    shell = angle / 2 * (R ** 2 - (R - t) ** 2) * length
    for part in model.parts:
        if part.kind == "sheet-top":
            np.testing.assert_allclose(part.volume, shell, rtol=1e-3)
            np.testing.assert_allclose(part.mass, part.volume * job.material.density)
    # bottom sheet: between R - t - h and R - t - h - b
    top_in = R - t - job.sandwich.rib_height
    bot = angle / 2 * (top_in ** 2 - (top_in - job.sandwich.bottom_thickness) ** 2) * length
    np.testing.assert_allclose(model.parts[1].volume, bot, rtol=1e-3)
    # area of the mid-surface
    np.testing.assert_allclose(model.parts[0].area, angle * (R - t / 2) * length, rtol=1e-4)


def test_sheet_fit_and_mid_fibre_grid(model, job):
    assert model.metrics["max_sheet_fit_error_mm"] < 1e-6
    t = job.sandwich.sheet_thickness
    top = model.parts[0]
    grid = top.surface_grid
    assert grid.shape == (33, 33, 3)
    np.testing.assert_allclose(np.hypot(grid[..., 1], grid[..., 2]), R - t / 2, atol=0.01)
    # side convention: corners of the developed grid, moved to the mid fibre
    samples = model.developed.samples[0]
    for (i, j), (a, b) in zip([(0, 0), (-1, 0), (-1, -1), (0, -1)],
                              [(0, 0), (-1, 0), (-1, -1), (0, -1)]):
        corner = samples[i, j] * np.array([1.0, (R - t / 2) / R, (R - t / 2) / R])
        np.testing.assert_allclose(grid[a, b], corner, atol=1e-6)


def test_ribs_planar_and_inside_their_plane(model, developed, job):
    assert model.metrics["max_rib_planarity_mm"] < 0.05
    t_rib = job.sandwich.rib_thickness
    for p, pid in enumerate(developed.panel_ids):
        for s in range(4):
            rib = model.parts[6 * p + 2 + s]
            assert rib.id == f"{pid}-RIB-{s}"
            plane = developed.side_planes[p, s]
            dist = occ.plane_distances(occ.from_brep(rib.brep), plane)
            assert dist.min() > -0.05 and dist.max() < t_rib + 0.05
            # outer face exactly in the plane
            assert np.abs(_world(rib) @ plane[:3] - plane[3]).max() < 0.05
            assert polygon_area(rib.outline) > 0
            np.testing.assert_allclose(rib.area, polygon_area(rib.outline))
            np.testing.assert_allclose(rib.volume, rib.area * t_rib, rtol=1e-3)


def test_back_to_back_ribs_share_their_outer_plane(model, developed):
    neighbours = developed.layout.side_neighbours
    pairs = 0
    for p, pid in enumerate(developed.panel_ids):
        for s in range(4):
            q = neighbours[p, s]
            if q < 0:
                continue
            t = [t for t in range(4) if neighbours[q, t] == p][0]
            a = model.parts[6 * p + 2 + s]
            b = model.parts[6 * q + 2 + t]
            plane = developed.side_planes[q, t]
            assert np.abs(_world(a) @ plane[:3] - plane[3]).max() <= 0.1
            # normals opposite: the ribs stand back to back, not through each other
            assert developed.side_planes[p, s, :3] @ plane[:3] < -0.999
            assert occ.common_volume(occ.from_brep(a.brep), occ.from_brep(b.brep)) < 1.0
            pairs += 1
    assert pairs == 8
    assert model.metrics["max_rib_contact_gap_mm"] <= 0.1


def test_ribs_of_one_panel_do_not_overlap(model):
    ribs = [occ.from_brep(p.brep) for p in model.parts_of("P001") if p.kind == "rib"]
    for s in range(4):
        assert occ.common_volume(ribs[s], ribs[(s + 1) % 4]) < 1.0


def test_step_assembly_round_trip(model, tmp_path):
    path = write_step_assembly(model, tmp_path / "assembly.step")
    shapes = read_step_parts(path)
    assert sorted(shapes) == sorted(p.id for p in model.parts)
    for part in model.parts:
        assert occ.is_valid(shapes[part.id]), part.id
        np.testing.assert_allclose(occ.volume(shapes[part.id]), part.volume, rtol=1e-3)
    files = write_panel_steps(model, tmp_path / "panels")
    assert files == {pid: f"{pid}.step" for pid in model.developed.panel_ids}
    assert sorted(read_step_parts(tmp_path / "panels" / "P002.step")) == \
        sorted(p.id for p in model.parts_of("P002"))
    glb = write_glb(model, tmp_path / "preview.glb")
    assert glb.read_bytes()[:4] == b"glTF"


def test_cladding_gives_top_sheets_only(developed, job):
    clad = build(developed, job.replace(sandwich={"buildup": "cladding"}), jobs=1)
    assert [p.id for p in clad.parts] == [f"P00{i}-TOP" for i in range(1, 5)]
    assert clad.metrics["counts"] == {"sheet-top": 4}


def test_buildup_offsets(job):
    t, h, b = 3.0, 150.0, 3.0
    assert buildup_offsets(job) == {"top_outer": 0.0, "top_inner": -t, "bottom_upper": -t - h,
                                    "bottom_lower": -t - h - b}
    low = buildup_offsets(job.replace(sandwich={"design_face": "bottom-outer"}))
    assert low["bottom_lower"] == pytest.approx(0.0) and low["top_outer"] == t + h + b
    mid = buildup_offsets(job.replace(sandwich={"design_face": "middle"}))
    assert mid["top_outer"] == pytest.approx(-mid["bottom_lower"])


def test_bottom_outer_design_face_and_outer_fibre():
    d = cylinder_developed(n_arc=1, n_len=1)
    job = Job.from_dict({"sandwich": {"design_face": "bottom-outer"},
                         "cutting": {"neutral_fibre": "outer"}})
    model = build(d, job, jobs=1)
    bot = model.parts[1].surface_grid
    depth = job.sandwich.total_depth
    # outer fibre of the bottom sheet = its upper face, bottom thickness above the design face
    np.testing.assert_allclose(np.hypot(bot[..., 1], bot[..., 2]),
                               R + job.sandwich.bottom_thickness, atol=0.01)
    top = model.parts[0].surface_grid
    np.testing.assert_allclose(np.hypot(top[..., 1], top[..., 2]), R + depth, atol=0.01)


def test_parallel_build_matches_inline(model, developed, job):
    calls = []
    parallel = build(developed, job, jobs=2, progress=calls.append)
    assert calls == [1, 1, 1, 1]
    assert [p.id for p in parallel.parts] == [p.id for p in model.parts]
    np.testing.assert_allclose([p.volume for p in parallel.parts],
                               [p.volume for p in model.parts], rtol=1e-12)


def test_clip_polyline_cuts_on_the_line():
    line = np.c_[np.linspace(0, 10, 11), np.zeros(11)]
    clipped = clip_polyline(line, np.array([1.0, 0.0]), 2.5)
    assert clipped[0, 0] == pytest.approx(2.5) and clipped[-1, 0] == 10
    assert len(clip_polyline(line, np.array([1.0, 0.0]), 20.0)) == 0


def test_kernel_error_names_the_part():
    grid = np.zeros((3, 3, 3))
    grid[..., 0] = np.nan
    with pytest.raises(KernelError, match="P099-TOP"):
        occ.bspline_surface(grid, "P099-TOP")
