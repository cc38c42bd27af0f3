"""Reaching the bolts: bolt sizes, the tool's place on the hex, the slot, the swept envelope,
and the reach check on built panels (slots cut, every bolt reachable, blocked bolts named)."""

from __future__ import annotations

import json
import re

import manifold3d as m3d
import numpy as np
import pytest
from conftest import cylinder_developed
from shapely.geometry import Polygon

from fabpanel.fasteners import (
    MIN_ENGAGEMENT,
    SHEET_BEFORE_RIB,
    SLOT_CLEARANCE,
    TOOL_RIB_GAP,
    access_design,
    bolt_for_hole,
    default_tool,
)
from fabpanel.flat.unroll import unroll_sheet
from fabpanel.job import Job
from fabpanel.model import build
from fabpanel.model.access import opening_prism, tool_envelope


def test_holes_take_the_largest_standard_bolt_with_normal_clearance():
    assert bolt_for_hole(13.0).name == "M12"
    assert bolt_for_hole(18.0).name == "M16"  # M16-M24: 2 mm clearance
    assert bolt_for_hole(17.0).name == "M14"
    assert bolt_for_hole(33.0).name == "M30"
    assert bolt_for_hole(8.5) is None


@pytest.mark.parametrize("kind", ["ring-spanner", "socket"])
def test_the_tool_grips_the_hex_and_keeps_off_the_rib(kind):
    bolt = bolt_for_hole(13.0)
    design = access_design(bolt, default_tool(kind, bolt), 8.0, 78.0)
    assert design.engagement >= MIN_ENGAGEMENT
    assert design.inner_end >= 8.0 + min(TOOL_RIB_GAP, bolt.washer) - 1e-9
    # slid out, the tool's inner end clears the bolt end by 1 mm
    bolt_end = 8.0 + bolt.washer + bolt.nut_height + bolt.protrusion
    assert design.inner_end + design.slide == pytest.approx(bolt_end + 1.0)
    # the slot keeps 1 mm of sheet before the rib's inner face
    assert design.slot[:, 1].min() >= 8.0 + SHEET_BEFORE_RIB - 1e-9


def test_a_thin_ring_grips_too_little_of_the_hex():
    bolt = bolt_for_hole(13.0)
    thin = default_tool("ring-spanner", bolt, head_thickness=4.0)
    assert access_design(bolt, thin, 8.0, 78.0).engagement < MIN_ENGAGEMENT


@pytest.mark.parametrize(
    "kind,swing", [("ring-spanner", 30.0), ("ring-spanner", 60.0), ("socket", 30.0)]
)
def test_the_tool_path_crosses_the_sheet_only_through_the_slot(kind, swing):
    """A flat 3 mm access sheet at the reach, less the slot's prism: the envelope shares no
    volume with it, and without the slot it shares a lot."""
    bolt = bolt_for_hole(13.0)
    design = access_design(bolt, default_tool(kind, bolt, swing=swing), 8.0, 78.0)
    envelope = tool_envelope(design)
    t = 3.0
    sheet = m3d.Manifold.cube((800.0, 800.0, t)).translate((-400.0, -400.0, design.reach - t))
    slotted = sheet - opening_prism(design.slot, np.eye(4), design.reach, t)
    assert (envelope ^ slotted).volume() < 1e-6
    assert (envelope ^ sheet).volume() > 100.0
    # the slot is no larger than the path needs: the clearance all round
    at_sheet = envelope ^ sheet
    low, high = np.asarray(at_sheet.bounding_box()).reshape(2, 3)
    slot_low, slot_high = design.slot.min(axis=0), design.slot.max(axis=0)
    np.testing.assert_allclose(slot_high[:2] - high[:2], SLOT_CLEARANCE, atol=0.2)
    assert low[0] - slot_low[0] == pytest.approx(SLOT_CLEARANCE, abs=0.2)
    # towards the rib, the sheet before it may take some of the clearance
    assert SHEET_BEFORE_RIB <= low[1] - slot_low[1] <= SLOT_CLEARANCE + 0.2


R, LENGTH, ARC = 4000.0, 2400.0, np.pi / 3


@pytest.fixture(scope="module")
def developed():
    return cylinder_developed(radius=R, length=LENGTH, arc=ARC)


@pytest.fixture(scope="module")
def model(developed):
    return build(developed, Job.from_dict({}), jobs=1)


def test_every_bolt_is_reachable_through_a_slot_on_the_demo_build_up(model):
    metrics = model.metrics
    assert metrics["bolts_total"] * 2 == metrics["bolt_holes"] > 0
    assert metrics["bolts_unreachable"] == 0
    assert not [i for i in model.issues if i.code in ("bolt-unreachable", "access-clash")]
    # one slot per bolt of the panel, two merged into one at corners
    for part in model.parts:
        if part.kind == "sheet-bottom":
            panel_bolts = metrics["panels"][part.panel_id]["bolts"]
            assert 0 < len(part.openings) <= panel_bolts
        if part.kind == "sheet-top":
            assert part.openings == ()


def test_slots_unroll_with_their_size(model):
    job = Job.from_dict({})
    length, width = job.sandwich.access_design().slot_size()
    sheet = next(p for p in model.parts if p.kind == "sheet-bottom")
    flat = unroll_sheet(sheet)
    assert len(flat.holes) == len(sheet.openings)
    outline = Polygon(flat.outline)
    sizes = []
    for contour in flat.holes:
        hole = Polygon(contour)
        assert outline.contains(hole)
        # the slot's long side and width, whatever its direction in the flat frame
        rect = hole.minimum_rotated_rectangle
        edges = np.diff(np.asarray(rect.exterior.coords), axis=0)[:2]
        sizes.append(sorted(np.linalg.norm(edges, axis=1)))
    single = [s for s in sizes if s[1] < length + 1.0]
    assert single, "every slot was merged"
    # the 3D wall runs along the tool's way in, not the sheet normal: within 0.3 mm on R 4 m;
    # the length follows each bolt's own reach to the sheet (76.5-78 mm here: the swing's span)
    sizes = np.array(single)
    np.testing.assert_allclose(sizes[:, 0], width, atol=0.3)
    assert np.all(np.abs(sizes[:, 1] - length) < 1.5)


def test_end_bolts_under_a_stiffener_move_past_it_on_both_ribs(developed):
    """Stiffeners 90 mm from the corners stand over the end bolts' slots at the job's 60 mm:
    the room probe finds the nearest end distance past the stiffener where slot and tool
    clear every part, the same for both panels of the joint."""
    job = Job.from_dict({"sandwich": {"stiffener_offset": "90 mm"}})
    model = build(developed, job, jobs=1)
    assert model.metrics["bolts_unreachable"] == 0
    assert not [i for i in model.issues if i.code == "bolt-unreachable"]
    assert model.metrics["max_bolt_coaxial_error_mm"] < 1e-6
    stiffener = next(p for p in model.parts if p.kind == "stiffener")
    for rib in (p for p in model.parts if p.kind == "rib" and p.holes):
        along = np.sort([h.centre[0] for h in rib.holes]) - rib.outline[:, 0].min()
        span = np.ptp(rib.outline[:, 0])
        # past the stiffener (its offset and thickness) at both ends, and not far past it
        for end in (along[0], span - along[-1]):
            assert 90.0 + stiffener.thickness < end < 90.0 + 80.0


def test_a_tool_too_large_for_the_panel_leaves_every_bolt_unreachable_and_named(developed):
    job = Job.from_dict({"sandwich": {"bolts": {"tool_head_diameter": "160 mm"}}})
    model = build(developed, job, jobs=1)
    blocked = [i for i in model.issues if i.code == "bolt-unreachable"]
    # every joint's bolt, reported by both of its panels
    assert model.metrics["bolts_unreachable"] == model.metrics["bolts_total"] > 0
    assert len(blocked) == 2 * model.metrics["bolts_total"]
    assert all(i.severity == "error" for i in blocked)
    # each names its rib, its bolt and why
    assert all(re.match(r"P\d+-RIB-\d bolt \d+: .*(edge|hits)", i.message) for i in blocked)
    assert model.metrics["bolts_unreachable"] == len(model.metrics["bolts_unreachable_ids"])
    # the rooms the panels handed over for the moves (tuple keys) stay out of the manifest
    json.dumps(model.metrics)


def test_end_bolts_move_out_from_under_a_leaning_stiffener(tmp_path):
    """Two 1 m panels of a dome (radius ~12 m): at the shared rib's ends the corner
    stiffeners, standing along the corner normals, lean over the slots of bolts at the default
    60 mm. The build moves those end bolts into the stiffeners' pockets, the same on both ribs."""
    from test_packaging import _grid_obj

    import fabpanel as fp

    _grid_obj(tmp_path / "patch.obj")
    job = fp.Job.from_dict(
        {
            "input": {"path": str(tmp_path / "patch.obj"), "units": "m"},
            "panelize": {"panel_size": "1 m"},
        }
    )
    model = fp.run(job, until="build", write=False, jobs=1).model
    assert not [i for i in model.issues if i.code in ("access-clash", "bolt-unreachable")]
    assert model.metrics["bolts_unreachable"] == 0
    assert model.metrics["max_bolt_coaxial_error_mm"] < 1e-6
    rib = next(p for p in model.parts if p.kind == "rib" and p.holes)
    along = sorted(h.centre[0] for h in rib.holes)
    span = np.ptp(rib.outline[:, 0])
    # both end bolts nearer their corners than the job's 60 mm
    assert along[0] - rib.outline[:, 0].min() < 60.0 - 1.0
    assert rib.outline[:, 0].max() - along[-1] < 60.0 - 1.0
    assert span > 900.0


def test_the_reach_is_the_farthest_the_sheet_stands_over_the_slot():
    """A sheet sloping across the slot (z = 100 + 0.3 y, flat in x) stands farthest over the
    slot's far edge: the tool's handle leaves the sheet there and swings wider, so the slot
    is sized for that reach, not the one above the bolt."""
    from fabpanel.model import occ
    from fabpanel.model.openings import footprint_reaches

    u, v = np.meshgrid(np.linspace(-300, 300, 7), np.linspace(-50, 400, 7), indexing="ij")
    surface, _ = occ.bspline_surface(np.stack([u, v, 100 + 0.3 * v], axis=-1))
    design = Job.from_dict({}).sandwich.access_design().at_reach(100.0)
    frames = {0: np.eye(4)[None]}
    reach = footprint_reaches(surface, frames, {0: [design]})[0][0]
    far = design.slot[::3, 1].max()
    assert reach == pytest.approx(100 + 0.3 * far, abs=1e-6)
    # a sheet sloping the other way keeps the reach above the bolt at least
    surface, _ = occ.bspline_surface(np.stack([u, v, 100 - 0.3 * v], axis=-1))
    assert footprint_reaches(surface, frames, {0: [design]})[0][0] == pytest.approx(100.0)


def test_the_reach_reads_the_sheet_only_not_its_surface_past_the_edge():
    """A slot hanging over the sheet's edge: past the edge the B-spline runs on as the
    boundary span's polynomial (here the same slope, up and away), which is no sheet. Read
    there, the reach grew the slot, the wider slot read farther out, and on the pavilion two
    rounds took a 78 mm reach to hundreds of metres (minutes and gigabytes per panel)."""
    from fabpanel.model import occ
    from fabpanel.model.openings import footprint_reaches

    design = Job.from_dict({}).sandwich.access_design().at_reach(100.0)
    edge = 0.5 * design.slot[:, 1].max()  # the sheet ends half-way across the slot
    u, v = np.meshgrid(np.linspace(-300, 300, 7), np.linspace(-50, edge, 7), indexing="ij")
    surface, _ = occ.bspline_surface(np.stack([u, v, 100 + 3.0 * v], axis=-1))
    reach = footprint_reaches(surface, {0: np.eye(4)[None]}, {0: [design]})[0][0]
    assert 100.0 < reach <= 100 + 3.0 * edge + 1e-6
