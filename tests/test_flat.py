"""Unrolling sheets and writing part DXF files, checked against analytic truth."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, Polygon

from fabpanel.data import Hole, Model, Part
from fabpanel.flat import audit_dxf, cut, part_area_from_dxf, write_part_dxf, write_parts
from fabpanel.flat.dxf import DECIMALS
from fabpanel.flat.strokefont import CHARACTERS, text_strokes
from fabpanel.flat.unroll import grid_point
from fabpanel.geom.flatten import flatten_grid
from fabpanel.geom.polygon import polygon_area
from fabpanel.job import Job

RADIUS, ARC, LENGTH = 4000.0, 0.3, 1200.0


def cylinder_grid(a: int = 41, b: int = 25) -> np.ndarray:
    """Vault patch (axis x, crown +z), i along the arc, j along x: outer normal d_i x d_j = +r."""
    t = np.linspace(np.pi / 2 - ARC / 2, np.pi / 2 + ARC / 2, a)[:, None]
    x = np.linspace(0.0, LENGTH, b)[None, :]
    return np.stack(np.broadcast_arrays(x, RADIUS * np.cos(t), RADIUS * np.sin(t)), axis=-1)


CONE_HALF_ANGLE, CONE_S, CONE_T = np.radians(30.0), (1500.0, 2600.0), (0.0, 0.6)


def cone_grid(a: int = 41, b: int = 25) -> np.ndarray:
    """Cone patch (apex at origin, axis +z): i along the angle, j along the rulings (distance s)."""
    t = np.linspace(*CONE_T, a)[:, None, None]
    s = np.linspace(*CONE_S, b)[None, :, None]
    ruling = np.concatenate(
        [
            np.sin(CONE_HALF_ANGLE) * np.cos(t),
            np.sin(CONE_HALF_ANGLE) * np.sin(t),
            np.full_like(t, np.cos(CONE_HALF_ANGLE)),
        ],
        axis=-1,
    )
    return s * ruling


def sphere_grid(radius: float = 3000.0, k: int = 25) -> np.ndarray:
    u = np.linspace(-0.2, 0.2, k)[:, None]
    v = np.linspace(-0.2, 0.2, k)[None, :]
    return radius * np.stack(
        np.broadcast_arrays(np.sin(u) * np.cos(v), np.sin(v) + 0 * u, np.cos(u) * np.cos(v)),
        axis=-1,
    )


def sides(grid):
    return [grid[:, 0], grid[-1, :], grid[::-1, -1], grid[0, ::-1]]


def lengths(polylines):
    return np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in polylines])


def sheet(grid, pid="P001", kind="sheet-top", holes=()) -> Part:
    return Part(
        id=f"{pid}-{'TOP' if kind == 'sheet-top' else 'BOT'}",
        kind=kind,
        panel_id=pid,
        material="S235",
        thickness=3.0,
        volume=0.0,
        area=0.0,
        mass=0.0,
        brep=b"",
        surface_grid=grid,
        holes=holes,
    )


def rib(pid="P001", side=0) -> Part:
    outline = np.array([[0, 0], [900, 0], [900, 150], [600, 170], [0, 150]], dtype=float)
    return Part(
        id=f"{pid}-RIB-{side}",
        kind="rib",
        panel_id=pid,
        material="S235",
        thickness=8.0,
        volume=0.0,
        area=0.0,
        mass=0.0,
        brep=b"",
        outline=outline,
        frame=np.eye(4),
        holes=(Hole((100.0, 75.0), 13.0), Hole((800.0, 75.0), 13.0)),
    )


def test_cylinder_unrolls_exactly():
    uv, strain = flatten_grid(cylinder_grid())
    assert strain < 1e-6
    flat = lengths(sides(uv))
    arc = RADIUS * ARC
    # the 3D sides: polylines on the arc (chords) -> compare with R * theta within 0.1 mm
    np.testing.assert_allclose(flat, [arc, LENGTH, arc, LENGTH], atol=0.1)
    np.testing.assert_allclose(flat, lengths(sides(cylinder_grid())), atol=1e-6)
    # pinned rigid motion: corner 0 at the origin, side 0 along +x, counter-clockwise
    np.testing.assert_allclose(uv[0, 0], [0, 0], atol=1e-9)
    assert abs(uv[-1, 0, 1]) < 1e-9 and uv[-1, 0, 0] > 0
    outline = np.concatenate([s[:-1] for s in sides(uv)])
    assert polygon_area(outline) > 0
    np.testing.assert_allclose(polygon_area(outline), RADIUS * ARC * LENGTH, rtol=1e-4)


def test_cone_unrolls_exactly():
    uv, strain = flatten_grid(cone_grid())
    assert strain < 1e-6
    flat = lengths(sides(uv))
    theta = CONE_T[1] - CONE_T[0]
    rho = np.sin(CONE_HALF_ANGLE) * np.array(CONE_S)  # circle radii at the two ends
    ruling = CONE_S[1] - CONE_S[0]
    np.testing.assert_allclose(flat, [rho[0] * theta, ruling, rho[1] * theta, ruling], atol=0.1)
    # the unrolled sector: rulings meet at the apex, at distance s from it; the sampled cone is a
    # pyramid whose faces have apex angle 2 asin(sin(half angle) sin(dtheta / 2))
    a = cone_grid().shape[0]
    apex_angle = (a - 1) * 2 * np.arcsin(np.sin(CONE_HALF_ANGLE) * np.sin(theta / (a - 1) / 2))
    chord = 2 * CONE_S[0] * np.sin(apex_angle / 2)
    np.testing.assert_allclose(np.linalg.norm(uv[-1, 0] - uv[0, 0]), chord, rtol=1e-9)


def test_sphere_reports_strain():
    _, strain = flatten_grid(sphere_grid())
    assert strain > 1e-3


def test_cut_sheets_and_ribs(tmp_path):
    # sheet holes are given in surface parameters; two on one straight ruling (grid[i, :])
    openings = (Hole((0.5, 0.2), 40.0, "access"), Hole((0.5, 0.8), 40.0, "access"))
    model = Model(
        parts=(sheet(cylinder_grid(), holes=openings), sheet(cone_grid(), "P002"), rib()),
        developed=None,
    )  # type: ignore[arg-type]
    flat = cut(model, Job.from_dict({}))
    top, cone, rib_part = flat.parts
    grid = cylinder_grid()
    a, b = (grid_point(grid, *h.centre) for h in openings)
    fa, fb = (np.array(h.centre) for h in top.round_holes)
    np.testing.assert_allclose(np.linalg.norm(fb - fa), np.linalg.norm(b - a), atol=1e-6)
    assert all(Polygon(top.outline).contains(Point(h.centre)) for h in top.round_holes)
    assert top.max_strain < 1e-6 and cone.max_strain < 1e-6 and rib_part.max_strain == 0
    assert polygon_area(top.outline) > 0 and polygon_area(rib_part.outline) > 0
    np.testing.assert_allclose(top.edge_lengths_flat, top.edge_lengths_3d, atol=1e-6)
    assert flat.metrics["max_edge_length_error_mm"] < 0.1
    assert flat.metrics["count_by_kind"] == {"sheet-top": 2, "rib": 1}
    # the vault's straight grid lines run along x (j): bend lines parallel to flat y
    assert len(top.bend_lines) > 0
    direction = top.bend_lines[:, 1] - top.bend_lines[:, 0]
    np.testing.assert_allclose(np.abs(direction[:, 0]), 0, atol=1e-6)
    assert len(cone.bend_lines) > 0
    # the mark first, then the part (unique here) and the forming
    assert [p.mark for p in flat.parts] == ["T001", "T002", "R001"]
    assert [label[0] for label in top.labels] == [
        "T001",
        "P001-TOP",
        "OUT CONVEX R4000 SPRING",
        "RIB FACE UP",
    ]
    # "OUT CONVEX" still names the outer face, though the top sheet is drawn from below; the
    # 3 mm sheet at R 4 m keeps 79 MPa sprung (at most half of f_y), the cone at R 866 is rolled
    assert top.forming == "OUT CONVEX R4000 SPRING" and cone.forming == "OUT CONVEX R866-1501 ROLL"
    # drawn as seen from the rib face: the flattening (seen from outside) mirrored
    from fabpanel.flat.unroll import grid_outline

    seen_from_outside = grid_outline(flatten_grid(grid)[0])
    mirrored = seen_from_outside * [-1.0, 1.0]
    gaps = np.linalg.norm(top.outline[:, None] - mirrored[None], axis=2)
    assert gaps.min(axis=1).max() < 1e-9 and len(top.outline) == len(mirrored)
    outside = np.linalg.norm(top.outline[:, None] - seen_from_outside[None], axis=2)
    assert outside.min(axis=1).max() > 100.0
    # bend lines stop short of the etched labels (the middle ones run through them)
    from shapely.geometry import LineString

    from fabpanel.flat.labels import label_boxes

    text = label_boxes(top.labels).buffer(-0.5)
    assert len(top.bend_lines) > 5
    assert not any(LineString(line).intersects(text) for line in top.bend_lines)
    assert not flat.issues

    files = write_parts(flat, tmp_path)
    assert set(files) == {p.id for p in flat.parts}
    for part in flat.parts:
        path = tmp_path / files[part.id]
        assert audit_dxf(path) == []
        np.testing.assert_allclose(part_area_from_dxf(path), part.area, rtol=1e-4)
        # the header's extents hold the drawing (a viewer zooms to them)
        import ezdxf

        document = ezdxf.readfile(path)
        # coordinates to 1 um: what a float's 17 digits would add is noise to a plasma
        points = [
            np.asarray(e.get_points("xy"))
            for e in document.modelspace()
            if e.dxftype() == "LWPOLYLINE"
        ]
        coordinates = np.concatenate(points).ravel()
        assert len(coordinates) > 100
        scaled = coordinates * 10.0**DECIMALS
        assert DECIMALS == 3 and np.abs(scaled - np.round(scaled)).max() < 1e-6
        header = document.header
        low, high = part.outline.min(axis=0), part.outline.max(axis=0)
        # (the drawing's coordinates are rounded to DECIMALS; its extents hold those)
        rounding = 0.5 * 10.0**-DECIMALS + 1e-9
        assert np.all(np.asarray(header["$EXTMIN"])[:2] <= low + rounding)
        assert np.all(np.asarray(header["$EXTMAX"])[:2] >= high - rounding)
        assert np.all(
            np.asarray(header["$EXTMAX"])[:2] - np.asarray(header["$EXTMIN"])[:2]
            < (high - low) + 50
        )


def skewed_cylinder_grid(a: int = 33, b: int = 33) -> np.ndarray:
    """A vault patch sampled along helices: neither family of grid lines is a ruling."""
    i = np.linspace(0.0, 1.0, a)[:, None]
    j = np.linspace(0.0, 1.0, b)[None, :]
    t = np.pi / 2 + ARC * (i - 0.5) + 0.1 * (j - 0.5)
    x = LENGTH * (j + 0.3 * i)
    return np.stack(np.broadcast_arrays(x, RADIUS * np.cos(t), RADIUS * np.sin(t)), axis=-1)


def bend_lines_in_3d(grid):
    """Unroll a grid, lay its bend lines, map their ends and midpoints back onto the surface."""
    from scipy.interpolate import LinearNDInterpolator

    from fabpanel.flat.bending import bending_of
    from fabpanel.flat.unroll import grid_outline

    uv, _ = flatten_grid(grid)
    bending = bending_of(grid, uv, grid_outline(uv))
    to_3d = LinearNDInterpolator(uv.reshape(-1, 2), grid.reshape(-1, 3))
    lines = bending.lines
    # pull the ends 1 mm inside so the piecewise-linear map is defined there
    direction = (lines[:, 1] - lines[:, 0]) / np.linalg.norm(lines[:, 1] - lines[:, 0], axis=1)[
        :, None
    ]
    ends = np.stack([lines[:, 0] + direction, lines[:, 1] - direction], axis=1)
    middle = ends.mean(axis=1)
    return bending, to_3d(ends.reshape(-1, 2)).reshape(-1, 2, 3), to_3d(middle)


@pytest.mark.parametrize(
    "grid",
    [cylinder_grid(), skewed_cylinder_grid()],
    ids=["grid-lines-are-rulings", "helical-grid"],
)
def test_bend_lines_are_the_cylinder_rulings(grid):
    bending, ends, middle = bend_lines_in_3d(grid)
    assert bending.form == "single" and len(bending.lines) == 5 and bending.convex
    np.testing.assert_allclose(bending.radii, RADIUS, rtol=2e-3)
    # a cylinder's rulings run along its axis (x): the line's ends differ in x only
    np.testing.assert_allclose(ends[:, 0, 1:], ends[:, 1, 1:], atol=0.5)
    # and the line is straight on the surface: its middle lies midway between its ends
    np.testing.assert_allclose(middle, ends.mean(axis=1), atol=0.5)
    # each bend line spans the sheet: from one side of the outline to the other
    assert np.all(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1) > 300)


def test_bend_lines_of_a_cone_meet_at_its_apex():
    bending, ends, _ = bend_lines_in_3d(cone_grid())
    assert bending.form == "single" and len(bending.lines) == 5
    # the apex is the origin: the 3D line through the ends passes through it
    direction = ends[:, 1] - ends[:, 0]
    miss = np.linalg.norm(np.cross(ends[:, 0], direction), axis=1) / np.linalg.norm(
        direction, axis=1
    )
    assert miss.max() < 1.0
    rho = np.tan(CONE_HALF_ANGLE) * np.array(CONE_S)  # radius of curvature across a ruling
    np.testing.assert_allclose(
        [bending.radii[:, 0].min(), bending.radii[:, 1].max()], rho, rtol=2e-3
    )


def test_roll_direction_follows_the_face_seen():
    from fabpanel.flat.bending import bending_of
    from fabpanel.flat.unroll import grid_outline

    outside, inside = cylinder_grid(), cylinder_grid()[:, ::-1]  # d_i x d_j out / in
    forms = []
    for grid in (outside, inside):
        uv, _ = flatten_grid(grid)
        forms.append(bending_of(grid, uv, grid_outline(uv)).instruction())
    assert forms == ["OUT CONVEX R4000", "OUT CONCAVE R4000"]
    flat = np.stack(
        np.broadcast_arrays(np.linspace(0, 900, 9)[:, None], np.linspace(0, 600, 7)[None, :], 0.0),
        axis=-1,
    )
    uv, _ = flatten_grid(flat)
    assert bending_of(flat, uv, grid_outline(uv)).instruction() == "OUT FLAT"
    uv, _ = flatten_grid(sphere_grid())
    assert bending_of(sphere_grid(), uv, grid_outline(uv)).form == "double"


def test_dxf_conventions(tmp_path):
    import ezdxf

    # fine-beam plasma (ISO 9013 range 3) holds a 13 mm bolt hole in 8 mm to 0.48 mm: burnt
    job = Job.from_dict({"cutting": {"plasma_quality": 3}})
    flat = cut(Model(parts=(rib(),), developed=None), job)  # type: ignore[arg-type]
    path = write_part_dxf(flat.parts[0], tmp_path / "rib.dxf")
    doc = ezdxf.readfile(path)
    assert doc.header["$INSUNITS"] == 4 and doc.header["$MEASUREMENT"] == 1
    assert not doc.audit().has_errors
    kinds = {e.dxftype() for e in doc.modelspace()}
    assert kinds <= {"LWPOLYLINE", "CIRCLE"}
    layers = {e.dxf.layer for e in doc.modelspace()}
    assert layers == {"CUT-OUTER", "CUT-INNER", "ETCH"}
    outer = doc.modelspace().query('LWPOLYLINE[layer=="CUT-OUTER"]')
    assert len(outer) == 1 and outer[0].closed


def test_small_holes_are_drilled_not_cut(tmp_path):
    import ezdxf

    from fabpanel.flat.nest import pierces

    model = Model(parts=(rib(),), developed=None)  # type: ignore[arg-type]
    fine = {"plasma_quality": 3}  # holds the bolt holes' tolerance (tests/test_welds.py)
    cut_holes = cut(model, Job.from_dict({"cutting": fine})).parts[0]  # 13 mm in 8 mm: 1.6 t
    drilled = cut(model, Job.from_dict({"cutting": {**fine, "min_plasma_hole": 2.0}})).parts[0]
    assert len(cut_holes.round_holes) == 2 and not cut_holes.drill_holes
    assert len(drilled.drill_holes) == 2 and not drilled.round_holes
    assert pierces(cut_holes) == 3 and pierces(drilled) == 1
    assert drilled.area == pytest.approx(cut_holes.area)
    path = write_part_dxf(drilled, tmp_path / "rib.dxf")
    msp = ezdxf.readfile(path).modelspace()
    assert len(msp.query('CIRCLE[layer=="DRILL"]')) == 2
    assert not msp.query('CIRCLE[layer=="CUT-INNER"]')
    # each drill hole gets an etched centre cross through its centre
    centres = {tuple(np.round(h.centre, 6)) for h in drilled.drill_holes}
    crosses = [
        e
        for e in msp.query('LWPOLYLINE[layer=="ETCH"]')
        if len(e) == 2
        and tuple(np.round(np.mean([p[:2] for p in e.get_points()], axis=0), 6)) in centres
    ]
    assert len(crosses) == 4
    assert part_area_from_dxf(path) == pytest.approx(drilled.area, rel=1e-6)
    assert audit_dxf(path) == []


def test_stroke_font_covers_label_characters():
    assert set("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_. ") <= CHARACTERS
    # a forming instruction of a cone opening up: its "+" etched, not dropped (it was, until
    # 2026-12-03: "R2134  ROLL" on a hyperbolic paraboloid's sheets)
    assert set("OUT CONVEX R934+ ROLL") <= CHARACTERS
    assert (
        len(text_strokes("R934+", 0.0, 0.0, 20.0)) == len(text_strokes("R934-", 0.0, 0.0, 20.0)) + 1
    )
    strokes = text_strokes("P012-RIB-3", 0.0, 0.0, 20.0, 90.0)
    points = np.concatenate(strokes)
    # turned by 90 degrees about the centre: the line runs along y, 20 mm high along x
    assert np.ptp(points[:, 1]) > np.ptp(points[:, 0])
    np.testing.assert_allclose(np.ptp(points[:, 0]), 20.0, atol=1e-9)


@pytest.mark.parametrize("grid", [cylinder_grid(9, 5), cone_grid(5, 9)])
def test_coarse_grids_still_exact(grid):
    assert flatten_grid(grid)[1] < 1e-6


@pytest.mark.parametrize("marks", ["ticks", "lines"])
def test_bend_lines_are_etched_as_ticks_at_the_edges_by_default(marks):
    from shapely.geometry import LineString

    from fabpanel.flat.dxf import bend_marks
    from fabpanel.flat.unroll import BEND_TICK

    model = Model(parts=(sheet(cylinder_grid()),), developed=None)  # type: ignore[arg-type]
    top = cut(model, Job.from_dict({"cutting": {"bend_marks": marks}})).parts[0]
    edge = Polygon(top.outline).exterior
    etched = bend_marks(top)
    full = sum(np.linalg.norm(b[1] - b[0]) for b in top.bend_lines)
    if marks == "lines":
        assert len(etched) == len(top.bend_lines)
        return
    # two ticks per bend line, each from the sheet's edge inwards, BEND_TICK long
    lines = len({tuple(np.round(b[0], 3)) for b in top.bend_lines})
    assert len(etched) >= 2 * min(lines, 1) and len(etched) % 2 == 0
    for tick in etched:
        assert edge.distance(Point(tick[0])) < 1.0
        assert np.linalg.norm(tick[1] - tick[0]) == pytest.approx(BEND_TICK)
        assert Polygon(top.outline).buffer(1e-6).contains(LineString(tick))
    assert sum(np.linalg.norm(t[1] - t[0]) for t in etched) < 0.2 * full


def test_a_sheet_whose_flat_outline_crosses_itself_is_an_error_issue_not_a_crash():
    """A folded sample grid (its last two rows reversed) unrolls to an outline that crosses
    itself: the cut reports it as ``invalid-outline`` and goes on, with no bend lines for it
    (the bend-line search needs a valid polygon; shapely raised on it and stopped the run)."""
    t = np.linspace(0, 0.3, 9)
    x = np.linspace(0, 1000, 9)
    tt, xx = np.meshgrid(t, x, indexing="ij")
    grid = np.stack([xx, 4000 * np.sin(tt), 4000 * np.cos(tt)], -1)
    grid[-2:] = grid[-2:, ::-1]
    model = Model(parts=(sheet(grid), rib()), developed=None)  # type: ignore[arg-type]
    flat = cut(model, Job.from_dict({}), jobs=1)
    folded = next(p for p in flat.parts if p.kind == "sheet-top")
    assert not Polygon(folded.outline).is_valid and len(folded.bend_lines) == 0
    assert [(i.code, i.severity, i.item) for i in flat.issues if i.code == "invalid-outline"] == [
        ("invalid-outline", "error", "P001-TOP")
    ]


@pytest.mark.parametrize("seed", range(6))
def test_a_label_stack_keeps_clear_of_holes_near_the_roomiest_point(seed):
    """A rib-like strip with bolt holes along its middle (and one hole beside the middle, where
    the pole of inaccessibility's stack would reach): every line of the stack lies inside the
    outline and clear of every grown hole, and stays legible."""
    from fabpanel.flat.labels import LABEL_CLEARANCE, LABEL_HEIGHT, _line_boxes, place_labels

    rng = np.random.default_rng(seed)
    length, depth = rng.uniform(600.0, 1400.0), rng.uniform(90.0, 160.0)
    outline = np.array([[0.0, 0.0], [length, 0.0], [length, depth], [0.0, depth]])
    pitch = rng.uniform(150.0, 260.0)
    centres = [(x, depth * rng.uniform(0.35, 0.65)) for x in np.arange(20.0, length, pitch)]
    obstacles = shapely.union_all([Point(c).buffer(6.5 + LABEL_CLEARANCE) for c in centres])
    lines = ["R012", f"P{seed:03d}-RIB-1", "IN"]
    labels = place_labels(outline, lines, obstacles=obstacles)
    free = Polygon(outline).difference(obstacles)
    assert [line[0] for line in labels] == lines
    for box in _line_boxes(labels):
        assert free.buffer(1e-6).contains(box)
    assert labels[0][3] >= LABEL_HEIGHT[0]
    # legible on the shop floor: a 90-160 mm strip with holes down its middle has room for
    # a three-line stack of 10 mm capitals between or beside them
    assert labels[0][3] >= 10.0


def test_a_gently_curved_sheet_within_the_strain_tolerance_is_rolled_not_pressed():
    """A 1.5 m sheet on z = x^2 / 2R1 + y^2 / 2R2, R1 15 m, R2 75 m: the curvature ratio (0.2)
    alone called it double-curved (press or wheel), yet it unrolls far within the job's strain
    tolerance; it is rolled at about R1, and only a tolerance it exceeds makes it pressed."""
    from fabpanel.flat.unroll import unroll_sheet

    s = np.linspace(-750.0, 750.0, 25)
    x, y = np.meshgrid(s, s, indexing="ij")
    grid = np.stack([x, y, x**2 / 30_000.0 + y**2 / 150_000.0], axis=-1)
    part = sheet(grid, kind="sheet-bottom")
    tolerance = Job.from_dict({}).develop.strain_tolerance
    rolled = unroll_sheet(part, tolerance)
    assert rolled.max_strain < tolerance
    assert unroll_sheet(part).forming == "OUT DOUBLE CURVED"  # the ratio alone
    assert rolled.forming.endswith(("SPRING", "ROLL")) or rolled.forming.startswith("OUT CONC")
    assert "DOUBLE" not in rolled.forming
    assert 14_000 < rolled.bend_radius < rolled.bend_radius_max < 16_500
    assert unroll_sheet(part, rolled.max_strain / 2).forming == "OUT DOUBLE CURVED"


def test_a_bend_radius_ignores_samples_spoiled_near_a_corner():
    from fabpanel.flat.bending import _radius_range

    along = np.linspace(0.1, 0.9, 11)
    radius = 866.0 + (1501.0 - 866.0) * along  # a cone's radius along its ruling
    spoiled = radius.copy()
    spoiled[[0, 1, 10]] = [40.0, 120.0, 9.0]  # one-sided differences at a near-180 corner
    np.testing.assert_allclose(_radius_range(along, spoiled), [866.0, 1501.0], rtol=1e-9)
