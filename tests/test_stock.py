"""Several stock sizes in one nest, and the stock suggestion: sheets sized like the demo's
(1256 x 1200 and 1208 x 1200 mm) nest two to a 3000 x 1500 plate but a pair to 2500 x 1250."""

from __future__ import annotations

import numpy as np
import pytest
from test_nest import flat_part, rectangle

from fabpanel.data import FlatParts
from fabpanel.flat import nest, validate_nests
from fabpanel.flat.stock import STANDARD_WIDTHS, stock_toml, suggest_stock
from fabpanel.job import Job


def sheets(count: int = 6) -> FlatParts:
    parts = [flat_part(f"P{i:03d}-TOP", rectangle(1256.0, 1200.0)) for i in range(count)]
    parts += [flat_part(f"P{i:03d}-BOT", rectangle(1208.0, 1200.0)) for i in range(count)]
    return FlatParts(parts=tuple(parts))


def job(stock=None, **cutting):
    section = {"nest_time": "0 s", **cutting}
    if stock is not None:
        section["stock"] = stock
    return Job.from_dict({"cutting": section})


def kg(plates, thickness=3.0):
    return sum(p.size[0] * p.size[1] for p in plates) * thickness * 7.85e-6


def test_the_nest_takes_the_stock_size_that_buys_least():
    flat = sheets()
    wide, narrow = (
        {"length": "3000 mm", "width": "1500 mm"},
        {"length": "2500 mm", "width": "1250 mm"},
    )
    j = job([wide, narrow])
    nests = nest(flat, j)
    assert validate_nests(nests, flat, j) == []
    assert {p.size for p in nests.plates} == {(2500.0, 1250.0)}
    assert len(nests.plates) == 6  # a top and a bottom sheet on each
    # against the single 3000 x 1500 plate: the same plate count, 31 % less steel
    alone = nest(flat, job([wide]))
    assert len(alone.plates) == 6
    assert kg(nests.plates) < 0.7 * kg(alone.plates)
    np.testing.assert_allclose(nests.metrics["bought_kg"], kg(nests.plates), atol=0.01)
    group = nests.metrics["groups"][0]
    assert group["plates_by_size"] == {"2500 x 1250": 6}
    assert group["utilisation_min_but_last"] > 0.9


def test_a_limited_stock_is_used_up_before_the_next_size():
    flat = sheets()
    j = job(
        [
            {"length": "2500 mm", "width": "1250 mm", "count": 2},
            {"length": "3000 mm", "width": "1500 mm"},
        ]
    )
    nests = nest(flat, j)
    assert validate_nests(nests, flat, j) == []
    sizes = [p.size for p in nests.plates]
    assert sizes.count((2500.0, 1250.0)) == 2
    assert nests.metrics["parts_placed"] == len(flat.parts)


def test_parts_without_a_plate_left_are_errors():
    flat = sheets(3)
    j = job([{"length": "2500 mm", "width": "1250 mm", "count": 2}])
    nests = nest(flat, j)
    stranded = [i for i in nests.issues if i.code == "stock-exhausted"]
    assert len(stranded) == 2 and all(i.severity == "error" for i in stranded)
    assert validate_nests(nests, flat, j) == [
        f"{i.item} is placed 0 times, expected 1" for i in stranded
    ]


def test_the_last_plate_moves_to_a_smaller_size_when_that_costs_less():
    # five sheets: two 2500 x 1250 plates of pairs and one sheet alone, which a 1500 x 1250
    # plate holds for less
    parts = [flat_part(f"P{i:03d}-TOP", rectangle(1200.0, 1200.0)) for i in range(5)]
    flat = FlatParts(parts=tuple(parts))
    j = job([{"length": "2500 mm", "width": "1250 mm"}, {"length": "1500 mm", "width": "1250 mm"}])
    nests = nest(flat, j)
    assert validate_nests(nests, flat, j) == []
    assert sorted(p.size for p in nests.plates) == [(1500.0, 1250.0)] + [(2500.0, 1250.0)] * 2


def test_prices_must_be_given_for_all_stock_or_none():
    with pytest.raises(Exception, match="price all of them"):
        job(
            [
                {"length": "2500 mm", "width": "1250 mm", "price_per_kg": 1.1},
                {"length": "3000 mm", "width": "1500 mm"},
            ]
        )


def test_the_suggestion_buys_less_than_the_job_plate_and_pastes_back():
    flat = sheets()
    j = job()
    suggestion = suggest_stock(flat, j)
    assert len(suggestion) == 1
    best = suggestion[0]
    assert best["width_mm"] in STANDARD_WIDTHS
    now = nest(flat, j).metrics
    assert best["bought_kg"] < now["bought_kg"]
    assert best["bought_to_net"] < 1.15
    np.testing.assert_allclose(best["net_kg"], now["net_kg"], rtol=1e-3)
    # the suggestion as job text gives a nest that buys what it said
    text = stock_toml(suggestion)
    import tomllib

    stock = tomllib.loads(text)["cutting"]["stock"]
    again = nest(flat, job(stock))
    np.testing.assert_allclose(again.metrics["bought_kg"], best["bought_kg"], rtol=1e-3)


def test_a_length_cut_from_coil_is_suggested_where_no_format_fits_well():
    """2700 x 1100 mm sheets take one standard 3000 x 1250 plate each (1.26 x net); cut to
    2750 mm from a 1250 mm coil they buy 1.16 x, and 25 mm plates (thicker than coil) do not
    get coil lengths."""
    parts = tuple(flat_part(f"P{i:03d}-TOP", rectangle(2700.0, 1100.0)) for i in range(4))
    suggestion = suggest_stock(FlatParts(parts=parts), job(), jobs=1)
    (best,) = suggestion
    # 2750 mm, or 5500 mm holding two (the same steel, fewer plates)
    assert best["from_coil"] and best["width_mm"] == 1250.0
    assert best["plates"] * best["length_mm"] == 4 * 2750.0
    assert best["bought_to_net"] == pytest.approx(2750 * 1250 / (2700 * 1100), abs=1e-3)
    assert "# cut to length from coil" in stock_toml(suggestion)
    thick = tuple(flat_part(f"P{i:03d}-TOP", rectangle(2700.0, 1100.0), 25.0) for i in range(4))
    (plate,) = suggest_stock(FlatParts(parts=thick), job(), jobs=1)
    assert not plate["from_coil"]


def test_the_jobs_own_nest_stands_in_for_its_candidate_only_where_it_is_the_same_nest(
    monkeypatch,
):
    """With one unlimited stock size and no time budget, the job's nest is the candidate's
    nest: it is not run again, and the suggestion is the same as without it."""
    import fabpanel.flat.stock as stock_module

    flat, j = sheets(), job()
    plain = suggest_stock(flat, j, jobs=1)
    asked = []
    real = stock_module._plates_on
    monkeypatch.setattr(
        stock_module,
        "_plates_on",
        lambda items, jb, s, *scale: asked.append(s) or real(items, jb, s, *scale),
    )
    assert suggest_stock(flat, j, jobs=1, nests=nest(flat, j)) == plain
    assert (3000.0, 1500.0) not in {(s.length, s.width) for s in asked}
    # a time budget makes the job's nest another computation: every candidate runs
    asked.clear()
    timed = job(nest_time="1 s")
    suggest_stock(flat, timed, jobs=1, nests=nest(flat, j))
    assert (3000.0, 1500.0) in {(s.length, s.width) for s in asked}


def test_a_large_group_is_ranked_on_a_sample_and_its_choice_nested_in_full(monkeypatch):
    """Above ``SAMPLE_PARTS`` parts the candidates are ranked on every k-th part, and only the
    best of them and the job's own stock are nested with the whole group: the plates reported
    are the whole group's real nest on the suggested size, and never more steel than the
    job's own stock buys."""
    import fabpanel.flat.stock as stock_module

    flat, j = sheets(12), job()  # 24 sheets, ranked on 6
    monkeypatch.setattr(stock_module, "SAMPLE_PARTS", 6)
    whole = []
    real = stock_module._plates_on

    def counting(items, jb, s, *scale):
        if len(items) == 24:
            whole.append((s.length, s.width))
        return real(items, jb, s, *scale)

    monkeypatch.setattr(stock_module, "_plates_on", counting)
    (best,) = suggest_stock(flat, j, jobs=1)
    assert best["ranked_on_parts"] == 6
    assert (3000.0, 1500.0) in whole and len(whole) <= 2  # the best and the job's own
    size = {"length": f"{best['length_mm']:g} mm", "width": f"{best['width_mm']:g} mm",
            "thickness": "3 mm"}  # fmt: skip
    again = nest(flat, job([size]))
    assert len(again.plates) == best["plates"]
    np.testing.assert_allclose(again.metrics["bought_kg"], best["bought_kg"], rtol=1e-3)
    assert best["bought_kg"] <= nest(flat, j).metrics["bought_kg"] + 1e-6


def test_a_large_group_is_ranked_by_the_boxes_of_a_sample(monkeypatch):
    """Above ``BOX_SAMPLE_PARTS`` parts the bounding-box ranking packs every k-th part (its
    time grows with the square of the parts), scaled to the group by area with the last plate
    counted by its fill: close to the whole group's box count. A size too short for one part
    left out of the sample is still refused."""
    import fabpanel.flat.stock as stock_module
    from fabpanel.flat.nest import nest_groups, on_stock, usable
    from fabpanel.flat.packing import box_plates

    parts = [
        flat_part(f"P{i:03d}-R", rectangle(900.0 + 7 * (i % 60), 140.0 + i % 50))
        for i in range(240)
    ]
    parts.insert(1, flat_part("P999-LONG", rectangle(2300.0, 150.0)))  # the second: not sampled
    flat, j = FlatParts(parts=tuple(parts)), job()
    (items,) = nest_groups(flat, j)[0].values()
    packed = []
    real = stock_module._box_counts
    monkeypatch.setattr(
        stock_module,
        "_box_counts",
        lambda its, *rest: packed.append(len(its)) or real(its, *rest),
    )
    monkeypatch.setattr(stock_module, "BOX_SAMPLE_PARTS", 81)
    ranked = stock_module._box_ranked(items, j, 3.0 * 7.85e-6)
    assert set(packed) == {81}  # every third part
    sizes = {(s.length, s.width): kg for kg, s in ranked}
    # the 2300 mm part is not in the sample, and the 2000 x 1000 format is refused for it
    assert "P999-LONG" not in {it.part.id for it in items[::3]}
    assert (2000.0, 1000.0) not in sizes and (2500.0, 1250.0) in sizes
    # the sample's estimate against the whole group's box count, on the job's own stock
    stock = j.cutting.stock_for(3.0)[0]
    turns = {r % 180 for r in j.cutting.rotations} == {0, 90}
    whole = len(box_plates(on_stock(items, j, stock), *usable(j, stock), turns))
    estimate = sizes[(stock.length, stock.width)] / (stock.length * stock.width * 3.0 * 7.85e-6)
    assert abs(estimate - whole) <= 0.1 * whole, (estimate, whole)


def test_the_sizes_holding_every_part_are_those_the_nest_would_take():
    """The vectorised fit of every part (rotations, 0.1 mm rounding, strictly inside) agrees
    with the nest's own per-part check on every candidate size."""
    import fabpanel.flat.stock as stock_module
    from fabpanel.flat.nest import nest_groups, on_stock

    parts = [
        flat_part(f"P{i:03d}-S", rectangle(1000.0 + 60 * i, 400.0 + 50 * i)) for i in range(30)
    ]
    j = job(rotations=[0])
    for jb in (j, job()):
        (items,) = nest_groups(FlatParts(parts=tuple(parts)), jb)[0].values()
        sizes = stock_module.candidate_sizes(jb, 3.0)
        expected = [s for s in sizes if len(on_stock(items, jb, s)) == len(items)]
        assert stock_module._holding_every_part(items, jb, sizes) == expected
        assert 0 < len(expected) < len(sizes)
