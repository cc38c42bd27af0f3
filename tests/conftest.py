"""Analytic fixtures: panels on cylinders and a sphere cap whose geometry is known in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel import load_surface
from fabpanel.data import DevelopedPanels, PanelLayout
from fabpanel.develop.sides import side_planes


def cylinder_developed(
    radius: float = 4000.0,
    length: float = 2400.0,
    n_arc: int = 2,
    n_len: int = 2,
    k: int = 9,
    arc: float = np.pi / 3,
    depth: float = 161.0,
) -> DevelopedPanels:
    """Panels on a cylinder (axis along x, outer normals radial), exact samples and normals.

    The vault spans angles ``pi/2 - arc/2 .. pi/2 + arc/2`` around the x axis (crown at +z),
    ``n_len`` panels along x and ``n_arc`` around. Units mm.
    """
    xs = np.linspace(0.0, length, n_len + 1)
    ts = np.linspace(np.pi / 2 - arc / 2, np.pi / 2 + arc / 2, n_arc + 1)

    def point(x, t):
        return np.stack([x, radius * np.cos(t), radius * np.sin(t)], axis=-1)

    def normal(x, t):
        return np.stack([np.zeros_like(t), np.cos(t), np.sin(t)], axis=-1)

    # corners: index (ix, it) -> ix * (n_arc + 1) + it
    X, T = np.meshgrid(xs, ts, indexing="ij")
    vertices = point(X, T).reshape(-1, 3)
    quads, samples, normals = [], [], []
    s = np.linspace(0.0, 1.0, k)
    for ix in range(n_len):
        for it in range(n_arc):
            c = lambda a, b: a * (n_arc + 1) + b
            # counter-clockwise seen from outside (+radial): first along the angle, then along x
            quads.append([c(ix, it), c(ix, it + 1), c(ix + 1, it + 1), c(ix + 1, it)])
            gt = ts[it] + s[:, None] * (ts[it + 1] - ts[it]) + 0 * s[None, :]
            gx = xs[ix] + s[None, :] * (xs[ix + 1] - xs[ix]) + 0 * s[:, None]
            samples.append(point(gx, gt))
            normals.append(normal(gx, gt))
    quads = np.array(quads)
    layout = PanelLayout(
        vertices=vertices,
        quads=quads,
        panel_ids=tuple(f"P{i + 1:03d}" for i in range(len(quads))),
        method="analytic-cylinder",
    )
    samples, normals = np.array(samples), np.array(normals)
    planes, *_ = side_planes(samples, normals)
    m = len(quads)
    return DevelopedPanels(
        layout=layout,
        samples=samples,
        normals=normals,
        side_planes=planes,
        classes=("single-curved",) * m,
        bending_radius=np.full(m, radius),
        method="analytic",
    )


@pytest.fixture
def cylinder_panels() -> DevelopedPanels:
    return cylinder_developed()


def grid_surface(tmp_path, name: str, points: np.ndarray):
    """A quad mesh through a grid of points (a, b, 3) in metres, written as OBJ and loaded."""
    a, b = points.shape[:2]
    i, j = np.meshgrid(np.arange(a - 1), np.arange(b - 1), indexing="ij")
    v = (i * b + j).ravel()
    quads = np.stack([v, v + b, v + b + 1, v + 1], axis=1)
    path = tmp_path / f"{name}.obj"
    path.write_text(
        "\n".join(f"v {x} {y} {z}" for x, y, z in points.reshape(-1, 3))
        + "\n"
        + "\n".join("f " + " ".join(str(q + 1) for q in quad) for quad in quads)
    )
    return load_surface(path, "m")


def sphere_cap(tmp_path, n=24, half=3.0, radius=5.0):
    """A spherical cap patch (radius 5 m) over a 6 x 6 m square, mesh in metres."""
    x, y = np.meshgrid(
        np.linspace(-half, half, n + 1), np.linspace(-half, half, n + 1), indexing="ij"
    )
    z = np.sqrt(radius**2 - x**2 - y**2)
    return grid_surface(tmp_path, "cap", np.stack([x, y, z], axis=-1))


def cone_patch(tmp_path, n=60, slope_deg=30.0):
    """A cone patch (axis z, generators 30 degrees off horizontal, apex at the origin) between
    radii 3 and 6 m over 0.8 rad, mesh in metres."""
    r, phi = np.meshgrid(np.linspace(3.0, 6.0, n + 1), np.linspace(-0.4, 0.4, n + 1), indexing="ij")
    z = -r * np.tan(np.radians(slope_deg))
    return grid_surface(tmp_path, "cone", np.stack([r * np.cos(phi), r * np.sin(phi), z], -1))


def hypar_patch(tmp_path, n=48, half=2.4, c=8.0):
    """A hyperbolic paraboloid z = (x^2 - y^2) / 2c over a square (K = -1/c^2 at the
    centre), mesh in metres."""
    x, y = np.meshgrid(
        np.linspace(-half, half, n + 1), np.linspace(-half, half, n + 1), indexing="ij"
    )
    return grid_surface(tmp_path, "hypar", np.stack([x, y, (x**2 - y**2) / (2 * c)], -1))


def unit_quad_grid(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The regular n x n grid of unit quads on [0, n]²: points (n + 1)², quads (n², 4)
    counter-clockwise, and which points are interior."""
    ij = np.stack(np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="ij"), -1)
    ids = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    interior = np.zeros((n + 1) ** 2, dtype=bool)
    interior[ids[1:-1, 1:-1].ravel()] = True
    return ij.reshape(-1, 2), quads, interior


def random_surface(seed: int, tmp_path):
    """The surface of one seed of ``benchmarks/random_shapes.py`` (metres), written as OBJ."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "random_shapes.py"
    spec = importlib.util.spec_from_file_location("random_shapes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _, vertices, faces = module.random_shape(seed)
    obj = module.hard_shapes.write_obj(tmp_path / f"random{seed}.obj", vertices, faces)
    return load_surface(obj, "m")
