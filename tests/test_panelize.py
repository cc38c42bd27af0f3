"""Grid panelisation on the barrel vault, exact (STEP) and meshed (OBJ)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabpanel import GeometryError, Job, load_surface, panelize
from fabpanel.data import Surface

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # shipped: fabpanel demo
RADIUS, LENGTH = 4000.0, 12000.0


@pytest.fixture(scope="module")
def vault_step():
    return load_surface(DEMO / "barrel-vault.step")


@pytest.fixture(scope="module")
def vault_obj():
    return load_surface(EXAMPLES / "barrel-vault.obj", "m")


def _radius(points):
    return np.hypot(points[:, 1], points[:, 2])


def test_step_grid_follows_the_target_size_and_lies_on_the_cylinder(vault_step):
    job = Job.from_dict({"panelize": {"panel_size": "1.2 m"}})
    layout = panelize(vault_step, job)
    assert len(layout.quads) == 10 * 10  # arc 12.57 m / 1.2 m -> 10, length 12 m -> 10
    np.testing.assert_allclose(_radius(layout.vertices), RADIUS, atol=1e-6)
    lengths = layout.metrics["edge_length_mm"]
    # arc panels are 1256.6 mm (chord 1254.0), panels along x 1200 mm
    assert 1195 < lengths["min"] and lengths["max"] < 1260
    assert layout.metrics["corner_angle_deg"]["min"] == pytest.approx(90, abs=1e-6)
    assert layout.parameters is not None and layout.parameters.shape == (100, 4, 2)


def test_panels_are_oriented_outwards(vault_step):
    layout = panelize(vault_step, Job.from_dict({}))
    c = layout.vertices[layout.quads]
    normal = np.cross(c[:, 1] - c[:, 0], c[:, 3] - c[:, 0])
    centre = c.mean(axis=1)
    radial = centre * [0, 1, 1]
    assert np.all(np.einsum("ij,ij->i", normal, radial) > 0)


def test_neighbours_are_consistent(vault_step):
    layout = panelize(vault_step, Job.from_dict({"panelize": {"grid_u": 3, "grid_v": 4}}))
    assert len(layout.quads) == 12
    nb = layout.side_neighbours
    for panel, row in enumerate(nb):
        for other in row[row >= 0]:
            assert panel in nb[other]
    assert (nb < 0).sum() == 2 * (3 + 4)  # boundary sides


def test_mesh_grid_matches_the_exact_one(vault_obj, vault_step):
    job = Job.from_dict({"panelize": {"panel_size": "1.2 m"}})
    mesh_layout = panelize(vault_obj, job)
    assert len(mesh_layout.quads) == 100
    # mesh vertices lie on chords of the 96-segment arc: within its sagitta of the cylinder
    sagitta = RADIUS * (1 - np.cos(np.pi / 96 / 2))
    assert np.all(np.abs(_radius(mesh_layout.vertices) - RADIUS) <= sagitta + 1e-6)
    assert mesh_layout.metrics["panels_exceeding_plate"] == 0


def test_panels_larger_than_the_plate_are_reported(vault_step):
    layout = panelize(vault_step, Job.from_dict({"panelize": {"panel_size": "2 m"}}))
    assert any(issue.code == "panel-exceeds-plate" for issue in layout.issues)


def test_grid_refuses_surfaces_with_openings(tmp_path):
    from fabpanel.errors import InputError

    # a 3 x 3 square plate with the middle square missing: one opening
    vertices = [(x, y, 0.0) for y in range(4) for x in range(4)]
    quads = [
        (y * 4 + x, y * 4 + x + 1, y * 4 + x + 5, y * 4 + x + 4)
        for y in range(3)
        for x in range(3)
        if (x, y) != (1, 1)
    ]
    path = tmp_path / "frame.obj"
    path.write_text(
        "\n".join(f"v {x} {y} {z}" for x, y, z in vertices)
        + "\n"
        + "\n".join("f " + " ".join(str(i + 1) for i in q) for q in quads)
        + "\n"
    )
    with pytest.raises((GeometryError, InputError), match="boundary loop"):
        panelize(load_surface(path, "m"), Job(panelize={"method": "grid"}))


def _plate(width: float = 6000.0, depth: float = 4000.0, spacing: float = 250.0) -> Surface:
    """A four-sided, gently curved plate in mm (z = x^2 / 60 m), triangulated on a grid."""
    nx, ny = int(width / spacing) + 1, int(depth / spacing) + 1
    xx, yy = np.meshgrid(np.linspace(0, width, nx), np.linspace(0, depth, ny), indexing="ij")
    vertices = np.column_stack([xx.ravel(), yy.ravel(), xx.ravel() ** 2 / 60000.0])
    ids = np.arange(nx * ny).reshape(nx, ny)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    loop = np.concatenate([ids[:, 0], ids[-1, 1:], ids[-2::-1, -1], ids[0, -2:0:-1]])
    return Surface(vertices, faces, (loop,), Path("plate.obj"), "obj", "mm")


COLUMN = [2130.0, 1370.0, 2130.0**2 / 60000.0]  # mm, on the plate, off any 1 m grid line


def test_auto_makes_a_singular_point_a_vertex_even_on_a_four_sided_surface():
    job = Job.from_dict(
        {"input": {"units": "mm"}, "panelize": {"panel_size": "1 m", "singular_points": [COLUMN]}}
    )
    layout = panelize(_plate(), job)
    assert layout.method == "field"  # a grid cannot put a vertex where asked
    assert "singular_points" in layout.metrics["auto"]["reason"]
    assert np.linalg.norm(layout.vertices - COLUMN, axis=1).min() < 1.0
    assert not [i for i in layout.issues if i.code == "singular-point-missed"]


def test_a_grid_that_misses_a_singular_point_says_so():
    job = Job.from_dict(
        {
            "input": {"units": "mm"},
            "panelize": {"panel_size": "1 m", "method": "grid", "singular_points": [COLUMN]},
        }
    )
    layout = panelize(_plate(), job)
    missed = [i for i in layout.issues if i.code == "singular-point-missed"]
    assert missed and missed[0].severity == "warning"
    assert "1 of 1 singular_points" in missed[0].message and '"field"' in missed[0].message


def test_a_tall_short_vault_is_four_sided_by_its_tangent_planes(tmp_path):
    # a half cylinder 8 m across and 2.4 m long: its outline's best-fitting plane is that of
    # its end arches, which sees the two straight sides end on (zero length, no corner)
    from conftest import grid_surface

    from fabpanel.panelize.grid import is_four_sided

    phi = np.linspace(0.0, np.pi, 97)
    x = np.array([0.0, 2.4])
    xx, pp = np.meshgrid(x, phi, indexing="ij")
    points = np.stack([xx, 4.0 * np.cos(pp), 4.0 * np.sin(pp)], axis=-1)
    surface = grid_surface(tmp_path, "tall-vault", points)
    assert is_four_sided(surface, 30.0)
    job = Job.from_dict(
        {"input": {"path": "x.obj", "units": "m"}, "panelize": {"panel_size": "1.2 m"}}
    )
    layout = panelize(surface, job)
    assert layout.method == "grid" and len(layout.quads) == 20
