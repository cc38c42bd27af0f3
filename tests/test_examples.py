"""The example shapes: each generator gives a valid design surface of the intended topology."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from fabpanel import Job
from fabpanel.surface import describe_surface, load_surface

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _shapes():
    spec = importlib.util.spec_from_file_location("example_shapes", EXAMPLES / "shapes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


shapes = _shapes()


def _xy_signed_areas(surface) -> np.ndarray:
    tri = surface.vertices[surface.faces]
    a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
    return 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )


# generator, coarse resolution for speed, boundary loops expected
CASES = {
    "one-opening": (lambda p: shapes.write_one_opening(p, spacing=0.6), 2),
    "pavilion": (lambda p: shapes.write_pavilion(p, spacing=0.6, rim_points=24), 4),
    "formfound": (lambda p: shapes.write_formfound(p, divisions=12), 1),
    "patch": (lambda p: shapes.write_patch_obj(p, nx=10, ny=8), 1),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_generator_gives_valid_surface(tmp_path, name):
    write, loops = CASES[name]
    surface = load_surface(write(tmp_path / f"{name}.obj"), "m")
    info = describe_surface(surface)
    assert info["boundary_loops"] == loops
    assert info["manifold"]
    assert surface.area > 50e6  # tens of m2, in mm2
    # a graph over XY, wound counter-clockwise seen from above after loading (outer side up)
    signed = _xy_signed_areas(surface)
    assert np.all(signed > 0) or np.all(signed < 0)


def test_pavilion_rims_stand_on_the_ground_and_flare(tmp_path):
    surface = load_surface(
        shapes.write_pavilion(tmp_path / "p.obj", spacing=0.6, rim_points=24), "m"
    )
    size = np.ptp(surface.vertices, axis=0)
    assert 18_000 < size[0] < 23_000 and 18_000 < size[1] < 23_000  # about 20 m across
    assert 5_000 < size[2] < 6_000  # 5-6 m high
    for loop in surface.boundary_loops[1:]:
        rim = surface.vertices[loop]
        np.testing.assert_allclose(rim[:, 2], 0.0, atol=50.0)  # within 0.05 m
        radius = np.linalg.norm(rim[:, :2] - rim[:, :2].mean(axis=0), axis=1)
        np.testing.assert_allclose(radius, shapes.SUPPORT_RADIUS * 1000, rtol=1e-3)
    # trumpets: 1.5 m beyond each rim the shell is already well above the ground
    centres = shapes.pavilion_supports()
    z = shapes.pavilion_height(centres[:, 0] + shapes.SUPPORT_RADIUS + 1.5, centres[:, 1])
    assert np.all(z > 3.0)
    assert len(surface.faces) > 1000


def test_default_pavilion_is_fine_enough_and_small_enough():
    vertices, triangles = shapes.pavilion_mesh()
    assert 5_000 <= len(triangles) <= 15_000
    assert vertices[:, 2].min() == 0.0


def test_formfound_is_four_sided_and_rises_4_m(tmp_path):
    from fabpanel.panelize.grid import is_four_sided

    surface = load_surface(shapes.write_formfound(tmp_path / "f.obj", divisions=12), "m")
    assert is_four_sided(surface, 30.0)
    assert np.ptp(surface.vertices[:, 2]) == pytest.approx(4000.0, abs=1e-6)
    # supports at the four corners, at z = 0
    corners = surface.vertices[np.abs(surface.vertices[:, :2]).min(axis=1) > 6999.0]
    assert len(corners) == 4
    np.testing.assert_allclose(corners[:, 2], 0.0, atol=1e-9)


def test_patch_step_is_one_exact_face(tmp_path):
    from fabpanel.surface import SurfaceQuery

    surface = load_surface(shapes.write_patch_step(tmp_path / "patch.step"))
    query = SurfaceQuery(surface)
    assert query.face_count == 1 and len(surface.boundary_loops) == 1
    # the bicubic interpolation reproduces the quadratic saddle (between the grid points too)
    x, y = np.meshgrid(np.linspace(-4.9, 4.9, 7), np.linspace(-3.9, 3.9, 5))
    exact = np.stack([x, y, shapes.patch_height(x, y)], axis=-1).reshape(-1, 3) * 1000.0
    _, normals, distance = query.closest(exact - surface.origin)  # the surface is local
    np.testing.assert_allclose(distance, 0.0, atol=1e-3)
    assert np.all(normals[:, 2] > 0)  # outer side up


@pytest.mark.parametrize("name", sorted(shapes.JOBS))
def test_job_files_are_valid_and_current(name):
    path = EXAMPLES / f"{name}.toml"
    assert path.read_text() == shapes.job_text(name), "run python examples/shapes.py"
    job = Job.from_toml(path)
    assert job.panelize.method == "auto"
    assert 1000.0 <= job.panelize.panel_size <= 1200.0
    assert job.cutting.nest_time == 0.0
    assert (EXAMPLES / job.input.path).is_file()


def test_committed_example_files_are_small():
    for name in ("one-opening.obj", "pavilion.obj", "formfound.obj", "patch.obj", "patch.step"):
        assert (EXAMPLES / name).stat().st_size < 400_000
