"""Fold lines: seams between B-rep faces where the surface kinks are found, the field layout
puts panel sides along them, and a layout that spans one is reported."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from test_surface import write_step

import fabpanel as fp
from fabpanel.panelize.folds import on_folds, panels_across_folds
from fabpanel.surface import describe_surface
from fabpanel.surface.folds import FOLD_DEG, fold_lines

#: the fold: x = FOLD_X mm, the slope along x rising by tan(FOLD_SLOPE_DEG) past it
FOLD_X, FOLD_SLOPE_DEG = 3300.0, 6.0


def _height(x: float, y: float) -> float:
    """mm: a gentle vault across y, kinked along x = FOLD_X (mm)."""
    crown = 1200.0 - 0.05 * (y - 3000.0) ** 2 / 1000.0
    return crown + math.tan(math.radians(FOLD_SLOPE_DEG)) * max(0.0, x - FOLD_X)


def _fading(x: float, y: float) -> float:
    """mm: the vault kinked by 8° along x = FOLD_X at y = 0, the kink fading smoothly to none
    at y = 3 m (where it ends, the seams beyond it smooth)."""
    crown = 1200.0 - 0.05 * (y - 3000.0) ** 2 / 1000.0
    fade = (max(0.0, 3000.0 - y) / 3000.0) ** 2
    return crown + math.tan(math.radians(8.0)) * max(0.0, x - FOLD_X) * fade


def _chamfered(x: float, y: float) -> float:
    """mm: the vault with a 150 mm strip rising at 8° across it at x = FOLD_X (a chamfer
    face: two folds 150 mm apart)."""
    crown = 1200.0 - 0.05 * (y - 3000.0) ** 2 / 1000.0
    return crown + math.tan(math.radians(8.0)) * min(max(0.0, x - FOLD_X), 150.0)


def _face(x0: float, x1: float, y0: float = 0.0, y1: float = 6000.0, height=_height):
    from OCP.Approx import Approx_ParametrizationType
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.collections import Array2_gp_Pnt as TColgp_Array2OfPnt
    from OCP.GeomAPI import GeomAPI_PointsToBSplineSurface
    from OCP.gp import gp_Pnt

    nu, nv = 9, 13
    grid = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i in range(nu):
        x = x0 + (x1 - x0) * i / (nu - 1)
        for j in range(nv):
            y = y0 + (y1 - y0) * j / (nv - 1)
            grid.SetValue(i + 1, j + 1, gp_Pnt(x, y, height(x, y)))
    fit = GeomAPI_PointsToBSplineSurface()
    fit.Interpolate(grid, Approx_ParametrizationType.Approx_IsoParametric, False)
    return BRepBuilderAPI_MakeFace(fit.Surface(), 1e-6).Face()


@pytest.fixture(scope="module")
def folded_roof(tmp_path_factory) -> Path:
    """An 8 x 6 m roof of three faces: a smooth seam at x = 1.5 m, a 6° fold at 3.3 m."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    sewing = BRepBuilderAPI_Sewing(0.01)
    for x0, x1 in ((0.0, 1500.0), (1500.0, FOLD_X), (FOLD_X, 8000.0)):
        sewing.Add(_face(x0, x1))
    sewing.Perform()
    return write_step(tmp_path_factory.mktemp("fold") / "folded.step", sewing.SewedShape())


@pytest.fixture(scope="module")
def fading_fold(tmp_path_factory) -> Path:
    """Three faces meeting at (FOLD_X, 3 m): the fold between the first two fades out there."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    sewing = BRepBuilderAPI_Sewing(0.1)
    for box in (
        (0.0, FOLD_X, 0.0, 6000.0),
        (FOLD_X, 8000.0, 0.0, 3000.0),
        (FOLD_X, 8000.0, 3000.0, 6000.0),
    ):
        sewing.Add(_face(*box, height=_fading))
    sewing.Perform()
    return write_step(tmp_path_factory.mktemp("fade") / "fading.step", sewing.SewedShape())


@pytest.fixture(scope="module")
def chamfered(tmp_path_factory) -> Path:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    sewing = BRepBuilderAPI_Sewing(0.1)
    for x0, x1 in ((0.0, FOLD_X), (FOLD_X, FOLD_X + 150.0), (FOLD_X + 150.0, 8000.0)):
        sewing.Add(_face(x0, x1, height=_chamfered))
    sewing.Perform()
    return write_step(tmp_path_factory.mktemp("chamfer") / "chamfered.step", sewing.SewedShape())


def _job(path: Path, method: str) -> fp.Job:
    return fp.Job.for_input(path, panelize={"method": method, "panel_size": "1 m"})


def test_a_kinked_seam_is_a_fold_and_a_smooth_one_is_not(folded_roof):
    surface = fp.load_surface(folded_roof)
    assert len(surface.folds) == 1
    chain = surface.folds[0]
    world = surface.vertices[chain] + surface.origin
    np.testing.assert_allclose(world[:, 0], FOLD_X, atol=0.01)
    assert np.ptp(world[:, 1]) == pytest.approx(6000.0, abs=0.01)  # boundary to boundary
    rim = np.concatenate(surface.boundary_loops)
    assert {int(chain[0]), int(chain[-1])} <= set(rim.tolist())
    (line,) = describe_surface(surface)["fold_lines"]
    assert line["largest_fold_deg"] == pytest.approx(FOLD_SLOPE_DEG, abs=1.0)
    # along the crown's parabola, 6 m across: a little longer than the chord
    assert 6000.0 < line["length_mm"] < 6100.0


def test_fold_lines_need_a_kink_along_the_seam():
    """Two strips of triangles meeting along y = 0 at an angle, each its own face: a fold
    above FOLD_DEG, none below it, and none where the faces are one."""
    x = np.arange(6.0)
    for angle, folds in ((FOLD_DEG * 1.5, 1), (FOLD_DEG * 0.5, 0)):
        lift = np.tan(np.radians(angle))
        rows = [
            np.column_stack([x, np.full(6, y), lift * max(y, 0.0) * np.ones(6)]) for y in (-1, 0, 1)
        ]
        vertices = np.concatenate(rows)
        quads = [
            (r * 6 + i, r * 6 + i + 1, (r + 1) * 6 + i + 1, (r + 1) * 6 + i)
            for r in (0, 1)
            for i in range(5)
        ]
        triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
        faces = np.repeat([0, 1], 10)
        found = fold_lines(vertices, triangles, faces)
        assert len(found) == folds
        if folds:
            np.testing.assert_array_equal(np.sort(found[0]), np.arange(6, 12))
        assert fold_lines(vertices, triangles, np.zeros(20, dtype=int)) == ()


def test_the_field_layout_puts_panel_sides_along_the_fold(folded_roof):
    surface = fp.load_surface(folded_roof)
    layout = fp.panelize(surface, _job(folded_roof, "field"))
    gates = layout.metrics["gates"]
    assert gates["fold_lines"] == 1 and gates["panels_across_folds"] == []
    assert gates["passed"], gates["failed"]
    on = np.flatnonzero(on_folds(layout.vertices, surface))
    assert len(on) >= 6  # 6 m of fold at 1 m panels: both ends and the vertices between
    # consecutive vertices along the fold are joined by panel sides
    order = on[np.argsort(layout.vertices[on, 1])]
    sides = {tuple(sorted(edge)) for edge in layout.edges.tolist()}
    assert all(tuple(sorted(pair)) in sides for pair in itertools.pairwise(order))


def test_a_layout_across_the_fold_is_reported(folded_roof):
    surface = fp.load_surface(folded_roof)
    layout = fp.panelize(surface, _job(folded_roof, "grid"))
    across = panels_across_folds(layout, surface, 1000.0)
    assert len(across) > 0
    found = [i for i in layout.issues if i.code == "layout-crosses-fold"]
    assert len(found) == 1 and found[0].severity == "warning"
    assert layout.panel_ids[across[0]] in found[0].message
    assert 'method = "field"' in found[0].message
    assert "layout-crosses-fold" in layout.metrics["gates"]["failed"]


def test_a_fold_that_fades_out_inside_is_followed_as_far_as_it_runs(fading_fold):
    surface = fp.load_surface(fading_fold)
    assert len(surface.folds) == 1
    ends = surface.vertices[surface.folds[0][[0, -1]]] + surface.origin
    np.testing.assert_allclose(sorted(ends[:, 1]), [0.0, 3000.0], atol=0.01)
    grid = fp.panelize(surface, _job(fading_fold, "grid"))
    assert len(panels_across_folds(grid, surface, 1000.0)) > 0
    layout = fp.panelize(surface, _job(fading_fold, "auto"))
    assert layout.method == "field"
    assert layout.metrics["gates"]["passed"], layout.metrics["gates"]["failed"]
    assert len(panels_across_folds(layout, surface, 1000.0)) == 0
    assert on_folds(layout.vertices, surface).sum() >= 3


def test_folds_closer_than_a_panel_is_wide_are_smoothed_across(chamfered):
    """Followed, the two folds of a 150 mm chamfer face make a row of 150 mm slivers (an
    error); the layout across them is kept, and says it crosses them."""
    surface = fp.load_surface(chamfered)
    assert len(surface.folds) == 2
    layout = fp.panelize(surface, _job(chamfered, "field"))
    folds = layout.metrics["folds"]
    assert not folds["followed"] and folds["scores"]["across"] > folds["scores"]["along"]
    assert not [i for i in layout.issues if i.severity == "error"]
    assert "layout-crosses-fold" in layout.metrics["gates"]["failed"]


def test_panels_either_side_of_the_fold_develop(folded_roof):
    """Each side of the fold is a smooth surface: the global optimiser makes every panel
    developable, close to the design, where a panel across the 6° kink cannot be."""
    surface = fp.load_surface(folded_roof)
    job = _job(folded_roof, "field").replace(develop={"method": "global", "samples": 7})
    layout = fp.panelize(surface, job)
    developed = fp.develop(layout, surface, job)
    metrics = developed.metrics
    assert metrics["panels_not_developable"] == 0
    assert metrics["unroll_strain"]["max"] <= job.develop.strain_tolerance
    assert metrics["deviation_mm"]["max"] < 5.0
