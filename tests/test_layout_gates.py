"""Panel layouts that a shop can build (issue 15): the field method, the layout gates, the
boundary followed exactly, and the conformal flattening they rest on.

Generated fixtures: planar discs and annuli (exact circles known), a cylinder patch (a
developable surface, so a conformal flattening is an isometry), structured grids with a
squeezed row (a sliver panel that must be an error).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import random_surface
from scipy.spatial import Delaunay

import fabpanel as fp
from fabpanel.data import PanelLayout, Surface
from fabpanel.develop.project import sample_panels
from fabpanel.geom.conformal import conformal_flattening
from fabpanel.panelize.gates import (
    failed_gates,
    gate_issues,
    gate_measures,
    layout_score,
    meets_every_gate,
    panel_widths,
)
from fabpanel.panelize.quality import corner_angles
from fabpanel.pipeline import _layout_verdict
from fabpanel.surface import SurfaceQuery
from fabpanel.surface.design_boundary import DesignBoundary, boundary_deviation, smooth_loop


def _annulus(outer: float, inner: float, spacing: float, rim: int, z=None) -> Surface:
    """A planar (or lifted by ``z(x, y)``) annulus mesh in mm, its rims as ``rim``-gons."""
    t = np.linspace(0, 2 * np.pi, rim, endpoint=False)
    outer_ring = outer * np.column_stack([np.cos(t), np.sin(t)])
    n_inner = max(12, int(rim * inner / outer))
    s = np.linspace(0, 2 * np.pi, n_inner, endpoint=False)
    inner_ring = inner * np.column_stack([np.cos(s), np.sin(s)])
    xs = np.arange(-outer, outer + spacing, spacing)
    grid = np.array([(x, y) for x in xs for y in xs])
    radius = np.linalg.norm(grid, axis=1)
    keep = (radius < outer - 0.5 * spacing) & (radius > inner + 0.5 * spacing)
    points = np.vstack([outer_ring, inner_ring, grid[keep]])
    tri = Delaunay(points).simplices
    centre = points[tri].mean(axis=1)
    r = np.linalg.norm(centre, axis=1)
    tri = tri[(r < outer) & (r > inner)]
    cross = np.cross(points[tri[:, 1]] - points[tri[:, 0]], points[tri[:, 2]] - points[tri[:, 0]])
    tri[cross < 0] = tri[cross < 0][:, [0, 2, 1]]
    height = np.zeros(len(points)) if z is None else z(points[:, 0], points[:, 1])
    vertices = np.column_stack([points, height])
    loops = (np.arange(rim), rim + np.arange(n_inner)[::-1])
    return Surface(vertices, tri, loops, Path("annulus.obj"), "obj", "mm")


def _job(size: str = "1 m", **panelize) -> fp.Job:
    return fp.Job.from_dict(
        {
            "input": {"path": "annulus.obj", "units": "mm"},
            "panelize": {"panel_size": size, **panelize},
        }
    )


# ---------------------------------------------------------------------------------------------
# conformal flattening and the design boundary
# ---------------------------------------------------------------------------------------------
def test_a_cylinder_patch_flattens_isometrically():
    radius, nu, nv = 4000.0, 40, 30
    theta = np.linspace(0, 1.2, nu)
    y = np.linspace(0, 6000.0, nv)
    tt, yy = np.meshgrid(theta, y, indexing="ij")
    vertices = np.column_stack(
        [radius * np.sin(tt).ravel(), yy.ravel(), radius * np.cos(tt).ravel()]
    )
    ids = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)
    loop = np.concatenate([ids[:, 0], ids[-1, 1:], ids[-2::-1, -1], ids[0, -2:0:-1]])
    flat, scale = conformal_flattening(vertices, faces, loop)
    np.testing.assert_allclose(scale, 1.0, atol=2e-3)  # developable: lengths kept
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    surface_length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    flat_length = np.linalg.norm(flat[edges[:, 0]] - flat[edges[:, 1]], axis=1)
    np.testing.assert_allclose(flat_length, surface_length, rtol=5e-3)


def test_the_smooth_boundary_lies_on_the_true_circle():
    radius = 700.0
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    polygon = radius * np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    chord_sagitta = radius * (1 - np.cos(np.pi / 40))
    assert chord_sagitta > 2.0  # the polygon's chords are 2 mm inside the circle
    curve = smooth_loop(polygon)
    assert np.abs(np.linalg.norm(curve[:, :2], axis=1) - radius).max() < 0.05


def test_a_boundary_stretch_runs_along_the_outline_the_short_way():
    surface = _annulus(5000.0, 1500.0, 400.0, 120)
    boundary = DesignBoundary(surface)
    a = np.array([5000.0, 0.0, 0.0])
    b = np.array([0.0, 5000.0, 0.0])
    stretch = boundary.between(a, b, 9)
    radii = np.linalg.norm(stretch[:, :2], axis=1)
    assert np.abs(radii - 5000.0).max() < 0.05
    angles = np.degrees(np.arctan2(stretch[:, 1], stretch[:, 0]))
    np.testing.assert_allclose(angles, np.linspace(0, 90, 9), atol=0.05)  # even, quarter arc
    assert boundary.between(a, np.array([1500.0, 0.0, 0.0]), 9) is None  # two loops


# ---------------------------------------------------------------------------------------------
# the field method
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dish():
    """A shallow dish 12 m across with a 2.4 m opening (rims as 160- and 40-gons)."""
    surface = _annulus(6000.0, 1200.0, 250.0, 160, z=lambda x, y: 1.5e-4 * (x**2 + y**2) / 2)
    job = _job("1 m", method="field")
    query = SurfaceQuery(surface)
    return surface, job, query, fp.panelize(surface, job, query)


def test_the_field_layout_meets_the_gates_on_a_dish_with_an_opening(dish):
    _, _, _, layout = dish
    gates = layout.metrics["gates"]
    assert layout.method == "field" and layout.quads.shape[1] == 4
    assert gates["manifold"] and gates["euler_characteristic"] == 0  # one hole: 2 - 2
    assert gates["count_ratio"] <= 1.3
    assert gates["edges_in_band"] >= 0.9
    assert gates["shortest_edge_vs_panel_size"] >= 0.3
    assert gates["corners_in_60_120"] >= 0.95
    assert not [i for i in layout.issues if i.severity == "error"]
    # the verdict beside the figures, and on the progress line
    assert gates["passed"] and gates["failed"] == []
    assert _layout_verdict(layout).endswith("panels (field), every layout gate passed")


def test_field_boundary_vertices_lie_on_the_design_outline(dish):
    _, _, _, layout = dish
    from fabpanel.panelize.quality import vertex_valences

    _, on_boundary = vertex_valences(layout.quads, len(layout.vertices))
    radii = np.linalg.norm(layout.vertices[on_boundary][:, :2], axis=1)
    on_outer = np.abs(radii - 6000.0) < 50
    on_inner = np.abs(radii - 1200.0) < 50
    assert (on_outer | on_inner).all()
    assert np.abs(radii[on_outer] - 6000.0).max() < 0.5  # the true circle, not the 160-gon
    assert np.abs(radii[on_inner] - 1200.0).max() < 0.5


def test_developed_panels_follow_the_design_boundary_or_cut_its_chord(dish):
    surface, job, query, layout = dish
    design = sample_panels(layout, query, job.develop.samples)
    samples = design.samples
    # a ring rib in a rim's level plane leans 48 degrees from square where the dish slopes 42
    # (the outer rim) and 80 where it slopes 10 (round the opening): beyond the 45 the build
    # can trim the sheets to, so every side cuts its chord, the rims' arcs' sagittas deep
    chords = design.chords
    assert len(chords) == int((layout.side_neighbours < 0).sum())
    sides = np.isin(layout.side_edges, list(chords))
    deviation = boundary_deviation(layout, samples, surface, sides)
    sagitta = max(c.offset for c in chords.values())
    assert deviation["design_to_panels"] == pytest.approx(sagitta, rel=0.05)
    for e, chord in chords.items():
        a, b = layout.vertices[layout.edges[e]]
        rim = np.linalg.norm(a[:2])
        half = 0.5 * np.linalg.norm(b[:2] - a[:2])
        in_plan = rim - np.sqrt(rim**2 - half**2)  # the arc's sagitta over the chord, in plan
        slope = np.arctan(1.5e-4 * rim)  # measured across the upright plane through the chord
        assert chord.offset == pytest.approx(in_plan * np.cos(slope), rel=0.05, abs=0.5)


def test_the_field_layout_is_deterministic(dish):
    surface, job, query, layout = dish
    again = fp.panelize(surface, job, query)
    np.testing.assert_array_equal(again.quads, layout.quads)
    np.testing.assert_array_equal(again.vertices, layout.vertices)


def test_auto_keeps_a_field_layout_that_passes_every_gate_without_making_the_other():
    surface = _annulus(6000.0, 1200.0, 300.0, 160)
    layout = fp.panelize(surface, _job("1.2 m"))
    auto = layout.metrics["auto"]
    assert layout.method == auto["chosen"] == "field" and set(auto["scores"]) == {"field"}
    assert "passes every layout gate" in auto["reason"]
    assert not [i for i in layout.issues if i.code.startswith("layout-")]


def test_auto_compares_both_methods_when_the_field_layout_fails_a_gate(tmp_path):
    # random seed 17 of benchmarks/random_shapes.py: three openings closer than a panel to
    # each other leave the field layout short of the corner gate (a 148° corner; 90 % in
    # 60-120°)
    layout = fp.panelize(random_surface(17, tmp_path), _job("1 m"))
    auto = layout.metrics["auto"]
    assert set(auto["scores"]) == {"skeleton", "field"}
    assert auto["chosen"] == layout.method == "field"
    assert auto["scores"]["field"] == max(auto["scores"].values())
    assert "layout-corner-angle" in auto["gates_failed"]["field"]
    assert "field scores" in auto["reason"]
    gates = layout.metrics["gates"]
    assert not gates["passed"] and gates["failed"] == auto["gates_failed"]["field"]
    assert f"layout gates failed: {', '.join(gates['failed'])}" in _layout_verdict(layout)


def test_a_singular_point_becomes_a_vertex_with_the_field_method():
    surface = _annulus(6000.0, 1200.0, 300.0, 160)
    column = (3100.0, 1700.0, 0.0)
    layout = fp.panelize(surface, _job("1 m", method="field", singular_points=[column]))
    nearest = np.linalg.norm(layout.vertices - np.array(column), axis=1).min()
    assert nearest < 1.0


# ---------------------------------------------------------------------------------------------
# the gates
# ---------------------------------------------------------------------------------------------
def _grid_layout(squeeze: float) -> tuple[PanelLayout, Surface]:
    """A 6 x 4 grid of 1 m panels on a plane whose third row is ``squeeze`` m wide."""
    xs = np.arange(7) * 1000.0
    ys = np.concatenate([[0, 1000, 2000], 2000 + squeeze * 1000 + np.array([0, 1000])])
    xx, yy = np.meshgrid(xs, ys, indexing="ij")
    vertices = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    ids = np.arange(xx.size).reshape(xx.shape)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    panel_ids = tuple(f"P{i + 1:03d}" for i in range(len(quads)))
    layout = PanelLayout(vertices, quads, panel_ids, "layout")
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    surface = Surface(vertices, tris, (), Path("grid.obj"), "obj", "mm")
    return layout, surface


def test_a_sliver_row_is_an_error_that_names_its_panels():
    layout, surface = _grid_layout(0.05)
    job = _job("1 m")
    measures = gate_measures(layout, surface, 1000.0)
    assert measures["narrowest_panel_mm"] == pytest.approx(50.0)
    assert measures["shortest_edge_mm"] == pytest.approx(50.0)
    issues = {i.code: i for i in gate_issues(layout, measures, job)}
    narrow = issues["layout-narrow-panel"]
    assert narrow.severity == "error" and "P003" in narrow.message and "50 mm" in narrow.message
    assert "layout-short-edge" in issues
    good, good_surface = _grid_layout(1.0)
    good_measures = gate_measures(good, good_surface, 1000.0)
    assert not gate_issues(good, good_measures, job)
    assert layout_score(good_measures, 300.0) > layout_score(measures, 300.0)
    # the narrow panel alone costs a whole point: an error no share of good corners makes up
    assert layout_score(measures, 300.0) == pytest.approx(layout_score(measures, 40.0) - 1.0)


def test_min_panel_width_is_a_job_setting():
    layout, surface = _grid_layout(0.25)
    measures = gate_measures(layout, surface, 1000.0)
    assert any(i.code == "layout-narrow-panel" for i in gate_issues(layout, measures, _job()))
    relaxed = _job("1 m", min_panel_width="200 mm")
    assert not any(i.code == "layout-narrow-panel" for i in gate_issues(layout, measures, relaxed))


def test_panel_widths_are_the_narrower_mid_lines():
    corners = np.array([[[0, 0, 0], [2000, 0, 0], [2000, 300, 0], [0, 300, 0]]], dtype=float)
    assert panel_widths(corners)[0] == pytest.approx(300.0)


def test_too_many_panels_and_bad_corners_are_warnings():
    layout, surface = _grid_layout(1.0)
    shear = layout.vertices.copy()
    shear[:, 0] += 1.2 * shear[:, 1]  # 40 degree corners
    sheared = PanelLayout(shear, layout.quads, layout.panel_ids, "layout")
    measures = gate_measures(sheared, surface, 500.0)  # 0.5 m asked: 4 x too few... per area
    codes = {i.code: i.severity for i in gate_issues(sheared, measures, _job("500 mm"))}
    assert codes["layout-corner-angle"] == "warning"
    dense = gate_measures(layout, surface, 2000.0)
    assert dense["count_ratio"] == pytest.approx(24 / (24e6 / 4e6))
    found = {i.code: i for i in gate_issues(layout, dense, _job("2 m"))}
    assert "try a larger panel_size" in found["layout-panel-count"].message


# ---------------------------------------------------------------------------------------------
# the hard shapes of benchmarks/hard_shapes.py (the README's table), at 1 m
# ---------------------------------------------------------------------------------------------
def _hard_shape(name: str, folder: Path) -> Surface:
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "hard_shapes.py"
    spec = importlib.util.spec_from_file_location("hard_shapes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    vertices, faces = module.SHAPES[name]()
    target = module.write_obj(folder / f"{name}.obj", vertices, faces)
    return fp.load_surface(target, "m")


@pytest.mark.parametrize("name", ["canopy4", "dome_oculus", "hypar_hole"])
def test_field_layouts_of_hard_shapes_meet_the_size_gates(tmp_path, name):
    surface = _hard_shape(name, tmp_path)
    layout = fp.panelize(surface, _job("1 m", method="field"))
    gates = layout.metrics["gates"]
    assert gates["manifold"]
    assert gates["euler_characteristic"] == gates["surface_euler_characteristic"]
    assert gates["count_ratio"] <= 1.3  # measured 1.08-1.27
    # measured 0.895-1.0; canopy4's 1.1-1.6 m openings get eight edges of 0.45 m each
    assert gates["edges_in_band"] >= 0.88
    assert gates["shortest_edge_vs_panel_size"] >= 0.3  # measured 0.37-0.62
    # corners: measured 46-134 degrees, 95.5-98 % within 60-120
    assert gates["corners_in_45_135"] == 1.0
    assert gates["corners_in_60_120"] >= 0.95
    assert not [i for i in layout.issues if i.code == "layout-narrow-panel"]
    # the method's own measures describe the layout as polished, as its gates do
    assert layout.metrics["polish"]["vertices_moved"] > 0 or name != "canopy4"
    lengths = np.linalg.norm(np.diff(layout.vertices[layout.edges], axis=1)[:, 0], axis=1)
    assert layout.metrics["edge_length_mm"]["min"] == pytest.approx(lengths.min(), abs=1e-3)
    assert layout.metrics["edge_length_mm"]["min"] == pytest.approx(
        gates["shortest_edge_mm"], abs=0.1
    )
    assert layout.metrics["corner_angle_deg"]["min"] == pytest.approx(
        gates["corner_angle_deg"][0], abs=0.01
    )


@pytest.mark.parametrize("name", ["dome_oculus", "hypar_hole", "wavy_strip"])
def test_sliding_boundary_nodes_bring_every_corner_within_45_to_135_degrees(tmp_path, name):
    # before the boundary nodes slid, leaning boundary panels had corners of 134-151 degrees
    layout = fp.panelize(_hard_shape(name, tmp_path), _job("1 m", method="field"))
    gates = layout.metrics["gates"]
    assert gates["corners_in_45_135"] == 1.0  # measured 47-131 degrees
    assert gates["corners_in_60_120"] >= 0.95  # measured 0.96-0.98
    assert gates["shortest_edge_vs_panel_size"] >= 0.3  # wavy_strip: 50 mm before its
    # cut corners (two 40-degree turns 150 mm apart) became one corner each
    assert layout.metrics["field"]["relaxation"]["vertices_sliding"] > 20


@pytest.mark.parametrize("name", ["canopy4", "quarry"])
def test_holding_the_gate_bands_passes_every_gate_where_squaring_alone_did_not(tmp_path, name):
    # squaring alone: canopy4 93 % of corners in 60-120° (its 14 valence-3 vertices at 120°
    # each, half a fraction over), edges 89.5 % in band; quarry corners down to 40°
    layout = fp.panelize(_hard_shape(name, tmp_path), _job("1 m", method="field"))
    gates = layout.metrics["gates"]
    band = layout.metrics["field"]["relaxation"]["gate_band"]
    assert band["kept"] and band["score_after"] > band["score_before"]
    assert gates["corners_in_45_135"] == 1.0  # measured 46-134°
    assert gates["corners_in_60_120"] >= 0.95  # measured 0.955, 0.964
    assert gates["edges_in_band"] >= 0.9  # measured 0.949, 0.957
    assert gates["shortest_edge_vs_panel_size"] >= 0.3
    assert gates["count_ratio"] <= 1.3


def test_a_smooth_outline_is_not_meshed_as_a_disk(tmp_path):
    # gmsh's pattern-based faces made the 3 m roundings a disk: four valence-3 vertices 3 m
    # inside, rim panels 1.7 m long, and after two plate rounds 206 panels for 95 m²; without
    # them, a grid turning the roundings
    layout = fp.panelize(_hard_shape("rounded_slab", tmp_path), _job("1 m", method="field"))
    field = layout.metrics["field"]
    assert field["gmsh_topology"] == 10 and field["plate_rounds"] == 0
    gates = layout.metrics["gates"]
    assert gates["count_ratio"] <= 1.3  # measured 1.17 (111 panels)
    assert gates["edges_in_band"] >= 0.9  # measured 1.0
    assert gates["corners_outside_45_135"] == 0  # measured 64-125°
    assert gates["corners_in_60_120"] >= 0.95  # measured 0.99


def test_small_openings_are_missing_panels_of_the_grid(tmp_path):
    # three openings about a panel across, two of them rectangles turned off the axes with
    # sides under the 0.6 m at which close corners merge: meshed as loops, gmsh gave each
    # eight edges of 0.25-0.4 m or merged the short sides' corners (150° panel corners);
    # filled in and punched out, each is bounded by four panel sides
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    surface = _hard_shape("skylights", tmp_path)
    layout = fp.panelize(surface, _job("1 m", method="field"))
    assert layout.metrics["field"]["small_openings"] == "punched"
    sides = np.sort(np.stack([layout.quads, np.roll(layout.quads, -1, axis=1)], 2), 2)
    edges, counts = np.unique(sides.reshape(-1, 2), axis=0, return_counts=True)
    once = edges[counts == 1]
    graph = coo_matrix((np.ones(len(once)), (once[:, 0], once[:, 1])), (len(layout.vertices),) * 2)
    _, label = connected_components(graph, directed=False)
    per_loop = np.bincount(label[once[:, 0]])
    per_loop = np.sort(per_loop[per_loop > 0])
    assert len(per_loop) == 4 and list(per_loop[:3]) == [4, 4, 4]  # and the roof's outline
    gates = layout.metrics["gates"]
    assert meets_every_gate(gates, 300.0)  # measured 97 panels, 60-134°, 99 %, band 95 %


def test_panels_near_the_plate_width_are_brought_onto_it_without_a_smaller_size(tmp_path):
    # 1.2 m panels on the default 3 x 1.5 m plate (1480 mm usable): the band's 1.25 x panel
    # size is wider than the plate. A random polygon (seed 19 of benchmarks/random_shapes.py,
    # 105 panels at 1 m): gmsh's chosen mesh misses the plate, and a plate round
    # (12 % smaller everywhere) would add a third more panels; gmsh's next finer mesh at the
    # asked size fits, placed with the band smoothing holding edges under the plate's width.
    # (With the band measure's edge rotations the first mesh fits the plate but fails a gate:
    # the same next finer mesh is then taken for the gates, step 8 of the README.)
    from fabpanel.panelize.decompose import oversize_panels

    surface = random_surface(19, tmp_path)
    job = _job("1.2 m", method="field")
    layout = fp.panelize(surface, job)
    field = layout.metrics["field"]
    assert field.get("finer_mesh", 0) + field.get("finer_mesh_for_gates", 0) == 1
    assert field["plate_rounds"] == 0 and field["smallest_size_factor"] == 1.0
    assert not oversize_panels(layout.vertices, layout.quads, job).any()
    assert layout.metrics["gates"]["count_ratio"] <= 1.3  # measured 1.29 (90 panels)
    assert layout.metrics["gates"]["failed"] == []


def test_a_plate_round_makes_panels_smaller_only_near_those_that_miss(tmp_path):
    # seed 63 of benchmarks/random_shapes.py, a 35 m2 polygon with a 28° tip, at 1 m: one
    # panel misses the plate, and a plate round 12 % smaller everywhere made 53 panels (1.53 x
    # the area's count); smaller only within 1-2.5 panel sizes of it, 42 (1.21 x)
    from fabpanel.panelize.decompose import oversize_panels

    surface = random_surface(63, tmp_path)
    job = _job("1 m", method="field")
    layout = fp.panelize(surface, job)
    field = layout.metrics["field"]
    assert field["plate_rounds"] == 1 and field["plate_rounds_where"] == "near"
    assert field["smallest_size_factor"] == 0.88
    assert not oversize_panels(layout.vertices, layout.quads, job).any()
    gates = layout.metrics["gates"]
    assert gates["count_ratio"] <= 1.3  # measured 1.21
    # every gate but the design's 28° tip
    assert [code for code in gates["failed"] if code != "layout-corner-angle"] == []
    assert gates["corners_outside_45_135"] == 1 and gates["corners_in_60_120"] >= 0.95


def test_a_small_opening_is_a_missing_panel_at_1_2_m_too(tmp_path):
    # hypar_hole's 1.6 x 1.0 m elliptical opening (4.1 m round) at 1.2 m panels: as a loop,
    # two plate rounds made 62 panels (1.83 x the area's count); punched out of a 6 x 6 grid,
    # 35
    layout = fp.panelize(_hard_shape("hypar_hole", tmp_path), _job("1.2 m", method="field"))
    field = layout.metrics["field"]
    assert field["small_openings"] == "punched" and field["plate_rounds"] == 0
    assert meets_every_gate(layout.metrics["gates"], 360.0)  # measured 59.6-134.3°, band 95 %


def test_a_layout_corner_on_a_smooth_lobe_is_dissolved(tmp_path):
    # gmsh puts a boundary vertex of one panel on the funnel's 2.5 m lobe: 159-165° however
    # the outline nodes slide; dissolved, its inner vertex has three panels (one or two such
    # vertices, by the size factor gmsh's calibration settles on)
    layout = fp.panelize(_hard_shape("funnel", tmp_path), _job("1 m", method="field"))
    false_corners = layout.metrics["field"]["relaxation"]["false_corners"]
    assert false_corners["dissolved"] >= 1 and false_corners["kept"]
    gates = layout.metrics["gates"]
    assert gates["corners_in_45_135"] == 1.0  # measured 60-127°
    assert gates["corners_in_60_120"] >= 0.95  # measured 0.952
    assert gates["euler_characteristic"] == gates["surface_euler_characteristic"]
    assert gates["edges_in_band"] >= 0.9 and gates["shortest_edge_vs_panel_size"] >= 0.3
    assert gates["count_ratio"] <= 1.3  # 94 panels for 76.3 m²


def test_the_corner_at_a_rounded_end_is_held_in_the_gates_by_its_neighbours(tmp_path):
    # the ellipse's ends round off at 1.04 m: its corners there were 137-138°, outside the
    # band's reach until the band held the corners of one-panel vertices that slide too
    layout = fp.panelize(_hard_shape("ellipse_shell", tmp_path), _job("1 m", method="field"))
    gates = layout.metrics["gates"]
    assert gates["corners_in_45_135"] == 1.0  # measured 62-133°
    assert gates["corners_in_60_120"] >= 0.95  # measured 0.992
    assert gates["edges_in_band"] >= 0.9  # measured 1.0


# ---------------------------------------------------------------------------------------------
# curvature alignment
# ---------------------------------------------------------------------------------------------
def test_curvature_alignment_follows_the_rulings_of_a_skewed_vault(tmp_path):
    """A barrel vault (R 5 m, axis along y) cut by a square turned 30° to the axis, with an
    opening: the boundary-aligned layout runs about 30° off the principal directions, the
    curvature-aligned one turns towards them."""
    import importlib.util

    from shapely import affinity
    from shapely.geometry import Point, box

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "hard_shapes.py"
    spec = importlib.util.spec_from_file_location("hard_shapes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    # an opening, or gmsh would mesh the four-sided face as a structured grid along its sides
    square = affinity.rotate(box(-3.2, -3.2, 3.2, 3.2), 30).difference(Point(0.8, 0.5).buffer(0.7))
    vertices, faces = module._mesh(square, lambda x, y: np.sqrt(25.0 - x**2), spacing=0.2)
    surface = fp.load_surface(module.write_obj(tmp_path / "vault.obj", vertices, faces), "m")
    found = {}
    for align in ("boundary", "curvature"):
        layout = fp.panelize(surface, _job("0.5 m", method="field", align=align))
        found[align] = layout.metrics["field"]["curvature_alignment"]["median_deg"]
    # measured 28.7° and 22.1°: gmsh follows a guiding field only loosely where the boundary's
    # front is near (layout.md §4.4), but the panels do turn towards the rulings
    assert found["boundary"] > 20.0  # the square's sides run about 30° off the rulings
    assert found["curvature"] < found["boundary"] - 4.0


def test_auto_replaces_a_poor_grid_on_a_four_sided_strip_by_the_field_layout(tmp_path):
    # the wavy strip has four corners, so auto tries a grid first: 0.9 mm edges and 38
    # narrow panels there, where the field layout passes every gate
    layout = fp.panelize(_hard_shape("wavy_strip", tmp_path), _job("1 m", method="auto"))
    assert layout.method == "field"
    auto = layout.metrics["auto"]
    assert auto["chosen"] == "field" and auto["scores"]["field"] > auto["scores"]["grid"]
    assert not [i for i in layout.issues if i.severity == "error"]


# ---------------------------------------------------------------------------------------------
# a tip of the design outline sharper than 45° is the design's, not the layout's


def _triangle(tip_deg: float, leg: float = 3000.0) -> tuple[Surface, np.ndarray]:
    """A planar isosceles triangle (mm) with its tip at the origin, meshed with its edges
    sampled every 100 mm; and its three corners."""
    half = np.radians(tip_deg / 2)
    corners = np.array([[0.0, 0.0], [leg * np.cos(half), -leg * np.sin(half)]])
    corners = np.vstack([corners, [leg * np.cos(half), leg * np.sin(half)]])
    ring = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        count = int(np.ceil(np.linalg.norm(b - a) / 100.0))
        ring.append(a + np.linspace(0, 1, count, endpoint=False)[:, None] * (b - a))
    ring = np.vstack(ring)
    points = np.vstack([ring, corners.mean(axis=0)])
    centre = len(ring)
    tri = np.array([[i, (i + 1) % centre, centre] for i in range(centre)])
    vertices = np.column_stack([points, np.zeros(len(points))])
    surface = Surface(vertices, tri, (np.arange(centre),), Path("tri.obj"), "obj", "mm")
    return surface, np.column_stack([corners, np.zeros(3)])


def _three_quads(corners: np.ndarray) -> PanelLayout:
    """A triangle split into three quads at its centroid and edge midpoints."""
    mids = 0.5 * (corners + np.roll(corners, -1, axis=0))
    vertices = np.vstack([corners, mids, corners.mean(axis=0)])
    quads = np.array([[0, 3, 6, 5], [1, 4, 6, 3], [2, 5, 6, 4]])
    return PanelLayout(vertices, quads, ("P001", "P002", "P003"), "layout")


def test_a_tip_sharper_than_45_degrees_is_named_as_the_designs():
    surface, corners = _triangle(30.0)
    layout = _three_quads(corners)
    measures = gate_measures(layout, surface, 1000.0)
    assert measures["outline_tip_corners"] == [[0, 0]]
    assert measures["outline_tip_angles_deg"][0] == pytest.approx(30.0, abs=0.5)
    assert measures["outline_tip_points_mm"] == [[0.0, 0.0, 0.0]]
    issues = {i.code: i for i in gate_issues(layout, measures, _job())}
    tip = issues["outline-sharp-corner"]
    assert tip.item == "P001" and "30°" in tip.message and "(0, 0, 0) mm" in tip.message
    # the 30° corner is not listed again among the layout's own bad corners
    corner = issues.get("layout-corner-angle")
    assert corner is None or "P001" not in corner.message
    # nor is the tip a failed layout gate in the verdict
    assert "outline-sharp-corner" not in failed_gates(issues.values())


def test_the_designs_tips_can_be_set_apart_when_asking_whether_every_gate_is_met():
    surface, corners = _triangle(30.0)
    layout = _three_quads(corners)
    measures = gate_measures(layout, surface, 1000.0)
    angles = corner_angles(layout.vertices[layout.quads])
    assert measures["corners_outside_45_135"] == np.sum((angles < 45) | (angles > 135)) >= 1
    # as if the tip were the one corner outside the gates (three panels on 0.43 m² fail the
    # others too)
    measures = {**measures, "count_ratio": 1.0, "edges_in_band": 1.0}
    measures.update(corners_outside_45_135=1, corners_in_60_120=11 / 12)
    assert not meets_every_gate(measures, 300.0)
    assert meets_every_gate(measures, 300.0, tips_apart=True)
    # one corner beyond 45-135° that is not the design's fails either way
    measures["corners_outside_45_135"] = 2
    assert not meets_every_gate(measures, 300.0, tips_apart=True)


def test_a_sharp_panel_corner_on_a_straight_outline_is_the_layouts():
    surface, corners = _triangle(60.0)
    layout = _three_quads(corners)
    # the centre moved so that two panels meet at the first edge's midpoint at 150° and 30°
    along = (corners[1] - corners[0]) / np.linalg.norm(corners[1] - corners[0])
    inward = np.array([-along[1], along[0], 0.0])
    vertices = layout.vertices.copy()
    vertices[6] = vertices[3] + 600.0 * (np.cos(np.radians(30)) * along + 0.5 * inward)
    layout = PanelLayout(vertices, layout.quads, layout.panel_ids, "layout")
    measures = gate_measures(layout, surface, 1000.0)
    assert measures["corner_angle_deg"][0] == pytest.approx(30.0, abs=0.01)
    assert measures["outline_tip_corners"] == []
    codes = {i.code for i in gate_issues(layout, measures, _job())}
    assert "layout-corner-angle" in codes and "outline-sharp-corner" not in codes


def test_a_finer_mesh_of_gmsh_is_kept_where_the_first_fails_a_gate(tmp_path):
    # random seed 57 of benchmarks/random_shapes.py: gmsh's first mesh of the punched way
    # leaves its rotated rectangular opening two corners of two panels (147°, 95 % of corners
    # in 60-120°); the next finer one has three panels at every corner and passes every gate
    layout = fp.panelize(random_surface(57, tmp_path), _job("1 m", method="field"))
    assert layout.metrics["field"]["finer_mesh_for_gates"] >= 1
    gates = layout.metrics["gates"]
    assert gates["passed"], gates["failed"]
    assert gates["corners_in_45_135"] == 1.0 and gates["corners_in_60_120"] >= 0.95
    assert gates["count_ratio"] <= 1.3
    assert gates["euler_characteristic"] == gates["surface_euler_characteristic"]
