"""The shell model's own checks after the static run: its mass against the parts, the
reactions against the applied loads per case and per support, and the knots CalculiX made
where no junction is (a sign of flipped or kinked elements)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import Issue
from .buckling import significant
from .checks import panel_labels, relative_error
from .loads import gravity_forces
from .mesh import ShellModel, built_share

#: mass of the shell model against the sum of the part masses (holes and trims are modelled,
#: so what is left is meshing: the thesis found 0.07 %)
MASS_TOLERANCE = 0.005
#: reactions against the applied load per case (the thesis's Tables 5-7)
REACTION_TOLERANCE = 0.001


def _r(values, digits: int) -> list:
    # + 0.0 turns a rounded -0.0 into 0.0: "0, -0, -0" in the report reads as a sign that matters
    return (np.round(np.asarray(values, float), digits) + 0.0).tolist()


def panels_built(model) -> np.ndarray:
    """(m,) bool: the panels of a :class:`~fabpanel.data.Model` that have parts (a panel the
    build stage could not build has none)."""
    with_parts = {part.panel_id for part in model.parts}
    return np.array([pid in with_parts for pid in model.developed.panel_ids], bool)


def stray_knots(shell: ShellModel, knots: np.ndarray) -> tuple[np.ndarray, list[Issue]]:
    """The knots CalculiX made away from the rib/sheet junctions, and a warning if any."""
    _, el_side = panel_labels(shell)
    junction = np.zeros(len(shell.nodes), bool)
    junction[shell.quads[el_side[: len(shell.quads)] >= 0].ravel()] = True
    stray = knots[~junction[knots]] if len(knots) else knots
    if not len(stray):
        return stray, []
    return stray, [
        Issue(
            "stray-knots",
            f"CalculiX made {len(stray)} knots away from the rib/sheet junctions (flipped or "
            f"kinked sheet elements stiffen the model there)",
            severity="warning",
        )
    ]


def mass_check(shell: ShellModel, model, dat, panel_ids) -> tuple[dict, list[Issue]]:
    """The shell model's mass against the parts' (the summary's ``mass``). A panel not built
    is in the shell model but has no parts: the built panels' share of the model (by element
    mass, a shared rib half each) is compared with their parts."""
    parts_mass = float(sum(p.mass for p in model.parts))
    lumped = float(shell.lumped_mass.sum()) if shell.lumped_mass is not None else 0.0
    built = panels_built(model)
    element_mass = shell.density * shell.thickness * shell.element_areas()
    share = float((element_mass * built_share(shell, built)).sum() / element_mass.sum())
    fe_total = dat.mass[0] * 1e3 + lumped
    fe_mass = dat.mass[0] * 1e3 * share + lumped
    error = (fe_mass - parts_mass) / parts_mass if parts_mass > 0 else 0.0
    not_built = [pid for pid, ok in zip(panel_ids, built) if not ok]
    summary = {
        "model_kg": round(fe_mass, 2),
        "parts_kg": round(parts_mass, 2),
        "lumped_stiffeners_kg": round(lumped, 2),
        "error": significant(error, 3),
        "tolerance": MASS_TOLERANCE,
        "ok": abs(error) <= MASS_TOLERANCE,
    }
    if not_built:
        summary.update(
            panels_not_built=not_built,
            not_built_kg=round(fe_total - fe_mass, 2),
            model_total_kg=round(fe_total, 2),
            note="panels not built are in the shell model (from their developed surface, "
            "without stiffeners) and left out of the mass check",
        )
    if summary["ok"]:
        return summary, []
    return summary, [
        Issue(
            "mass-mismatch",
            f"shell model mass {fe_mass:.1f} kg{' (built panels)' if not_built else ''} differs "
            f"from the parts' {parts_mass:.1f} kg by {error:.2%}",
            severity="error",
        )
    ]


def case_reactions(shell: ShellModel, cases, case_info, dat) -> tuple[dict, list, list[Issue]]:
    """Per load case, the applied load against the reactions (the summary's ``load_cases``),
    the nodal loads applied (for the supports' own reactions) and an error per mismatch."""
    supported = np.zeros(len(shell.nodes), bool)
    supported[shell.supports] = True
    reactions, applied_loads, issues = {}, [], []
    for c, case in enumerate(cases):
        if case.gravity is not None:
            applied = gravity_forces(shell, case.gravity)
        elif case.forces is not None:
            applied = case.forces
        else:  # a case without loads (as the deck writes it)
            applied = np.zeros((len(shell.nodes), 3))
        applied_loads.append(applied)
        total = applied.sum(axis=0)
        reaction = dat.forces[c] - applied[supported].sum(axis=0)
        error = relative_error(-reaction, total)
        reactions[case.name] = {
            "description": case_info[case.name].description,
            "action": case_info[case.name].action,
            "applied_N": _r(total, 2),
            "reaction_N": _r(reaction, 2),
            "on_support_nodes_N": _r(applied[supported].sum(axis=0), 2),
            "error": significant(error, 2),
            "ok": bool(error <= REACTION_TOLERANCE),
        }
        if error > REACTION_TOLERANCE:
            issues.append(
                Issue(
                    "reaction-mismatch",
                    f"load case {case.name}: reactions differ from the applied load by {error:.3%}",
                    severity="error",
                )
            )
    return reactions, applied_loads, issues


def support_sum_issues(per_support, reactions: dict) -> list[Issue]:
    """The supports' reactions must add up to the total CalculiX printed, per case."""
    issues = []
    for c, case in enumerate(per_support.cases):
        total = np.asarray(reactions[case]["reaction_N"], float)
        summed = per_support.force[c].sum(axis=0)
        if relative_error(summed, total) > REACTION_TOLERANCE:
            issues.append(
                Issue(
                    "reaction-mismatch",
                    f"load case {case}: the supports' reactions add up to "
                    f"{np.round(summed / 1e3, 2).tolist()} kN, not the total "
                    f"{np.round(total / 1e3, 2).tolist()} kN",
                    severity="error",
                )
            )
    return issues


def support_summary(per_support, combined) -> list[dict]:
    """Per support: where it is, its reaction per characteristic case and the envelope of
    the combinations (kN, kN m)."""
    out = []
    for s, name in enumerate(per_support.names):
        force = combined.force[:, s] / 1e3
        out.append(
            {
                "support": name,
                "centroid_mm": _r(per_support.centroids[s], 1),
                "cases_kN": {
                    case: _r(per_support.force[c, s] / 1e3, 3)
                    for c, case in enumerate(per_support.cases)
                },
                "cases_kNm": {
                    case: _r(per_support.moment[c, s] / 1e6, 3)
                    for c, case in enumerate(per_support.cases)
                },
                "max_kN": _r(force.max(axis=0), 3),
                "min_kN": _r(force.min(axis=0), 3),
                "max_moment_kNm": _r(np.abs(combined.moment[:, s]).max(axis=0) / 1e6, 3),
            }
        )
    return out


def with_tie_pull(shell: ShellModel, dat, cases):
    """``dat`` with the ties' pull on restrained masters added to those masters' RF and to the
    totals. CalculiX leaves it out: on a test cylinder whose stiffener plates are tied to
    supported rib nodes the reported reaction fell short of the load by 1.3 %; with each tied
    node's constraint force (its printed RF less the load applied at it) shared out by the
    tie's weights it balances as without the plates (0.5 N in 6987 N, the same as there).
    ``cases`` are the static cases' :class:`~.ccx.LoadCase` (their loads at the tied nodes)."""
    ties = shell.ties
    if ties is None or not len(ties.nodes) or not dat.tie_forces:
        return dat

    restrained = np.zeros(len(shell.nodes), bool)
    restrained[np.asarray(shell.supports, int)] = True
    shares = np.where(restrained[ties.masters], ties.weights, 0.0)  # (k, 8)
    forces, node_forces = [], []
    for c, case in enumerate(cases):
        applied = np.zeros((len(shell.nodes), 3))
        if case.gravity is not None and np.any(case.gravity):
            applied += gravity_forces(shell, case.gravity)
        if case.forces is not None:
            applied += case.forces
        tied_ids, tied_rf = dat.tie_forces[c]
        rf = np.zeros((len(shell.nodes), 3))
        rf[tied_ids - 1] = tied_rf
        constraint = rf[ties.nodes] - applied[ties.nodes]  # (k, 3)
        pull = np.zeros((len(shell.nodes), 3))
        np.add.at(
            pull, ties.masters.ravel(), (shares[..., None] * constraint[:, None]).reshape(-1, 3)
        )
        ids, values = dat.node_forces[c]
        node_forces.append((ids, values + pull[ids - 1]))
        forces.append(dat.forces[c] + pull[ids - 1].sum(axis=0))
    return replace(dat, forces=forces, node_forces=node_forces)
