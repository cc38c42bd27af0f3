"""The cut stage on a pipeline model that is not a cylinder: a cone patch through panelise,
global develop and build. Flat sheet edges are checked against the edges of the built solids
(OCCT), and the bend lines against the cone's generators."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import cone_patch

import fabpanel as fp
from fabpanel.tolerances import TOLERANCES


@pytest.fixture(scope="module")
def cone_run(tmp_path_factory):
    surface = cone_patch(tmp_path_factory.mktemp("cone"))
    job = fp.Job.from_dict(
        {"panelize": {"grid_u": 3, "grid_v": 3}, "develop": {"method": "global"}}
    )
    developed = fp.develop(fp.panelize(surface, job), surface, job)
    model = fp.build(developed, job, jobs=2)
    return model, fp.cut(model, job, jobs=2)


def face_edges(brep: bytes) -> list[list[tuple[np.ndarray, float]]]:
    """Per large face of a sheet solid (its two sheet faces): (midpoint, length) of each edge
    of the face's outer wire, measured by OCCT."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepTools import BRepTools
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from fabpanel.model import occ

    faces = []
    explorer = TopExp_Explorer(occ.from_brep(brep), TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(face, props)
        faces.append((props.Mass(), face))
        explorer.Next()
    out = []
    for _, face in sorted(faces, key=lambda f: -f[0])[:2]:
        edges = []
        walk = TopExp_Explorer(BRepTools.OuterWire_s(face), TopAbs_EDGE)
        while walk.More():
            curve = BRepAdaptor_Curve(TopoDS.Edge(walk.Current()))
            middle = curve.Value((curve.FirstParameter() + curve.LastParameter()) / 2)
            edges.append(
                (
                    np.array([middle.X(), middle.Y(), middle.Z()]),
                    GCPnts_AbscissaPoint.Length_s(curve),
                )
            )
            walk.Next()
        out.append(edges)
    return out


def test_unrolled_edges_equal_the_edges_of_the_built_sheets(cone_run):
    from fabpanel.flat.unroll import grid_sides

    model, flat = cone_run
    parts = {p.id: p for p in model.parts}
    sheets = [p for p in flat.parts if p.kind.startswith("sheet")]
    assert len(sheets) == 18
    worst = 0.0
    for sheet in sheets:
        sides = grid_sides(np.asarray(parts[sheet.id].surface_grid))
        faces = face_edges(parts[sheet.id].brep)
        for side, flat_length in zip(sides, sheet.edge_lengths_flat):
            middle = side[len(side) // 2]
            # the mid fibre's edge: the mean of the matching edges of the two sheet faces
            lengths = [
                min(edges, key=lambda e: np.linalg.norm(e[0] - middle))[1] for edges in faces
            ]
            worst = max(worst, abs(flat_length - np.mean(lengths)))
    assert worst < TOLERANCES.unrolled_edge


def test_bend_lines_follow_the_cone_generators(cone_run):
    from scipy.interpolate import LinearNDInterpolator

    from fabpanel.geom.flatten import flatten_grid

    model, flat = cone_run
    parts = {p.id: p for p in model.parts}
    # the cone's apex, at the world origin, in the local frame: generators pass through it
    apex = -model.developed.layout.origin
    for sheet in (p for p in flat.parts if p.kind.startswith("sheet")):
        assert sheet.forming.startswith("OUT CON"), sheet.forming  # convex or concave
        grid = np.asarray(parts[sheet.id].surface_grid)
        uv, _ = flatten_grid(grid)
        if sheet.kind == "sheet-top":
            uv = uv * [-1.0, 1.0]  # top sheets are drawn as seen from the rib face
        to_3d = LinearNDInterpolator(uv.reshape(-1, 2), grid.reshape(-1, 3))
        lines = sheet.bend_lines
        assert len(lines) >= 5
        # the long pieces (bend lines cut short by the labels are checked as part of them)
        lines = lines[np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1) > 300.0]
        assert len(lines) >= 3
        t = np.linspace(0.01, 0.99, 41)[:, None]
        for line in lines:
            points = to_3d(line[0] + t * (line[1] - line[0]))
            axis = (points[-1] - points[0]) / np.linalg.norm(points[-1] - points[0])
            rel = points - points[0]
            # a ruling of the built sheet: straight on the surface
            bow = np.linalg.norm(rel - (rel @ axis)[:, None] * axis, axis=1).max()
            assert bow < 0.05, (sheet.id, bow)
            if sheet.kind == "sheet-bottom":
                continue  # an offset cone 150 mm down: its apex lies elsewhere
            # and close to the cone's generator there (the developed panel is a developable
            # surface within millimetres of the cone, not the cone itself)
            generator = points[len(points) // 2] - apex
            generator /= np.linalg.norm(generator)
            assert np.degrees(np.arccos(min(abs(generator @ axis), 1.0))) < 1.5, sheet.id


def test_plates_say_which_face_looks_into_the_panel(cone_run):
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from fabpanel.model import occ

    model, flat = cone_run
    parts = {p.id: p for p in model.parts}
    centre = {
        p.panel_id: np.asarray(p.surface_grid).reshape(-1, 3).mean(axis=0)
        for p in model.parts
        if p.kind == "sheet-top"
    }
    plates = [p for p in flat.parts if p.kind in ("rib", "stiffener")]
    assert len(plates) == 9 * 8
    for plate in plates:
        # its mark; the part, or how many to cut where the mark has several; the face
        count = next(g.quantity for g in flat.marks if plate.id in g.part_ids)
        second = plate.id if count == 1 else f"{count} OFF"
        assert [label[0] for label in plate.labels] == [plate.mark, second, "IN"]
        # the drawing shows the frame's +z face: the solid lies on that side of its plane, and
        # so does the panel's centre
        frame = np.asarray(parts[plate.id].frame)
        points = []
        explorer = TopExp_Explorer(occ.from_brep(parts[plate.id].brep), TopAbs_VERTEX)
        while explorer.More():
            p = BRep_Tool.Pnt_s(TopoDS.Vertex(explorer.Current()))
            points.append((p.X(), p.Y(), p.Z()))
            explorer.Next()
        height = (np.asarray(points) - frame[:3, 3]) @ frame[:3, 2]
        assert height.min() > -1e-6
        assert height.max() == pytest.approx(plate.thickness, abs=1e-6)
        assert (centre[plate.panel_id] - frame[:3, 3]) @ frame[:3, 2] > 0


def _glyph_boxes(labels):
    """The area the etched strokes of each label line take (no border)."""
    from shapely.geometry import Polygon

    from fabpanel.flat.strokefont import text_width

    boxes = []
    for text, x, y, height, angle in labels:
        half = np.array([text_width(text, height) / 2, height / 2])
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
        turn = np.radians(angle)
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        boxes.append(Polygon(corners @ rotation.T + [x, y]))
    return boxes


def test_no_label_is_crossed_by_a_hole_an_opening_or_the_outline(cone_run):
    from shapely.geometry import Polygon

    from fabpanel.flat.labels import hole_areas

    _, flat = cone_run
    for part in flat.parts:
        holes = hole_areas(part, 0.0)
        inside = Polygon(part.outline)
        for box in _glyph_boxes(part.labels):
            assert inside.contains(box), (part.id, box.bounds)
            assert not box.intersects(holes), (part.id, box.bounds)


def test_the_cut_in_worker_processes_equals_the_cut_inline(cone_run):
    """Unrolled and labelled in two worker processes or in this one: the same outlines,
    labels, bend lines and marks, part for part."""
    model, flat = cone_run
    inline = fp.cut(model, fp.Job.from_dict({"develop": {"method": "global"}}), jobs=1)
    assert [p.id for p in flat.parts] == [p.id for p in inline.parts]
    for pooled, alone in zip(flat.parts, inline.parts):
        assert pooled.mark == alone.mark
        assert pooled.labels == alone.labels and pooled.labels
        np.testing.assert_array_equal(pooled.outline, alone.outline)
        assert len(pooled.bend_lines) == len(alone.bend_lines)
        for a, b in zip(pooled.bend_lines, alone.bend_lines):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert [(m.mark, m.part_ids) for m in flat.marks] == [
        (m.mark, m.part_ids) for m in inline.marks
    ]
