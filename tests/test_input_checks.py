"""Load-time checks of the design surface: self-intersections, creases, separate pieces, unwelded
seams, each refused with one line naming the file, the place (input units) and the fix.

Every fixture is generated here: small OBJ meshes, and STEP files written with build123d/OCCT.
"""

from __future__ import annotations

import re
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fabpanel import Job
from fabpanel.errors import InputError
from fabpanel.surface import load_surface
from fabpanel.surface.checks import (
    CREASE_ANGLE,
    check_surface,
    fold_angles,
    format_point,
    self_intersections,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE_DIRS = (ROOT / "examples", ROOT / "fabpanel" / "examples")
_POINT = re.compile(r"\((-?\d+(?:\.\d+)?), (-?\d+(?:\.\d+)?), (-?\d+(?:\.\d+)?)\)")


# --------------------------------------------------------------------------------------------
# fixture writers
# --------------------------------------------------------------------------------------------
def write_obj(path: Path, *patches: tuple[np.ndarray, np.ndarray], digits: int = 9) -> Path:
    """OBJ of one or more patches, each with its own vertex list (as separate objects are
    exported: vertices on a common edge are written once per patch)."""
    lines, offset = [], 0
    for number, (vertices, faces) in enumerate(patches):
        lines.append(f"o patch{number}")
        lines += [f"v {x:.{digits}g} {y:.{digits}g} {z:.{digits}g}" for x, y, z in vertices]
        lines += ["f " + " ".join(str(offset + i + 1) for i in face) for face in faces]
        offset += len(vertices)
    path.write_text("\n".join(lines) + "\n")
    return path


def grid_triangles(nu: int, nv: int) -> np.ndarray:
    """(2 nu nv, 3) triangles of a (nu + 1) x (nv + 1) point grid, row-major."""
    ids = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
    return np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )


def sweep(profile: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A sheet swept along y: ``profile (k, 2)`` x, z points; returns vertices and triangles."""
    vertices = np.array([(x, y, z) for x, z in profile for y in ys], dtype=float)
    return vertices, grid_triangles(len(profile) - 1, len(ys) - 1)


def points_in(message: str) -> np.ndarray:
    return np.array([[float(x) for x in match] for match in _POINT.findall(message)])


def assert_one_line(message: str, name: str) -> None:
    assert message.startswith(f"{name}: ") and "\n" not in message


def write_step(path: Path, shape, unit: str = "MM") -> Path:
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Controller, STEPControl_Writer

    STEPControl_Controller.Init_s()
    Interface_Static.SetCVal_s("write.step.unit", unit)
    try:
        writer = STEPControl_Writer()
        writer.Transfer(shape, STEPControl_AsIs)
        assert writer.Write(str(path)) == IFSelect_ReturnStatus.IFSelect_RetDone
    finally:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
    return path


def polygon_face(points):
    import build123d as bd

    return bd.Face(bd.Wire.make_polygon([bd.Vector(*p) for p in points]))


# --------------------------------------------------------------------------------------------
# 1. self-intersections
# --------------------------------------------------------------------------------------------
def looping_sheet(scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth sheet whose profile (a prolate cycloid) loops through itself; 4 x 2 m."""
    t = np.linspace(-np.pi, np.pi, 121)
    profile = np.stack([0.7 * (t - 1.9 * np.sin(t)), 0.7 * (1.0 - 1.9 * np.cos(t))], axis=1)
    vertices, faces = sweep(profile, np.linspace(0.0, 2.0, 9))
    return vertices * scale, faces


def test_sheet_looping_through_itself_is_refused(tmp_path):
    vertices, faces = looping_sheet()
    _, angles = fold_angles(vertices, faces)
    assert angles.max() < CREASE_ANGLE  # smooth: no crease on the way
    path = write_obj(tmp_path / "loop.obj", (vertices, faces))
    with pytest.raises(InputError, match="passes through itself") as info:
        load_surface(path, "m")
    message = str(info.value)
    assert_one_line(message, "loop.obj")
    assert "remove the fold or overlap in the modeller" in message
    # the profile crosses itself where x(t) = x(-t) = 0: t = 1.9 sin t, z = 0.7 (1 - 1.9 cos t)
    from scipy.optimize import brentq

    t = brentq(lambda t: t - 1.9 * np.sin(t), 1.0, 3.0)
    point = points_in(message)[0]
    np.testing.assert_allclose(point[[0, 2]], [0.0, 0.7 * (1 - 1.9 * np.cos(t))], atol=0.02)
    assert 0.0 <= point[1] <= 2.0
    assert re.search(r"near \([^)]*\) m;", message)


def two_crossing_patches(scale: float) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """A flat strip and a patch sharing its edge x = 0, curling up and back down through it.

    The curl continues the strip smoothly (an arc of radius 0.65 m, then a vertical straight), so
    nothing but the crossing (along x = 0.65 m, z = 0) is wrong. Sample positions avoid placing
    the crossing exactly on an edge of either patch.
    """
    ys = np.linspace(0.0, 1.0, 5)
    strip = sweep(np.stack([np.linspace(0.0, 2.0, 9), np.zeros(9)], axis=1), ys)
    theta = np.linspace(0.0, 1.5 * np.pi, 25)
    arc = np.stack([-0.65 * np.sin(theta), 0.65 - 0.65 * np.cos(theta)], axis=1)
    down = np.stack([np.full(6, 0.65), np.linspace(0.65, -0.35, 7)[1:]], axis=1)
    curl = sweep(np.vstack([arc, down]), ys)
    return tuple((vertices * scale, faces) for vertices, faces in (strip, curl))


def test_crossing_patches_sharing_an_edge_are_refused_in_mm(tmp_path):
    path = write_obj(tmp_path / "crossing.obj", *two_crossing_patches(1000.0))
    with pytest.raises(InputError, match="passes through itself") as info:
        load_surface(path, "mm")
    message = str(info.value)
    assert_one_line(message, "crossing.obj")
    point = points_in(message)[0]
    np.testing.assert_allclose(point[[0, 2]], [650.0, 0.0], atol=1.0)  # mm, as declared
    assert re.search(r"near \([^)]*\) mm;", message)


def test_cli_export_exits_2_with_the_one_line(tmp_path):
    from click.testing import CliRunner

    from fabpanel.cli import main

    path = write_obj(tmp_path / "loop.obj", looping_sheet())
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["export", str(path), "--units", "m", "--out", str(out)])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "loop.obj: the surface passes through itself" in lines[0]
    assert not out.exists()


def test_the_same_patches_not_crossing_load(tmp_path):
    """Control: shorten the straight so that it stops above the strip: loads (one piece)."""
    strip, curl = two_crossing_patches(1.0)
    keep = curl[0][:, 2] > 0.1  # rows of the curl above z = 0.1 m
    rows = int(keep.sum()) // 5
    curl = (curl[0][: rows * 5], grid_triangles(rows - 1, 4))
    surface = load_surface(write_obj(tmp_path / "curl.obj", strip, curl), "m")
    assert len(surface.boundary_loops) == 1


def test_self_intersections_of_single_triangles():
    base = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    pierce = np.array([[0.5, 0.5, -1.0], [0.6, 0.5, 1.0], [3.0, 3.0, 1.0]])
    vertices = np.vstack([base, pierce])
    pairs, points = self_intersections(vertices, np.array([[0, 1, 2], [3, 4, 5]]))
    np.testing.assert_array_equal(pairs, [[0, 1]])
    np.testing.assert_allclose(points[0], [0.55, 0.5, 0.0])
    # touching (a corner on the other's plane) is not crossing
    touch = pierce.copy()
    touch[0, 2] = 0.0
    pairs, _ = self_intersections(np.vstack([base, touch]), np.array([[0, 1, 2], [3, 4, 5]]))
    assert len(pairs) == 0
    # triangles with a common vertex never count
    fan = np.vstack([base, pierce[1:]])
    pairs, _ = self_intersections(fan, np.array([[0, 1, 2], [0, 3, 4]]))
    assert len(pairs) == 0


# --------------------------------------------------------------------------------------------
# 2. creases
# --------------------------------------------------------------------------------------------
def folded_plate(angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """2 x 1 m plate folded along x = 1 m by ``angle_deg`` (0 = flat), metres."""
    fold = np.radians(angle_deg)
    s = np.linspace(0.0, 2.0, 9)
    x = np.where(s <= 1.0, s, 1.0 + (s - 1.0) * np.cos(fold))
    z = np.where(s <= 1.0, 0.0, (s - 1.0) * np.sin(fold))
    return sweep(np.stack([x, z], axis=1), np.linspace(0.0, 1.0, 5))


def test_mesh_crease_is_refused_and_crease_angle_lets_it_pass(tmp_path):
    path = write_obj(tmp_path / "fold.obj", folded_plate(60.0))
    with pytest.raises(InputError, match="crease") as info:
        load_surface(path, "m")
    message = str(info.value)
    assert_one_line(message, "fold.obj")
    assert "60 degrees" in message and "crease_angle = 45" in message
    assert "along 4 edges from (1.00, 0.00, 0.00) to (1.00, 1.00, 0.00) m" in message
    assert (
        "split the surface into separate jobs along the crease, or raise [input] "
        "crease_angle if the fold is intended and smooth"
    ) in message
    assert load_surface(path, "m", crease_angle=61.0).faces.shape == (64, 3)
    # a gentle fold passes at the default
    load_surface(write_obj(tmp_path / "gentle.obj", folded_plate(30.0)), "m")


def right_angle_faces(split_edge: bool = False):
    """Two planar faces meeting at 90 degrees along y = 1000 mm, z = 0, x = 0..2000 mm.

    split_edge: the vertical face has an extra corner in the middle of the common edge, so the
    two faces are tessellated with different points along it (an unsewn B-rep seam).
    """
    floor = polygon_face([(0, 0, 0), (2000, 0, 0), (2000, 1000, 0), (0, 1000, 0)])
    wall = [(0, 1000, 0), (2000, 1000, 0), (2000, 1000, 1000), (0, 1000, 1000)]
    if split_edge:
        wall.insert(1, (700, 1000, 0))
    return floor, polygon_face(wall)


@pytest.mark.parametrize(
    "unit, corners",
    [
        ("MM", "from (0, 1000, 0) to (2000, 1000, 0) mm"),
        ("M", "from (0.00, 1.00, 0.00) to (2.00, 1.00, 0.00) m"),
    ],
)
def test_step_crease_between_two_faces_is_refused(tmp_path, unit, corners):
    import build123d as bd

    path = write_step(tmp_path / "corner.step", bd.Shell(right_angle_faces()).wrapped, unit)
    with pytest.raises(InputError, match="crease") as info:
        load_surface(path)
    message = str(info.value)
    assert_one_line(message, "corner.step")
    assert "90 degrees" in message and corners in message


def test_step_crease_between_unsewn_faces_with_different_points_is_refused(tmp_path):
    import build123d as bd

    faces = right_angle_faces(split_edge=True)
    path = write_step(tmp_path / "unsewn.step", bd.Compound(list(faces)).wrapped)
    with pytest.raises(InputError, match="crease") as info:
        load_surface(path)
    message = str(info.value)
    assert_one_line(message, "unsewn.step")
    assert "90 degrees" in message and "unwelded seam" in message
    assert "(0, 1000, 0) to (2000, 1000, 0) mm" in message


def test_step_in_the_wrong_unit_is_refused_before_it_is_meshed(tmp_path):
    """A 14 x 11 m roof whose file says metres where its numbers are millimetres is 14 km
    across: meshing it to the surface tolerance ran out of memory with no word. It is refused
    at once, with the unit that would make it a shell; the same roof in mm loads."""
    import build123d as bd

    roof = bd.Face.make_rect(14_000.0, 11_000.0)
    ok = write_step(tmp_path / "roof.step", roof.wrapped)
    assert load_surface(ok).bounds[1, 0] - load_surface(ok).bounds[0, 0] == pytest.approx(14_000)
    # the numbers 14000 x 11000 declared as metres: the shape is 1000 x as large
    huge = write_step(tmp_path / "roof_m.step", roof.scale(1000.0).wrapped, "M")
    with pytest.raises(InputError) as info:
        load_surface(huge)
    message = str(info.value)
    assert_one_line(message, "roof_m.step")
    assert "14,000 x 11,000 x 0 m" in message and "(m)" in message
    assert "with mm as its unit (14 m across then)" in message
    # nothing plausible: no unit suggested, the export named
    far = write_step(tmp_path / "far.step", roof.scale(1e6).wrapped)
    with pytest.raises(InputError, match="in the unit it was drawn in"):
        load_surface(far)


def test_crease_angle_is_a_job_key_with_the_same_default():
    assert Job.from_dict({}).input.crease_angle == CREASE_ANGLE
    assert Job.from_dict({"input": {"crease_angle": 90}}).input.crease_angle == 90.0
    for bad in (0, -5, 181):
        with pytest.raises(InputError, match=r"\[input\] crease_angle"):
            Job.from_dict({"input": {"crease_angle": bad}})


def test_closed_solids_keep_loading_with_their_edges(tmp_path):
    """A box has 90-degree edges by design; panelize refuses closed surfaces on its own."""
    import trimesh

    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(path)
    assert load_surface(path, "m").boundary_loops == ()


# --------------------------------------------------------------------------------------------
# 3. separate pieces and unwelded seams
# --------------------------------------------------------------------------------------------
def square(x0: float, y0: float, size: float, n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    s = np.linspace(0.0, size, n + 1)
    x, y = np.meshgrid(x0 + s, y0 + s, indexing="ij")
    vertices = np.stack([x, y, 0.05 * x * y], axis=-1).reshape(-1, 3)
    return vertices, grid_triangles(n, n)


def test_separate_pieces_are_refused(tmp_path):
    path = write_obj(tmp_path / "two.obj", square(0.0, 0.0, 3.0), square(5.0, 1.0, 2.0))
    with pytest.raises(InputError, match="2 separate pieces") as info:
        load_surface(path, "m")
    message = str(info.value)
    assert_one_line(message, "two.obj")
    assert "(the second spans (5.00, 1.00, 0.25)–(7.00, 3.00, 1.05) m)" in message
    assert "join them into one surface or run them as separate jobs" in message


def split_vault(nu_left: int, nu_right: int, shift: float = 0.0):
    """Cylinder vault (radius 2 m, quarter arc, 3 m long) in two halves at x = 1.5 m.

    The halves divide the arc into ``nu_left`` and ``nu_right`` segments; the right half's seam
    points are moved by ``shift`` m along x.
    """

    def half(x0, x1, n_arc, dx):
        t = np.linspace(np.pi / 4, 3 * np.pi / 4, n_arc + 1)
        x = np.linspace(x0, x1, 7)
        vertices = np.array([(xi, 2.0 * np.cos(ti), 2.0 * np.sin(ti)) for ti in t for xi in x])
        vertices[np.isclose(vertices[:, 0], 1.5), 0] += dx
        return vertices, grid_triangles(n_arc, 6)

    return half(0.0, 1.5, nu_left, 0.0), half(1.5, 3.0, nu_right, shift)


@pytest.mark.parametrize("nu_right, shift", [(16, 0.0), (16, 1e-6), (24, 0.0)])
def test_unwelded_seams_are_refused_before_pieces(tmp_path, nu_right, shift):
    """Equal divisions moved by 1 micrometre (above the welding grid), and different divisions
    (each half's points lie on the chords of the other only up to the arc's sagitta)."""
    path = write_obj(tmp_path / "halves.obj", *split_vault(16, nu_right, shift))
    if nu_right == 16 and shift == 0.0:  # control: identical points are welded
        assert len(load_surface(path, "m").boundary_loops) == 1
        return
    with pytest.raises(InputError, match="unwelded seam") as info:
        load_surface(path, "m")
    message = str(info.value)
    assert_one_line(message, "halves.obj")
    assert "coincide with other boundary edges; weld the mesh (merge vertices)" in message
    point = points_in(message)[0]
    assert point[0] == pytest.approx(1.5, abs=0.01)
    assert np.hypot(point[1], point[2]) == pytest.approx(2.0, abs=0.01)


def test_tube_with_an_unwelded_seam_is_refused(tmp_path):
    """One piece whose own boundary closes on itself: a tube exported with float32 noise."""
    t = np.linspace(0.0, 2 * np.pi, 33)
    x = np.linspace(0.0, 4.0, 9)
    vertices = np.array([(xi, 1.5 * np.cos(ti), 1.5 * np.sin(ti)) for ti in t for xi in x])
    vertices[-9:] += np.float32(3e-7)  # the closing column, a float32 step off
    path = write_obj(tmp_path / "tube.obj", (vertices, grid_triangles(32, 8)))
    with pytest.raises(InputError, match="unwelded seam: 16 boundary edges near") as info:
        load_surface(path, "m")
    assert_one_line(str(info.value), "tube.obj")


def test_narrow_opening_is_not_a_seam(tmp_path):
    """A slot 20 mm wide between 100 mm triangles is an opening, not a seam."""
    xs = np.linspace(0.0, 2.0, 21)
    ys = np.concatenate([np.linspace(0.0, 0.99, 10), np.linspace(1.01, 2.0, 10)])
    x, y = np.meshgrid(xs, ys, indexing="ij")
    vertices = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 3)
    faces = grid_triangles(20, 19)
    # drop the row of cells across the slot between x = 0.5 and 1.5 m
    tri = vertices[faces]
    centre = tri.mean(axis=1)
    slot = (np.abs(centre[:, 1] - 1.0) < 0.01) & (centre[:, 0] > 0.5) & (centre[:, 0] < 1.5)
    surface = load_surface(write_obj(tmp_path / "slot.obj", (vertices, faces[~slot])), "m")
    assert len(surface.boundary_loops) == 2


# --------------------------------------------------------------------------------------------
# every example still loads, quickly
# --------------------------------------------------------------------------------------------
def _declared_units() -> dict[str, str | None]:
    """Units of each example surface, from the job files that name it."""
    units: dict[str, str | None] = {}
    for folder in EXAMPLE_DIRS:
        for job in folder.glob("*.toml"):
            section = tomllib.loads(job.read_text()).get("input", {})
            if "path" in section:
                units[Path(section["path"]).name] = section.get("units")
    return units


EXAMPLE_SURFACES = sorted(
    p for folder in EXAMPLE_DIRS for pattern in ("*.obj", "*.step") for p in folder.glob(pattern)
)


@pytest.mark.parametrize("path", EXAMPLE_SURFACES, ids=lambda p: p.name)
def test_every_example_passes_the_checks(path):
    units = _declared_units().get(path.name)
    if path.suffix == ".obj" and units is None:
        units = "m"  # barrel-vault.obj: the mesh twin of the STEP, metres
    surface = load_surface(path, units)
    assert len(surface.boundary_loops) >= 1
    _, angles = fold_angles(surface.vertices, surface.faces)
    assert angles.max() < CREASE_ANGLE / 2  # the default keeps a factor two margin
    start = time.process_time()
    check_surface(surface.vertices, surface.faces, name=path.name, units=surface.units)
    # about 0.1 s for 15k triangles; the bound only catches a broken broad phase
    assert time.process_time() - start < 1.5


def test_format_point_uses_the_declared_unit():
    assert format_point([3204.0, 1049.0, -0.4], "m") == "(3.20, 1.05, 0.00) m"
    assert format_point([3204.0, 1049.0, 400.4], "cm") == "(320.4, 104.9, 40.0) cm"
    assert format_point([3204.0, 1049.0, 400.4], "mm") == "(3204, 1049, 400) mm"
    assert format_point([25.4, 0.0, 0.0], "inch") == "(25, 0, 0) mm"


def test_a_job_unit_a_brep_does_not_take_is_a_warning(tmp_path):
    """[input] units = "m" on a STEP in mm: the file's millimetres are read, and the run says
    so instead of running silently; the same unit, or none, says nothing."""
    import build123d as bd

    from fabpanel.pipeline import _units_not_applied

    path = write_step(tmp_path / "roof.step", bd.Face.make_rect(14_000.0, 11_000.0).wrapped)
    surface = load_surface(path, "m")
    assert surface.units == "mm" and surface.bounds[1, 0] - surface.bounds[0, 0] == pytest.approx(
        14_000
    )
    job = Job.from_dict({"input": {"path": str(path), "units": "m"}})
    (issue,) = _units_not_applied(job, surface)
    assert issue.code == "input-units-not-applied" and issue.severity == "warning"
    assert issue.message.startswith(
        'roof.step is read in the unit its STEP file declares (mm), not in [input] units = "m"'
    )
    assert "singular and support points, a drawn layout" in issue.message
    assert not _units_not_applied(job.replace(input={"units": "mm"}), surface)
    assert not _units_not_applied(Job.from_dict({"input": {"path": str(path)}}), surface)
