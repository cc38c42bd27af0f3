"""Bolted joints in the structural model: springs between back-to-back ribs, their forces read
back from CalculiX, and the bolts checked against EN 1993-1-8."""

from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest
from conftest import cylinder_developed

import fabpanel as fp
from fabpanel.fasteners import bolt_for_hole
from fabpanel.structure.analysis import analyse
from fabpanel.structure.bolt_checks import corrected_reactions
from fabpanel.structure.ccx import LoadCase, read_dat, run_ccx, write_deck
from fabpanel.structure.connectors import BoltDesign, station_forces
from fabpanel.structure.mesh import Material, Springs, patch_model
from fabpanel.structure.validation import joined_patches

needs_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) missing")


def test_bolt_stiffness_and_resistances_reproduce_en_1993_1_8_worked_values():
    """notes/eurocode.md §4.3 and §5.1: M12 8.8 in two 8 mm S235 ribs."""
    bolt = bolt_for_hole(13.0)
    design = BoltDesign(bolt, "8.8", t_rib=8.0, gap=0.0, fu_plate=360.0, E=210000.0)
    assert design.shear_stiffness / 1e3 == pytest.approx(34.2, abs=0.05)
    assert design.shear_resistance / 1e3 == pytest.approx(32.4, abs=0.05)
    assert design.tension_resistance / 1e3 == pytest.approx(48.6, abs=0.05)
    # single-lap cap 1.5 f_u d t / gamma_M2 governs over 2.5 alpha_b f_u d t / gamma_M2
    assert design.bearing_resistance(250.0) / 1e3 == pytest.approx(41.47, abs=0.01)
    # close bolts: alpha_b = p1 / (3 d0) - 1/4 = 0.519 -> 2.5 * 0.519 * 360 * 12 * 8 / 1.25
    assert design.bearing_resistance(30.0) / 1e3 == pytest.approx(35.9, abs=0.1)
    # an end bolt 20 mm from its rib's end: along the rib alpha_d = e1 / (3 d0) = 0.513,
    # 2.5 x 0.513 x 360 x 12 x 8 / 1.25 = 35.45 kN; across it k_1 = 2.8 x 20 / 13 - 1.7 = 2.61,
    # so 2.5: the single-lap cap, 41.47 kN; the smaller governs
    assert design.bearing_resistance(250.0, 20.0) / 1e3 == pytest.approx(35.45, abs=0.01)
    # 10 mm: across, k_1 = 2.8 x 10 / 13 - 1.7 = 0.454 -> 0.454 x 360 x 12 x 8 / 1.25 = 12.55 kN
    # (along: alpha_d 0.256, 17.72 kN)
    assert design.bearing_resistance(250.0, 10.0) / 1e3 == pytest.approx(12.55, abs=0.01)
    # the defaults' 60 mm end distance does not reduce it
    assert design.bearing_resistance(250.0, 60.0) == design.bearing_resistance(250.0)
    # axial: 1.6 E A_s / L_b, L_b = 16 + 2 x 2.5 washers + (7.5 + 10.8) / 2
    assert design.axial_stiffness == pytest.approx(1.6 * 210000 * 84.3 / 30.15, rel=1e-9)


@needs_ccx
@pytest.mark.parametrize(("angle", "held_at_springs"), [(0.0, False), (35.0, False), (35.0, True)])
def test_spring_forces_read_back_carry_the_load_across_the_joint(tmp_path, angle, held_at_springs):
    """Two plates joined edge to edge by springs only, pulled apart obliquely: the springs'
    forces (from their energies) along their local directions add up to the load. Held at
    the springs' own nodes, the reactions balance the load once the springs' pull is taken
    off CalculiX's RF there."""
    steel = Material()
    xs, ys = np.linspace(0, 100, 9), np.linspace(0, 40, 5)
    grid_a = np.stack([*np.meshgrid(xs, ys, indexing="ij"), np.zeros((9, 5))], axis=-1)
    grid_b = grid_a + [100.0, 0.0, 0.0]
    a, index_a = patch_model(grid_a, 5.0, steel)
    b, index_b = patch_model(grid_b, 5.0, steel)
    offset = len(a.nodes)
    edge_a, edge_b = index_a[-1], index_b[0] + offset
    load_nodes, fixed = index_b[-1] + offset, (edge_a if held_at_springs else index_a[0])
    t = np.radians(angle)
    frame = np.array([[np.cos(t), np.sin(t), 0.0], [-np.sin(t), np.cos(t), 0.0], [0, 0, 1.0]])
    k = np.array([2.0e5, 4.0e3, 1.0e4])
    springs = Springs(
        np.stack([edge_a, edge_b], 1), np.repeat(frame[None], 5, 0), np.tile(k, (5, 1))
    )
    model = joined_patches(a, b, springs, fixed)
    forces = np.zeros((len(model.nodes), 3))
    weights = np.array([1, 4, 2, 4, 1]) / 12.0
    forces[load_nodes] = np.outer(weights, [600.0, 300.0, 0.0])
    deck = write_deck(model, tmp_path / "springs.inp", [LoadCase("pull", forces=forces)])
    run = run_ccx(deck, threads=1)
    dat = read_dat(run.dat)
    ids, energy = dat.spring_energy[0]
    nodes, u = dat.spring_nodes[0]
    table = np.zeros(15)
    table[ids - len(model.quads) - 1] = energy
    disp = dict(zip(nodes.tolist(), u, strict=True))
    relative = np.array([disp[int(j) + 1] - disp[int(i) + 1] for i, j in springs.nodes])
    local = station_forces(springs, table.reshape(5, 3), relative)
    total = np.einsum("cj,cji->i", local, springs.frames)
    np.testing.assert_allclose(total, [600.0, 300.0, 0.0], atol=0.5)
    # hand calculation of the lap: the plates are ~40 times stiffer in plane than the springs,
    # so the five share the load evenly and slip by F / (5 k) along each local direction
    load = frame @ np.array([600.0, 300.0, 0.0])
    slip = np.einsum("cij,cj->ci", springs.frames, relative).mean(axis=0)
    np.testing.assert_allclose(slip[:2], load[:2] / (5 * k[:2]), rtol=0.03)
    reaction = corrected_reactions(model, dat).forces[0]
    if held_at_springs:  # without the correction the reported RF does not balance the load
        assert np.abs(dat.forces[0][:2] - reaction[:2]).max() > 100.0
    np.testing.assert_allclose(reaction[:2], [-600.0, -300.0], atol=0.5)


@pytest.fixture(scope="module")
def joints_compared(tmp_path_factory):
    developed = cylinder_developed(radius=4000.0, length=2400.0, arc=np.pi / 3)
    out = {}
    for joints in ("bolted", "rigid"):
        # the stiffeners as masses (the plates' ties are tested in tests/test_structure.py)
        job = fp.Job.from_dict(
            {
                "structure": {
                    "joints": joints,
                    "buckling_convergence": False,
                    "stiffeners": "mass",
                }
            }
        )
        model = fp.build(developed, job, jobs=1)
        folder = tmp_path_factory.mktemp(joints)
        out[joints] = (model, analyse(model, job, folder=folder), folder)
    return out


@needs_ccx
def test_bolted_joints_soften_the_shell_and_every_bolt_is_checked(joints_compared):
    model, bolted, folder = joints_compared["bolted"]
    _, rigid, _ = joints_compared["rigid"]
    assert bolted.analysed and rigid.analysed
    s, r = bolted.summary, rigid.summary
    assert s["checks"]["reactions"] and s["checks"]["mass"]
    # each panel its own rib: no rib of twice the thickness, and the panels share no node
    assert "RIB2" not in s["mesh"]["groups"] or s["mesh"]["groups"]["RIB2"]["elements"] == 0
    shell = bolted.shell
    panel = shell.panel[:, 0]
    node_panels = [
        set(panel[np.nonzero((shell.quads == n).any(axis=1))[0]]) for n in range(len(shell.nodes))
    ]
    assert max(len(p) for p in node_panels) == 1
    # the joints are springs now, softer than one shell: larger deflection, lower buckling
    assert s["deflection"]["max_mm"] > r["deflection"]["max_mm"]
    assert s["buckling"]["first"] < r["buckling"]["first"]
    bolts = s["bolts"]
    holes = sum(1 for p in model.parts if p.kind == "rib" for h in p.holes if h.purpose == "bolt")
    assert bolts["checked"] and bolts["bolts"] * 2 == holes  # two ribs per bolt
    assert 0 < bolts["utilisation"] < 1 and s["checks"]["bolts"]
    with open(folder / "bolts.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == bolts["bolts"]
    # one worst bolt per joint: 4 shared sides of the 2 x 2 panels
    assert bolts["joints"] == 4 and sum(row["worst_in_joint"] == "True" for row in rows) == 4
    assert max(float(row["utilisation"]) for row in rows) == pytest.approx(bolts["utilisation"])
    # each bolt's end distance along its rib: every joint's end bolts sit about the job's
    # 60 mm edge distance from the rib's end (measured 54.8-60 mm on the model's rib line)
    ends: dict[str, list[float]] = {}
    for row in rows:
        ends.setdefault(row["joint"], []).append(float(row["end_distance_mm"]))
    assert all(50.0 < min(e) <= 60.5 for e in ends.values()), ends
    assert r["bolts"]["checked"] is False and "rigid" in r["bolts"]["why"]


@needs_ccx
def test_every_sheet_edge_weld_is_checked_in_both_joint_models(joints_compared):
    for joints in ("bolted", "rigid"):
        _, result, _ = joints_compared[joints]
        s = result.summary
        welds = s["welds"]
        # 4 panels x 2 sheets x 4 sides x the elements along a side, all standing on ribs
        assert welds["edges"] == 4 * 2 * 4 * s["mesh"]["elements_per_side"]
        # S235: f_vw,d = 360 / (sqrt 3 x 0.8 x 1.25) = 207.8 MPa; a = 3 mm / sqrt 2 by default
        assert welds["throat_mm"] == pytest.approx(3.0 / np.sqrt(2.0), abs=0.01)
        assert welds["resistance_N_per_mm"] == pytest.approx(207.85 * welds["throat_mm"], abs=0.1)
        assert 0 < welds["utilisation"] < 1 and s["checks"]["welds"]
        assert welds["governing"]["panel"] in result.panel_ids


@needs_ccx
def test_superposed_half_span_snow_equals_the_case_solved_on_its_own(joints_compared, tmp_path):
    """S2 and S4 are (1 + share) S less S1 and S3, not solved: every result (displacements,
    stresses, reactions, spring forces) matches CalculiX solving them on their own."""
    import dataclasses

    from fabpanel.structure.bolt_checks import case_spring_forces
    from fabpanel.structure.cases import load_cases
    from fabpanel.structure.static import run_static

    _, bolted, _ = joints_compared["bolted"]
    shell = bolted.shell
    cases, _, _ = load_cases(shell, fp.Job.from_dict({}))
    superposed = [c.name for c in cases if c.superposed]
    assert superposed == ["S2", "S4"]
    snow = [c for c in cases if c.name.startswith("S")]
    # the loads themselves add up: the superposed case is what its terms say
    by_name = {c.name: c for c in snow}
    for name in superposed:
        terms = by_name[name].superposed
        loads = sum(f * by_name[n].forces for n, f in terms)
        np.testing.assert_allclose(loads, by_name[name].forces, atol=1e-9)
    plain = [dataclasses.replace(c, superposed=()) for c in snow]
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    solved = run_static(shell, plain, tmp_path / "a", 2, 600.0, "ccx")
    summed = run_static(shell, snow, tmp_path / "b", 2, 600.0, "ccx")
    forces_solved = case_spring_forces(shell, solved.dat)
    forces_summed = case_spring_forces(shell, summed.dat)
    for k, name in enumerate(c.name for c in snow):
        scale = np.abs(solved.displacement[k]).max()
        np.testing.assert_allclose(
            summed.displacement[k], solved.displacement[k], atol=1e-4 * scale
        )
        s_scale = np.abs(solved.stress[k]).max()
        np.testing.assert_allclose(
            summed.stress[k], solved.stress[k], atol=1e-4 * s_scale, err_msg=name
        )
        np.testing.assert_allclose(
            summed.dat.forces[k],
            solved.dat.forces[k],
            atol=1e-3 * np.abs(solved.dat.forces[k]).max(),
        )
        f_scale = np.abs(forces_solved[k]).max()
        np.testing.assert_allclose(
            forces_summed[k], forces_solved[k], atol=1e-3 * f_scale, err_msg=name
        )
        assert np.array_equal(summed.dat.node_forces[k][0], solved.dat.node_forces[k][0])


@needs_ccx
def test_the_summary_places_its_findings_in_the_design_frame(joints_compared, tmp_path):
    """The largest stress and deflection are placed where the issues and reactions are: in the
    design's own frame (the layout's origin added), not the local frame the model is built in."""
    import dataclasses

    model, bolted, _ = joints_compared["bolted"]
    origin = np.array([10_000.0, -20_000.0, 3_000.0])
    layout = dataclasses.replace(model.developed.layout, origin=origin)
    moved = dataclasses.replace(
        model, developed=dataclasses.replace(model.developed, layout=layout)
    )
    job = fp.Job.from_dict(
        {"structure": {"joints": "bolted", "buckling_convergence": False, "stiffeners": "mass"}}
    )
    shifted = analyse(moved, job, folder=tmp_path).summary
    places = [(shifted[k]["at_mm"], bolted.summary[k]["at_mm"]) for k in ("stress", "deflection")]
    places.append(
        (shifted["welds"]["governing"]["at_mm"], bolted.summary["welds"]["governing"]["at_mm"])
    )
    for moved_place, place in places:
        np.testing.assert_allclose(moved_place, np.add(place, origin), atol=0.11)


def test_an_overloaded_bolt_gets_the_smallest_bolt_that_carries_it():
    # the pavilion's crown bolts: M12 8.8 in 8 mm ribs, 62.0 kN of tension (F_t,Rd 48.6 kN,
    # utilisation 1.28); an M16 8.8 has F_t,Rd = 0.9 x 800 x 157 / 1.25 = 90.4 kN -> 0.686
    from fabpanel.structure.bolt_checks import _advice, _bolt_that_carries
    from fabpanel.structure.connectors import JointBolts, bolt_design

    job = fp.Job.from_dict({"input": {"path": "x.obj"}})
    design = bolt_design(job)
    assert design.bolt.name == "M12"
    joint = JointBolts(
        names=("P001-RIB-0 bolt 0", "P001-RIB-0 bolt 1"),
        points=np.zeros((2, 3)),
        stations=np.zeros((2, 2, 3), int),
        weights=np.full((2, 2), 0.5),
        pitch=np.array([220.0, 220.0]),
        end=np.array([60.0, 160.0]),
    )
    shear = np.array([[2.9e3, 1.0e3], [1.0e3, 7.2e3]])  # (K, b), N
    tension = np.array([[62.0e3, 10.0e3], [30.0e3, 20.0e3]])

    found = _bolt_that_carries(design, joint, shear, tension, job)

    assert found is not None and found["bolt"] == "M16 8.8" and found["diameter_mm"] == 18.0
    # tension governs: 62.0 / 90.43 = 0.686 (the interaction 2.9 / 60.29 + 62.0 /
    # (1.4 x 90.43) = 0.538); M14 (66.2 kN, 0.94) is second choice and skipped
    assert found["utilisation"] == pytest.approx(62.0 / (0.9 * 800 * 157 / 1.25 / 1e3), abs=1e-3)
    advice = _advice(found, design, joint, 0, shear, tension, job)
    assert "an M16 8.8 carries every bolt" in advice and 'diameter = "18 mm"' in advice
    # 200 kN: M20 8.8 (141 kN) is short, M24 8.8 (203 kN) carries it
    found = _bolt_that_carries(design, joint, shear, tension * 200 / 62, job)
    assert found is not None and found["bolt"] == "M24 8.8"
    # beyond every bolt the 150 mm ribs take (a hole up to 62 mm; M30 10.9 at 0.9 x 1000 x
    # 561 / 1.25 = 404 kN): none, and the advice says to add bolts
    assert _bolt_that_carries(design, joint, shear, tension * 10, job) is None
    # where none carries every bolt, each overloaded bolt is told what it needs alone
    many = tension.copy()
    many[0, 0] = 620e3
    advice = _advice(None, design, joint, 0, shear, many, job)
    assert "none carries this one" in advice and "more bolts" in advice
    many[0, 0], many[1, 1] = 100e3, 620e3
    advice = _advice(None, design, joint, 0, shear, many, job)
    assert 'this one needs an M20 8.8 ([sandwich.bolts] diameter = "22 mm"' in advice
