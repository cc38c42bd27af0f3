"""The joints' bolt layout against EN 1993-1-8 Table 3.3 (issue 17.4), on generated ribs."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.data import Hole, Part
from fabpanel.structure.bolt_layout import bolt_layout


def _rib(pid: str, stations, length=1200.0, d0=13.0) -> Part:
    outline = np.array([[0, 0], [length, 0], [length, 150], [0, 150.0]])
    return Part(
        id=pid,
        kind="rib",
        panel_id=pid.split("-")[0],
        material="S235",
        thickness=8.0,
        volume=1.0,
        area=1.0,
        mass=1.0,
        brep=b"",
        outline=outline,
        holes=tuple(Hole((float(s), 75.0), d0) for s in stations),
    )


def test_the_layout_is_measured_on_the_ribs_and_the_minimums_hold():
    ribs = [_rib("P001-RIB-0", np.linspace(60, 1140, 6)), _rib("P002-RIB-2", [40, 600, 1160])]
    summary, issues = bolt_layout(ribs, 8.0)
    assert not issues
    assert summary["end_distance_min_mm"] == 40.0
    assert summary["spacing_min_mm"] == pytest.approx(216.0)
    assert summary["spacing_max_mm"] == pytest.approx(560.0)
    assert summary["end_distance_required_mm"] == pytest.approx(15.6)
    assert summary["spacing_required_mm"] == pytest.approx(28.6)
    # min(14 t, 200 mm) for compression members: reported, with the reason it is not enforced
    assert summary["compression_spacing_limit_mm"] == 112.0
    assert not summary["compression_limit_applied"] and "welded" in summary["why"]


def test_end_distances_and_spacings_below_table_3_3_are_errors():
    ribs = [_rib("P001-RIB-0", [10, 30, 1100])]
    _, issues = bolt_layout(ribs, 8.0)
    assert [i.severity for i in issues] == ["error", "error"]
    assert issues[0].item == "P001-RIB-0" and "1.2 d_0 = 15.6 mm" in issues[0].message
    assert "2.2 d_0 = 28.6 mm" in issues[1].message
    assert bolt_layout([], 8.0) == ({"checked": False}, [])
