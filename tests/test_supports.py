"""Supports named by points and boundary ranges (structure/supports.py, [structure] supports)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from conftest import cylinder_developed

import fabpanel as fp
from fabpanel.errors import GeometryError
from fabpanel.structure.analysis import analyse, shell_of
from fabpanel.structure.supports import support_regions

needs_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) missing")

RADIUS = 4000.0
#: the vault's four corners (x, at 60° and 120° round the x axis): its springing lines are
#: x = 0..2400 at y = +-2000, z = 3464.1
CORNERS = [
    [x, RADIUS * np.cos(t), RADIUS * np.sin(t)]
    for x in (0.0, 2400.0)
    for t in (np.pi / 3, 2 * np.pi / 3)
]


def _job(**structure) -> fp.Job:
    return fp.Job.from_dict({"structure": {"buckling_convergence": False, **structure}})


@pytest.fixture(scope="module")
def model():
    return fp.build(cylinder_developed(radius=RADIUS, length=2400.0, arc=np.pi / 3), _job(), jobs=1)


def test_ranges_along_the_springing_lines_hold_the_same_nodes_as_lowest(model):
    lowest = shell_of(model, _job())
    ranges = [[CORNERS[0], CORNERS[2]], [CORNERS[1], CORNERS[3]]]  # each springing line
    ranged = shell_of(model, _job(supports="ranges", support_ranges=ranges))
    assert len(lowest.supports) > 6
    np.testing.assert_array_equal(np.sort(ranged.supports), np.sort(lowest.supports))
    # one range only: that line's pinned nodes form a hinge, refused
    with pytest.raises(GeometryError, match="on one line"):
        shell_of(model, _job(supports="ranges", support_ranges=ranges[:1]))
    # a range between opposite corners: a springing line and an end arc, round the corner
    bent = shell_of(model, _job(supports="ranges", support_ranges=[[CORNERS[2], CORNERS[1]]]))
    held = bent.nodes[bent.supports]
    assert np.ptp(held[:, 1]) > 3000  # across the end arc from y = 2000 to -2000
    assert np.ptp(held[:, 0]) > 2000  # and along a springing line from x = 0 to 2400


def test_point_supports_hold_the_anchor_nodes_near_each_point_one_support_each(model):
    shell = shell_of(
        model, _job(supports="points", support_points=CORNERS, support_radius="350 mm")
    )
    region, centroids = support_regions(shell)
    assert len(centroids) == 4
    held = shell.nodes[shell.supports]
    for k in range(4):
        near = np.linalg.norm(held[region == k][:, None] - np.array(CORNERS)[None], axis=2)
        assert (near.min(axis=1) <= 350.0).all()
    # every anchor node of the boundary ribs within the radius of a corner is held
    everything = shell_of(model, _job(supports="boundary"))
    pool = everything.nodes[everything.supports]
    within = (np.linalg.norm(pool[:, None] - np.array(CORNERS)[None], axis=2) <= 350.0).any(1)
    assert within.sum() == len(shell.supports)


def test_a_point_off_the_boundary_is_refused_with_its_distance(model):
    crown = [1200.0, 0.0, RADIUS]
    with pytest.raises(GeometryError, match=r"support_points 5 lies \d+ mm from"):
        shell_of(model, _job(supports="points", support_points=[*CORNERS, crown]))


def test_points_or_ranges_without_their_list_are_refused():
    with pytest.raises(fp.InputError, match="needs support_ranges"):
        _job(supports="ranges")


@needs_ccx
def test_four_column_supports_carry_the_load(model, tmp_path):
    job = _job(supports="points", support_points=CORNERS, support_radius="350 mm")
    result = analyse(model, job, folder=tmp_path)
    s = result.summary
    assert s["checks"]["reactions"]
    supports = s["supports"]["reactions"]
    assert [r["support"] for r in supports] == ["R1", "R2", "R3", "R4"]
    weight = -s["load_cases"]["G"]["applied_N"][2] / 1e3
    # symmetric vault on four symmetric columns: a quarter of the weight each
    for r in supports:
        assert r["cases_kN"]["G"][2] == pytest.approx(weight / 4, rel=0.02)


def test_supports_all_to_one_side_of_the_centre_of_mass_are_a_warning():
    """A 12 x 8 m roof held along one short edge is a cantilever: said, with the overhang;
    held along both short edges, or at four corners, it is not."""
    from fabpanel.structure.mesh import Material, patch_model
    from fabpanel.structure.supports import cantilever_issues

    xs, ys = np.linspace(0, 12_000, 13), np.linspace(0, 8_000, 9)
    x, y = np.meshgrid(xs, ys, indexing="ij")
    grid = np.stack([x, y, 500.0 * np.sin(np.pi * x / 12_000)], axis=-1)
    shell, index = patch_model(grid, 3.0, Material())
    one_end = index[0, :][index[0, :] >= 0]
    both_ends = np.r_[one_end, index[-1, :][index[-1, :] >= 0]]
    corners = index[[0, 0, -1, -1], [0, -1, 0, -1]]
    found = cantilever_issues(shell.replace(supports=one_end), "supports")
    assert [i.code for i in found] == ["supports-one-sided"]
    assert found[0].severity == "warning" and "6.0 m away" in found[0].message
    assert not cantilever_issues(shell.replace(supports=both_ends), "supports")
    assert not cantilever_issues(shell.replace(supports=corners), "supports")


def _ridge_roof():
    """A 2 x 2 panel roof on a 2 x 2 m plan whose height rises from 0 at x = 0 to a 1.5 m
    ridge at x = 1 m and falls to 0.3 m at x = 2 m: its lowest edge is one end."""
    from types import SimpleNamespace

    x, y = np.meshgrid([0.0, 1000.0, 2000.0], [0.0, 1000.0, 2000.0], indexing="ij")
    z = np.interp(x, [0.0, 1000.0, 2000.0], [0.0, 1500.0, 300.0])
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    index = np.arange(9).reshape(3, 3)
    quads = np.array(
        [
            [index[i, j], index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]]
            for i in (0, 1)
            for j in (0, 1)
        ]
    )
    layout = fp.data.PanelLayout(vertices, quads, ("P001", "P002", "P003", "P004"), "grid")
    sides = np.argwhere(layout.side_neighbours < 0)
    return SimpleNamespace(layout=layout), sides


def test_lowest_supports_are_raised_until_they_surround_the_centre():
    """Held at its lowest edge alone the roof would be a 2 m cantilever: the band rises to
    the far end's 300 mm, which takes the far edge too and not the sides over the ridge; a
    vault whose springing lines are both lowest keeps its band."""
    from fabpanel.structure.supports import lowest_sides, surrounding_band

    developed, sides = _ridge_roof()
    assert len(lowest_sides(developed, sides, 10.0)) == 2  # the x = 0 edge's two sides
    band = surrounding_band(developed, sides, 10.0)
    assert band == pytest.approx(300.0)
    held = lowest_sides(developed, sides, band)
    corners = developed.layout.vertices[developed.layout.quads[held[:, 0], held[:, 1]]]
    assert len(held) == 4 and set(np.round(corners[:, 0])) == {0.0, 2000.0}
    # already surrounding: unchanged
    level = developed.layout.vertices.copy()
    level[:, 2] = np.where(level[:, 0] == 2000.0, 0.0, level[:, 2])
    from dataclasses import replace
    from types import SimpleNamespace

    flat_ends = SimpleNamespace(layout=replace(developed.layout, vertices=level))
    assert surrounding_band(flat_ends, sides, 10.0) == 10.0
    # the report's assumptions say which band held the shell
    from fabpanel.structure.assumptions import assumptions

    said = [a for a in assumptions(_job(), None, 0, band) if a.startswith("supports:")]
    assert "within 300 mm" in said[0] and "raised" in said[0]
    said = [a for a in assumptions(_job(), None, 0, 10.0) if a.startswith("supports:")]
    assert "within 10 mm" in said[0] and "raised" not in said[0]


def test_a_failed_check_is_an_error_that_names_its_figures():
    """The stage's checks that fail end the run with errors (exit 3) naming the governing
    figure, combination and place; on one-sided supports each says to name them first."""
    from fabpanel.structure.checks import failed_check_issues

    summary = {
        "deflection": {
            "max_mm": 41.2,
            "ratio": "L/146",
            "combination": "G+S",
            "panel": "P007",
            "limit_mm": 20.0,
            "span_mm": 6000.0,
            "ok": False,
        },
        "stress": {
            "max_von_mises_MPa": 120.0,
            "fy_MPa": 235.0,
            "utilisation": 0.51,
            "combination": "1.35G+1.5S",
            "part": "P007-TOP",
            "ok": True,
        },
        "buckling": {
            "checked": 4.2,
            "combination": "1.35G+1.5S",
            "required": 6.0,
            "modes": [{"mode": 1, "factor": 4.3, "panels": ["P008"]}],
            "ok": False,
        },
        "checks": {"deflection": False, "stress": True, "buckling": False},
    }
    found = failed_check_issues(summary, one_sided=False)
    assert [(i.code, i.severity) for i in found] == [
        ("structure-deflection", "error"),
        ("structure-buckling", "error"),
    ]
    assert "41.2 mm" in found[0].message and "P007" in found[0].message
    assert "4.2" in found[1].message and "6 required" in found[1].message
    assert found[1].item == "P008" and "lies in P008" in found[1].message
    assert all("supports" in i.message for i in failed_check_issues(summary, one_sided=True))
    summary["deflection"]["ok"] = summary["buckling"]["ok"] = True
    assert failed_check_issues(summary, one_sided=False) == []


def test_fixed_supports_clamp_the_whole_base_rib(model):
    """``support_fixity = "fixed"`` holds every node of the springing ribs (their sheet
    nodes too: two rows of anchor bolts clamp the base plate), ``"pinned"`` only the anchor
    line between the sheets; the same two supports either way."""
    pinned = shell_of(model, _job())
    fixed = shell_of(model, _job(support_fixity="fixed"))
    assert set(pinned.supports) < set(fixed.supports)
    assert len(fixed.supports) > 2 * len(pinned.supports)
    assert len(support_regions(pinned)[1]) == len(support_regions(fixed)[1]) == 2
    # the pinned line lies between the sheets; the fixed base rib spans their depth
    depth = lambda shell: np.ptp(np.linalg.norm(shell.nodes[shell.supports][:, 1:], axis=1))
    assert depth(fixed) > 100.0 > depth(pinned)


@needs_ccx
def test_fixed_supports_stiffen_the_vault(model, tmp_path):
    pinned = analyse(model, _job(), folder=tmp_path / "pinned").summary
    fixed = analyse(model, _job(support_fixity="fixed"), folder=tmp_path / "fixed").summary
    assert fixed["supports"]["fixity"] == "fixed" and pinned["supports"]["fixity"] == "pinned"
    assert fixed["deflection"]["max_mm"] < pinned["deflection"]["max_mm"]
    for summary in (pinned, fixed):
        assert all(case["ok"] for case in summary["load_cases"].values())


def test_lowest_is_read_on_the_design_not_on_the_developed_sheets(model):
    """A doubly curved shell's developed sheets leave the design by up to the deviation
    tolerance (20 mm): a springing line stays level on the design, and "lowest" still finds
    all of it when one panel's developed samples sit 15 mm higher than the design (a 10 mm band
    on the developed samples held one stretch of a level dome rim: a cantilever)."""
    from dataclasses import replace

    from fabpanel.structure.supports import layout_boundary_loops, lowest_sides

    developed = model.developed
    layout = developed.layout
    sides = np.concatenate(
        layout_boundary_loops(
            np.asarray(layout.quads),
            np.asarray(layout.side_neighbours),
            np.asarray(layout.vertices),
        )
    )
    found = lowest_sides(developed, sides, 10.0)
    assert len(found) == 4  # two springing lines of two panel sides each
    lifted = np.array(developed.samples, copy=True)
    lifted[0, :, :, 2] += 15.0
    np.testing.assert_array_equal(
        lowest_sides(replace(developed, samples=lifted), sides, 10.0), found
    )
    # the end arcs rise from the springing: none of their sides is "lowest"
    z = np.asarray(layout.vertices)[:, 2]
    for p, s in found:
        corners = np.asarray(layout.quads)[p, [s, (s + 1) % 4]]
        assert np.ptp(z[corners]) < 1e-6
