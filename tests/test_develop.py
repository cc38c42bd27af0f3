"""The `project` develop method: exact on a cylinder, honest on a doubly curved surface."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import sphere_cap

from fabpanel import Job, develop, load_surface, panelize
from fabpanel.develop.sides import panel_sides

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def vault():
    surface = load_surface(EXAMPLES / "barrel-vault.step")
    job = Job.from_dict({"panelize": {"grid_u": 4, "grid_v": 3}})
    return develop(panelize(surface, job), surface, job)


def test_cylinder_panels_are_single_curved_and_exact(vault):
    assert set(vault.classes) == {"single-curved"}
    np.testing.assert_allclose(np.hypot(vault.samples[..., 1], vault.samples[..., 2]), 4000.0,
                               atol=1e-6)
    np.testing.assert_allclose(vault.bending_radius, 4000.0, rtol=1e-6)
    assert vault.metrics["unroll_strain"]["max"] < 1e-6
    assert vault.metrics["deviation_mm"]["max"] < 0.05       # chord of 8 sample segments
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
    signed = np.einsum("msi,mi->ms", vault.side_planes[..., :3], centres) - vault.side_planes[..., 3]
    assert np.all(signed > 0)


def test_doubly_curved_panels_are_not_developable(tmp_path):
    surface = sphere_cap(tmp_path, n=30)
    job = Job.from_dict({"panelize": {"grid_u": 3, "grid_v": 3}})
    developed = develop(panelize(surface, job), surface, job)
    assert developed.classes.count("not-developable") == 9
    assert developed.metrics["unroll_strain"]["min"] > 1e-3
    assert {i.code for i in developed.issues} >= {"not-developable"}
