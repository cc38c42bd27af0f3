"""End to end on the barrel vault: outputs, STEP re-import, unrolled lengths, ribs, DXF audit."""

from __future__ import annotations

import csv
import html
import json
from pathlib import Path

import numpy as np
import pytest

import fabpanel as fp
from fabpanel.buildup import Buildup
from fabpanel.tolerances import TOLERANCES

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEMO = Path(__file__).resolve().parents[1] / "fabpanel" / "examples"  # shipped: fabpanel demo
# a smaller vault than the example keeps the test fast: radius 2 m, length 2.4 m, 8 panels
RADIUS, LENGTH = 2000.0, 2400.0
GRID_U, GRID_V = 4, 2  # 4 panels around the arc (45 degrees, 1571 mm), 2 along x


@pytest.fixture(scope="session")
def small_vault(tmp_path_factory) -> Path:
    from fabpanel.examples.barrel_vault import write_barrel_vault_step

    folder = tmp_path_factory.mktemp("input")
    return write_barrel_vault_step(folder / "small-vault.step", radius=RADIUS, length=LENGTH)


@pytest.fixture(autouse=True)
def _vault_path(small_vault):
    global VAULT
    VAULT = small_vault


def _job(**changes) -> fp.Job:
    job = fp.Job.from_toml(DEMO / "barrel-vault.toml")
    job = fp.Job.from_dict({**job.to_dict(), "input": {"path": str(VAULT)}}, base_dir=VAULT.parent)
    sections = {"panelize": {"grid_u": GRID_U, "grid_v": GRID_V}, "cutting": {"nest_time": "0 s"}}
    for section, values in changes.items():
        sections[section] = {**sections.get(section, {}), **values}
    return job.replace(**sections)


@pytest.fixture(scope="module")
def vault_run(tmp_path_factory, small_vault):
    global VAULT
    VAULT = small_vault
    out = tmp_path_factory.mktemp("vault") / "out"
    return fp.run(_job(), out_dir=out, jobs=2)


def test_output_contract(vault_run):
    out = vault_run.out_dir
    for name in (
        "manifest.json",
        "bom.csv",
        "model/assembly.step",
        "model/preview.glb",
        "model/design.3dm",
        "model/panels.obj",
        "model/developed.obj",
        "report/summary.json",
        "report/index.html",
    ):
        assert (out / name).is_file(), name
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["units"]["length"] == "mm"
    assert len(manifest["panels"]) == GRID_U * GRID_V
    # the layout gates in the summary too, where a user looks first
    panels = json.loads((out / "report" / "summary.json").read_text())["panels"]
    gates = panels["gates"]
    assert gates["panels"] == GRID_U * GRID_V and gates["manifold"]
    # the verdict, and why the layout has its method, beside the figures
    assert gates["passed"] is (gates["failed"] == [])
    assert all(code.startswith("layout-") for code in gates["failed"])
    assert panels["chosen_because"] and panels["method"] in panels["chosen_because"]
    assert 0 < gates["count_ratio"] and "edges_in_band" in gates and "corners_in_60_120" in gates
    assert len(manifest["parts"]) == 10 * GRID_U * GRID_V
    # assembly.step holds every panel: a STEP per panel only when asked (step_per_panel)
    assert not (out / "model" / "panels").exists()
    for panel in manifest["panels"]:
        assert panel["class"] == "single-curved"
    marks = {m["mark"]: m for m in manifest["marks"]}
    assert sum(m["quantity"] for m in marks.values()) == len(manifest["parts"])
    for part in manifest["parts"]:
        # one DXF per mark, shared by the mark's parts
        mark = part["flat"]["mark"]
        assert part["id"] in marks[mark]["parts"]
        assert part["files"] and all((out / f).is_file() for f in part["files"])
        assert f"cut/parts/{mark}.dxf" in part["files"]
        assert part["plate"] is not None
    assert len(list((out / "cut" / "parts").glob("*.dxf"))) == len(marks) < len(manifest["parts"])
    with (out / "marks.csv").open() as handle:
        summary = list(csv.DictReader(handle))
    assert sorted(r["mark"] for r in summary) == sorted(marks)
    assert sum(int(r["quantity"]) for r in summary) == len(manifest["parts"])
    plates = sorted((out / "cut" / "nests").glob("plate-*.dxf"))
    assert plates and all(p.with_suffix(".png").is_file() for p in plates)
    with (out / "bom.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [r["part"] for r in rows] == [p["id"] for p in manifest["parts"]]
    assert all(int(r["quantity"]) == marks[r["mark"]]["quantity"] for r in rows)
    assert {r["stock"] for r in rows} == {"plate"}  # [cutting] flat_bar is off by default
    mass = sum(float(r["mass_kg"]) for r in rows)
    assert mass == pytest.approx(vault_run.model.mass, rel=1e-4)
    # the vault's sheets roll with their outer faces convex, at their mid-fibre radii
    sheets = [r for r in rows if r["kind"].startswith("sheet")]
    assert all(r["forming"].startswith("OUT CONVEX R") for r in sheets)
    radii = [int(r["forming"].split()[2][1:]) for r in sheets if r["kind"] == "sheet-top"]
    assert max(abs(r - (RADIUS - 1.5)) for r in radii) <= 2
    # sprung where E t / (2 R) keeps at most half of f_y, else rolled (fabpanel.forming)
    sprung = 210000.0 * 3.0 / (2 * (RADIUS - 1.5)) <= 0.5 * 235.0
    assert all(r["forming"].endswith(" SPRING" if sprung else " ROLL") for r in sheets)
    assert sum(int(r["pierces"]) for r in rows) == manifest["metrics"]["nest"]["pierces"]
    assert sum(float(r["cut_length_mm"]) for r in rows) == pytest.approx(
        manifest["metrics"]["nest"]["cut_length_mm"], abs=0.05 * len(rows)
    )
    assert not list(out.parent.glob(".out.*"))  # no staging folder left
    report = (out / "report" / "index.html").read_text()
    # the default (global) rationalisation draws curvature before/after and the deviation map
    assert 'alt="Gaussian curvature before and after"' in report
    assert 'alt="Deviation from the design surface"' in report
    # every plate's image in the gallery (the report waits for the cut files it shows)
    assert all(f'href="../cut/nests/{p.stem}.png"' in report for p in plates)
    # the structure section an engineer signs: what the check assumes, under one heading, and
    # every support's reaction per characteristic case, forces and moments
    structure = json.loads((out / "report" / "summary.json").read_text())["structure"]
    assert "What the check assumes and leaves out" in report
    assert all(html.escape(a)[:40] in report for a in structure["assumptions"])
    assert "Reactions per support" in report and "Mx, My, Mz [kN m]" in report
    for support in structure["supports"]["reactions"]:
        for case in support["cases_kN"]:
            assert f"<td>{support['support']}</td><td>{case}</td>" in report, case


def test_step_reimports_to_the_manifest_parts(vault_run):
    from OCP.BRepCheck import BRepCheck_Analyzer

    from fabpanel.model import occ, read_step_parts

    shapes = read_step_parts(vault_run.out_dir / "model" / "assembly.step")
    parts = {p.id: p for p in vault_run.model.parts}
    assert set(shapes) == set(parts)
    for name, shape in shapes.items():
        assert BRepCheck_Analyzer(shape).IsValid(), name
        # the same adaptive integration the build measures with: OCCT's default Gauss rule is
        # 0.2 % off on a sheet with access slots (trimmed B-spline faces)
        assert occ.volume(shape) == pytest.approx(parts[name].volume, rel=TOLERANCES.step_volume)


def test_unrolled_sheet_edges_equal_the_3d_arc_lengths(vault_run):
    job = vault_run.job
    t, h = job.sandwich.sheet_thickness, job.sandwich.rib_height
    mid_radius = {"sheet-top": RADIUS - t / 2, "sheet-bottom": RADIUS - t - h - t / 2}
    angle, length = np.pi / GRID_U, LENGTH / GRID_V
    sheets = [p for p in vault_run.flat.parts if p.kind.startswith("sheet")]
    assert len(sheets) == 2 * GRID_U * GRID_V
    # every edge is short by the weld set-back at each end that meets a joint (along the arc
    # too: r asin(s / r) = s to 1e-6 mm)
    setback = Buildup.of(job).welds.setback
    developed = vault_run.developed
    for part in sheets:
        arc = mid_radius[part.kind] * angle
        joints = developed.layout.side_neighbours[developed.panel_ids.index(part.panel_id)] >= 0
        ends = np.roll(joints, 1).astype(int) + np.roll(joints, -1).astype(int)
        expected = np.array([arc, length, arc, length]) - setback * ends
        np.testing.assert_allclose(
            part.edge_lengths_flat, expected, atol=TOLERANCES.unrolled_edge, err_msg=part.id
        )
        np.testing.assert_allclose(
            part.edge_lengths_3d, expected, atol=TOLERANCES.unrolled_edge, err_msg=part.id
        )
        assert part.max_strain < 1e-5


def test_rib_outlines_are_planar(vault_run):
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from fabpanel.model import read_step_parts

    shapes = read_step_parts(vault_run.out_dir / "model" / "assembly.step")
    developed = vault_run.developed
    index = {pid: i for i, pid in enumerate(developed.panel_ids)}
    ribs = [p for p in vault_run.model.parts if p.kind == "rib"]
    assert len(ribs) == 4 * GRID_U * GRID_V
    for rib in ribs:
        panel, side = index[rib.panel_id], int(rib.id.rsplit("-", 1)[1])
        plane = developed.side_planes[panel, side]
        points = []
        explorer = TopExp_Explorer(shapes[rib.id], TopAbs_VERTEX)
        while explorer.More():
            p = BRep_Tool.Pnt_s(TopoDS.Vertex(explorer.Current()))
            points.append((p.X(), p.Y(), p.Z()))
            explorer.Next()
        distance = np.asarray(points) @ plane[:3] - plane[3]
        # the rib occupies [0, thickness] on the inner side of its plane
        outer = distance[distance < rib.thickness / 2]
        inner = distance[distance >= rib.thickness / 2]
        assert np.abs(outer).max() < TOLERANCES.rib_planarity, rib.id
        assert np.abs(inner - rib.thickness).max() < TOLERANCES.rib_planarity, rib.id


def test_every_dxf_passes_audit(vault_run):
    from fabpanel.flat.dxf import audit_dxf

    files = sorted((vault_run.out_dir / "cut").rglob("*.dxf"))
    # a DXF per part mark and per plate
    assert len(files) == len(vault_run.flat.marks) + len(vault_run.nests.plates)
    for path in files:
        assert audit_dxf(path) == [], path.name


def test_nests_are_valid(vault_run):
    from fabpanel.flat.nest import validate_nests

    assert validate_nests(vault_run.nests, vault_run.flat, vault_run.job) == []


def test_until_stops_after_a_stage_and_writes_what_ran(tmp_path):
    result = fp.run(_job(), out_dir=tmp_path / "out", until="develop")
    assert result.model is None and result.stages_run == ("panelize", "develop")
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert len(manifest["panels"]) == GRID_U * GRID_V and manifest["parts"] == []
    assert not (tmp_path / "out" / "model" / "assembly.step").exists()
    assert (tmp_path / "out" / "model" / "panels.obj").is_file()
    # the developed sample grids: one group per panel, k x k vertices each
    text = (tmp_path / "out" / "model" / "developed.obj").read_text()
    k = result.developed.samples.shape[1]
    assert text.count("\ng P") == GRID_U * GRID_V
    assert text.count("\nv ") == GRID_U * GRID_V * k * k


def test_same_job_same_output(tmp_path):
    # through the cut and nest, with the geometry files (STEP, DXF); the report, the preview
    # and the structure add time here, not geometry (test_ray compares a whole run's files)
    job = _job(
        panelize={"grid_u": 2, "grid_v": 1}, output={"report": False, "glb": False, "rhino": False}
    )
    first = fp.run(job, out_dir=tmp_path / "a", jobs=1, until="cut")
    second = fp.run(job, out_dir=tmp_path / "b", jobs=2, until="cut")

    def without_timings(value):
        if isinstance(value, dict):
            return {
                k: without_timings(v)
                for k, v in value.items()
                if k not in {"time_s", "seconds", "versions"}
            }
        if isinstance(value, list):
            return [without_timings(v) for v in value]
        return value

    def stable(result):
        return without_timings(json.loads((result.out_dir / "manifest.json").read_text()))

    assert stable(first) == stable(second)


def test_force_replaces_only_after_success(tmp_path):
    out = tmp_path / "out"
    fp.run(_job(), out_dir=out, until="panelize")
    with pytest.raises(fp.InputError):
        fp.run(_job(), out_dir=out, until="panelize")
    broken = fp.Job.from_dict(
        {**_job().to_dict(), "input": {"path": "missing.step"}}, base_dir=EXAMPLES
    )
    with pytest.raises(fp.InputError):
        fp.run(broken, out_dir=out, force=True)
    assert (out / "manifest.json").is_file()  # the old run is still there


def _half_cylinder_obj(folder: Path, radius: float, length: float, segments: int) -> Path:
    """A half cylinder (axis x, metres) as a quad mesh: ``segments`` round the arc, one
    quad along its length."""
    phi = np.linspace(0.0, np.pi, segments + 1)
    rows = [
        f"v {x} {radius * np.cos(p):.9f} {radius * np.sin(p):.9f}"
        for x in (0.0, length)
        for p in phi
    ]
    n = segments + 1
    faces = [f"f {i + 1} {n + i + 1} {n + i + 2} {i + 2}" for i in range(segments)]
    path = folder / "half-cylinder.obj"
    path.write_text("\n".join(rows + faces) + "\n")
    return path


def test_mesh_input_runs_end_to_end(tmp_path):
    # a 4 m half cylinder 2.4 m long, its arc a 96-gon as in the example vault's mesh
    path = _half_cylinder_obj(tmp_path, 4.0, 2.4, 96)
    job = fp.Job.for_input(
        path,
        units="m",
        panelize={"panel_size": "1.2 m"},
        sandwich={"bolts": {"access_sheet": "none"}},  # the openings are tested elsewhere
        cutting={"nest_time": "0 s"},
    )
    result = fp.run(job, out_dir=tmp_path / "out", jobs=2, until="build")
    assert result.layout.method == "grid" and len(result.layout.quads) == 20  # 10 x 2
    assert len(result.model.parts) == 10 * 20
    assert not [i for i in result.issues if i.severity == "error"]
    assert result.flat is None
    assert set(result.developed.classes) == {"single-curved"}
    assert result.developed.metrics["unroll_strain"]["max"] < 1e-5
    # the mesh's 96-segment arc lies up to its sagitta (0.54 mm) inside the true cylinder
    assert result.developed.metrics["deviation_mm"]["max"] < 0.6
    assert result.model.metrics["all_valid"]


def test_global_develop_runs_end_to_end(tmp_path):
    # the optimiser's panels feed the build and the cut like the projected ones: a cylinder
    # stays a cylinder, the sheets unroll to the 3D lengths, ribs stay planar
    job = _job(
        develop={"method": "global"},
        sandwich={"bolts": {"access_sheet": "none"}},  # the openings are tested elsewhere
    )
    result = fp.run(job, out_dir=tmp_path / "out", until="cut", jobs=2)
    metrics = result.developed.metrics
    assert metrics["method"] == "global" and metrics["solver"]["converged"]
    assert metrics["deviation_mm"]["max"] < 0.05 and metrics["gap_mm_max"] == 0.0
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["job"]["develop"]["method"] == "global"
    assert len(manifest["parts"]) == 10 * GRID_U * GRID_V
    assert not [i for i in result.issues if i.severity == "error"]


#: injected before the report's own scripts: records console errors and uncaught exceptions,
#: then on load every image that did not decode and every table wider than its box, and
#: writes them into the page, which --dump-dom prints
BROWSER_PROBE = """<script>
window.__probe = {errors: [], images: [], tables: [], overflow: false};
(function(){
  var error = console.error;
  console.error = function(){ window.__probe.errors.push(Array.from(arguments).join(' '));
    error.apply(console, arguments); };
  window.addEventListener('error', function(e){
    window.__probe.errors.push(String(e.message || (e.target && e.target.src) || e)); }, true);
  window.addEventListener('load', function(){
    var p = window.__probe;
    document.querySelectorAll('img').forEach(function(img){
      if (!img.complete || img.naturalWidth === 0) p.images.push(img.alt || img.src.slice(0, 60)); });
    document.querySelectorAll('table').forEach(function(t){
      var box = t.parentElement, style = getComputedStyle(box);
      if (t.scrollWidth > box.clientWidth + 1 && style.overflowX !== 'auto') p.tables.push(t.id); });
    p.overflow = document.documentElement.scrollWidth > window.innerWidth + 1;
    p.svg = document.querySelectorAll('svg').length;
    p.sortable = document.querySelectorAll('table.sortable').length;
    var out = document.createElement('pre'); out.id = 'probe';
    out.textContent = JSON.stringify(p); document.body.appendChild(out);
  });
})();
</script>"""


def test_report_renders_in_a_real_browser(vault_run, tmp_path):
    """Headless Chromium loads the report: no console error, every image decodes, no table
    wider than its box, no horizontal page overflow; the plate thumbnails link to images that
    exist. Also checks the PDF and that no table cell holds a raw dict."""
    import re
    import shutil
    import subprocess

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("chromium is not installed (.ci/setup --test installs it)")
    report = vault_run.out_dir / "report"
    page = report / "index.html"
    text = page.read_text()
    assert "<td>{" not in text and "{&quot;" not in text  # never a raw dict in a cell
    for link in re.findall(r'<a href="(\.\./cut/nests/[^"]+)"', text):
        assert (report / link).is_file(), link
    probed = tmp_path / "report" / "index.html"
    probed.parent.mkdir()
    probed.write_text(text.replace("<head>", "<head>" + BROWSER_PROBE, 1))
    dom = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,900",
         "--virtual-time-budget=20000", "--dump-dom", probed.as_uri()],
        check=False, capture_output=True, text=True, timeout=120,
    ).stdout  # fmt: skip
    found = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.DOTALL)
    assert found, "the page did not finish loading"
    probe = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert probe["errors"] == [] and probe["images"] == [] and probe["tables"] == []
    assert not probe["overflow"]
    assert probe["svg"] >= 1 and probe["sortable"] >= 1  # the key plan; a sortable table
    pdf = report / "report.pdf"
    assert pdf.read_bytes().startswith(b"%PDF")
    if shutil.which("pdftotext"):
        pdf_text = subprocess.run(
            ["pdftotext", str(pdf), "-"], capture_output=True, text=True, check=True
        ).stdout
        for heading in ("Verdicts", "Key plan", "Shop schedules", "Structure", "Issues"):
            assert heading in pdf_text and heading in text, heading
