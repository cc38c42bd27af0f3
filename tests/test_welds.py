"""Weld and fit-up details: sheet set-back, snipes, erection gap with packing plates, and which
bolt holes the plasma may burn (ISO 9013 ranges against the hole tolerance)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import cylinder_developed

from fabpanel.buildup import Buildup
from fabpanel.data import Hole
from fabpanel.errors import InputError
from fabpanel.flat import cut
from fabpanel.flat.holing import is_drilled, perpendicularity
from fabpanel.geom.polygon import polygon_area
from fabpanel.job import Job
from fabpanel.model import build, occ
from fabpanel.model.plates import outline_edges
from fabpanel.welds import default_setback, default_throat, packing_side


def _refused(sandwich: dict) -> str:
    with pytest.raises(InputError) as caught:
        Job.from_dict({"sandwich": sandwich}, source="job.toml")
    message = str(caught.value)
    assert message.startswith("job.toml: ") and "\n" not in message
    return message


# --------------------------------------------------------------------------------------------
# the job's weld keys and the build-up derived from them
# --------------------------------------------------------------------------------------------
def test_default_weld_details_follow_the_sheet():
    welds = Buildup.of(Job.from_dict({})).welds
    # 3 mm sheets: the largest equal-leg fillet on the edge has a 3 mm leg, a 2.12 mm throat
    assert welds.throat == pytest.approx(3 / math.sqrt(2))
    assert welds.leg == pytest.approx(3.0)
    assert welds.setback == 4.0 and welds.snipe == 15.0
    assert welds.erection_gap == 0.0 and welds.packing == 0.0
    # thicker sheets: EN 1993-1-8's 3 mm throat, a 4.24 mm leg, 5.5 mm set-back (0.5 mm steps)
    assert default_throat(8.0, 10.0) == 3.0
    # 4 mm sheets on 6 mm ribs: a 3 mm leg, so the sheet keeps 2 mm of the rib
    assert default_throat(4.0, 6.0) == pytest.approx(3 / math.sqrt(2))
    assert default_setback(3.0) == 5.5
    # M12 in a 13 mm hole: 3.4 x 13 = 44.2 -> a 45 mm square, never taller than the rib
    assert packing_side(13.0, 150.0) == 45.0 and packing_side(13.0, 40.0) == 40.0
    cladding = Buildup.of(Job.from_dict({"sandwich": {"buildup": "cladding"}})).welds
    assert cladding.setback == 0.0 and cladding.snipe == 0.0


def test_weld_rules_refuse_details_that_cannot_be_made():
    message = _refused({"welds": {"throat": "3 mm"}})
    assert "[sandwich.welds] throat" in message and "at most 2.12 mm" in message
    message = _refused({"welds": {"setback": "7 mm"}})
    assert "setback" in message and "less than 2 mm of the rib" in message
    message = _refused({"welds": {"snipe": "2 mm"}})
    assert "snipe" in message and "between 3 and 50 mm" in message
    assert "snipe" in _refused({"welds": {"snipe": "60 mm"}})
    assert "splice" in _refused({"welds": {"erection_gap": "12 mm"}})
    # a thicker sheet takes a thicker weld and its wider set-back
    thick = {"sheet_thickness": "6 mm", "welds": {"throat": "4 mm"}}
    message = _refused(thick)
    assert message.startswith("job.toml: [sandwich.welds] throat") and "set back 7 mm" in message
    job = Job.from_dict({"sandwich": {**thick, "rib_thickness": "10 mm"}})
    assert Buildup.of(job).welds.setback == 7.0


# --------------------------------------------------------------------------------------------
# snipes
# --------------------------------------------------------------------------------------------
def test_snipes_cut_every_corner_at_45_degrees():
    top = np.c_[np.linspace(0, 200, 21), np.full(21, 100.0)]
    bottom = np.c_[np.linspace(0, 200, 21), np.zeros(21)]
    edges = outline_edges(top, bottom, 15.0)
    assert len(edges) == 8
    outline = np.vstack([e[:-1] for e in edges])
    assert abs(polygon_area(outline)) == pytest.approx(200 * 100 - 4 * 15**2 / 2)
    for cut_edge in edges[1::2]:
        run, rise = np.abs(cut_edge[1] - cut_edge[0])
        assert run == pytest.approx(15.0) and rise == pytest.approx(15.0)
    # consecutive edges share their end points: one closed wire
    for here, after in zip(edges, edges[1:] + edges[:1]):
        np.testing.assert_allclose(here[-1], after[0])
    # a plate end too short for the snipe keeps its corners; snipe 0 gives none
    assert len(outline_edges(top, bottom * 0 + 90.0, 15.0)) == 4
    assert len(outline_edges(top, bottom, 0.0)) == 4


# --------------------------------------------------------------------------------------------
# built panels
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def developed():
    return cylinder_developed(radius=4000.0, length=2000.0, arc=np.pi / 4)


@pytest.fixture(scope="module")
def gap_job():
    return Job.from_dict({"sandwich": {"welds": {"erection_gap": "3 mm"}}})


@pytest.fixture(scope="module")
def gapped(developed, gap_job):
    return build(developed, gap_job, jobs=1)


def _corners(outline: np.ndarray, angle: float = 10.0) -> int:
    """Vertices where the outline turns by more than ``angle`` degrees."""
    a = outline - np.roll(outline, 1, axis=0)
    b = np.roll(outline, -1, axis=0) - outline
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return int((cos < np.cos(np.radians(angle))).sum())


def test_stiffeners_and_butting_ribs_are_sniped(gapped):
    for part in gapped.parts:
        corners = _corners(part.outline) if part.outline is not None else 0
        if part.kind == "stiffener":
            assert corners == 8, part.id
        elif part.kind == "rib":
            side = int(part.id.rsplit("-", 1)[1])
            # ribs 1 and 3 butt against 0 and 2 (three welds meet at their ends)
            assert corners == (8 if side % 2 == 1 else 4), part.id
    assert gapped.metrics["all_valid"] and gapped.metrics["clash"]["clashes"] == 0


def test_erection_gap_has_a_packing_plate_at_every_bolt(developed, gapped, gap_job):
    gap = 3.0
    packs = [p for p in gapped.parts if p.kind == "packing"]
    assert len(packs) == gapped.metrics["bolts_total"] > 0
    side = Buildup.of(gap_job).welds.packing
    assert side == 45.0
    for pack in packs:
        assert pack.thickness == gap
        assert abs(polygon_area(pack.outline)) == pytest.approx(side**2)
        np.testing.assert_allclose(pack.volume, (side**2 - np.pi * 13.0**2 / 4) * gap, rtol=1e-6)
    # ribs stand half the gap off the contact plane, the sheets a set-back further at joints
    assert gapped.metrics["max_rib_contact_gap_mm"] < 0.05
    neighbours = developed.layout.side_neighbours
    for p, pid in enumerate(developed.panel_ids):
        for s in range(4):
            plane = developed.side_planes[p, s] / np.linalg.norm(developed.side_planes[p, s, :3])
            rib = next(x for x in gapped.parts if x.id == f"{pid}-RIB-{s}")
            dist = occ.plane_distances(occ.from_brep(rib.brep), plane)
            expected = gap / 2 if neighbours[p, s] >= 0 else 0.0
            assert dist.min() == pytest.approx(expected, abs=0.05), rib.id
    # each packing plate fills the gap between its two ribs and shares their bolt axis
    ribs = {x.id: occ.from_brep(x.brep) for x in gapped.parts if x.kind == "rib"}
    for pack in packs:
        shape = occ.from_brep(pack.brep)
        pid, _, s, _ = pack.id.split("-")
        p = developed.panel_ids.index(pid)
        plane = developed.side_planes[p, int(s)]
        dist = occ.plane_distances(shape, plane / np.linalg.norm(plane[:3]))
        assert dist.min() == pytest.approx(-gap / 2, abs=1e-6)
        assert dist.max() == pytest.approx(gap / 2, abs=1e-6)
        assert occ.common_volume(shape, ribs[f"{pid}-RIB-{s}"]) < 1e-3
    assert gapped.metrics["max_bolt_coaxial_error_mm"] < 0.1


def test_packing_plates_are_cut_marked_and_drilled(gapped, gap_job):
    flat = cut(gapped, gap_job, jobs=1)
    packs = [f for f in flat.parts if f.kind == "packing"]
    assert packs and all(len(f.drill_holes) == 1 and not f.round_holes for f in packs)
    marks = {m.mark for m in flat.marks if m.mark.startswith("K")}
    assert marks == {"K001"}  # every packing plate is the same part


# --------------------------------------------------------------------------------------------
# holes: drilled or burnt
# --------------------------------------------------------------------------------------------
def test_iso_9013_ranges():
    assert perpendicularity(1, 1.5) == pytest.approx(0.0545)
    assert perpendicularity(4, 8.0) == pytest.approx(0.96)
    assert perpendicularity(2, 8.0) == pytest.approx(0.206)


@pytest.mark.parametrize(
    ("hole", "thickness", "quality", "fit", "drilled"),
    [
        (Hole((0, 0), 13.0, "bolt"), 8.0, 4, "normal", True),  # u 0.96 > 0.5
        (Hole((0, 0), 13.0, "bolt"), 8.0, 3, "normal", False),  # u 0.48
        (Hole((0, 0), 13.0, "bolt"), 8.0, 2, "fitted", True),  # fitted: always drilled
        (Hole((0, 0), 6.0, "bolt"), 8.0, 1, "normal", True),  # smaller than the plate
        (Hole((0, 0), 40.0, "access"), 8.0, 5, "fitted", False),  # not a bolt hole
    ],
)
def test_bolt_holes_are_burnt_only_within_their_tolerance(hole, thickness, quality, fit, drilled):
    got = is_drilled(hole, thickness, min_plasma_hole=1.0, quality=quality, tolerance=0.5, fit=fit)
    assert got is drilled


def test_rib_bolt_holes_are_drilled_by_default_and_burnt_by_fine_plasma(developed):
    job = Job.from_dict({"sandwich": {"welds": {"snipe": "0 mm"}}})
    model = build(developed, job, jobs=1)
    default = cut(model, job, jobs=1)
    ribs = [f for f in default.parts if f.kind == "rib" and (f.round_holes or f.drill_holes)]
    assert ribs and all(f.drill_holes and not f.round_holes for f in ribs)
    fine = cut(model, job.replace(cutting={"plasma_quality": 2}), jobs=1)
    ribs = [f for f in fine.parts if f.kind == "rib" and (f.round_holes or f.drill_holes)]
    assert ribs and all(f.round_holes and not f.drill_holes for f in ribs)
    # unsniped: every plate keeps its four corners
    assert all(_corners(p.outline) == 4 for p in model.parts if p.kind in ("rib", "stiffener"))


# --------------------------------------------------------------------------------------------
# flat bar
# --------------------------------------------------------------------------------------------
def test_straight_ribs_are_sawn_from_flat_bar(developed):
    from fabpanel.flat.flatbar import bar_size, bars_needed
    from fabpanel.flat.nest import nest

    job = Job.from_dict({"cutting": {"flat_bar": True}})
    model = build(developed, job, jobs=1)
    flat = cut(model, job, jobs=1)
    sawn = [f for f in flat.parts if f.stock_form == "flat-bar"]
    # the straight ribs along the cylinder's axis (ribs 1 and 3 here, sniped: coped after
    # sawing) are 150 x 8 flat bar; the arched ribs across it stay plate parts
    straight = [f for f in flat.parts if f.kind == "rib" and np.ptp(f.outline[:, 1]) < 151]
    assert {f.id for f in sawn} == {f.id for f in straight} and len(sawn) == 8
    for part in sawn:
        width, length = bar_size(part)
        assert width == pytest.approx(150.0, abs=0.2)
        assert length == pytest.approx(np.ptp(part.outline[:, 0]), abs=1e-6)
    arched = [f for f in flat.parts if f.kind == "rib" and f.stock_form == "plate"]
    assert len(arched) == 8 and all(bar_size(f) is None for f in arched)
    nests = nest(flat, job)
    placed = {pl.part_id for plate in nests.plates for pl in plate.placements}
    assert not placed & {f.id for f in sawn}
    assert nests.metrics["parts_left_out"] == 0
    (bars,) = nests.metrics["flat_bars"]
    assert bars["pieces"] == len(sawn) and bars["width_mm"] == pytest.approx(150.0, abs=0.2)
    lengths = [bar_size(f)[1] for f in sawn]
    assert bars["bars"] == bars_needed(lengths, 6000.0, 3.0)
    assert bars["bought_kg"] >= bars["net_kg"] > 0
    # first fit decreasing: a 3 m and a 2.9 m piece share a 6 m bar with a 3 mm kerf, two 3 m
    # pieces do not (the cut between them eats 3 mm)
    assert bars_needed([2900.0] * 5 + [3000.0] * 5, 6000.0, 3.0) == 5
    assert bars_needed([3000.0] * 10, 6000.0, 3.0) == 10
    assert bars_needed([3000.0] * 10, 6000.0, 0.0) == 5
