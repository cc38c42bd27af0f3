"""Nesting flat parts on plates with spyrrow, checked with exact polygon tests."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.data import FlatPart, FlatParts, Hole
from fabpanel.flat import audit_dxf, nest, validate_nests, write_nests
from fabpanel.flat.nest import bounding_box_plates
from fabpanel.job import Job

JOB = Job.from_dict(
    {"cutting": {"nest_time": "0 s", "plate_length": "2000 mm", "plate_width": "1000 mm"}}
)


def rectangle(w, h):
    return np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)


def l_shape(w, h, t):
    return np.array([[0, 0], [w, 0], [w, t], [t, t], [t, h], [0, h]], dtype=float)


def flat_part(pid, outline, thickness=3.0, holes=()):
    return FlatPart(
        id=pid,
        kind="rib",
        panel_id=pid[:4],
        material="S235",
        thickness=thickness,
        outline=outline,
        round_holes=holes,
        labels=((pid, *outline.mean(axis=0).tolist(), 10.0, 0.0),),
    )


def mixed_parts() -> FlatParts:
    rng = np.random.default_rng(7)
    parts = []
    for i in range(8):
        w, h = rng.uniform(300, 700), rng.uniform(200, 500)
        parts.append(
            flat_part(f"P{i:03d}-REC", rectangle(w, h), holes=(Hole((w / 2, h / 2), 40.0),))
        )
    for i in range(6):
        parts.append(
            flat_part(f"P{i:03d}-L", l_shape(rng.uniform(300, 600), rng.uniform(300, 600), 120.0))
        )
    for i in range(6):
        parts.append(flat_part(f"P{i:03d}-STR", rectangle(rng.uniform(900, 1600), 150.0)))
    return FlatParts(parts=tuple(parts))


@pytest.fixture(scope="module")
def mixed():
    flat = mixed_parts()
    return flat, nest(flat, JOB)


def test_nest_is_valid_over_several_plates(mixed):
    flat, nests = mixed
    assert validate_nests(nests, flat, JOB) == []
    assert len(nests.plates) >= 2
    placed = [pl.part_id for plate in nests.plates for pl in plate.placements]
    assert sorted(placed) == sorted(p.id for p in flat.parts)
    m = nests.metrics
    assert m["plates_lower_bound"] <= m["plates"] <= m["bounding_box_plates"]
    # steel bought (whole 2000 x 1000 x 3 mm plates) against steel in the parts
    density = JOB.material.density
    assert m["bought_kg"] == pytest.approx(m["plates"] * 2000 * 1000 * 3.0 * density, abs=0.01)
    net = sum(p.area for p in flat.parts) * 3.0 * density
    assert m["net_kg"] == pytest.approx(net, abs=0.01)
    assert m["net_kg"] / m["bought_kg"] == pytest.approx(m["utilisation"], rel=1e-3)
    assert m["bought_to_net"] == pytest.approx(m["bought_kg"] / m["net_kg"], abs=1e-3)
    assert m["bounding_box_plates"] == sum(bounding_box_plates(flat, JOB).values())
    assert 0 < m["utilisation"] <= 1
    assert m["pierces"] == 20 + 8
    assert m["cut_length_mm"] > 0


def test_validate_nests_catches_overlap(mixed):
    flat, nests = mixed
    plate = nests.plates[0]
    moved = list(plate.placements)
    moved[1] = type(moved[1])(moved[1].part_id, moved[0].transform)
    broken = type(nests)(
        plates=(
            type(plate)(
                plate.index,
                plate.material,
                plate.thickness,
                plate.size,
                tuple(moved),
                plate.utilisation,
            ),
            *nests.plates[1:],
        )
    )
    assert any("apart" in e for e in validate_nests(broken, flat, JOB))


def test_oversize_part_is_an_issue():
    flat = FlatParts(
        parts=(
            flat_part("P900-BIG", rectangle(2500, 1200)),
            flat_part("P901-OK", rectangle(500, 400)),
        )
    )
    nests = nest(flat, JOB)
    assert [(i.code, i.item) for i in nests.issues] == [("part-too-large", "P900-BIG")]
    assert "P900-BIG" in nests.issues[0].message
    assert validate_nests(nests, flat, JOB) == []
    assert [pl.part_id for plate in nests.plates for pl in plate.placements] == ["P901-OK"]


def test_a_part_too_wide_along_its_first_side_is_nested_turned_to_its_narrowest():
    """A skewed sheet whose box along its first side fits no plate in any quarter turn is
    turned to its narrowest bounding rectangle (an 1800 x 800 mm plate drawn at 30 degrees:
    1959 x 1593 mm along its side, on a 2000 x 1000 mm plate); a part wider than the plate
    at its narrowest is still refused, and says how narrow it gets. Where the job keeps the
    parts' direction on the plate (no quarter turns), no part is turned."""
    angle = np.radians(30.0)
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    skewed = rectangle(1800, 800) @ turn.T
    flat = FlatParts(
        parts=(
            flat_part("P903-SKEW", skewed),
            flat_part("P904-OK", rectangle(500, 400)),
            flat_part("P905-WIDE", rectangle(1800, 1100) @ turn.T),
        )
    )
    nests = nest(flat, JOB)
    assert [(i.code, i.item) for i in nests.issues] == [("part-too-large", "P905-WIDE")]
    assert "1800 x 1100 mm at its narrowest" in nests.issues[0].message
    assert validate_nests(nests, flat, JOB) == []
    (placed,) = [
        pl for plate in nests.plates for pl in plate.placements if pl.part_id == "P903-SKEW"
    ]
    t = np.asarray(placed.transform)
    on_plate = skewed @ t[:2, :2].T + t[:2, 2]
    assert on_plate.min() >= 0 and on_plate[:, 0].max() <= 2000 and on_plate[:, 1].max() <= 1000
    # its long side lies along or across the plate
    side = on_plate[1] - on_plate[0]
    assert min(abs(side[0]), abs(side[1])) == pytest.approx(0.0, abs=1e-6)
    kept = nest(flat, JOB.replace(cutting={"rotations": [0, 180]}))
    assert {i.item for i in kept.issues} == {"P903-SKEW", "P905-WIDE"}


def test_rotation_needed_to_fit():
    job = JOB.replace(cutting={"rotations": [0]})
    flat = FlatParts(parts=(flat_part("P902-TALL", rectangle(300, 1500)),))
    assert [i.code for i in nest(flat, job).issues] == ["part-too-large"]
    rotated = nest(flat, JOB)
    assert not rotated.issues and validate_nests(rotated, flat, JOB) == []


def test_groups_by_thickness():
    flat = FlatParts(
        parts=(
            flat_part("P001-A", rectangle(400, 300), 3.0),
            flat_part("P001-B", rectangle(400, 300), 8.0),
        )
    )
    nests = nest(flat, JOB)
    assert sorted(p.thickness for p in nests.plates) == [3.0, 8.0]
    assert validate_nests(nests, flat, JOB) == []


def test_same_seed_same_placements(mixed):
    flat, first = mixed
    second = nest(flat, JOB)
    assert [[pl.part_id for pl in p.placements] for p in first.plates] == [
        [pl.part_id for pl in p.placements] for p in second.plates
    ]
    for a, b in zip(first.plates, second.plates):
        for pa, pb in zip(a.placements, b.placements):
            np.testing.assert_allclose(pa.transform, pb.transform, atol=1e-9)


def test_write_nests(mixed, tmp_path):
    flat, nests = mixed
    files = write_nests(nests, flat, tmp_path)
    assert set(files) == {p.name for p in nests.plates}
    for dxf, png in files.values():
        assert audit_dxf(tmp_path / dxf) == []
        assert (tmp_path / png).stat().st_size > 1000
    import ezdxf

    from fabpanel.flat.dxf import exploded

    doc = ezdxf.readfile(tmp_path / files["plate-001"][0])
    msp = doc.modelspace()
    # the plate outline on a layer never cut or plotted, then one INSERT per part
    assert next(e.dxf.layer for e in msp) == "PLATE" and doc.layers.get("PLATE").dxf.plot == 0
    inserts = msp.query("INSERT")
    assert len(inserts) == len(nests.plates[0].placements)
    assert {i.dxf.name for i in inserts} <= {p.mark or p.id for p in flat.parts}
    # the header's extents are the plate (its outline is the outermost entity)
    np.testing.assert_allclose(doc.header["$EXTMIN"][:2], [0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(doc.header["$EXTMAX"][:2], nests.plates[0].size, atol=1e-6)
    # cut order: per part, etching, then its holes before its outer contour: every inner contour
    # lies inside the next outer contour in the file
    from shapely.geometry import Point, Polygon

    entities = exploded(msp)
    cuts = [e for e in entities if e.dxf.layer.startswith("CUT")]
    for index, entity in enumerate(cuts):
        if entity.dxf.layer != "CUT-INNER":
            continue
        centre = (
            entity.dxf.center
            if entity.dxftype() == "CIRCLE"
            else np.mean([p[:2] for p in entity.get_points()], axis=0)
        )
        following = next(e for e in cuts[index + 1 :] if e.dxf.layer == "CUT-OUTER")
        outline = Polygon([p[:2] for p in following.get_points()])
        assert outline.contains(Point(centre[0], centre[1]))
    for insert in inserts:
        inside = [e.dxf.layer for e in insert.virtual_entities()]
        assert max(i for i, x in enumerate(inside) if x == "ETCH") < inside.index("CUT-OUTER")


def test_plate_files_hold_the_parts_at_their_spacing(mixed, tmp_path):
    """Read back from the plate DXFs alone: every part once, inside the plate margin, at least
    the part spacing apart, with the same net area as its own part DXF."""
    import ezdxf
    from ezdxf.path import make_path
    from shapely.geometry import Polygon, box

    from fabpanel.flat import part_area_from_dxf, write_parts
    from fabpanel.flat.dxf import exploded

    flat, nests = mixed
    part_files = write_parts(flat, tmp_path / "parts")
    part_area = sum(part_area_from_dxf(tmp_path / "parts" / name) for name in part_files.values())
    plate_files = write_nests(nests, flat, tmp_path / "nests")
    cutting = JOB.cutting
    contours, net = 0, 0.0
    for plate in nests.plates:
        path = tmp_path / "nests" / plate_files[plate.name][0]
        outers = [
            Polygon([(v.x, v.y) for v in make_path(e).flattening(0.01)])
            for e in exploded(ezdxf.readfile(path).modelspace())
            if e.dxftype() == "LWPOLYLINE" and e.dxf.layer == "CUT-OUTER"
        ]
        assert len(outers) == len(plate.placements)
        usable = box(
            cutting.plate_margin,
            cutting.plate_margin,
            cutting.plate_length - cutting.plate_margin,
            cutting.plate_width - cutting.plate_margin,
        ).buffer(0.05)
        assert all(usable.contains(p) for p in outers)
        for i, a in enumerate(outers):
            for b in outers[i + 1 :]:
                assert a.distance(b) >= cutting.part_spacing - 0.05
        contours += len(outers)
        net += part_area_from_dxf(path)
    assert contours == len(flat.parts)
    assert net == pytest.approx(part_area, rel=1e-9)


def test_quarter_turns_only_and_parts_as_high_as_the_plate():
    flat = FlatParts(
        parts=(flat_part("P001-A", rectangle(800, 300)), flat_part("P002-B", rectangle(600, 200)))
    )
    turned = Job.from_dict(
        {**JOB.to_dict(), "cutting": {**JOB.to_dict()["cutting"], "rotations": [90, 270]}}
    )
    nests = nest(flat, turned)
    assert validate_nests(nests, flat, turned) == [] and not nests.issues
    # a part whose grown shape is exactly as high as the usable plate is refused, not crashed
    tall = FlatParts(parts=(flat_part("P003-C", rectangle(1500, 969.0)),))
    result = nest(tall, JOB)
    assert validate_nests(result, tall, JOB) == []


def test_long_parts_in_rows_leave_their_tail_to_the_small_ones():
    """27 ribs 1190 x 150 and 18 blocks 180 x 140 fill one 4000 x 1500 plate exactly as rows of
    three ribs (3600 mm) and two columns of blocks in the 380 mm left behind them (89 % of the
    usable area); spyrrow's own pack of the ribs staggers them past 3.9 m and needs a second
    plate."""
    ribs = [flat_part(f"P{i:03d}-RIB-0", rectangle(1190.0, 150.0), 8.0) for i in range(27)]
    blocks = [flat_part(f"P{i:03d}-STF-0", rectangle(180.0, 140.0), 8.0) for i in range(18)]
    flat = FlatParts(parts=tuple(ribs + blocks))
    job = Job.from_dict(
        {"cutting": {"plate_length": "4000 mm", "plate_width": "1500 mm", "nest_time": "0 s"}}
    )
    nests = nest(flat, job)
    assert len(nests.plates) == 1 and len(nests.plates[0].placements) == 45
    assert validate_nests(nests, flat, job) == []


def test_plate_files_take_the_part_files_fits_and_fit_nothing_again(mixed, tmp_path, monkeypatch):
    """The write stage hands each plate writer the arcs its parts' DXFs were fitted with: the
    plate files come out byte for byte as when each contour is fitted on the spot, and no
    contour of a handed-over part is fitted again."""
    from fabpanel.flat import dxf

    flat, nests = mixed
    fresh = write_nests(nests, flat, tmp_path / "fresh")
    dxf._fitted.clear()
    arcs = dxf.contour_arcs(flat.parts)
    dxf._fitted.clear()

    def no_fit(points):
        raise AssertionError(f"a contour of {len(points)} points fitted again")

    monkeypatch.setattr(dxf, "fit_arcs", no_fit)
    with dxf.given_arcs(arcs):
        given = write_nests(nests, flat, tmp_path / "given")
    assert not dxf._given  # handed over for the block only
    assert given == fresh
    for dxf_name, _png in fresh.values():
        assert (tmp_path / "given" / dxf_name).read_bytes() == (
            tmp_path / "fresh" / dxf_name
        ).read_bytes()


def test_a_part_as_long_as_the_plate_is_wide_is_not_turned_by_the_box_assignment():
    """A part exactly as long as the plate's usable width may not lie across the plate (the
    nest keeps shapes strictly inside), though rectpack's integer plate takes its turned box:
    its box is grown along the plate so that rectpack cannot turn it."""
    from fabpanel.flat.packing import Item, box_plates, fitting_rotations

    length, height = 2490.1, 1240.1
    shape = rectangle(1240.1, 198.1)
    rotations = fitting_rotations(shape, [0, 90, 180, 270], length, height)
    assert rotations == (0, 180)
    items = [Item(flat_part(f"P{i:03d}-R", shape), shape, rotations) for i in range(14)]
    plates = box_plates(items, length, height, True)
    for plate in plates:
        for item, t in zip(plate.items, plate.transforms):
            corners = item.shape @ t[:2, :2].T + t[:2, 2]
            assert np.ptp(corners[:, 0]) == pytest.approx(1240.1)  # along the plate
            assert corners.min() >= 0 and corners[:, 0].max() <= length
            assert corners[:, 1].max() <= height
    assert sum(len(p.items) for p in plates) == 14
    assert len(plates) == 2  # two rows of six along the plate, and two more


def test_a_large_box_assignment_is_packed_in_runs_of_the_largest_boxes_first(monkeypatch):
    """Past ``BOX_CHUNK`` items the boxes are packed in runs (rectpack's best-fit time grows
    with the square of the parts): every item is placed once, inside its plate, no two boxes
    overlap, the runs go largest first, and each run costs at most one plate more."""
    import shapely

    from fabpanel.flat import packing

    rng = np.random.default_rng(3)
    sizes = np.column_stack([rng.uniform(200, 1200, 90), rng.uniform(100, 700, 90)])
    items = [
        packing.Item(flat_part(f"P{i:03d}-R", rectangle(*s)), rectangle(*s), (0, 90, 180, 270))
        for i, s in enumerate(sizes)
    ]
    whole = packing.box_plates(items, 2000.0, 1000.0, True)
    monkeypatch.setattr(packing, "BOX_CHUNK", 30)
    runs = packing.box_plates(items, 2000.0, 1000.0, True)
    assert len(whole) <= len(runs) <= len(whole) + 2
    placed = [id(it) for p in runs for it in p.items]
    assert sorted(placed) == sorted(id(it) for it in items)
    for plate in runs:
        boxes = [
            shapely.box(*(c := it.shape @ t[:2, :2].T + t[:2, 2]).min(axis=0), *c.max(axis=0))
            for it, t in zip(plate.items, plate.transforms)
        ]
        assert all(b.bounds[0] >= 0 and b.bounds[1] >= 0 for b in boxes)
        assert all(b.bounds[2] <= 2000.0 and b.bounds[3] <= 1000.0 for b in boxes)
        assert shapely.union_all(boxes).area == pytest.approx(sum(b.area for b in boxes))
    # the first plate holds boxes of the first run: the 30 largest
    largest = sorted(items, key=lambda it: -it.area)[:30]
    assert {id(it) for it in runs[0].items} <= {id(it) for it in largest}
