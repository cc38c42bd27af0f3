"""The sheet-to-rib fillet welds checked from the model (structure/weld_checks.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpanel.job import Job
from fabpanel.structure.mesh import Material, ShellGroup, ShellModel
from fabpanel.structure.weld_checks import (
    FilletWeld,
    beta_w,
    junction_edges,
    stiffener_edges,
    weld_checks,
)


def test_the_fillet_weld_resistance_is_en_1993_1_8_4_5_3_3():
    # f_vw,d = f_u / (sqrt 3 beta_w gamma_M2): S235 360 / (1.732 x 0.8 x 1.25) = 207.8 MPa
    assert FilletWeld(3.0, 8.0, 360.0, 235.0).resistance == pytest.approx(623.5, abs=0.05)
    assert FilletWeld(4.0, 8.0, 490.0, 355.0).resistance == pytest.approx(
        4.0 * 490.0 / (math.sqrt(3.0) * 0.9 * 1.25)
    )
    assert [beta_w(f) for f in (235.0, 275.0, 355.0, 460.0)] == [0.8, 0.85, 0.9, 1.0]


def _sheet_on_a_rib() -> ShellModel:
    """A 100 mm square sheet element (3 mm) in z = 0 whose side x = 100 stands on a 150 mm
    deep rib element (8 mm) in the plane x = 100."""
    sheet = [(0, 0, 0), (100, 0, 0), (100, 100, 0), (0, 100, 0)]
    rib = [(100, 0, 0), (100, 0, -150), (100, 100, -150), (100, 100, 0)]
    nodes: list[tuple[float, float, float]] = []

    def element(corners):
        corners = [np.array(c, float) for c in corners]
        mids = [(corners[i] + corners[(i + 1) % 4]) / 2 for i in range(4)]
        ids = []
        for point in [*corners, *mids]:
            found = [i for i, n in enumerate(nodes) if np.allclose(n, point)]
            if not found:
                nodes.append(tuple(point))
                found = [len(nodes) - 1]
            ids.append(found[0])
        return ids

    quads = np.array([element(sheet), element(rib)])
    return ShellModel(
        nodes=np.array(nodes),
        quads=quads,
        triangles=np.zeros((0, 6), int),
        group=np.array([0, 1]),
        groups=(ShellGroup("TOP", 3.0), ShellGroup("RIB", 8.0)),
        material=Material(),
        panel=np.array([[0, -1], [0, -1]]),
        side=np.array([-1, 1]),
    )


def test_the_weld_force_is_the_sheet_edge_traction_plus_its_moment_over_the_rib():
    shell = _sheet_on_a_rib()
    element, side = junction_edges(shell)
    assert element.tolist() == [0] and side.tolist() == [1]  # only the sheet's side x = 100
    # membrane sxx 100, sxy 50 MPa; the faces differ by +-30 MPa in sxx (bending)
    s_bot = np.zeros((1, 2, 8, 6))
    s_top = np.zeros((1, 2, 8, 6))
    s_bot[0, 0, :, 0], s_top[0, 0, :, 0] = 70.0, 130.0
    s_bot[0, 0, :, 3] = s_top[0, 0, :, 3] = 50.0
    summary, issues = weld_checks(
        shell,
        s_bot,
        s_top,
        np.array([[1.35]]),
        ["ULS1"],
        FilletWeld(3.0, 8.0, 360.0, 235.0),
        ("P001",),
    )
    # traction 3 x (100, 50) N/mm: 300 across, 150 along; moment 30 x 3^2 / 6 = 45 N mm/mm
    expected = 1.35 * (math.hypot(300.0, 150.0) + 45.0 / 8.0)
    governing = summary["governing"]
    assert governing["force_N_per_mm"] == pytest.approx(expected, abs=0.05)
    assert governing["across_N_per_mm"] == pytest.approx(1.35 * 300.0, abs=0.05)
    assert abs(governing["along_N_per_mm"]) == pytest.approx(1.35 * 150.0, abs=0.05)
    assert governing["moment_Nmm_per_mm"] == pytest.approx(1.35 * 45.0, abs=0.05)
    assert summary["utilisation"] == pytest.approx(expected / 623.5, abs=1e-3)
    assert summary["ok"] and not issues
    # twice the stress overloads a 3 mm weld: an error that names the panel
    summary, issues = weld_checks(
        shell,
        2 * s_bot,
        2 * s_top,
        np.array([[1.35]]),
        ["ULS1"],
        FilletWeld(3.0, 8.0, 360.0, 235.0),
        ("P001",),
    )
    assert not summary["ok"] and issues[0].code == "weld-overloaded"
    assert issues[0].severity == "error" and "P001" in issues[0].message


def test_a_stiffener_plate_is_welded_all_round_on_both_faces():
    # the sheet on its rib, and a 100 x 150 mm stiffener plate (8 mm) in the plane y = 50
    base = _sheet_on_a_rib()
    corners = np.array([(0, 50, 0), (100, 50, 0), (100, 50, -150), (0, 50, -150)], float)
    mids = (corners + np.roll(corners, -1, axis=0)) / 2
    first = len(base.nodes)
    shell = base.replace(
        nodes=np.vstack([base.nodes, corners, mids]),
        quads=np.vstack([base.quads, first + np.arange(8)]),
        group=np.array([0, 1, 2]),
        groups=(*base.groups, ShellGroup("STF", 8.0, element="S8")),
        panel=np.array([[0, -1], [0, -1], [0, -1]]),
        side=np.array([-1, 1, -1]),
    )
    element, side = stiffener_edges(shell)
    assert element.tolist() == [2] * 4 and side.tolist() == [0, 1, 2, 3]
    # the stiffener welds' joint: two fillets of at most 3 mm (the job's throat is 4 mm)
    job = Job.from_dict(
        {
            "sandwich": {
                "sheet_thickness": "6 mm",
                "rib_thickness": "10 mm",
                "welds": {"throat": "4 mm"},
            }
        }
    )
    weld = FilletWeld.stiffener_of(job)
    assert weld.throat == 3.0 and weld.fillets == 2
    assert weld.resistance == pytest.approx(2 * FilletWeld(3.0, 8.0, weld.fu, weld.fy).resistance)
    # a uniform membrane stress of 120 MPa in the plate's x: 960 N/mm across its ends (x = 0
    # and 100), nothing along its top and bottom
    s_bot = np.zeros((1, 3, 8, 6))
    s_top = np.zeros((1, 3, 8, 6))
    s_bot[0, 2, :, 0] = s_top[0, 2, :, 0] = 120.0
    summary, issues = weld_checks(
        shell, s_bot, s_top, np.array([[1.0]]), ["ULS1"], FilletWeld.of(job), ("P001",), weld
    )
    stiffeners = summary["stiffeners"]
    assert stiffeners["edges"] == 4 and stiffeners["fillets"] == 2
    assert stiffeners["governing"]["force_N_per_mm"] == pytest.approx(960.0, abs=0.05)
    assert stiffeners["utilisation"] == pytest.approx(960.0 / weld.resistance, abs=1e-4)
    assert summary["ok"] == stiffeners["ok"] and not issues  # 960 < 2 x 623.5
    # the faces 30 MPa either side of the mean: a moment of 30 x 8^2 / 6 = 320 N mm/mm, a
    # couple on the plate's thickness (the job's 10 mm stiffener) that each fillet takes whole
    s_bot[0, 2, :, 0], s_top[0, 2, :, 0] = 90.0, 150.0
    summary, _ = weld_checks(
        shell, s_bot, s_top, np.array([[1.0]]), ["ULS1"], FilletWeld.of(job), ("P001",), weld
    )
    governing = summary["stiffeners"]["governing"]
    assert governing["moment_Nmm_per_mm"] == pytest.approx(320.0, abs=0.05)
    assert governing["force_N_per_mm"] == pytest.approx(960.0 + 2 * 320.0 / 10.0, abs=0.05)
    s_bot[0, 2, :, 0] = s_top[0, 2, :, 0] = 120.0
    summary, issues = weld_checks(
        shell,
        2 * s_bot,
        2 * s_top,
        np.array([[1.0]]),
        ["ULS1"],
        FilletWeld.of(job),
        ("P001",),
        weld,
    )
    assert not summary["ok"] and [i.code for i in issues] == ["stiffener-weld-overloaded"]
    assert "corner stiffener" in issues[0].message and "stiffener_thickness" in issues[0].message
