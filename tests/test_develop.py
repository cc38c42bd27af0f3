"""The `project` develop method: exact on a cylinder, honest on a doubly curved surface."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import sphere_cap

from fabpanel import Job, develop, load_surface, panelize
from fabpanel.develop.measure import advised_panel_size
from fabpanel.develop.sides import panel_sides, side_planes
from fabpanel.report.develop_figures import gaussian_curvature

DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # shipped: fabpanel demo


@pytest.fixture(scope="module")
def vault():
    surface = load_surface(DEMO / "barrel-vault.step")
    job = Job.from_dict({"panelize": {"grid_u": 4, "grid_v": 3}, "develop": {"method": "project"}})
    return develop(panelize(surface, job), surface, job)


def test_cylinder_panels_are_single_curved_and_exact(vault):
    assert set(vault.classes) == {"single-curved"}
    np.testing.assert_allclose(
        np.hypot(vault.samples[..., 1], vault.samples[..., 2]), 4000.0, atol=1e-6
    )
    np.testing.assert_allclose(vault.bending_radius, 4000.0, rtol=1e-6)
    assert vault.metrics["unroll_strain"]["max"] < 1e-6
    assert vault.metrics["deviation_mm"]["max"] < 0.05  # chord of 8 sample segments
    assert vault.metrics["rib_plane_residual_mm_max"] < 1e-6


def test_normals_point_outwards(vault):
    radial = vault.samples * [0, 1, 1] / 4000.0
    np.testing.assert_allclose(vault.normals, radial, atol=1e-9)


def test_neighbours_share_side_samples_exactly(vault):
    layout = vault.layout
    sides = panel_sides(vault.samples)
    nb = layout.side_neighbours
    for panel, side in zip(*np.nonzero(nb >= 0)):
        other = nb[panel, side]
        matches = [np.array_equal(sides[panel, side], sides[other, s][::-1]) for s in range(4)]
        assert any(matches)


def test_rib_planes_point_into_the_panel(vault):
    centres = vault.samples[:, 4, 4]
    signed = (
        np.einsum("msi,mi->ms", vault.side_planes[..., :3], centres) - vault.side_planes[..., 3]
    )
    assert np.all(signed > 0)


def test_doubly_curved_panels_are_not_developable(tmp_path):
    surface = sphere_cap(tmp_path, n=30)
    job = Job.from_dict({"panelize": {"grid_u": 3, "grid_v": 3}, "develop": {"method": "project"}})
    developed = develop(panelize(surface, job), surface, job)
    assert developed.classes.count("not-developable") == 9
    assert developed.metrics["unroll_strain"]["min"] > 1e-3
    assert {i.code for i in developed.issues} >= {"not-developable", "panel-size-advice"}
    # advice: the strain of a doubly curved patch grows with its size squared, so a panel at
    # the advised size unrolls within tolerance
    for panel in developed.metrics["per_panel"].values():
        assert panel["advised_panel_size_mm"] < 2000.0
    advised = min(p["advised_panel_size_mm"] for p in developed.metrics["per_panel"].values())
    smaller = job.replace(panelize={"grid_u": None, "grid_v": None, "panel_size": f"{advised} mm"})
    again = develop(panelize(surface, smaller), surface, smaller)
    assert again.metrics["unroll_strain"]["max"] <= smaller.develop.strain_tolerance


def test_panels_far_from_the_design_are_named_with_the_size_that_stays_within(tmp_path):
    surface = sphere_cap(tmp_path, n=30)
    job = Job.from_dict(
        {
            "panelize": {"grid_u": 3, "grid_v": 3},
            "develop": {"method": "loft", "deviation_tolerance": "20 mm"},
        }
    )
    developed = develop(panelize(surface, job), surface, job)
    per_panel = developed.metrics["per_panel"]
    far = {pid for pid, p in per_panel.items() if p["deviation_max_mm"] > 20.0}
    assert far  # 2 m ruled panels on a 5 m sphere leave it by far more than 20 mm
    warned = [i for i in developed.issues if i.code == "panel-off-design"]
    assert {i.item for i in warned} == far and all(i.severity == "warning" for i in warned)
    # the deviation of a ruled panel from a sphere grows with its size squared: at the
    # smallest size advised, every panel stays within the tolerance
    sizes = [float(i.message.split("panels of about ")[1].split(" mm")[0]) for i in warned]
    smaller = job.replace(
        panelize={"grid_u": None, "grid_v": None, "panel_size": f"{min(sizes)} mm"}
    )
    again = develop(panelize(surface, smaller), surface, smaller)
    assert again.metrics["deviation_mm"]["max"] <= 20.0
    assert not [i for i in again.issues if i.code == "panel-off-design"]


def test_advised_panel_size_follows_the_square_law():
    side = np.linspace(0.0, 1000.0, 5)
    grid = np.stack([*np.meshgrid(side, side, indexing="ij"), np.zeros((5, 5))], -1)[None]
    # four times the tolerance: half the size, less the margin
    assert advised_panel_size(grid, np.array([4e-3]), 1e-3)[0] == 450.0
    assert advised_panel_size(grid, np.array([1e-4]), 1e-3)[0] == 900.0


def test_rib_planes_of_a_cone_hold_the_sides_at_a_constant_bevel():
    # cone with generators at 30 degrees: parallels and generators are planar curvature lines;
    # the normals stand square to the generators' planes and at 60 degrees to the parallels'
    r = np.linspace(3000.0, 4000.0, 9)
    t = np.linspace(0.0, 0.25, 9)
    rr, tt = np.meshgrid(r, t, indexing="ij")
    slope = np.tan(np.radians(30.0))
    grid = np.stack([rr * np.cos(tt), rr * np.sin(tt), -rr * slope], -1)[None]
    normal = np.stack(
        [
            np.sin(np.radians(30.0)) * np.cos(tt),
            np.sin(np.radians(30.0)) * np.sin(tt),
            np.full_like(tt, np.cos(np.radians(30.0))),
        ],
        -1,
    )[None]
    _, edge, angle, twist = side_planes(grid, normal)
    assert edge.max() < 1e-6
    assert twist.max() < 1e-6
    np.testing.assert_allclose(angle[0], [0.0, 60.0, 0.0, 60.0], atol=1e-6)


@pytest.mark.parametrize("bow, square", [(0.3, True), (3.0, False)])
def test_a_nearly_straight_level_side_under_a_rising_sheet_gets_a_square_rib(bow, square):
    """A sheet rising at 40 degrees from a springing line on the ground that bows ``bow`` mm
    in plan: the line lies exactly in the level plane, which leans 50 degrees from square to
    the sheet (a vault's base rib its bottom sheet never met). Within the rib-edge tolerance
    of the square plane, the rib stands square; a line bowing further keeps its own plane."""
    u, v = np.meshgrid(np.linspace(0.0, 1.0, 9), np.linspace(0.0, 1.0, 9), indexing="ij")
    rise = np.radians(40.0)
    grid = np.stack(
        [
            1000.0 * u,
            1000.0 * v * np.cos(rise) + bow * 4 * u * (1 - u) * (1 - v),
            1000.0 * v * np.sin(rise),
        ],
        -1,
    )[None]
    normal = np.broadcast_to([0.0, -np.sin(rise), np.cos(rise)], grid.shape).copy()
    planes, edge, angle, _ = side_planes(grid, normal)
    level = abs(planes[0, 0, 2]) / np.linalg.norm(planes[0, 0, :3])  # side 0 runs along v = 0
    if square:
        assert (
            angle[0, 0] < 1.0
            and edge[0, 0] <= 0.5
            and level == pytest.approx(np.sin(rise), abs=1e-3)
        )
    else:
        assert angle[0, 0] == pytest.approx(50.0, abs=0.5) and edge[0, 0] < 1e-6 and level > 0.999


def test_gaussian_curvature_figures_match_analytic_shapes():
    t = np.linspace(-0.15, 0.15, 9)
    a, b = np.meshgrid(t, t, indexing="ij")
    sphere = 5000.0 * np.stack([np.cos(a) * np.cos(b), np.cos(a) * np.sin(b), np.sin(a)], -1)
    np.testing.assert_allclose(gaussian_curvature(sphere[None]), 1 / 25.0, rtol=0.01)
    cylinder = np.stack([1000.0 * b, 4000.0 * np.cos(a), 4000.0 * np.sin(a)], -1)
    assert np.abs(gaussian_curvature(cylinder[None])).max() < 1e-9


def test_a_3d_curvature_map_of_a_developable_design_shows_its_panels():
    """K = 0 is white on the diverging scale: without the panel outlines the 3D map of the
    demo's vault was a blank box. The outlines are drawn, one closed loop per panel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from conftest import cylinder_developed
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    from fabpanel.report.develop_figures import _cells_3d

    samples = np.asarray(cylinder_developed(radius=4000.0, length=12000.0, arc=np.pi).samples)
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    _cells_3d(ax, samples, np.zeros(samples[:, 1:, 1:, 0].shape), "RdBu_r", (-1e-4, 1e-4))
    fig.canvas.draw()  # a 3D collection's segments are its projected ones, after a draw
    lines = [c for c in ax.collections if isinstance(c, Line3DCollection)]
    plt.close(fig)
    assert len(lines) == 1 and len(lines[0].get_segments()) == len(samples)
