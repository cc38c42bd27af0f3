"""Build stage on analytic cylinder panels: ids, validity, volumes, rib planes, STEP round trip."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import cylinder_developed

from fabpanel.buildup import Buildup
from fabpanel.errors import KernelError
from fabpanel.geom.polygon import polygon_area
from fabpanel.job import Job
from fabpanel.model import (
    build,
    occ,
    read_step_parts,
    write_glb,
    write_panel_steps,
    write_step_assembly,
)
from fabpanel.model.clash import SolidsOnDemand, find_clashes, part_solid
from fabpanel.model.joints import along_polyline
from fabpanel.model.plates import clip_polyline
from fabpanel.model.rhino import write_3dm
from fabpanel.model.trim import side_rows

R, LENGTH, ARC = 4000.0, 2400.0, np.pi / 3


@pytest.fixture(scope="module")
def developed():
    return cylinder_developed(radius=R, length=LENGTH, arc=ARC)


@pytest.fixture(scope="module")
def job():
    return Job.from_dict({})


@pytest.fixture(scope="module")
def model(developed, job):
    return build(developed, job, jobs=1)


def _world(part):
    pts = part.outline
    return (np.c_[pts, np.zeros(len(pts)), np.ones(len(pts))] @ part.frame.T)[:, :3]


PER_PANEL = ("TOP", "BOT", "RIB-0", "RIB-1", "RIB-2", "RIB-3", "STF-0", "STF-1", "STF-2", "STF-3")


def _part(model, pid, suffix):
    return next(p for p in model.parts if p.id == f"{pid}-{suffix}")


def _joints(developed):
    neighbours = developed.layout.side_neighbours
    for p in range(len(neighbours)):
        for s in range(4):
            q = neighbours[p, s]
            if q > p:
                yield p, s, int(q), next(t for t in range(4) if neighbours[q, t] == p)


def _circle_centres(shape):
    """Centres of the circular edges of a shape (bolt holes), mm."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_Circle
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    centres = []
    explorer = TopExp_Explorer(shape, TopAbs_EDGE)
    while explorer.More():
        curve = BRepAdaptor_Curve(TopoDS.Edge(explorer.Current()))
        if curve.GetType() == GeomAbs_Circle:
            c = curve.Circle().Location()
            centres.append((c.X(), c.Y(), c.Z()))
        explorer.Next()
    return np.unique(np.round(np.array(centres), 6), axis=0)


def test_parts_ids_kinds_and_order(model):
    ids = [p.id for p in model.parts]
    assert ids == [f"P00{i}-{s}" for i in range(1, 5) for s in PER_PANEL]
    kinds = {p.id: p.kind for p in model.parts}
    assert kinds["P001-TOP"] == "sheet-top" and kinds["P003-BOT"] == "sheet-bottom"
    assert kinds["P004-RIB-2"] == "rib" and kinds["P002-STF-3"] == "stiffener"
    assert model.metrics["counts"] == {
        "sheet-top": 4,
        "sheet-bottom": 4,
        "rib": 16,
        "stiffener": 16,
    }
    # a cap standing on its rim: the build-up hangs below it, a note for the foundations
    assert [i.code for i in model.issues] == ["below-design"]
    assert model.issues[0].severity == "info"


def test_every_solid_valid(model):
    assert model.metrics["all_valid"] is True
    for part in model.parts:
        assert occ.is_valid(occ.from_brep(part.brep)), part.id


def test_sheet_volumes_are_cylindrical_shells_less_the_openings(model, job):
    """Each panel of the 2 x 2 grid has one interior side across the axis and one along it; the
    sheets stand back from both by the weld set-back (a slice s thick across the axis, a strip
    s wide along it: s t per unit length to within (s / R)^2)."""
    t, s = job.sandwich.sheet_thickness, Buildup.of(job).welds.setback
    assert s == 4.0  # 3 mm sheets: a 2.1 mm throat, a 3 mm leg, 1 mm fit-up
    angle, length = ARC / 2, LENGTH / 2
    shell = (angle / 2 * (R**2 - (R - t) ** 2) - s * t) * (length - s)
    top_in = R - t - job.sandwich.rib_height
    b = job.sandwich.bottom_thickness
    bot = (angle / 2 * (top_in**2 - (top_in - b) ** 2) - s * b) * (length - s)
    slot = job.sandwich.access_design().slot
    for part in model.parts:
        if part.kind == "sheet-top":
            assert part.holes == () and part.openings == ()
            np.testing.assert_allclose(part.volume, shell, rtol=1e-4)
            np.testing.assert_allclose(part.mass, part.volume * job.material.density)
            np.testing.assert_allclose(
                part.area, (angle * (R - t / 2) - s) * (length - s), rtol=1e-4
            )
        if part.kind == "sheet-bottom":
            # every opening is one slot or two merged at a corner
            assert len(part.openings) > 0 and part.holes == ()
            assert part.opening_area >= len(part.openings) * abs(polygon_area(slot)) * 0.999
            np.testing.assert_allclose(part.volume, bot - part.opening_area * t, rtol=1e-4)


def test_sheet_fit_and_mid_fibre_grid(model, developed, job):
    assert model.metrics["max_sheet_fit_error_mm"] < 0.01
    assert model.metrics["max_sheet_edge_mismatch_mm"] < 1e-6
    t = job.sandwich.sheet_thickness
    top = model.parts[0]
    grid = top.surface_grid
    assert grid.shape == (33, 33, 3)
    np.testing.assert_allclose(np.hypot(grid[..., 1], grid[..., 2]), R - t / 2, atol=0.01)
    # side convention: each boundary row of the grid lies in its side's rib plane, moved into
    # the panel by the weld set-back where a neighbour's rib seats (boundary sides flush)
    setback = Buildup.of(job).welds.setback
    for side, row in enumerate(side_rows(grid)):
        plane = developed.side_planes[0, side] / np.linalg.norm(developed.side_planes[0, side, :3])
        interior = developed.layout.side_neighbours[0, side] >= 0
        expected = setback if interior else 0.0
        np.testing.assert_allclose(row @ plane[:3] - plane[3], expected, atol=1e-6)


def test_ribs_planar_and_inside_their_plane(model, developed, job):
    assert model.metrics["max_plate_planarity_mm"] < 0.05
    t_rib, d = job.sandwich.rib_thickness, job.sandwich.bolts.diameter
    for p, pid in enumerate(developed.panel_ids):
        for s in range(4):
            rib = _part(model, pid, f"RIB-{s}")
            plane = developed.side_planes[p, s]
            dist = occ.plane_distances(occ.from_brep(rib.brep), plane)
            assert dist.min() > -0.05 and dist.max() < t_rib + 0.05
            # outer face exactly in the plane
            assert np.abs(_world(rib) @ plane[:3] - plane[3]).max() < 0.05
            assert polygon_area(rib.outline) > 0
            holes = len(rib.holes)
            np.testing.assert_allclose(
                rib.area, polygon_area(rib.outline) - holes * np.pi * d**2 / 4
            )
            np.testing.assert_allclose(rib.volume, rib.area * t_rib, rtol=1e-3)
            interior = developed.layout.side_neighbours[p, s] >= 0
            assert (holes > 0) == interior


def test_back_to_back_ribs_touch_and_their_bolts_are_coaxial(model, developed):
    pairs = 0
    for p, s, q, t in _joints(developed):
        a = _part(model, developed.panel_ids[p], f"RIB-{s}")
        b = _part(model, developed.panel_ids[q], f"RIB-{t}")
        plane = developed.side_planes[q, t]
        assert np.abs(_world(a) @ plane[:3] - plane[3]).max() <= 0.1
        # normals opposite: the ribs stand back to back, not through each other
        assert developed.side_planes[p, s, :3] @ plane[:3] < -0.999
        shape_a, shape_b = occ.from_brep(a.brep), occ.from_brep(b.brep)
        assert occ.common_volume(shape_a, shape_b) < 1.0
        # the holes: circle centres in the shared plane coincide
        ca = _circle_centres(shape_a)
        cb = _circle_centres(shape_b)
        ca = ca[np.abs(ca @ plane[:3] - plane[3]) < 1e-3]
        cb = cb[np.abs(cb @ plane[:3] - plane[3]) < 1e-3]
        assert len(ca) == len(cb) == len(a.holes) >= 2
        gaps = np.linalg.norm(ca[:, None] - cb[None], axis=2).min(axis=1)
        assert gaps.max() < 0.1
        pairs += 1
    assert pairs == 4
    assert model.metrics["max_rib_contact_gap_mm"] <= 0.1
    assert model.metrics["max_bolt_coaxial_error_mm"] < 0.1


def test_parts_of_one_panel_do_not_overlap(model):
    """Exact booleans: parts touch along faces; the kernel's sliver on a curved contact is
    micrometres thick (1e-4 of a rib's volume is 0.015 mm over its edge)."""
    parts = {p.id: p for p in model.parts_of("P001")}
    shapes = {pid: occ.from_brep(p.brep) for pid, p in parts.items()}
    ids = sorted(shapes)
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            smaller = min(parts[a].volume, parts[b].volume)
            assert occ.common_volume(shapes[a], shapes[b]) < 1e-4 * smaller, (a, b)
    assert model.metrics["clash"]["clashes"] == 0


def test_stiffeners_cross_the_corners_at_the_offset(model, developed, job):
    x, t_rib = job.sandwich.stiffener_offset, job.sandwich.rib_thickness
    t_stf = job.sandwich.stiffener_thickness or t_rib
    for p, pid in enumerate(developed.panel_ids):
        rows = [developed.side_samples(p, s) for s in range(4)]
        for corner in range(4):
            stiffener = _part(model, pid, f"STF-{corner}")
            frame = stiffener.frame
            plane = np.r_[frame[:3, 2], frame[:3, 2] @ frame[:3, 3]]
            a, _ = along_polyline(rows[(corner - 1) % 4][::-1], np.array([x]))
            b, _ = along_polyline(rows[corner], np.array([x]))
            assert abs(a[0] @ plane[:3] - plane[3]) < 0.5
            assert abs(b[0] @ plane[:3] - plane[3]) < 0.5
            # it stands away from the corner, between the ribs' inner faces
            corner_point = rows[corner][0]
            assert corner_point @ plane[:3] - plane[3] < 0
            dist = occ.plane_distances(occ.from_brep(stiffener.brep), plane)
            assert dist.min() > -0.05 and dist.max() < t_stf + 0.05
            for side in ((corner - 1) % 4, corner):
                rib_plane = developed.side_planes[p, side]
                inside = occ.plane_distances(occ.from_brep(stiffener.brep), rib_plane)
                assert inside.min() > t_rib - 0.05
                assert inside.min() < t_rib + 1.0  # it reaches the rib


def test_clash_check_finds_a_deliberate_overlap(model):
    rib = _part(model, "P001", "RIB-1")
    other = _part(model, "P001", "STF-1")
    shifted = rib.frame.copy()
    shifted[:3, 3] += 20.0 * rib.frame[:3, 2]  # 20 mm into the panel: through the stiffener
    shapes = {
        "A": ("plate", rib.outline, shifted, rib.thickness),
        "B": ("plate", other.outline, other.frame, other.thickness),
        "C": ("plate", rib.outline, rib.frame, rib.thickness),
    }
    solids = {k: part_solid(shape, k) for k, shape in shapes.items()}
    found, measures = find_clashes(solids, {"P": ["A", "B"], "Q": ["C"]}, [("P", "Q")])
    # the solids made on demand, a panel at a time (as the build does), find the same
    lazy, lazy_measures = find_clashes(
        SolidsOnDemand(shapes), {"P": ["A", "B"], "Q": ["C"]}, [("P", "Q")]
    )
    assert [(a, b, v) for a, b, v, _ in lazy] == [(a, b, v) for a, b, v, _ in found]
    assert lazy_measures == measures
    assert [(a, b) for a, b, *_ in found] == [("A", "B")]
    assert found[0][2] > 100.0
    # where: the centre of the common volume lies in both parts' boxes
    for part in ("A", "B"):
        box = np.asarray(solids[part].bounding_box())
        assert np.all(box[:3] - 0.5 <= found[0][3]) and np.all(found[0][3] <= box[3:] + 0.5)
    assert measures["clashes"] == 1
    # the real rib against the stiffener: touching only
    ok, _ = find_clashes({k: solids[k] for k in ("B", "C")}, {"P": ["B", "C"]}, [])
    assert ok == []


def test_step_assembly_round_trip(model, tmp_path):
    path = write_step_assembly(model, tmp_path / "assembly.step")
    text = path.read_text()
    # material and part properties as STEP allows (material record, general properties)
    assert "DESCRIPTIVE_REPRESENTATION_ITEM('material','S235')" in text
    assert text.count("PROPERTY_DEFINITION('thickness_mm'") == len(model.parts)
    assert text.count("COLOUR_RGB") >= 3
    # compact (issue 18): no 2D curves, the reader projects the edges; read back valid below
    assert "PCURVE" not in text
    # compact text: an entity a line, each point once (tests/test_step_compact.py)
    points = re.findall(r"(?m)^#\d+=(CARTESIAN_POINT\(.*\));$", text)
    assert len(points) > 100 and len(points) == len(set(points))
    assert all(line.endswith(";") for line in text.split("DATA;")[1].splitlines() if line)
    shapes = read_step_parts(path)
    assert sorted(shapes) == sorted(p.id for p in model.parts)
    for part in model.parts:
        assert occ.is_valid(shapes[part.id]), part.id
        np.testing.assert_allclose(occ.volume(shapes[part.id]), part.volume, rtol=1e-3)
        if part.kind in ("rib", "stiffener"):
            frame = part.frame
            plane = np.r_[frame[:3, 2], frame[:3, 2] @ frame[:3, 3]]
            dist = occ.plane_distances(shapes[part.id], plane)
            flat = np.minimum(np.abs(dist), np.abs(dist - part.thickness))
            # every vertex and edge point on one of the two plate faces, except the points
            # of the edges through the thickness
            assert np.all((flat < 0.05) | ((dist > 0.05) & (dist < part.thickness - 0.05)))
    # bolt holes of back-to-back ribs, re-imported: coaxial within 0.1 mm
    developed = model.developed
    for p, s, q, t in _joints(developed):
        plane = developed.side_planes[p, s] / np.linalg.norm(developed.side_planes[p, s, :3])
        centres = []
        for panel, side in ((p, s), (q, t)):
            found = _circle_centres(shapes[f"{developed.panel_ids[panel]}-RIB-{side}"])
            centres.append(found[np.abs(found @ plane[:3] - plane[3]) < 1e-3])
        assert len(centres[0]) == len(centres[1]) >= 2
        assert np.linalg.norm(centres[0][:, None] - centres[1][None], axis=2).min(1).max() < 0.1
    files = write_panel_steps(model, tmp_path / "panels")
    assert files == {pid: f"{pid}.step" for pid in model.developed.panel_ids}
    assert sorted(read_step_parts(tmp_path / "panels" / "P002.step")) == sorted(
        p.id for p in model.parts_of("P002")
    )
    glb = write_glb(model, tmp_path / "preview.glb")
    assert glb.read_bytes()[:4] == b"glTF"
    import trimesh

    scene = trimesh.load(glb)
    # a part's tessellation has few vertices: its indices are 16-bit (fabpanel.model.glb)
    import json
    import struct

    from fabpanel.model.glb import UINT16

    data = glb.read_bytes()
    document = json.loads(data[20 : 20 + struct.unpack_from("<I", data, 12)[0]])
    index_types = {
        document["accessors"][p["indices"]]["componentType"]
        for m in document["meshes"]
        for p in m["primitives"]
    }
    assert index_types == {UINT16}
    # one named mesh per part, each under its panel's node
    assert sorted(scene.geometry) == sorted(p.id for p in model.parts)
    for part in model.parts:
        assert scene.graph.transforms.parents[part.id] == part.panel_id
    # metres, Y up: the model's z extent (mm) is the preview's y extent (m)
    from fabpanel.model.occ import from_brep, shape_points

    points = np.vstack([shape_points(from_brep(p.brep)) for p in model.parts])
    low, high = points.min(0), points.max(0)
    np.testing.assert_allclose(
        scene.bounds[1, 1] - scene.bounds[0, 1], (high - low)[2] / 1000, rtol=0.02
    )
    np.testing.assert_allclose(
        scene.bounds[1, 0] - scene.bounds[0, 0], (high - low)[0] / 1000, rtol=0.02
    )


def test_the_preview_shows_the_exchange_solids_closed_and_in_place(model, tmp_path):
    """Given the IFC's and 3DM's geometry, the GLB's plates are their profiles extruded (the
    sheets tessellated as without it); every part closed, with the solid's volume, in place."""
    import trimesh

    from fabpanel.docs.ifc import solid_geometries
    from fabpanel.model.occ import from_brep, shape_points

    geometry = solid_geometries([(p.id, p.brep, p.thickness, p.kind) for p in model.parts])
    scene = trimesh.load(write_glb(model, tmp_path / "preview.glb", geometry=geometry))
    assert sorted(scene.geometry) == sorted(p.id for p in model.parts)
    for part in model.parts:
        mesh = scene.geometry[part.id]
        assert mesh.is_watertight, part.id
        # m3 in the preview; a plate exact to its profile's chords, a sheet to its mesh's
        sheet = part.kind.startswith("sheet")
        assert mesh.volume * 1e9 == pytest.approx(part.volume, rel=5e-3 if sheet else 1e-3)
        # in place: the part's extent (mm, Z up) is the mesh's (m, Y up)
        points = shape_points(from_brep(part.brep))
        low = (points.min(0) + model.developed.layout.origin) / 1000
        np.testing.assert_allclose(
            mesh.bounds[0],
            [low[0], low[2], -(points.max(0)[1] + model.developed.layout.origin[1]) / 1000],
            atol=2e-3,
        )


def test_step_assembly_in_chunks_is_one_tree_whatever_the_workers(model, tmp_path, monkeypatch):
    """Written a panel per chunk (so four chunks merge), by one process or two workers: the
    same entities (OCCT numbers its colours in an order of memory addresses, so they compare
    renumbered away, as the Ray test does), one root, a node per chunk, every panel and part
    under it; every entity number defined once."""
    import re

    import build123d as bd

    from fabpanel.model import step_chunks

    monkeypatch.setattr(step_chunks, "STEP_CHUNK_PANELS", 1)
    one = write_step_assembly(model, tmp_path / "one.step", workers=1)
    two = write_step_assembly(model, tmp_path / "two.step", workers=2)

    def body(path):
        data = re.sub(rb"FILE_NAME\([^;]*;", b"", path.read_bytes())
        return sorted(re.sub(rb"#\d+", b"#", re.sub(rb"\s+", b"", data)).split(b";"))

    assert body(one) == body(two)
    text = one.read_bytes()
    defined = re.findall(rb"(?m)^#(\d+)\s*=", text)
    assert len(defined) == len(set(defined))
    assert set(re.findall(rb"#(\d+)", text)) <= set(defined) | {b"1"}  # 'Context #1' names
    assert text.count(b"PRODUCT('fabpanel'") == 1
    root = bd.import_step(str(one))
    assert root.label == "fabpanel"
    ids = list(model.developed.panel_ids)
    assert [c.label for c in root.children] == [f"{pid}-{pid}" for pid in ids]
    for chunk, pid in zip(root.children, ids):
        (panel,) = chunk.children
        assert panel.label == pid
        assert sorted(p.label for p in panel.children) == sorted(p.id for p in model.parts_of(pid))
    shapes = read_step_parts(one)
    for part in model.parts:
        np.testing.assert_allclose(occ.volume(shapes[part.id]), part.volume, rtol=1e-3)
        np.testing.assert_allclose(
            occ.mass_properties(shapes[part.id])[1], part.centroid, atol=0.05
        )


def test_cladding_gives_top_sheets_only(developed, job):
    clad = build(developed, job.replace(sandwich={"buildup": "cladding"}), jobs=1)
    assert [p.id for p in clad.parts] == [f"P00{i}-TOP" for i in range(1, 5)]
    assert clad.metrics["counts"] == {"sheet-top": 4}
    assert all(p.holes == () for p in clad.parts)


def test_buildup_offsets(job):
    t, h, b = 3.0, 150.0, 3.0
    assert Buildup.of(job).offset_map == {
        "top_outer": 0.0,
        "top_inner": -t,
        "bottom_upper": -t - h,
        "bottom_lower": -t - h - b,
    }
    low = Buildup.of(job.replace(sandwich={"design_face": "bottom-outer"})).offset_map
    assert low["bottom_lower"] == pytest.approx(0.0) and low["top_outer"] == t + h + b
    mid = Buildup.of(job.replace(sandwich={"design_face": "middle"})).offset_map
    assert mid["top_outer"] == pytest.approx(-mid["bottom_lower"])


def test_bottom_outer_design_face_and_outer_fibre():
    d = cylinder_developed(n_arc=1, n_len=1)
    job = Job.from_dict(
        {"sandwich": {"design_face": "bottom-outer"}, "cutting": {"neutral_fibre": "outer"}}
    )
    model = build(d, job, jobs=1)
    bot = model.parts[1].surface_grid
    depth = job.sandwich.total_depth
    # outer fibre of the bottom sheet = its face away from the ribs: on the design face
    # (within the sheet fit tolerance: one panel spans 60 degrees of arc here)
    np.testing.assert_allclose(np.hypot(bot[..., 1], bot[..., 2]), R, atol=0.05)
    top = model.parts[0].surface_grid
    np.testing.assert_allclose(np.hypot(top[..., 1], top[..., 2]), R + depth, atol=0.05)


def test_parallel_build_matches_inline(model, developed, job):
    calls = []
    parallel = build(developed, job, jobs=2, progress=calls.append)
    assert calls == [1, 1, 1, 1]
    assert parallel.metrics["bolt_holes"] == model.metrics["bolt_holes"] > 0
    assert [p.id for p in parallel.parts] == [p.id for p in model.parts]
    np.testing.assert_allclose(
        [p.volume for p in parallel.parts], [p.volume for p in model.parts], rtol=1e-12
    )


def test_clip_polyline_cuts_on_the_line():
    line = np.c_[np.linspace(0, 10, 11), np.zeros(11)]
    clipped = clip_polyline(line, np.array([1.0, 0.0]), 2.5)
    assert clipped[0, 0] == pytest.approx(2.5) and clipped[-1, 0] == 10
    assert len(clip_polyline(line, np.array([1.0, 0.0]), 20.0)) == 0


def test_kernel_error_names_the_part():
    grid = np.zeros((3, 3, 3))
    grid[..., 0] = np.nan
    with pytest.raises(KernelError, match="P099-TOP"):
        occ.bspline_surface(grid, "P099-TOP")


def test_design_3dm_holds_exact_panel_surfaces_and_layers(model, developed, tmp_path):
    import rhino3dm

    from fabpanel.docs.ifc import solid_geometries

    solids = solid_geometries([(p.id, p.brep, p.thickness, p.kind) for p in model.parts])
    path = write_3dm(model, tmp_path / "design.3dm", solids)
    doc = rhino3dm.File3dm.Read(str(path))
    assert doc.Settings.ModelUnitSystem == rhino3dm.UnitSystem.Millimeters
    layers = [layer.Name for layer in doc.Layers]
    assert layers == [
        "panels", "outlines", "ribs", "stiffeners", "packing", "labels", "solids-sheets",
        "solids-ribs", "solids-stiffeners", "solids-packing",
    ]  # fmt: skip
    by_layer = {}
    for obj in doc.Objects:
        by_layer.setdefault(layers[obj.Attributes.LayerIndex], []).append(obj)
    m = len(developed.panel_ids)
    assert len(by_layer["panels"]) == len(by_layer["outlines"]) == len(by_layer["labels"]) == m
    assert len(by_layer["ribs"]) == len(by_layer["stiffeners"]) == 4 * m
    for obj in by_layer["panels"]:
        surface = obj.Geometry
        p = developed.panel_ids.index(obj.Attributes.Name)
        du, dv = surface.Domain(0), surface.Domain(1)
        k = developed.samples.shape[1]
        for i, j in ((0, 0), (k // 2, 3), (k - 1, k - 1)):
            point = surface.PointAt(
                du.T0 + i / (k - 1) * (du.T1 - du.T0), dv.T0 + j / (k - 1) * (dv.T1 - dv.T0)
            )
            np.testing.assert_allclose(
                [point.X, point.Y, point.Z], developed.samples[p, i, j], atol=1e-6
            )
    assert sorted(dot.Geometry.Text for dot in by_layer["labels"]) == list(developed.panel_ids)
    # every part's solid on its kind's layer: a flat plate an exact, closed extrusion of its
    # profile and holes, a sheet a closed mesh of its volume
    from scipy.spatial import cKDTree

    origin_3dm = np.asarray(model.developed.layout.origin, dtype=float)
    by_id = {p.id: p for p in model.parts}
    solids_3dm = [o for name, objs in by_layer.items() if name.startswith("solids") for o in objs]
    assert sorted(o.Attributes.Name for o in solids_3dm) == sorted(by_id)
    kinds = set()
    for obj in solids_3dm:
        part, shape = by_id[obj.Attributes.Name], obj.Geometry
        kinds.add((part.kind, type(shape).__name__))
        if isinstance(shape, rhino3dm.Extrusion):
            profile = solids[part.id]
            assert shape.IsValid and shape.IsSolid and shape.CapCount == 2
            assert shape.ProfileCount == 1 + len(profile.inner)
            # each profile (outer, then the holes) at both ends of the path is the plate's
            # outline in place: its vertices are the profile's, in the design's frame
            y_axis = np.cross(profile.z_axis, profile.x_axis)
            for i, loop in enumerate((profile.outer, *profile.inner)):
                for s_end, shift in ((0.0, 0.0), (1.0, profile.depth)):
                    curve = shape.Profile3d(i, s_end)
                    got = np.array(
                        [[q.X, q.Y, q.Z] for q in map(curve.Point, range(curve.PointCount))]
                    )
                    want = (
                        origin_3dm
                        + profile.origin
                        + loop[:, :1] * profile.x_axis
                        + loop[:, 1:] * y_axis
                        + shift * profile.z_axis
                    )
                    assert len(got) == len(want) + 1
                    assert cKDTree(want).query(got)[0].max() < 1e-6
            continue
        vertices = np.array([[v.X, v.Y, v.Z] for v in shape.Vertices.ToPoint3dArray()])
        faces = np.array([list(shape.Faces[i])[:3] for i in range(shape.Faces.Count)])
        a, b, c = (vertices[faces[:, i]] for i in range(3))
        volume = abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0
        assert volume == pytest.approx(part.volume, rel=0.005)
    assert ("rib", "Extrusion") in kinds and ("stiffener", "Extrusion") in kinds
    assert {k for k, t in kinds if t == "Mesh"} == {"sheet-top", "sheet-bottom"}


def test_stiffeners_too_long_for_the_sides_are_skipped_and_reported(developed, job):
    long = build(developed, job.replace(sandwich={"stiffener_offset": "700 mm"}), jobs=1)
    # the panels are 1200 x 2094 mm: two 700 mm stiffeners would cross on the short sides
    assert long.metrics["counts"].get("stiffener", 0) == 0
    skipped = [i for i in long.issues if i.code == "stiffeners-skipped"]
    assert sorted(i.item for i in skipped) == list(developed.panel_ids)
    assert long.metrics["all_valid"] and long.metrics["clash"]["clashes"] == 0


def test_the_clash_check_keeps_only_a_band_of_panel_unions_alive():
    from fabpanel.model.clash import _visiting_order

    # a 12 x 12 grid of panels numbered in a scattered order, neighbours across sides and
    # corners: visited in reverse Cuthill-McKee order, at most about two rows are alive
    n = 12
    rng = np.random.default_rng(5)
    name = {
        (i, j): f"P{k:03d}"
        for k, (i, j) in enumerate(
            rng.permutation([(i, j) for i in range(n) for j in range(n)]).tolist()
        )
    }
    pairs = sorted(
        {
            tuple(sorted((name[i, j], name[i + di, j + dj])))
            for i in range(n)
            for j in range(n)
            for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1))
            if 0 <= i + di < n and 0 <= j + dj < n
        }
    )
    order, _, last = _visiting_order(sorted(name.values()), pairs)
    assert sorted(order) == sorted(name.values())
    alive = [sum(1 for g in order[: k + 1] if last[g] > k) for k in range(len(order))]
    assert max(alive) <= 3 * n
    # every pair is checked when its later panel is visited, after both unions were made
    position = {g: k for k, g in enumerate(order)}
    assert all(last[a] >= position[b] and last[b] >= position[a] for a, b in pairs)


def test_a_stiffener_without_a_seat_names_the_leaning_rib_not_the_panel_size():
    """A corner stiffener whose outline vanishes beside a rib leaning 44 degrees from square to
    the sheet (a vault's level base rib) is put down to that rib; beside square ribs the
    kernel's own reason stands."""
    from types import SimpleNamespace

    from fabpanel.errors import KernelError
    from fabpanel.model.panel import _unseated

    sheet = np.array([0.0, -np.sin(np.radians(44.0)), np.cos(np.radians(44.0))])
    payload = SimpleNamespace(normals=np.broadcast_to(sheet, (9, 9, 3)).copy())
    square = np.array([[0.0, np.cos(np.radians(44.0)), np.sin(np.radians(44.0)), 0.0]] * 4)
    err = KernelError("outline of P001-STF-1 vanished when trimmed at rib 0")
    assert _unseated(payload, square, 1, err) == f"not built: {err}"
    level = square.copy()
    level[0] = [0.0, 0.0, 1.0, 0.0]  # side 0: the level base rib
    message = _unseated(payload, level, 1, err)
    assert message.startswith("not built: rib 0 stands 46 degrees off square to the sheet")
    assert "too small" not in message


def test_a_build_up_hanging_below_the_design_is_said():
    """Sheets rising at 40 degrees from the ground with the design on the top sheet: the bottom
    sheet's lower face lies the build-up's depth down their normals, depth x cos 40 below the
    ground, which the foundations must be set for; with the design on the bottom sheet nothing
    hangs below, and a vertical springing (the demo's vault) hangs nothing either."""
    from types import SimpleNamespace

    from fabpanel.buildup import Buildup
    from fabpanel.model.build import _hanging_below

    rise = np.radians(40.0)
    u, v = np.meshgrid(np.linspace(0, 1000.0, 5), np.linspace(0, 1000.0, 5), indexing="ij")
    samples = np.stack([u, v * np.cos(rise), v * np.sin(rise)], -1)[None]
    normals = np.broadcast_to([0.0, -np.sin(rise), np.cos(rise)], samples.shape)
    developed = SimpleNamespace(samples=samples, normals=normals)
    job = Job.from_dict({})
    issues, below = _hanging_below(developed, Buildup.of(job))
    assert below == pytest.approx(Buildup.of(job).total_depth * np.cos(rise))
    assert [i.code for i in issues] == ["below-design"] and issues[0].severity == "info"
    assert f"{below:.0f} mm below" in issues[0].message
    above = Job.from_dict({"sandwich": {"design_face": "bottom-outer"}})
    assert _hanging_below(developed, Buildup.of(above)) == ([], 0.0)
    wall = SimpleNamespace(
        samples=samples, normals=np.broadcast_to([0.0, -1.0, 0.0], samples.shape)
    )
    assert _hanging_below(wall, Buildup.of(job))[0] == []
