"""The shop documents on a small vault run: schedules checked against the manifest and against
geometry measured independently (the IFC's own meshes), the IFC re-read with ifcopenshell, the
key plan's labels, and ``fabpanel docs`` making the same documents from the output folder."""

from __future__ import annotations

import csv
import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import fabpanel as fp
from fabpanel.cli import main
from fabpanel.docs import DocSource
from fabpanel.docs.keyplan import A3, MIN_FONT, keyplan_view, labels
from fabpanel.docs.panels import erection_sequence

DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"
RADIUS = 2000.0


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from fabpanel.examples.barrel_vault import write_barrel_vault_step

    folder = tmp_path_factory.mktemp("docs")
    step = write_barrel_vault_step(folder / "vault.step", radius=RADIUS, length=2400.0)
    job = fp.Job.from_toml(DEMO / "barrel-vault.toml")
    job = fp.Job.from_dict({**job.to_dict(), "input": {"path": str(step)}}, base_dir=folder)
    job = job.replace(
        panelize={"grid_u": 3, "grid_v": 2},
        cutting={"nest_time": "0 s"},
    )
    result = fp.run(job, out_dir=folder / "out", until="cut", jobs=2)
    manifest = json.loads((result.out_dir / "manifest.json").read_text())
    return result.out_dir, manifest


def rows(out: Path, name: str) -> list[dict]:
    with (out / "docs" / name).open() as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def ifc(run):
    """The run's IFC re-read and meshed once (:func:`ifc_meshes`: 20 s on the test vault)."""
    return ifc_meshes(run[0])


def ifc_meshes(out: Path):
    """The IFC re-read, and every plate triangulated by ifcopenshell's own geometry kernel
    (whatever its representation: extruded profile or triangulated face set), mm."""
    import ifcopenshell
    import ifcopenshell.geom

    model = ifcopenshell.open(str(out / "model" / "assembly.ifc"))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    meshes = {}
    for plate in model.by_type("IfcPlate"):
        shape = ifcopenshell.geom.create_shape(settings, plate)
        vertices = np.array(shape.geometry.verts).reshape(-1, 3) * 1000.0  # m -> mm
        meshes[plate.Name] = (vertices, np.array(shape.geometry.faces).reshape(-1, 3))
    return model, meshes


def volume_and_centroid(vertices: np.ndarray, triangles: np.ndarray):
    """Of a closed triangle mesh, by the divergence theorem (signed tetrahedra from 0)."""
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    six = np.einsum("ij,ij->i", a, np.cross(b, c))
    volume = six.sum() / 6.0
    centroid = ((a + b + c) * six[:, None]).sum(axis=0) / (24.0 * volume)
    return abs(volume), centroid


def test_every_document_is_written_and_listed(run):
    out, manifest = run
    names = {
        "docs/panels.csv",
        "docs/rolling.csv",
        "docs/fasteners.csv",
        "docs/welds.csv",
        "docs/keyplan.pdf",
        "docs/drawings.pdf",
        "model/assembly.ifc",
    }
    assert set(manifest["documents"]) == names
    for name in names:
        assert (out / name).stat().st_size > 0, name


def test_ifc_holds_every_part_with_its_volume_mark_and_panel(run, ifc):
    from ifcopenshell.util import element

    _, manifest = run
    model, meshes = ifc
    assemblies = model.by_type("IfcElementAssembly")
    assert sorted(a.Name for a in assemblies) == sorted(p["id"] for p in manifest["panels"])
    parts = {p["id"]: p for p in manifest["parts"]}
    assert set(meshes) == set(parts)
    for plate in model.by_type("IfcPlate"):
        part = parts[plate.Name]
        assert plate.Tag == part["flat"]["mark"]
        assert element.get_aggregate(plate).Name == part["panel"]
        assert element.get_material(plate).Name == part["material"]
        volume, _ = volume_and_centroid(*meshes[plate.Name])
        assert volume == pytest.approx(part["volume_mm3"], rel=5e-3), plate.Name
        representation = plate.Representation.Representations[0].RepresentationType
        assert representation == (
            "Tessellation" if part["kind"].startswith("sheet") else "SweptSolid"
        )
        qto = element.get_psets(plate)["Qto_PlateBaseQuantities"]
        assert qto["Width"] == part["thickness_mm"]
        assert qto["NetWeight"] == pytest.approx(part["mass_kg"])
    assert model.schema == "IFC4"


def test_ifc_passes_the_schema_and_its_rules(run):
    import ifcopenshell
    import ifcopenshell.validate

    out, _ = run
    logger = ifcopenshell.validate.json_logger()
    model = ifcopenshell.open(str(out / "model" / "assembly.ifc"))
    ifcopenshell.validate.validate(model, logger, express_rules=True)
    assert logger.statements == []


def test_bolts_pair_the_rib_holes_and_are_long_enough(run, ifc):
    from ifcopenshell.util import element

    out, manifest = run
    model, _ = ifc
    bolts_total = manifest["metrics"]["build"]["bolts_total"]
    fasteners = model.by_type("IfcMechanicalFastener")
    assert len(fasteners) == bolts_total > 0
    table = {r["item"]: r for r in rows(out, "fasteners.csv")}
    bolt, nut, washer = table["bolt"], table["nut"], table["washer"]
    assert int(bolt["count"]) == int(nut["count"]) == bolts_total
    assert int(washer["count"]) == 2 * bolts_total
    assert int(bolt["order"]) == math.ceil(bolts_total * 1.05)
    # M12 through two 8 mm ribs: grip 16 + 2 washers of 2.5 + nut 10.8 + 2 pitches of 1.75
    # = 35.3 mm, so the next EN ISO 4017 length, 40
    assert bolt["size"] == "M12 x 40" and float(bolt["grip_mm"]) == 16.0
    assert bolt["class"] == "8.8" and nut["class"] == "8"
    # every bolt sits between two coaxial holes of two ribs, 8 mm (one rib) from each
    holes = np.array([h["centre_mm"] for p in manifest["parts"] for h in p.get("bolt_holes", ())])
    for fastener in fasteners:
        solid = fastener.Representation.Representations[0].Items[0]
        start = np.array(solid.Position.Location.Coordinates)
        axis = np.array(solid.Position.Axis.DirectionRatios)
        centre = start + axis * fastener.NominalLength / 2.0
        distance = np.sort(np.linalg.norm(holes - centre, axis=1))
        assert distance[:2] == pytest.approx([4.0, 4.0], abs=1e-3)
        assert element.get_psets(fastener)["FABPANEL_Bolt"]["Grade"] == "8.8"


def test_a_hole_without_its_partner_takes_no_bolt_and_is_listed(run):
    """Bolts pair only across a joint's two ribs: a rib whose partner lost a hole (a mismatched
    joint) keeps every other bolt, and the lone hole is listed, not counted as an anchor."""
    import copy

    from fabpanel.docs.bolts import joint_bolts
    from fabpanel.docs.schedules import fastener_schedule

    _, manifest = run
    source = DocSource.from_manifest(manifest)
    whole = joint_bolts(source)
    assert len(whole.diameters) == manifest["metrics"]["build"]["bolts_total"]
    assert whole.unmatched == () and whole.anchor_holes == 0
    # every pair joins a rib with the rib of its neighbour that faces it
    by_id = {p.id: p for p in source.panels}
    for a, b in whole.ribs:
        (pa, _, sa), (pb, _, sb) = a.split("-"), b.split("-")
        assert by_id[pa].neighbours[int(sa)] == pb and by_id[pb].neighbours[int(sb)] == pa
    broken = copy.deepcopy(manifest)
    rib = next(p for p in broken["parts"] if p["kind"] == "rib" and p.get("bolt_holes"))
    rib["bolt_holes"][1]["centre_mm"][0] += 40.0  # a hole moved off its partner
    bolts = joint_bolts(DocSource.from_manifest(broken))
    assert len(bolts.diameters) == len(whole.diameters) - 1
    partner = next(b if a == rib["id"] else a for a, b in whole.ribs if rib["id"] in (a, b))
    assert sorted(bolts.unmatched) == sorted([rib["id"], partner])
    schedule = fastener_schedule(DocSource.from_manifest(broken))
    lone = [r for r in schedule.rows if r[0].startswith("no bolt")]
    assert len(lone) == 1 and lone[0][6] == "2" and rib["id"] in lone[0][2]


def test_panel_weights_and_centres_of_gravity_match_the_solids(run, ifc):
    out, manifest = run
    _, meshes = ifc
    density = 7850e-9  # kg/mm3
    by_panel: dict[str, list] = {}
    for part in manifest["parts"]:
        by_panel.setdefault(part["panel"], []).append(part)
    table = rows(out, "panels.csv")
    assert len(table) == len(manifest["panels"])
    for row in table:
        parts = by_panel[row["panel"]]
        assert float(row["mass_kg"]) == pytest.approx(sum(p["mass_kg"] for p in parts), abs=0.06)
        # measured here from the IFC meshes, not from the manifest's centroids
        measured = [volume_and_centroid(*meshes[p["id"]]) for p in parts]
        mass = np.array([v for v, _ in measured]) * density
        cog = (mass[:, None] * np.array([c for _, c in measured])).sum(0) / mass.sum()
        written = [float(row[f"cog_{axis}_mm"]) for axis in "xyz"]
        assert written == pytest.approx(cog, abs=1.0)
        assert row["cog_inside_lifting_points"] == "true"
        assert all(len(row[f"lift_{i}_mm"].split()) == 3 for i in range(1, 5))
        # both faces and the edges of every plate
        coat = sum(2 * p["flat"]["area_mm2"] for p in parts) / 1e6
        assert float(row["coating_area_m2"]) == pytest.approx(coat, rel=0.03)


def test_erection_sequence_builds_onto_erected_panels(run):
    out, _manifest = run
    source = DocSource.from_folder(out)
    order = erection_sequence(source)
    assert sorted(order.values()) == list(range(1, len(source.panels) + 1))
    ground = min(p.corners[:, 2].min() for p in source.panels)
    span = max(p.corners[:, 2].min() for p in source.panels) - ground
    on_support = {
        p.id
        for p in source.panels
        if None in p.neighbours and p.corners[:, 2].min() <= ground + 0.01 * span
    }
    # both springing rows of the vault stand on the supports and go first
    assert on_support and all(order[pid] <= len(on_support) for pid in on_support)
    for panel in source.panels:
        # set on a support, or bolted onto a panel already up
        assert panel.id in on_support or any(
            n and order[n] < order[panel.id] for n in panel.neighbours
        ), panel.id


def test_rolling_schedule_gives_radius_chord_and_sagitta(run):
    out, manifest = run
    table = rows(out, "rolling.csv")
    sheets = [p for p in manifest["parts"] if p["kind"].startswith("sheet")]
    assert sum(int(r["quantity"]) for r in table) == len(sheets)
    # mid fibres: top sheet R - 1.5, bottom sheet R - 3 - 150 - 1.5 (radius of the vault 2 m)
    expected = {"sheet-top": RADIUS - 1.5, "sheet-bottom": RADIUS - 154.5}
    for row in table:
        radius = float(row["radius_min_mm"])
        assert radius == pytest.approx(expected[row["kind"]], abs=1.0)
        assert row["method"] in ("rolled", "sprung")
        chord, sagitta = float(row["chord_mm"]), float(row["sagitta_mm"])
        assert sagitta == pytest.approx(radius - math.sqrt(radius**2 - chord**2 / 4), abs=0.2)
        # the developed width across the roll axis is the arc over that chord
        arc = 2 * radius * math.asin(chord / (2 * radius))
        assert float(row["width_across_axis_mm"]) == pytest.approx(arc, abs=0.2)
        # the vault's rulings run along x, which is one side of the flat sheet
        assert float(row["roll_axis_deg"]) % 90 == pytest.approx(0, abs=0.5) or float(
            row["roll_axis_deg"]
        ) % 90 == pytest.approx(90, abs=0.5)


def test_weld_totals_add_up_and_follow_the_sheet_edges(run):
    out, manifest = run
    table = rows(out, "welds.csv")
    snipe = 15.0
    types = [r for r in table if r["panel_type"] != "all"]
    for total in (r for r in table if r["panel_type"] == "all"):
        parts = [float(r["length_total_mm"]) for r in types if r["weld"] == total["weld"]]
        assert float(total["length_total_mm"]) == pytest.approx(sum(parts), abs=0.2)
    edges = sum(
        sum(max(e - 2 * snipe, 0) for e in p["flat"]["edge_lengths_3d_mm"])
        for p in manifest["parts"]
        if p["kind"].startswith("sheet")
    )
    w1 = next(r for r in table if r["panel_type"] == "all" and r["weld"] == "W1")
    assert float(w1["length_total_mm"]) == pytest.approx(edges, abs=0.5)


def test_key_plan_labels_fit_their_panels(run):
    from shapely.affinity import rotate
    from shapely.geometry import Polygon, box

    from fabpanel.docs.keyplan import CHAR_WIDTH, POINT_MM

    out, _ = run
    source = DocSource.from_folder(out)
    # three panels round a half circle keep half their area in plan: drawn in plan
    assert keyplan_view(source).view.startswith("plan")
    # forty round it and thirty along (1200 panels): the sides are vertical, so the plan
    # would squash them; drawn developed, every label still fits its panel
    for dense in (source, vault_panels(source, 40, 30)):
        view = keyplan_view(dense)
        assert (view.quads >= 0).all() and (view.quads[..., 0] <= A3[0]).all()
        assert (view.quads[..., 1] <= A3[1]).all()
        for label, quad in zip(labels(dense, view), view.quads):
            assert label.font_pt >= MIN_FONT
            chars = max(len(line) for line in label.text.split("\n"))
            half = np.array(
                [CHAR_WIDTH * label.font_pt * POINT_MM * chars / 2, 1.2 * label.font_pt * POINT_MM]
            )
            centre = np.array(label.centre)
            frame = rotate(box(*(centre - half), *(centre + half)), label.angle_deg)
            assert Polygon(quad).contains(frame)
    assert keyplan_view(vault_panels(source, 40, 30)).view.startswith("developed")
    if shutil.which("pdftotext"):
        text = subprocess.run(
            ["pdftotext", str(out / "docs" / "keyplan.pdf"), "-"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        assert all(p.id in text for p in source.panels)


def vault_panels(source: DocSource, around: int, along: int) -> DocSource:
    """``source`` with its panels replaced by a grid on a half cylinder (radius 2 m, 12 m)."""
    import dataclasses

    from fabpanel.docs.source import PanelDoc

    t = np.linspace(0, np.pi, around + 1)
    x = np.linspace(0, 12000, along + 1)

    def point(i, j):
        return np.array([x[j], RADIUS * np.cos(t[i]), RADIUS * np.sin(t[i])])

    def pid(i, j):
        return f"P{i * along + j + 1:04d}" if 0 <= i < around and 0 <= j < along else None

    panels = tuple(
        PanelDoc(
            pid(i, j),
            np.array([point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)]),
            (pid(i, j - 1), pid(i + 1, j), pid(i, j + 1), pid(i - 1, j)),
            "single-curved",
        )
        for i in range(around)
        for j in range(along)
    )
    return dataclasses.replace(source, panels=panels, parts=())


def test_docs_command_makes_the_same_documents_again(run, tmp_path):
    out, _ = run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    before = {
        n: (copy / "docs" / n).read_text()
        for n in ("panels.csv", "rolling.csv", "fasteners.csv", "welds.csv")
    }
    for name in before:
        (copy / "docs" / name).unlink()
    (copy / "model" / "assembly.ifc").unlink()
    result = CliRunner().invoke(main, ["docs", str(copy), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    for name, text in before.items():
        assert (copy / "docs" / name).read_text() == text, name
    assert (copy / "model" / "assembly.ifc").stat().st_size > 0
    assert not list(copy.glob(".docs.partial-*"))


def test_docs_command_refuses_a_folder_fabpanel_did_not_write(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    result = CliRunner().invoke(main, ["docs", str(tmp_path)])
    assert result.exit_code == 2
    assert "not a fabpanel output folder" in result.output
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_drawings_have_a_page_per_panel_type_and_true_views(run):
    from fabpanel.docs.drawings import panel_frame
    from fabpanel.docs.schedules import panel_types
    from fabpanel.model import occ, read_step_parts
    from fabpanel.model.hlr import hidden_line_view

    out, _manifest = run
    source = DocSource.from_folder(out)
    types = panel_types(source)
    assert sum(len(ids) for _, ids in types) == len(source.panels)
    if shutil.which("pdfinfo"):
        info = subprocess.run(
            ["pdfinfo", str(out / "docs" / "drawings.pdf")],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
        assert f"Pages:           {len(types)}" in info
        text = subprocess.run(
            ["pdftotext", str(out / "docs" / "drawings.pdf"), "-"],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
        assert all(f"panel type {name}" in text for name, _ in types)
        assert all(f"side {s}:" in text for s in range(4)) and "C3" in text
    # dimensions: each side's chord, and the top sheet's edge: on the vault's arcs longer than
    # the chord, on the straight sides the chord less its set-backs; every bolt lies along its
    # side, between the side's corners
    from fabpanel.buildup import Buildup
    from fabpanel.docs.drawings import along_side, side_lengths

    setback = Buildup.of(source.job).welds.setback
    for panel in source.panels:
        parts = source.parts_of(panel.id)
        for s, text in enumerate(side_lengths(panel, parts)):
            chord, edge = float(text.split()[0]), float(text.split()[-1].rstrip(")"))
            # (set back at an end that meets an interior side only)
            assert edge > chord + 50.0 or chord - 2 * setback - 0.5 <= edge <= chord + 0.5
            assert chord == pytest.approx(
                np.linalg.norm(panel.corners[(s + 1) % 4] - panel.corners[s]), abs=0.05
            )
        for part in parts:
            for centre in part.bolt_centres:
                side, along = along_side(panel, f"{part.id.split('-', 1)[1]} {part.mark}", centre)
                chord = np.linalg.norm(panel.corners[(side + 1) % 4] - panel.corners[side])
                assert part.id.endswith(f"RIB-{side}") and 0.0 < along < chord
    # the top view of a panel, seen along its normal, spans its side 0 (plus the ribs)
    panel = source.panels[0]
    centre, normal, x_axis = panel_frame(panel, source.origin)
    shapes = read_step_parts(out / "model" / "assembly.step")
    breps = [occ.to_brep(s) for name, s in shapes.items() if name.startswith(panel.id + "-")]
    visible, hidden, _ = hidden_line_view(breps, centre, normal, x_axis)
    points = np.concatenate(visible)
    corners = panel.corners - source.origin
    side = np.linalg.norm(corners[1] - corners[0])
    assert np.ptp(points[:, 0]) == pytest.approx(side, abs=20.0)
    assert hidden  # the ribs and stiffeners under the top sheet


def test_drawings_drawn_in_runs_of_pages_by_workers_join_in_order(run, tmp_path, monkeypatch):
    """Each worker draws a run of pages into a PDF of its own and the runs are joined: the
    same pages, in the same order and with the same text, as drawn in one process; each view
    has its scale bar."""
    from fabpanel.docs import drawings
    from fabpanel.docs.schedules import panel_types
    from fabpanel.model import occ, read_step_parts

    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out, _manifest = run
    source = DocSource.from_folder(out)
    shapes = read_step_parts(out / "model" / "assembly.step")
    breps = {name: occ.to_brep(shape) for name, shape in shapes.items()}
    monkeypatch.setattr(drawings, "INLINE_PAGES", 1)  # a run of pages per type, in workers
    joined = drawings.write_drawings(source, breps, tmp_path / "joined.pdf", workers=2)
    alone = drawings.write_drawings(source, breps, tmp_path / "alone.pdf", workers=1)

    def pages(path: Path) -> list[str]:
        text = subprocess.run(
            ["pdftotext", "-layout", str(path), "-"], capture_output=True, text=True, check=True
        ).stdout
        return text.split("\f")[:-1]

    names = [name for name, _ in panel_types(source)]
    assert len(names) > 1
    assert pages(joined) == pages(alone)
    for page, name in zip(pages(joined), names, strict=True):
        assert f"panel type {name} " in page
        assert len(re.findall(r"\b\d+ mm\b", page)) >= 2  # the two views' scale bars


def test_a_panel_with_an_error_is_on_hold_in_the_schedule_and_its_drawing(run, tmp_path):
    from fabpanel.docs.drawings import write_drawings
    from fabpanel.docs.panels import panel_schedule
    from fabpanel.model import occ, read_step_parts

    out, manifest = run
    issue = {"code": "clash", "message": "ribs overlap", "item": "P002-RIB-1", "severity": "error"}
    held = DocSource.from_manifest({**manifest, "issues": [*manifest["issues"], issue]}, "vault")
    rows = {r[0]: r for r in panel_schedule(held).rows}
    assert rows["P002"][-2:] == ("1", "HOLD")
    assert all(r[-2:] == ("0", "") for pid, r in rows.items() if pid != "P002")
    if shutil.which("pdftotext"):
        shapes = read_step_parts(out / "model" / "assembly.step")
        breps = {name: occ.to_brep(shape) for name, shape in shapes.items()}
        path = write_drawings(held, breps, tmp_path / "drawings.pdf")
        text = subprocess.run(
            ["pdftotext", str(path), "-"], capture_output=True, text=True, check=True
        ).stdout
        assert "HOLD: 1 error-level issue(s) on P002" in text


def test_a_record_table_leaves_out_empty_values():
    from fabpanel.report.blocks import record_table

    table = record_table(
        {"narrowest_panel_mm": 605.5, "outline_tip_angles_deg": [], "notes": "", "tips": {}}
    )
    assert [row[0] for row in table.rows] == ["narrowest panel"]
