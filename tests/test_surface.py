"""Reading design surfaces, boundary loops, closest-point queries; all fixtures generated."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabpanel.data import Surface
from fabpanel.errors import GeometryError, InputError
from fabpanel.surface import SurfaceQuery, boundary_loops, describe_surface, load_surface
from fabpanel.surface.boundary import orient_consistently

RADIUS_M, LENGTH_M, ARC = 2.0, 3.0, np.pi / 2


# --------------------------------------------------------------------------------------------
# fixture writers
# --------------------------------------------------------------------------------------------
def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def grid_quads(nu: int, nv: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    v00 = (i * (nv + 1) + j).ravel()
    return np.stack([v00, v00 + nv + 1, v00 + nv + 2, v00 + 1], axis=1)


def cylinder_patch_obj(path: Path, nu: int = 30, nv: int = 40) -> Path:
    """Vault: cylinder of radius 2 m around x, 3 m long, quarter arc centred on +z; metres.

    The quads are wound so that their normals point down (inwards): the loader must turn them.
    """
    x = np.linspace(0.0, LENGTH_M, nu + 1)
    t = np.linspace(np.pi / 2 - ARC / 2, np.pi / 2 + ARC / 2, nv + 1)
    X, T = np.meshgrid(x, t, indexing="ij")
    vertices = np.stack([X, RADIUS_M * np.cos(T), RADIUS_M * np.sin(T)], axis=-1).reshape(-1, 3)
    quads = grid_quads(nu, nv)
    return write_obj(path, vertices, quads)


def plane_with_holes_obj(path: Path) -> Path:
    """2000 x 1000 mm plane, 100 mm quads, two 300 mm square holes."""
    nu, nv = 20, 10
    x, y = np.meshgrid(np.arange(nu + 1) * 100.0, np.arange(nv + 1) * 100.0, indexing="ij")
    vertices = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 3)
    quads = grid_quads(nu, nv)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    i, j = i.ravel(), j.ravel()
    hole = ((i >= 3) & (i < 6) & (j >= 3) & (j < 6)) | ((i >= 12) & (i < 15) & (j >= 4) & (j < 7))
    return write_obj(path, vertices, quads[~hole])


def write_step(path: Path, shape) -> Path:
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(shape, STEPControl_AsIs)
    assert writer.Write(str(path)) == IFSelect_ReturnStatus.IFSelect_RetDone
    return path


R_MM, L_MM, U0, U1 = 4000.0, 2400.0, np.pi / 3, 2 * np.pi / 3


def cylinder_face():
    """Cylinder segment of radius 4 m around x, 2.4 m long, crown at +z (u = angle from +y)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_CylindricalSurface
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt

    frame = gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(1, 0, 0), gp_Dir(0, 1, 0))
    surface = Geom_CylindricalSurface(frame, R_MM)
    maker = BRepBuilderAPI_MakeFace(surface, U0, U1, 0.0, L_MM, 1e-7)
    assert maker.IsDone()
    return maker.Face()


@pytest.fixture(scope="module")
def step_cylinder(tmp_path_factory) -> Path:
    return write_step(tmp_path_factory.mktemp("step") / "vault.step", cylinder_face())


# --------------------------------------------------------------------------------------------
# meshes
# --------------------------------------------------------------------------------------------
def test_obj_cylinder_patch_scaled_to_mm(tmp_path):
    surface = load_surface(cylinder_patch_obj(tmp_path / "vault.obj"), "m")
    assert surface.format == "obj" and surface.units == "m" and surface.brep is None
    assert len(surface.faces) == 2 * 30 * 40
    world = surface.vertices + surface.origin  # the surface is read into its local frame
    np.testing.assert_allclose(
        np.linalg.norm(world[:, 1:], axis=1), 2000.0, rtol=1e-8
    )  # the OBJ holds 9 digits
    np.testing.assert_allclose(surface.bounds[:, 0] + surface.origin[0], [0.0, 3000.0], atol=1e-6)
    analytic = RADIUS_M * ARC * LENGTH_M * 1e6
    assert abs(surface.area - analytic) / analytic < 0.005
    assert len(surface.boundary_loops) == 1
    # loaded with inward quads: the loader turns the vault to face up
    query = SurfaceQuery(surface)
    _, normals, _ = query.closest(np.array([[1500.0, 0.0, 2500.0]]) - surface.origin)
    assert normals[0, 2] > 0.99


def test_mesh_query_smooth_normals_and_distances(tmp_path):
    surface = load_surface(cylinder_patch_obj(tmp_path / "vault.obj"), "m")
    query = SurfaceQuery(surface)
    rng = np.random.default_rng(1)
    t = rng.uniform(np.pi / 2 - 0.6, np.pi / 2 + 0.6, 200)
    r = rng.uniform(1500.0, 2500.0, 200)
    x = rng.uniform(100.0, 2900.0, 200)
    points = np.stack([x, r * np.cos(t), r * np.sin(t)], axis=1) - surface.origin
    _foot, normals, dist = query.closest(points)
    # chord error of 40 segments on a quarter arc of 2 m: 2000 (1 - cos(pi/160)) = 0.4 mm
    np.testing.assert_allclose(dist, np.abs(r - 2000.0), atol=0.5)
    radial = np.stack([np.zeros_like(t), np.cos(t), np.sin(t)], axis=1)
    assert np.einsum("ij,ij->i", normals, radial).min() > 0.999
    # brute force over all triangles agrees
    import trimesh

    tri = surface.vertices[surface.faces]
    brute = np.array(
        [
            np.linalg.norm(
                trimesh.triangles.closest_point(tri, np.repeat(p[None], len(tri), 0)) - p, axis=1
            ).min()
            for p in points[:20]
        ]
    )
    np.testing.assert_allclose(dist[:20], brute, atol=1e-9)


def test_plane_with_two_holes_outer_loop_first(tmp_path):
    surface = load_surface(plane_with_holes_obj(tmp_path / "plate.obj"), "mm")
    assert len(surface.boundary_loops) == 3
    info = describe_surface(surface)
    assert info["openings"] == 2 and info["boundary_loops"] == 3
    assert info["manifold"] and not info["watertight"] and not info["closed"]
    np.testing.assert_allclose(info["loop_lengths_mm"], [6000.0, 1200.0, 1200.0])
    assert info["size_mm"] == [2000.0, 1000.0, 0.0]
    assert info["area_m2"] == pytest.approx(2.0 - 2 * 0.09)
    assert info["exact_brep"] is False
    # flat plate: the normal rule turns it to +z
    tri = surface.vertices[surface.faces]
    assert (np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2] > 0).all()


def test_describe_reports_non_manifold_edges():
    # closed tetrahedron plus a fin on edge (0, 1): that edge is used three times
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2], [0, 1, 4]])
    surface = Surface(
        vertices=vertices,
        faces=faces,
        boundary_loops=(),
        source=Path("fin.obj"),
        format="obj",
        units="mm",
    )
    info = describe_surface(surface)
    assert info["manifold"] is False and info["watertight"] is False
    with pytest.raises(InputError, match="vertex"):
        boundary_loops(faces, vertices, where="fin.obj")


def test_stl_binary_and_closed_mesh_outward(tmp_path):
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.faces = box.faces[:, ::-1]  # inside out
    path = tmp_path / "box.stl"
    box.export(path)
    surface = load_surface(path, "m")
    info = describe_surface(surface)
    assert info["closed"] and info["watertight"] and info["vertices"] == 8
    tri = surface.vertices[surface.faces]
    volume = np.einsum("ij,ij->", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0
    assert volume == pytest.approx(6e9)


def test_orient_consistently_repairs_flipped_faces():
    faces = grid_quads(4, 4)
    tris = np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])
    scrambled = tris.copy()
    scrambled[::3] = scrambled[::3, ::-1]
    fixed, remaining = orient_consistently(scrambled)
    assert remaining == 0
    x, y = np.meshgrid(np.arange(5.0), np.arange(5.0), indexing="ij")
    vertices = np.stack([x, y, 0 * x], axis=-1).reshape(-1, 3)
    t = vertices[fixed]
    nz = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, 2]
    assert (nz > 0).all() or (nz < 0).all()


# --------------------------------------------------------------------------------------------
# B-rep
# --------------------------------------------------------------------------------------------
def test_step_cylinder_exact_queries(step_cylinder):
    surface = load_surface(step_cylinder, None)
    assert surface.format == "step" and surface.brep is not None and surface.units == "mm"
    assert len(surface.boundary_loops) == 1
    analytic = R_MM * (U1 - U0) * L_MM
    assert abs(surface.area - analytic) / analytic < 1e-3
    query = SurfaceQuery(surface)
    assert query.face_count == 1 and query.exact
    rng = np.random.default_rng(7)
    n = 200
    t = rng.uniform(U0 + 0.05, U1 - 0.05, n)
    r = rng.uniform(0.5 * R_MM, 1.5 * R_MM, n)
    x = rng.uniform(10.0, L_MM - 10.0, n)
    origin = surface.origin
    points = np.stack([x, r * np.cos(t), r * np.sin(t)], axis=1)
    foot, normals, dist = query.closest(points - origin)
    foot = foot + origin
    np.testing.assert_allclose(np.linalg.norm(foot[:, 1:], axis=1), R_MM, rtol=1e-9)
    np.testing.assert_allclose(dist, np.abs(r - R_MM), rtol=1e-6, atol=1e-6 * R_MM)
    radial = np.stack([np.zeros(n), np.cos(t), np.sin(t)], axis=1)
    np.testing.assert_allclose(normals, radial, atol=1e-9)  # outward = up for the vault
    # a point beyond the end of the vault projects onto its end edge
    far = np.array([[L_MM + 500.0, 0.0, R_MM + 100.0]])
    foot, _, dist = query.closest(far - origin)
    np.testing.assert_allclose(foot[0] + origin, [L_MM, 0.0, R_MM], atol=1e-6)
    assert dist[0] == pytest.approx(np.hypot(500.0, 100.0), rel=1e-9)


def test_step_cylinder_parameters(step_cylinder):
    surface = load_surface(step_cylinder, "m")  # units ignored for B-rep
    query = SurfaceQuery(surface)
    umin, umax, vmin, vmax = query.uv_bounds()
    np.testing.assert_allclose([umin, umax, vmin, vmax], [U0, U1, 0.0, L_MM], atol=1e-9)
    u = np.linspace(umin, umax, 7)
    v = np.linspace(vmin, vmax, 7)
    points, normals = query.evaluate_uv(u, v)
    world = points + surface.origin  # parameters survive the move into the local frame
    np.testing.assert_allclose(np.linalg.norm(world[:, 1:], axis=1), R_MM, rtol=1e-12)
    np.testing.assert_allclose(world[:, 0], v, atol=1e-9)
    np.testing.assert_allclose(normals[:, 1:], world[:, 1:] / R_MM, atol=1e-12)
    pu, pv = query.project_uv(points + 10.0 * normals)
    np.testing.assert_allclose(pu, u, atol=1e-9)
    np.testing.assert_allclose(pv, v, atol=1e-6)


def test_single_face_methods_need_single_face_brep(tmp_path):
    query = SurfaceQuery(load_surface(plane_with_holes_obj(tmp_path / "plate.obj"), "mm"))
    assert query.face_count == 0
    for call in (
        query.uv_bounds,
        lambda: query.evaluate_uv([0.0], [0.0]),
        lambda: query.project_uv([[0.0, 0.0, 0.0]]),
    ):
        with pytest.raises(GeometryError, match="single face"):
            call()


def test_step_in_metres_is_read_in_mm(tmp_path):
    """Kernel quirk pinned: OCCT converts a STEP written in metres to the session unit, mm."""
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_Controller

    STEPControl_Controller.Init_s()
    Interface_Static.SetCVal_s("write.step.unit", "M")
    try:
        path = write_step(tmp_path / "vault_m.step", cylinder_face())
    finally:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
    assert "SI_UNIT($,.METRE.)" in path.read_text()
    surface = load_surface(path)
    assert surface.units == "m"
    np.testing.assert_allclose(surface.bounds[:, 0] + surface.origin[0], [0.0, L_MM], atol=1e-6)


@pytest.mark.parametrize("offset_m", [1e3, 1e6])
def test_a_surface_far_from_the_origin_reads_into_the_same_local_frame(tmp_path, offset_m):
    """Coordinates are recentred on load: a model in site coordinates gives the same local
    geometry (and so the same results) as the same model at the origin."""
    near = load_surface(cylinder_patch_obj(tmp_path / "near.obj"), "m")
    text = (tmp_path / "near.obj").read_text().splitlines()
    moved = [
        " ".join(["v"] + [f"{float(c) + offset_m:.12f}" for c in line.split()[1:]])
        if line.startswith("v ")
        else line
        for line in text
    ]
    (tmp_path / "far.obj").write_text("\n".join(moved) + "\n")
    far = load_surface(tmp_path / "far.obj", "m")
    np.testing.assert_allclose(far.origin - near.origin, offset_m * 1000.0, atol=1.0)
    np.testing.assert_allclose(far.vertices, near.vertices, atol=1.0 + 1e-6)
    # the origin is rounded to whole mm: the local frames agree to the rounding of the shift
    np.testing.assert_allclose(
        far.vertices - far.vertices[0], near.vertices - near.vertices[0], atol=1e-5 * offset_m / 1e3
    )
    np.testing.assert_allclose(
        far.to_dict()["bounds_mm"],
        np.array(near.to_dict()["bounds_mm"]) + offset_m * 1000.0,
        atol=1e-3,
    )


def test_multi_face_brep_solid(tmp_path):
    """A closed solid read from BREP: welded seams, closed, outward; exact normals outward."""
    import build123d as bd

    from fabpanel.surface import shape_to_brep

    path = tmp_path / "drum.brep"
    path.write_bytes(shape_to_brep(bd.Solid.make_cylinder(500.0, 800.0).wrapped))
    surface = load_surface(path)
    info = describe_surface(surface)
    assert info["closed"] and info["watertight"] and info["exact_brep"]
    query = SurfaceQuery(surface)
    assert query.face_count == 3
    points = np.array(
        [[0.0, 0.0, 1000.0], [900.0, 0.0, 400.0], [0.0, 0.0, -50.0], [100.0, 50.0, 700.0]]
    )
    foot, normals, dist = query.closest(points)
    np.testing.assert_allclose(
        foot, [[0, 0, 800], [500, 0, 400], [0, 0, 0], [100, 50, 800]], atol=1e-7
    )
    np.testing.assert_allclose(normals, [[0, 0, 1], [1, 0, 0], [0, 0, -1], [0, 0, 1]], atol=1e-9)
    np.testing.assert_allclose(dist, [200, 400, 50, 100], atol=1e-7)
    with pytest.raises(GeometryError):
        query.uv_bounds()


# --------------------------------------------------------------------------------------------
# bad input: one-line InputError naming the file
# --------------------------------------------------------------------------------------------
def _shape_step(tmp_path: Path, kind: str) -> Path:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeVertex
    from OCP.gp import gp_Pnt

    if kind == "point":
        shape = BRepBuilderAPI_MakeVertex(gp_Pnt(1, 2, 3)).Vertex()
    else:
        shape = BRepBuilderAPI_MakeEdge(gp_Pnt(0, 0, 0), gp_Pnt(100, 0, 0)).Edge()
    return write_step(tmp_path / f"only_{kind}.step", shape)


BAD_TEXT = {
    "empty.stl": b"",
    "points.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    "nan.obj": b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "inf.obj": b"v 0 0 0\nv 1 inf 0\nv 0 1 0\nf 1 2 3\n",
    "range.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n",
    "negative.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -99\n",
    "range.off": b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
    "bowtie.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv -1 0 0\nv 0 -1 0\nf 1 2 3\nf 1 4 5\n",
    "text.step": b"this is not a STEP file\n",
    "text.igs": b"this is not an IGES file either\n",
    "text.brep": b"nor a BREP file\n",
    "surface.xyz": b"0 0 0\n",
}


@pytest.mark.parametrize("name", sorted(BAD_TEXT))
def test_bad_files_raise_input_error(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(BAD_TEXT[name])
    with pytest.raises(InputError) as info:
        load_surface(path, "mm")
    message = str(info.value)
    assert name in message and "\n" not in message


@pytest.mark.parametrize("name", ["random.stl", "random.ply", "random.glb", "random.obj"])
def test_random_bytes_raise_input_error(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(np.random.default_rng(3).bytes(4000))
    with pytest.raises(InputError) as info:
        load_surface(path, "mm")
    assert name in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("kind", ["point", "edge"])
def test_step_without_surface(tmp_path, kind):
    path = _shape_step(tmp_path, kind)
    with pytest.raises(InputError, match=f"{path.name}: contains no surface"):
        load_surface(path)


def test_missing_file_and_missing_units(tmp_path):
    with pytest.raises(InputError, match="nope.obj: file not found"):
        load_surface(tmp_path / "nope.obj", "mm")
    path = cylinder_patch_obj(tmp_path / "vault.obj")
    with pytest.raises(InputError, match="vault.obj: mesh files carry no units"):
        load_surface(path, None)
    with pytest.raises(InputError, match="supported: .obj"):
        load_surface(tmp_path / "vault.dwg", "mm")
