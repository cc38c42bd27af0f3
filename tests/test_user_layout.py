"""User layouts: a hand-drawn quad mesh mapped onto the barrel vault, and written back."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from fabpanel import InputError, Job
from fabpanel.panelize import panelize
from fabpanel.panelize.export import write_layout_obj
from fabpanel.panelize.user_layout import read_quad_mesh, user_layout
from fabpanel.surface import SurfaceQuery, load_surface

DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # shipped: fabpanel demo
RADIUS = 4000.0  # mm, fabpanel/examples/barrel-vault.step: axis along +x, crown at +z, length 12 m


@pytest.fixture(scope="module")
def vault():
    surface = load_surface(DEMO / "barrel-vault.step")
    return surface, SurfaceQuery(surface)


@pytest.fixture
def job():
    return Job.from_dict({"panelize": {"panel_size": "4 m"}})


def vault_layout(radius_m: float = RADIUS / 1000) -> tuple[np.ndarray, np.ndarray]:
    """3 x 2 quads over the vault, metres: 3 along x (4 m), 2 around (90 degrees each).

    Vertex (i, j) = i * 3 + j at x = 4 i, angle 90 j degrees; quads counter-clockwise seen from
    outside (along the arc first, then along x), as fabpanel/examples/barrel_vault.py does.
    """
    xs, angles = np.array([0.0, 4.0, 8.0, 12.0]), np.radians([0.0, 90.0, 180.0])
    X, A = np.meshgrid(xs, angles, indexing="ij")
    vertices = np.stack([X, radius_m * np.cos(A), radius_m * np.sin(A)], axis=-1).reshape(-1, 3)
    quads = np.array(
        [
            [3 * i + j, 3 * i + j + 1, 3 * (i + 1) + j + 1, 3 * (i + 1) + j]
            for i in range(3)
            for j in range(2)
        ]
    )
    return vertices, quads


def write_obj(path: Path, vertices, faces) -> Path:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(vertices, dtype=float).tolist()]
    lines += ["f " + " ".join(f"{i + 1}/{i + 1}" for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def outward(layout) -> np.ndarray:
    """(m,) dot product of each quad's right-hand normal with the cylinder's radial direction."""
    corners = layout.vertices[layout.quads]
    normal = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    radial = corners.mean(axis=1) * [0.0, 1.0, 1.0]
    return np.einsum("ij,ij->i", normal, radial)


def test_layout_is_mapped_onto_the_surface(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout(radius_m=4.1)  # drawn 100 mm off the vault
    layout = user_layout(write_obj(tmp_path / "l.obj", vertices, quads), "m", surface, query, job)
    assert layout.method == "layout" and layout.parameters is None
    assert layout.panel_ids == ("P001", "P002", "P003", "P004", "P005", "P006")
    np.testing.assert_array_equal(layout.quads, quads)  # already outward: kept as drawn
    _, _, distance = query.closest(layout.vertices)
    np.testing.assert_allclose(distance, 0.0, atol=1e-6)
    world = layout.vertices + layout.origin  # drawn and reported in the design's frame
    np.testing.assert_allclose(np.linalg.norm(world[:, 1:], axis=1), RADIUS, atol=1e-6)
    np.testing.assert_allclose(world[:, 0], vertices[:, 0] * 1000, atol=1e-6)
    assert layout.metrics["mapping_distance_mm"]["max"] == pytest.approx(100.0, abs=1e-3)
    assert layout.metrics["panels"] == 6 and layout.metrics["flipped_quads"] == 0
    assert "layout-off-surface" not in {issue.code for issue in layout.issues}


def test_layout_far_from_the_surface_is_reported(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout(radius_m=4.5)  # 500 mm off: > 5 % of ~4 m
    layout = user_layout(write_obj(tmp_path / "l.obj", vertices, quads), "m", surface, query, job)
    issue = next(i for i in layout.issues if i.code == "layout-off-surface")
    assert issue.severity == "warning" and "500 mm" in issue.message


def test_quads_are_turned_outwards(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout()
    inward = quads[:, ::-1]  # clockwise seen from outside
    layout = user_layout(write_obj(tmp_path / "in.obj", vertices, inward), "m", surface, query, job)
    assert np.all(outward(layout) > 0)
    np.testing.assert_array_equal(layout.quads, inward[:, [0, 3, 2, 1]])
    assert layout.metrics["flipped_quads"] == 6
    # a drawing with mixed winding comes out consistent
    mixed = quads.copy()
    mixed[[1, 4]] = mixed[[1, 4], ::-1]
    layout = user_layout(
        write_obj(tmp_path / "mixed.obj", vertices, mixed), "m", surface, query, job
    )
    assert np.all(outward(layout) > 0) and layout.metrics["flipped_quads"] == 2
    sides = np.stack([layout.quads, np.roll(layout.quads, -1, axis=1)], axis=2).reshape(-1, 2)
    assert len({tuple(s) for s in sides.tolist()}) == len(sides)  # no side run twice alike


def test_triangles_and_other_polygons_are_refused(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout()
    faces = [list(q) for q in quads]
    faces[2] = faces[2][:3]
    path = write_obj(tmp_path / "tri.obj", vertices, faces)
    with pytest.raises(InputError, match=r"tri\.obj: face 2 has 3 corners.*quad"):
        user_layout(path, "m", surface, query, job)
    faces[2] = list(quads[2]) + [0]
    with pytest.raises(InputError, match="face 2 has 5 corners"):
        read_quad_mesh(write_obj(tmp_path / "penta.obj", vertices, faces), "m")


def test_bad_layout_files(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout()
    path = write_obj(tmp_path / "l.obj", vertices, quads)
    with pytest.raises(InputError, match="carries no units"):
        user_layout(path, None, surface, query, job)
    with pytest.raises(InputError, match="OBJ, PLY or 3DM"):
        read_quad_mesh(tmp_path / "l.stl", "m")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3 4\n")
    with pytest.raises(InputError, match="refers to vertex 4"):
        read_quad_mesh(bad, "m")
    # a drawing that folds back over itself on the surface
    fold = np.vstack([vertices, [[2.0, RADIUS / 1000, 0.0], [2.0, 0.0, RADIUS / 1000]]])
    faces = [quads[0], [3, 4, 13, 12]]  # second quad lies over the first
    with pytest.raises(InputError, match="fold over each other"):
        user_layout(write_obj(tmp_path / "fold.obj", fold, faces), "m", surface, query, job)


def test_welds_duplicates_and_drops_unused_vertices(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout()
    # an "unwelded" export: four own vertices per face, plus a stray point first
    loose = np.vstack([[[50.0, 50.0, 50.0]], vertices[quads].reshape(-1, 3)])
    faces = 1 + np.arange(4 * len(quads)).reshape(-1, 4)
    layout = user_layout(write_obj(tmp_path / "loose.obj", loose, faces), "m", surface, query, job)
    reference = user_layout(
        write_obj(tmp_path / "l.obj", vertices, quads), "m", surface, query, job
    )
    assert len(layout.vertices) == 12
    np.testing.assert_allclose(
        layout.vertices[layout.quads], reference.vertices[reference.quads], atol=1e-9
    )
    assert len(layout.edges) == len(reference.edges) == 17


def _write_ply(path: Path, vertices, quads, fmt: str) -> Path:
    header = [
        "ply",
        f"format {fmt} 1.0",
        "comment drawn by hand",
        f"element vertex {len(vertices)}",
        "property double x",
        "property double y",
        "property double z",
        "property uchar red",
        f"element face {len(quads)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    head = ("\n".join(header) + "\n").encode()
    if fmt == "ascii":
        rows = [f"{x!r} {y!r} {z!r} 7" for x, y, z in vertices.tolist()]
        rows += ["4 " + " ".join(map(str, q)) for q in quads.tolist()]
        path.write_bytes(head + ("\n".join(rows) + "\n").encode())
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        body = b"".join(struct.pack(order + "dddB", *v, 7) for v in vertices.tolist())
        body += b"".join(struct.pack(order + "B4i", 4, *q) for q in quads.tolist())
        path.write_bytes(head + body)
    return path


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_layouts(tmp_path, fmt):
    vertices, quads = vault_layout()
    read_vertices, read_quads = read_quad_mesh(
        _write_ply(tmp_path / "l.ply", vertices, quads, fmt), "m"
    )
    np.testing.assert_array_equal(read_quads, quads)
    np.testing.assert_allclose(read_vertices, vertices * 1000, atol=1e-9)


def test_3dm_layout_in_its_own_units(tmp_path):
    rhino3dm = pytest.importorskip("rhino3dm", reason="3DM layouts need rhino3dm")
    vertices, quads = vault_layout()
    mesh = rhino3dm.Mesh()
    for x, y, z in vertices.tolist():
        mesh.Vertices.Add(x, y, z)
    for a, b, c, d in quads.tolist():
        mesh.Faces.AddFace(a, b, c, d)
    model = rhino3dm.File3dm()
    model.Settings.ModelUnitSystem = rhino3dm.UnitSystem.Meters
    model.Objects.AddMesh(mesh)
    path = tmp_path / "l.3dm"
    assert model.Write(str(path), 7)
    read_vertices, read_quads = read_quad_mesh(path, "mm")  # the file's metres win
    np.testing.assert_array_equal(read_quads, quads)
    np.testing.assert_allclose(read_vertices, vertices * 1000, atol=1e-3)  # float32 vertices
    mesh.Faces.AddFace(0, 1, 4)
    model = rhino3dm.File3dm()
    model.Objects.AddMesh(mesh)
    model.Write(str(path), 7)
    with pytest.raises(InputError, match="face 6 has 3 corners"):
        read_quad_mesh(path, "m")


def test_round_trip_through_panels_obj(tmp_path, vault, job):
    surface, query = vault
    vertices, quads = vault_layout()
    layout = user_layout(write_obj(tmp_path / "l.obj", vertices, quads), "m", surface, query, job)
    path = write_layout_obj(layout, tmp_path / "model" / "panels.obj")
    text = path.read_text()
    assert "# units: mm" in text and "o panels" in text
    assert text.count("\nf ") == 6 and "# P006\nf " in text
    again = user_layout(path, "mm", surface, query, job)
    np.testing.assert_array_equal(again.quads, layout.quads)
    np.testing.assert_allclose(again.vertices, layout.vertices, atol=1e-6)
    assert again.panel_ids == layout.panel_ids
    assert again.metrics["mapping_distance_mm"]["max"] < 1e-6


def test_panelize_dispatches_to_the_layout(tmp_path, vault):
    surface, query = vault
    vertices, quads = vault_layout()
    write_obj(tmp_path / "drawn.obj", vertices, quads)
    job = Job.from_dict(
        {
            "input": {"path": str(DEMO / "barrel-vault.step"), "units": "m"},
            "panelize": {"method": "layout", "layout": "drawn.obj"},
        },
        base_dir=tmp_path,
    )
    layout = panelize(surface, job, query)
    assert layout.method == "layout" and len(layout.quads) == 6
