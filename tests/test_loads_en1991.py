"""Loads by EN 1991 and combinations by EN 1990 (issue 17): the code values reproduced, and the
cases on generated shells (no CalculiX needed: the applied resultants are integrated here)."""

from __future__ import annotations

import numpy as np
import pytest

from fabpanel.job import Job
from fabpanel.structure import Material, patch_model
from fabpanel.structure.actions import WindProfile, external_coefficients, snow_shape
from fabpanel.structure.cases import (
    _centres,
    load_cases,
    plan_axes,
    principal_axes,
    wind_directions,
)
from fabpanel.structure.checks import en1990_combinations
from fabpanel.structure.loads import gravity_forces


# --------------------------------------------------------------------------------------------
# code values
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("terrain", "z", "c_e"),
    [("0", 10, 2.98), ("I", 20, 3.20), ("II", 10, 2.35), ("III", 10, 1.71), ("IV", 5, 1.18)],
)
def test_exposure_factor_reproduces_the_profile_of_en1991_1_4(terrain, z, c_e):
    assert WindProfile(25.0, terrain).exposure(z) == pytest.approx(c_e, abs=0.006)


def test_peak_velocity_pressure_worked_example():
    """v_b = 25 m/s: q_b = 0.3906 kN/m2; terrain III at 10 m: q_p = 1.71 q_b = 0.67 kN/m2;
    below z_min the profile stays at z_min's value."""
    profile = WindProfile(25.0, "III")
    assert profile.q_b == pytest.approx(0.390625)
    assert profile.peak_pressure(10.0) == pytest.approx(0.67, abs=0.005)
    assert profile.peak_pressure(1.0) == pytest.approx(profile.peak_pressure(5.0))
    assert WindProfile(25.0, "III", c_dir=0.9).q_b == pytest.approx(0.390625 * 0.81)


def test_snow_shape_coefficient_by_pitch():
    np.testing.assert_allclose(
        snow_shape(np.array([0.0, 30.0, 45.0, 60.0, 80.0])), [0.8, 0.8, 0.4, 0.0, 0.0]
    )
    assert snow_shape(np.array([70.0]), fenced=True)[0] == 0.8


def test_external_coefficients_follow_the_duopitch_table_by_pitch_and_facing():
    wind = np.array([1.0, 0.0, 0.0])
    pitch = np.radians([30.0, 30.0, 0.0, 80.0])
    # facing the wind (normal against it), away, flat, steep windward
    normals = np.array(
        [
            [-np.sin(pitch[0]), 0, np.cos(pitch[0])],
            [np.sin(pitch[1]), 0, np.cos(pitch[1])],
            [0, 0, 1.0],
            [-np.sin(pitch[3]), 0, np.cos(pitch[3])],
        ]
    )
    np.testing.assert_allclose(
        external_coefficients(normals, wind),
        [[-0.2, 0.4], [-0.4, 0.0], [-0.6, 0.0], [0.8, 0.8]],
    )


# --------------------------------------------------------------------------------------------
# combinations
# --------------------------------------------------------------------------------------------
def test_en1990_combinations_lead_each_action_in_turn():
    loads = Job.from_dict({}).loads
    names = ["G", "S", "S1", "W0up", "W0down"]
    combos = en1990_combinations(names, loads)
    uls = {c.name: c.factors.tolist() for c in combos if c.kind == "ULS"}
    sls = {c.name: c.factors.tolist() for c in combos if c.kind == "SLS"}
    # the worked example of the notes: snow leading 1.35G+1.5S+0.9W, wind leading +0.75S
    assert uls["1.35G+1.5S+0.9W0up"] == pytest.approx([1.35, 1.5, 0, 0.9, 0])
    assert uls["1.35G+1.5W0down+0.75S1"] == pytest.approx([1.35, 0, 0.75, 0, 1.5])
    # G favourable under uplift
    assert uls["1.0G+1.5W0up"] == [1.0, 0, 0, 1.5, 0]
    assert "1.35G" in uls and "G+S+0.6W0up" in sls and "G+W0up+0.5S" in sls
    # one snow pattern at a time and one wind case at a time
    for factors in list(uls.values()) + list(sls.values()):
        assert np.count_nonzero(factors[1:3]) <= 1 and np.count_nonzero(factors[3:]) <= 1
    # (1 + 2 x 3 + 2 x 3) terms: G alone, each snow leading with no/each wind, and back
    assert len(uls) == 2 * 13 and len(sls) == 13


def test_national_annex_values_replace_the_recommended_ones():
    loads = Job.from_dict(
        {"loads": {"gamma_g_sup": 1.2, "gamma_g_inf": 0.9, "psi0_snow": 0.7, "gamma_q": 1.45}}
    ).loads
    uls = {c.name for c in en1990_combinations(["G", "S", "W0up"], loads) if c.kind == "ULS"}
    assert {"1.2G+1.45W0up+1.015S", "0.9G+1.45W0up"} <= uls


# --------------------------------------------------------------------------------------------
# load cases on generated shells
# --------------------------------------------------------------------------------------------
def _plate(width=6000.0, depth=4000.0, n=8, tilt=0.0):
    """A flat plate in a tilted plane (degrees about the x axis), normals up."""
    x, y = np.meshgrid(np.linspace(0, width, 2 * n + 1), np.linspace(0, depth, 2 * n + 1))
    t = np.radians(tilt)
    grid = np.stack([x, y * np.cos(t), 3000.0 + y * np.sin(t)], axis=-1).transpose(1, 0, 2)
    return patch_model(grid, 3.0, Material())[0]


def _job(**loads):
    return Job.from_dict({"loads": loads})


def test_snow_on_a_flat_roof_and_its_half_span_cases():
    model = _plate()
    cases, info, issues = load_cases(model, _job(snow_ground="1 kN/m2", wind_speed="20 m/s"))
    forces = {c.name: c.forces.sum(axis=0) for c in cases if c.forces is not None}
    area = 6000.0 * 4000.0
    # mu_1 = 0.8 on a flat roof, C_e = C_t = 1
    np.testing.assert_allclose(forces["S"], [0, 0, -0.8e-3 * area], rtol=1e-9, atol=1e-6)
    # each half-span case: one half at half the load
    for k in (1, 2, 3, 4):
        assert forces[f"S{k}"][2] == pytest.approx(0.75 * forces["S"][2], rel=1e-9)
    assert {info[n].action for n in forces} == {"snow", "wind"}
    assert not issues


def test_wind_up_and_down_on_a_flat_roof_are_the_net_pressures():
    model = _plate()
    job = _job(wind_speed="25 m/s", terrain="II", base_height="7 m")
    cases, info, _ = load_cases(model, job)
    forces = {c.name: c.forces.sum(axis=0) for c in cases if c.forces is not None}
    q_p = WindProfile(25.0, "II").peak_pressure(7.0) * 1e-3  # a flat roof 7 m above ground
    area = 6000.0 * 4000.0
    winds = [n for n in forces if n.startswith("W")]
    assert len(winds) == 8  # four directions, up and down
    for name in winds:
        # flat: c_pe = -0.6 (suction) or 0.0 (pressure); c_pi = +0.2 or -0.3
        expected = (-0.6 - 0.2) if name.endswith("up") else (0.0 + 0.3)
        np.testing.assert_allclose(
            forces[name], [0, 0, -expected * q_p * area], rtol=1e-9, atol=1e-6
        )
        assert "approximate" in info[name].description


def test_default_wind_directions_follow_the_plan_and_a_given_list_is_kept():
    model = _plate(width=4000.0, depth=9000.0)
    _, axes = principal_axes(model.nodes)
    assert abs(axes[0] @ [0, 1]) == pytest.approx(1.0)  # the long side along y
    assert sorted(wind_directions(model, _job().loads)) == pytest.approx([0, 90, 180, 270])
    assert wind_directions(model, _job(wind_directions=[30.0, 400.0]).loads) == [30.0, 40.0]


def test_the_plan_axes_do_not_follow_the_mesh_density():
    """A 14 x 11 m rectangular plan meshed much finer towards two of its corners: counted
    element by element the axes turn 28 degrees; weighted by plan area they stay on x and
    y, and the wind runs along and across them (W0, W90, ...)."""
    u, v = np.meshgrid(np.linspace(0, 1, 25), np.linspace(0, 1, 25), indexing="ij")
    x, y = 14000.0 * u ** (1 + 1.5 * v), 11000.0 * v ** (1 + 1.5 * u)
    model = patch_model(np.stack([x, y, 3000.0 + 0 * x], axis=-1), 3.0, Material())[0]
    _, counted = principal_axes(_centres(model))
    assert abs(np.degrees(np.arctan2(counted[0, 1], counted[0, 0]))) > 20
    centre, axes = plan_axes(model, model.group == 0)
    assert abs(np.degrees(np.arctan2(axes[0, 1], axes[0, 0]))) < 0.5
    np.testing.assert_allclose(centre, [7000.0, 5500.0], atol=10.0)
    assert wind_directions(model, _job().loads) == [0.0, 90.0, 180.0, 270.0]


def test_a_case_that_misses_the_shape_is_a_warning_naming_it():
    # a wall: steeper than 60 degrees, holds no snow
    model = _plate(tilt=80.0)
    _, _, issues = load_cases(model, _job(snow_ground="1 kN/m2"))
    negligible = [i for i in issues if i.code == "load-case-negligible"]
    assert negligible and all(i.severity == "warning" for i in negligible)
    assert any(i.message.startswith("load case S ") and "snow" in i.message for i in negligible)
    # the thesis's wind along the axis of a flat roof meets nothing
    model = _plate()
    _, _, issues = load_cases(model, _job(code="thesis", snow="0 kN/m2"))
    assert [i for i in issues if "load case W " in i.message and "wind" in i.message]
    assert gravity_forces(model).sum() < 0


def test_the_assumptions_name_the_code_and_what_is_left_out():
    from fabpanel.structure.assumptions import assumptions

    en = assumptions(_job(terrain="III", wind_speed="27 m/s"), 10.0, 0)
    assert any("terrain category III" in a and "v_b,0 = 27 m/s" in a for a in en)
    assert any(a.startswith("external wind pressure coefficients APPROXIMATE") for a in en)
    assert any("q_p = 0.779 kN/m2" in a for a in en)  # 1.71 x 0.5 x 1.25 kg/m3 x (27 m/s)^2
    thesis = assumptions(_job(code="thesis"), None, 2)
    assert thesis[0].startswith("loads of the thesis") and not any("APPROX" in a for a in thesis)
    assert any(a.startswith("2 sheets sprung") for a in thesis)


def test_the_buckling_mesh_study_refines_until_the_factor_settles_or_the_budget_stops_it():
    from fabpanel.structure.convergence import buckling_convergence

    def first_at(k):  # a factor that falls towards 10 as 1 / k^2
        calls.append(k)
        return 10.0 + 20.0 / k**2

    calls: list[int] = []
    study, issues = buckling_convergence(first_at, 2, first_at(2), lambda k: k <= 6)
    # 2 -> 1 (coarser) 30 vs 15: 100 %; 3: 12.2 (23 %); 4: 11.25 (8.6 %); 5: 10.8 (4.2 %)
    assert [r["per_side"] for r in study["table"]] == [1, 2, 3, 4, 5]
    assert study["converged"] and not issues and study["smallest"] == pytest.approx(10.8)
    calls.clear()
    study, issues = buckling_convergence(first_at, 2, 15.0, lambda k: k <= 4)
    assert [r["per_side"] for r in study["table"]] == [1, 2, 3, 4] and not study["converged"]
    assert issues[0].code == "buckling-not-converged"
    # the fall measured against the coarser mesh's factor: 12.22 -> 11.25 is 8 %
    assert "fell by 8% from 12.2 at 3 to 11.2 at 4 elements per panel side" in issues[0].message
    assert "may lower further" in issues[0].message  # 12.2 -> 11.25: still falling
    # the check, the progress line and the report use the smallest factor found, and name the
    # main run's beside it
    from fabpanel.structure.convergence import buckling_text, checked_factor

    checked = checked_factor(15.0, study)
    assert checked == pytest.approx(11.25)
    summary = {"first": 15.0, "checked": checked, "convergence": study, "required": 6.0}
    assert buckling_text(summary) == "11.25 (finer mesh of the study; 15.00 at 2 per side)"
    assert buckling_text({**summary, "checked": 15.0}) == "15.00"
    # the report's row: an OK at the finest mesh allowed says it is not converged
    from fabpanel.report.structure_figures import _unsettled

    assert _unsettled({"convergence": study}).startswith(
        " at the finest mesh allowed, NOT converged (the first factor fell by 8% from 12.2"
    )
    assert _unsettled({"convergence": {**study, "converged": True}}) == ""
