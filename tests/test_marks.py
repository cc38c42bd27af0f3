"""Part marks: flat parts equal within 0.1 mm share a mark, one DXF and a quantity; the nest
packs a mark's parts as one item with a quantity."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fabpanel.data import FlatPart, FlatParts, Hole
from fabpanel.flat import nest, validate_nests, write_parts
from fabpanel.flat.marks import mark_groups, rigid_match
from fabpanel.flat.unroll import labelled
from fabpanel.job import Job

JOB = Job.from_dict(
    {"cutting": {"nest_time": "0 s", "plate_length": "2000 mm", "plate_width": "1000 mm"}}
)
#: a gusset with a notch, two bolt holes and a slot: no symmetry, so one rotation fits
GUSSET = np.array(
    [[0, 0], [420, 0], [420, 90], [300, 90], [300, 150], [60, 260], [0, 260]], dtype=float
)
HOLES = (Hole((60.0, 45.0), 13.0), Hole((360.0, 45.0), 13.0), Hole((60.0, 200.0), 22.0))
SLOT = np.array([[120, 40], [200, 40], [200, 60], [120, 60]], dtype=float)


def _moved(points: np.ndarray, degrees: float, shift) -> np.ndarray:
    a = np.radians(degrees)
    rotation = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return points @ rotation.T + np.asarray(shift, dtype=float)


def gusset(pid: str, degrees: float = 0.0, shift=(0.0, 0.0), **changes) -> FlatPart:
    """The gusset in a frame turned by ``degrees`` and shifted, as another panel's copy of it
    lies in its own flat frame."""
    holes = tuple(
        Hole(tuple(_moved(np.array([h.centre]), degrees, shift)[0]), h.diameter) for h in HOLES
    )
    part = FlatPart(
        id=pid,
        kind="stiffener",
        panel_id=pid[:4],
        material="S355",
        thickness=8.0,
        outline=_moved(GUSSET, degrees, shift),
        holes=(_moved(SLOT, degrees, shift)[::-1],),
        round_holes=holes,
        face="IN",
    )
    return dataclasses.replace(part, **changes)


def test_a_turned_and_shifted_copy_matches_with_the_transform_between_them():
    a, b = gusset("P001-STF-1"), gusset("P002-STF-3", 137.0, (2500.0, -800.0))
    transform = rigid_match(a, b)
    assert transform is not None
    moved = a.outline @ transform[:2, :2].T + transform[:2, 2]
    np.testing.assert_allclose(moved, b.outline, atol=1e-9)
    assert np.linalg.det(transform[:2, :2]) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "change, equal",
    [
        ("vertex moved 0.05 mm", True),
        ("vertex moved 0.3 mm", False),
        ("mirror image", False),
        ("hole moved 0.3 mm", False),
        ("hole 0.5 mm larger", False),
        ("slot moved 0.3 mm", False),
        ("other face etched", False),
        ("other thickness", False),
    ],
)
def test_parts_differing_by_more_than_a_tenth_of_a_millimetre_do_not_match(change, equal):
    a = gusset("P001-STF-1")
    b = gusset("P002-STF-1", 63.0, (900.0, 400.0))
    if change.startswith("vertex moved"):
        outline = b.outline.copy()
        outline[4] += [float(change.split()[2]), 0.0]
        b = dataclasses.replace(b, outline=outline)
    elif change == "mirror image":
        b = dataclasses.replace(
            b,
            outline=(b.outline * [-1, 1])[::-1],
            holes=tuple(h * [-1, 1] for h in b.holes),
            round_holes=tuple(Hole((-h.centre[0], h.centre[1]), h.diameter) for h in b.round_holes),
        )
    elif change == "hole moved 0.3 mm":
        first = b.round_holes[0]
        b = dataclasses.replace(
            b,
            round_holes=(Hole((first.centre[0] + 0.3, first.centre[1]), 13.0), *b.round_holes[1:]),
        )
    elif change == "hole 0.5 mm larger":
        first = b.round_holes[0]
        b = dataclasses.replace(b, round_holes=(Hole(first.centre, 13.5), *b.round_holes[1:]))
    elif change == "slot moved 0.3 mm":
        b = dataclasses.replace(b, holes=(b.holes[0] + [0.0, 0.3],))
    elif change == "other face etched":
        b = dataclasses.replace(b, face="OUT")
    elif change == "other thickness":
        b = dataclasses.replace(b, thickness=10.0)
    assert (rigid_match(a, b) is not None) is equal


def _catalogue() -> list[FlatPart]:
    parts = [gusset(f"P{i:03d}-STF-1", 40.0 * i, (300.0 * i, 50.0 * i)) for i in range(1, 13)]
    long_rib = FlatPart(
        id="P001-RIB-0",
        kind="rib",
        panel_id="P001",
        material="S355",
        thickness=8.0,
        outline=np.array([[0, 0], [1180, 0], [1180, 150], [0, 150]], dtype=float),
        round_holes=(Hole((60.0, 75.0), 13.0), Hole((1120.0, 75.0), 13.0)),
        face="IN",
    )
    short_rib = dataclasses.replace(
        long_rib, id="P001-RIB-1", outline=long_rib.outline * [0.8, 1.0]
    )
    short_rib = dataclasses.replace(
        short_rib, round_holes=(Hole((60.0, 75.0), 13.0), Hole((884.0, 75.0), 13.0))
    )
    turned_rib = dataclasses.replace(
        long_rib,
        id="P002-RIB-2",
        outline=_moved(long_rib.outline, 180.0, (1180.0, 150.0)),
        round_holes=tuple(
            Hole(tuple(_moved(np.array([h.centre]), 180.0, (1180.0, 150.0))[0]), h.diameter)
            for h in long_rib.round_holes
        ),
    )
    return [*parts[:6], long_rib, *parts[6:], short_rib, turned_rib]


def test_equal_parts_share_a_mark_numbered_per_kind_in_order():
    groups = mark_groups(_catalogue())
    assert [(g.mark, g.quantity) for g in groups] == [("S001", 12), ("R001", 2), ("R002", 1)]
    assert groups[1].part_ids == ("P001-RIB-0", "P002-RIB-2")
    # each transform puts the first part on the other
    parts = {p.id: p for p in _catalogue()}
    for group in groups:
        first = parts[group.part_ids[0]]
        for pid, transform in zip(group.part_ids, group.transforms):
            moved = first.outline @ transform[:2, :2].T + transform[:2, 2]
            np.testing.assert_allclose(moved, parts[pid].outline, atol=1e-6)


def test_marked_parts_are_labelled_with_mark_and_quantity_and_drawn_once(tmp_path):
    parts = _catalogue()
    groups = mark_groups(parts)
    mark_of = {pid: g for g in groups for pid in g.part_ids}
    marked = [
        labelled(dataclasses.replace(p, mark=mark_of[p.id].mark), mark_of[p.id].quantity)
        for p in parts
    ]
    texts = {p.id: [label[0] for label in p.labels] for p in marked}
    assert texts["P003-STF-1"] == ["S001", "12 OFF", "IN"]
    assert texts["P001-RIB-1"] == ["R002", "P001-RIB-1", "IN"]
    files = write_parts(FlatParts(parts=tuple(marked), marks=groups), tmp_path)
    assert sorted({files[p.id] for p in marked}) == ["R001.dxf", "R002.dxf", "S001.dxf"]
    assert sorted(f.name for f in tmp_path.iterdir()) == ["R001.dxf", "R002.dxf", "S001.dxf"]


def test_a_mark_is_nested_as_one_item_with_its_quantity_and_every_copy_placed(monkeypatch):
    import spyrrow

    demands: list[int] = []
    item = spyrrow.Item

    def recording(*args, **kwargs):
        demands.append(kwargs["demand"])
        return item(*args, **kwargs)

    monkeypatch.setattr(spyrrow, "Item", recording)
    parts = _catalogue()
    groups = mark_groups(parts)
    mark_of = {pid: g.mark for g in groups for pid in g.part_ids}
    flat = FlatParts(
        parts=tuple(dataclasses.replace(p, mark=mark_of[p.id]) for p in parts), marks=groups
    )
    nests = nest(flat, JOB)
    assert max(demands) >= 6  # the gussets went to spyrrow as one item with a quantity
    # every copy on a plate, inside it and clear of the others, each in its own frame
    assert validate_nests(nests, flat, JOB) == []
    placed = sorted(pl.part_id for plate in nests.plates for pl in plate.placements)
    assert placed == sorted(p.id for p in parts)


def test_the_signature_filter_groups_exactly_as_matching_every_pair_would():
    """Copies jittered by up to 0.04 mm at every vertex share a mark; copies with one vertex
    moved 0.3 mm, or reshaped, do not: the same groups as comparing each part with every
    group's first part vertex by vertex (the filter only skips pairs that cannot match)."""
    rng = np.random.default_rng(7)
    parts = []
    for i in range(30):
        kind = i % 3
        part = gusset(f"P{i:03d}-STF-1", float(rng.uniform(0, 360)), rng.uniform(-5e3, 5e3, 2))
        outline = part.outline + rng.uniform(-0.028, 0.028, part.outline.shape)
        if kind == 1:
            outline[int(rng.integers(len(outline)))] += [0.3, 0.0]
        elif kind == 2:
            outline[2] += [5.0 * (1 + i % 4), 0.0]
        parts.append(dataclasses.replace(part, outline=outline))
    groups = mark_groups(parts)
    brute: list[list[int]] = []
    for index, part in enumerate(parts):
        for members in brute:
            if rigid_match(parts[members[0]], part) is not None:
                members.append(index)
                break
        else:
            brute.append([index])
    assert [g.part_ids for g in groups] == [tuple(parts[i].id for i in m) for m in brute]
    assert groups[0].quantity == 10  # the ten jittered copies
