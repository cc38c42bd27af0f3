"""Every joint bolt checked under every ULS combination (EN 1993-1-8 Table 3.4; the model and
the resistances in :mod:`.connectors`), with a per-bolt table for the engineer
(``structure/bolts.csv``: each bolt's joint, the worst bolt of each joint marked)."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import Issue
from ..fasteners import BOLT_SIZES
from . import ccx
from .connectors import BoltDesign, JointBolts, bolt_design, bolt_forces, station_forces
from .mesh import ShellModel

#: utilisations above this are an error
LIMIT = 1.0
#: diameters, mm, of the bolts suggested for overloaded ones: ISO 261's first choice, the
#: sizes a steel shop stocks (M14, M18, M22 and M27 are second choice)
FIRST_CHOICE = (8.0, 10.0, 12.0, 16.0, 20.0, 24.0, 30.0)


def case_spring_forces(shell: ShellModel, dat: ccx.DatResults) -> list[np.ndarray]:
    """Per static case, (c, 3) float, N: every spring pair's forces along its local
    directions (positive: tension, the second node moved away from the first)."""
    springs = shell.springs
    assert springs is not None
    first = len(shell.quads) + len(shell.triangles) + 1  # element id of the first spring
    count = len(springs.nodes)
    node_row = {int(n) + 1: i for i, n in enumerate(np.unique(springs.nodes))}
    per_case = []
    for (ids, energy), (nodes, u) in zip(dat.spring_energy, dat.spring_nodes, strict=True):
        table = np.zeros(3 * count)
        table[ids - first] = energy
        disp = np.zeros((len(node_row), 3))
        disp[[node_row[int(n)] for n in nodes]] = u
        rows = np.array([[node_row[int(a) + 1], node_row[int(b) + 1]] for a, b in springs.nodes])
        relative = disp[rows[:, 1]] - disp[rows[:, 0]]
        per_case.append(station_forces(springs, table.reshape(count, 3), relative))
    return per_case


def spring_energies(shell: ShellModel, forces: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The internal energies (N mm) of the spring elements ``ids`` under the station forces
    ``forces (c, 3)`` (N): ``f^2 / (2 k)``, the inverse of :func:`case_spring_forces`."""
    springs = shell.springs
    assert springs is not None
    first = len(shell.quads) + len(shell.triangles) + 1
    k = springs.stiffness.ravel()[ids - first]
    f = forces.ravel()[ids - first]
    return np.divide(f * f, 2.0 * k, out=np.zeros_like(f), where=k > 0)


def spring_pull(shell: ShellModel, local: np.ndarray) -> np.ndarray:
    """(n, 3) float, N: the force the springs exert on each node, world, from their local
    forces ``local (c, 3)`` (tension pulls the first node towards the second)."""
    springs = shell.springs
    assert springs is not None
    world = np.einsum("cj,cji->ci", local, springs.frames)
    pull = np.zeros((len(shell.nodes), 3))
    np.add.at(pull, springs.nodes[:, 0], world)
    np.add.at(pull, springs.nodes[:, 1], -world)
    return pull


def corrected_reactions(shell: ShellModel, dat: ccx.DatResults) -> ccx.DatResults:
    """``dat`` with the springs' forces on supported nodes taken off their RF: CalculiX counts
    a spring's force on a restrained node in that node's RF (measured on a saddle held at two
    short ribs whose end nodes carry joint springs: the reported RF exceeded the load by a
    third; less the springs' pull they balance it to 1e-5)."""
    if shell.springs is None or not len(shell.springs.nodes) or not dat.spring_energy:
        return dat
    forces, node_forces = [], []
    for c, local in enumerate(case_spring_forces(shell, dat)):
        pull = spring_pull(shell, local)
        ids, values = dat.node_forces[c]
        node_forces.append((ids, values - pull[ids - 1]))
        forces.append(dat.forces[c] - pull[ids - 1].sum(axis=0))
    return replace(dat, forces=forces, node_forces=node_forces)


def case_bolt_forces(
    shell: ShellModel, joint: JointBolts, dat: ccx.DatResults, design: BoltDesign
) -> np.ndarray:
    """(C, b, 3) float, N: every bolt's force per static case (axis; along; across)."""
    assert shell.springs is not None
    return np.stack(
        [bolt_forces(shell.springs, joint, f, design) for f in case_spring_forces(shell, dat)]
    )


def bolt_checks(
    shell: ShellModel,
    joint: JointBolts | None,
    dat: ccx.DatResults,
    factors: np.ndarray,
    names: list[str],
    job,
    origin: np.ndarray,
) -> tuple[dict, list[Issue]]:
    """``(summary, issues)``: the largest shear, tension and utilisation of the joint bolts
    over the ULS combinations ``factors (K, C)`` named ``names``; ``summary["rows"]`` holds
    one row per bolt for :func:`write_bolts_csv`, placed in the design's frame (``origin``
    added to the model's local points). Without bolted joints, says so."""
    if joint is None or shell.springs is None or not len(joint.names):
        why = (
            'rigid joints ([structure] joints = "rigid"): bolts not modelled or checked'
            if job.structure.joints == "rigid"
            else "no bolted joints in the model"
        )
        return {"checked": False, "why": why}, []
    design = bolt_design(job)
    per_case = case_bolt_forces(shell, joint, dat, design)  # (C, b, 3)
    combined = np.einsum("kc,cbj->kbj", factors, per_case)  # (K, b, 3)
    shear = np.hypot(combined[..., 1], combined[..., 2])
    tension = np.maximum(combined[..., 0], 0.0)
    f_b = _bearing(design, joint)
    util = _utilisations(design, f_b, shear, tension)  # (4, K, b)
    # SPOOLES on two threads may differ in the last digits from run to run: rounded, equal
    # utilisations (a wind case that leaves a bolt alone) name the same governing combination
    util = np.round(util, 9)
    worst = util.max(axis=0)  # (K, b)
    k_of = worst.argmax(axis=0)  # (b,)
    per_bolt = worst.max(axis=0)
    b_max = int(np.argmax(per_bolt))
    k_max = int(k_of[b_max])
    which = ("shear", "bearing", "tension", "shear and tension")[
        int(np.argmax(util[:, k_max, b_max]))
    ]
    joint_of = [name.split(" ")[0] for name in joint.names]
    worst_of: dict[str, int] = {}
    for b, name in enumerate(joint_of):
        if name not in worst_of or per_bolt[b] > per_bolt[worst_of[name]]:
            worst_of[name] = b
    worst_in_joint = set(worst_of.values())
    rows = [
        {
            "bolt": joint.names[b],
            "joint": joint_of[b],
            "worst_in_joint": b in worst_in_joint,
            "x_mm": round(float(joint.points[b, 0] + origin[0]), 1),
            "y_mm": round(float(joint.points[b, 1] + origin[1]), 1),
            "z_mm": round(float(joint.points[b, 2] + origin[2]), 1),
            "shear_kN": round(float(shear[:, b].max()) / 1e3, 3),
            "tension_kN": round(float(tension[:, b].max()) / 1e3, 3),
            "pitch_mm": round(float(joint.pitch[b]), 1),
            "end_distance_mm": round(float(joint.end[b]), 1),
            "bearing_resistance_kN": round(float(f_b[b]) / 1e3, 2),
            "utilisation": round(float(per_bolt[b]), 4),
            "combination": names[int(k_of[b])],
        }
        for b in range(len(joint.names))
    ]
    ok = bool(per_bolt.max() <= LIMIT)
    summary = {
        "checked": True,
        "bolts": len(joint.names),
        "bolt": f"{design.bolt.name} {design.grade}",
        "stiffness_kN_per_mm": {
            "axial": round(design.axial_stiffness / 1e3, 1),
            "shear": round(design.shear_stiffness / 1e3, 2),
        },
        "resistance_kN": {
            "shear": round(design.shear_resistance / 1e3, 2),
            "tension": round(design.tension_resistance / 1e3, 2),
            "bearing_min": round(float(f_b.min()) / 1e3, 2),
        },
        "joints": len(worst_of),
        "max_shear_kN": round(float(shear.max()) / 1e3, 3),
        "max_tension_kN": round(float(tension.max()) / 1e3, 3),
        "utilisation": round(float(per_bolt[b_max]), 4),
        "governing": {
            "bolt": joint.names[b_max],
            "combination": names[k_max],
            "check": which,
        },
        "ok": ok,
        "rows": rows,
    }
    stronger = None if ok else _bolt_that_carries(design, joint, shear, tension, job)
    if stronger is not None:
        summary["suggested"] = stronger
    issues = [
        Issue(
            "bolt-overloaded",
            f"{joint.names[b]}: utilisation {per_bolt[b]:.2f} under {names[int(k_of[b])]} "
            f"(shear {shear[k_of[b], b] / 1e3:.1f} kN, tension {tension[k_of[b], b] / 1e3:.1f} "
            f"kN; {design.bolt.name} {design.grade}); "
            + _advice(stronger, design, joint, int(b), shear, tension, job),
            joint.names[b].split(" ")[0],
            "error",
        )
        for b in np.flatnonzero(per_bolt > LIMIT)
    ]
    return summary, issues


def _bearing(design: BoltDesign, joint: JointBolts) -> np.ndarray:
    """(b,) float, N: each bolt's bearing resistance at its pitch and end distance."""
    return np.array(
        [design.bearing_resistance(p, e) for p, e in zip(joint.pitch, joint.end, strict=True)]
    )


def _utilisations(
    design: BoltDesign, f_b: np.ndarray, shear: np.ndarray, tension: np.ndarray
) -> np.ndarray:
    """(4, K, b) float: shear, bearing, tension and their interaction (Table 3.4) of the
    bolts' ``shear`` and ``tension (K, b)``, N, for bearing resistances ``f_b (b,)``."""
    f_v, f_t = design.shear_resistance, design.tension_resistance
    return np.stack(
        [shear / f_v, shear / f_b[None], tension / f_t, shear / f_v + tension / (1.4 * f_t)]
    )


def _bolt_that_carries(
    design: BoltDesign, joint: JointBolts, shear: np.ndarray, tension: np.ndarray, job
) -> dict | None:
    """The first bolt of :data:`FIRST_CHOICE`, larger sizes of the job's grade first and
    then 10.9, whose hole the ribs take (EN 1993-1-8 Table 3.3 as ``[sandwich.bolts]``
    checks it: ``rib_height >= 2.4 d0``, ``rib_thickness >= d0 / 6``) and which carries
    every bolt's forces under every combination, with its utilisation; None where none
    does. The forces are this model's: a stiffer bolt draws a little more (the pavilion's
    worst M12 bolt, 62.0 kN, is 63.4 kN as an M16), so the suggestion is to be checked by
    running again with it."""
    from ..buildup import Buildup

    bu = Buildup.of(job)
    grades = [design.grade] + [g for g in ("10.9",) if g != design.grade]
    for grade in grades:
        for size in BOLT_SIZES:
            if size.d not in FIRST_CHOICE or size.d < design.bolt.d:
                continue
            if size.d == design.bolt.d and grade == design.grade:
                continue
            if bu.rib_height < 2.4 * size.hole or bu.t_rib < size.hole / 6:
                continue
            candidate = replace(design, bolt=size, grade=grade)
            worst = float(
                _utilisations(candidate, _bearing(candidate, joint), shear, tension).max()
            )
            if worst <= LIMIT:
                return {
                    "bolt": f"{size.name} {grade}",
                    "diameter_mm": size.hole,
                    "grade": grade,
                    "utilisation": round(worst, 3),
                }
    return None


def _advice(
    stronger: dict | None,
    design: BoltDesign,
    joint: JointBolts,
    b: int,
    shear: np.ndarray,
    tension: np.ndarray,
    job,
) -> str:
    """What to change for the overloaded bolt ``b``: ``stronger``, the bolt that carries
    every bolt (:func:`_bolt_that_carries`); where there is none, the one that carries this
    bolt alone, as a part of the answer (the job has one bolt for every joint)."""
    if stronger is not None:
        return (
            f"an {stronger['bolt']} carries every bolt's forces of this model at "
            f"{stronger['utilisation']:.2f} ({_bolt_keys(stronger)}; run the check again "
            "with it), or use more bolts ([sandwich.bolts] spacing)"
        )
    alone = replace(joint, pitch=joint.pitch[[b]], end=joint.end[[b]])
    own = _bolt_that_carries(design, alone, shear[:, [b]], tension[:, [b]], job)
    this = (
        f"this one needs an {own['bolt']} ({_bolt_keys(own)}, {own['utilisation']:.2f})"
        if own is not None
        else "none carries this one"
    )
    return (
        f"no standard bolt the ribs take carries every bolt's forces of this model, {this}: "
        "use more bolts ([sandwich.bolts] spacing) or deeper or thicker ribs"
    )


def _bolt_keys(bolt: dict) -> str:
    """The ``[sandwich.bolts]`` keys that ask for ``bolt`` (:func:`_bolt_that_carries`)."""
    grade = f', grade = "{bolt["grade"]}"' if bolt["grade"] != "8.8" else ""
    return f'[sandwich.bolts] diameter = "{bolt["diameter_mm"]:g} mm"{grade}'


def write_bolts_csv(path: Path, summary: dict) -> None:
    """One row per bolt: its position, largest shear and tension, pitch and end distance,
    bearing resistance,
    utilisation and governing combination (``summary["rows"]`` of :func:`bolt_checks`)."""
    rows = summary.get("rows", [])
    if not rows:
        return
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
