"""Sheet faces trimmed at rib planes that lie beyond their samples (a bevelled rib under a deep
sandwich on a doubly curved shell): the trim reaches the plane on a smooth continuation."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.model import occ
from fabpanel.model.panel import _untrimmed_finding
from fabpanel.model.trim import continued, side_curve, trimmed_face

R, SIDE, K, DEPTH = 4000.0, 1200.0, 9, 150.0


def _cylinder_face(noise: float, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The face ``DEPTH`` below a cylindrical panel's design grid, offset along normals carrying
    ``noise`` (radians, as a developed panel's normals do), and the panel's outward normals."""
    t = np.linspace(-SIDE / 2, SIDE / 2, K)
    a = t / R
    x, ang = np.meshgrid(t, a, indexing="ij")
    normals = np.stack([np.zeros_like(x), np.sin(ang), np.cos(ang)], axis=-1)
    rng = np.random.default_rng(seed)
    tilted = normals + rng.normal(0.0, noise, normals.shape)
    tilted /= np.linalg.norm(tilted, axis=-1, keepdims=True)
    design = np.stack([x, R * np.sin(ang), R * np.cos(ang)], axis=-1)
    return design - DEPTH * tilted, normals


def _bevelled_planes(degrees: float) -> np.ndarray:
    """Rib planes (unit normals into the panel) through the design edges; those of sides 0 and
    1 lean outward by ``degrees`` about the edge, so that they pass ``DEPTH sin`` beyond the
    face's edge (side 0 at the angle -a, side 1 at x = +SIDE/2, side 2 at +a, side 3 at -x)."""
    b, a = np.radians(degrees), SIDE / 2 / R

    def across_generators(angle: float, into: float, lean: float) -> np.ndarray:
        tangent = into * np.array([0.0, np.cos(angle), -np.sin(angle)])
        radial = np.array([0.0, np.sin(angle), np.cos(angle)])
        n = np.cos(lean) * tangent + np.sin(lean) * radial
        return np.array([*n, n @ (R * radial)])

    def across_axis(x: float, into: float, lean: float) -> np.ndarray:
        n = np.array([into * np.cos(lean), 0.0, np.sin(lean)])
        return np.array([*n, n @ np.array([x, 0.0, R])])

    return np.array(
        [
            across_generators(-a, 1.0, b),
            across_axis(SIDE / 2, -1.0, b),
            across_generators(a, -1.0, 0.0),
            across_axis(-SIDE / 2, 1.0, 0.0),
        ]
    )


@pytest.mark.parametrize("noise", [0.0, 0.004])
def test_bevelled_planes_beyond_the_samples_are_reached(noise):
    grid, normals = _cylinder_face(noise)
    planes = _bevelled_planes(16.0)
    # the planes of sides 0 and 1 pass about DEPTH sin(16 deg) = 41 mm beyond the face's edge
    outside = planes[0, :3] @ grid[:, 0].T - planes[0, 3]
    assert outside.min() < -30.0
    face = trimmed_face(grid, normals[K // 2, K // 2], planes, np.ones(4, bool), DEPTH, "BOT")
    assert not face.untrimmed.any()
    for side in range(4):
        edge = side_curve(face.surface, side, 65)
        assert np.abs(edge @ planes[side, :3] - planes[side, 3]).max() < 1e-3
    # the continuation is the face's own curvature carried on: the new surface stays within
    # a millimetre of the cylinder 150 mm inside the design surface (noise-free case)
    if noise == 0.0:
        pts = occ.sample_surface(face.surface, 33, 33).reshape(-1, 3)
        radius = np.hypot(pts[:, 1], pts[:, 2])
        assert np.abs(radius - (R - DEPTH)).max() < 1.0


def test_continuation_is_the_surface_inside_and_smooth_across_its_edge():
    grid, _ = _cylinder_face(0.002)
    surface, _ = occ.bspline_surface(grid)
    inside = np.random.default_rng(0).random((40, 2))
    p, du, dv = continued(surface, inside)
    q, qu, qv = occ.surface_derivatives(surface, inside)
    np.testing.assert_allclose(p, q, atol=1e-9)
    np.testing.assert_allclose(du, qu, atol=1e-6)
    np.testing.assert_allclose(dv, qv, atol=1e-6)
    # across the edge u = 1: value and first derivative continuous
    v = np.linspace(0.1, 0.9, 7)
    edge = np.stack([np.full(7, 1.0), v], 1)
    a, au, _ = continued(surface, edge - [1e-7, 0])
    b, bu, _ = continued(surface, edge + [1e-7, 0])
    assert np.abs(a - b).max() < 1e-3
    assert np.abs(au - bu).max() < 1e-2 * np.abs(au).max()


@pytest.mark.parametrize(("lean", "severity"), [(0.3, "warning"), (16.0, "error")])
def test_an_edge_left_untrimmed_is_an_error_when_it_misses_its_rib(lean, severity):
    """An edge the trim may not slide to its plane (slide limit 1 mm here) stays at the
    developed edge: within a weld's bridging gap of its plane a warning, beyond an error that
    gives the distance."""
    grid, normals = _cylinder_face(0.0)
    planes = _bevelled_planes(lean)
    face = trimmed_face(grid, normals[K // 2, K // 2], planes, np.ones(4, bool), 1.0, "BOT")
    assert face.untrimmed[0]
    origin = np.array([10_000.0, -5_000.0, 300.0])
    finding = _untrimmed_finding("P001-BOT", 0, face, planes, origin)
    off = DEPTH * np.sin(np.radians(lean))
    assert finding[0] == "sheet-not-trimmed"
    assert f"{off:.1f} mm off its rib plane at (" in finding[2]
    # where: a point of the edge, in model coordinates
    where = finding[2].split("rib plane at (")[1].split(")")[0]
    point = np.array([float(c) for c in where.split(", ")]) - origin
    edge = side_curve(face.surface, 0, 33)
    assert np.linalg.norm(edge - point, axis=1).min() < 1.0
    assert (finding[3] if len(finding) > 3 else "warning") == severity


def test_a_corner_the_curved_continuation_cannot_reach_is_trimmed_on_the_tangent_planes():
    """A flat 1 x 1 m face whose parameter slows towards side 1 (x = 1000 (u - 0.45 u²), as
    a bottom face offset along turning normals bunches its grid): its second-order
    continuation beyond u = 1 turns back after 5.6 mm, so a rib plane 8 mm beyond the edge
    is out of its reach. The face continued by its tangent planes reaches it; every edge
    lies in its plane and the face stays flat (a crown panel's bottom sheet was left
    untrimmed on two sides, 6.5 and 10.4 mm off its ribs, before)."""
    u = np.linspace(0.0, 1.0, K)
    uu, vv = np.meshgrid(u, u, indexing="ij")
    grid = np.stack([1000.0 * (uu - 0.45 * uu**2), 1000.0 * vv, np.zeros_like(uu)], axis=-1)
    edge = 1000.0 * (1.0 - 0.45)
    planes = np.array(
        [[0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, -(edge + 8.0)], [0, -1, 0, -1000], [1, 0, 0, 0]]
    )
    # the curved continuation of side 1 falls short of the plane
    beyond = np.stack([np.linspace(1.0, 1.5, 201), np.full(201, 0.5)], 1)
    reach, _, _ = continued(occ.bspline_surface(grid)[0], beyond)
    assert reach[:, 0].max() < edge + 6.0
    face = trimmed_face(grid, np.array([0.0, 0.0, 1.0]), planes, np.ones(4, bool), DEPTH)
    assert not face.untrimmed.any()
    for side in range(4):
        curve = side_curve(face.surface, side, 65)
        assert np.abs(curve @ planes[side, :3] - planes[side, 3]).max() < 1e-3
    assert np.abs(occ.sample_surface(face.surface, 17, 17)[..., 2]).max() < 1e-6
    assert face.slide[1] == pytest.approx(8.0, abs=0.5)


def test_the_fit_is_measured_on_the_samples_a_face_cut_far_back_still_holds():
    """A rib plane 150 mm inside the face's edge across the cylinder's curvature: the trim
    slides that edge 150 mm round the arc. The samples the face still holds lie on it (the
    fit measured by projection); comparing each sample with the refit's point of the same
    index read the sagitta of that slide, about 150² / 2R = 2.9 mm. Moved 1 mm off the
    face, the samples are found 1 mm off."""
    from fabpanel.model.trim import _samples_fit

    grid, normals = _cylinder_face(0.0)
    planes = _bevelled_planes(0.0)
    planes[0, 3] += 150.0  # side 0's plane moved 150 mm into the panel
    face = trimmed_face(grid, normals[K // 2, K // 2], planes, np.ones(4, bool), 200.0, "BOT")
    assert not face.untrimmed.any()
    assert face.slide[0] == pytest.approx(150.0, abs=5.0)
    assert face.fit_error < 0.01
    # one row of samples and more lie beyond the new edge and are not counted; the rest are
    outward = grid + 1.0 * normals
    assert _samples_fit(face.surface, outward) == pytest.approx(1.0, abs=0.02)
