"""The characteristic load cases of the structural check, by the job's ``[loads] code``.

``en1991`` (default, :mod:`.actions`):

- ``G``: self-weight (every element, the stiffener plates included, and any lumped mass);
- ``S``: snow ``mu_1 C_e C_t s_k`` on the horizontal projection of the top sheet, mu_1 by each
  element's pitch (nothing above 60 degrees); ``S1``-``S4``: the half-span cases, one half of the
  plan (split through its centroid across either principal axis) at half the load, as EN
  1991-1-3 asks of pitched roofs and the notes ask of any shape; ``S2`` and ``S4`` are
  ``1.5 S - S1`` and ``1.5 S - S3`` exactly, so CalculiX solves 12 cases, not 14
  (:func:`fabpanel.structure.static.superpose`);
- ``W<angle>up`` and ``W<angle>down`` per wind direction (degrees from +x): the net pressure
  ``q_p (c_pe - c_pi)`` normal to the top sheet, with the suction values of c_pe and the
  positive internal pressure (uplift), and the pressure values with the negative one (down).

``thesis`` (§7.3): ``G``, ``S`` (``snow`` on the plan), ``W`` or ``W1``/``W2`` (``wind`` projected
along ``wind_direction`` on the faces it meets first), each wind case used in both signs.

A variable case whose resultant is below ``NEGLIGIBLE`` of the self-weight's is a warning that
names it and why (a wind direction that misses the shape, a roof too steep to hold snow).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, Issue
from . import ccx
from .actions import (
    TERRAIN,
    WindProfile,
    external_coefficients,
    snow_load,
    snow_shape,
)
from .loads import GRAVITY, area_forces, element_integrals, normal_forces, wind_exposed
from .mesh import ShellModel

#: a variable case below this share of the self-weight's resultant is reported
NEGLIGIBLE = 0.01
#: a half-span snow case carries this share of the load on its lighter half (EN 1991-1-3 5.3.3)
HALF_SPAN_SHARE = 0.5


@dataclass(frozen=True)
class CaseInfo:
    """What a load case is: ``action`` G, snow or wind, and a sentence for the report."""

    action: str
    description: str


def load_cases(
    shell: ShellModel, job
) -> tuple[list[ccx.LoadCase], dict[str, CaseInfo], list[Issue]]:
    """The characteristic cases (see the module docstring), what each is, and the warnings."""
    cases = [ccx.LoadCase("G", gravity=np.array([0.0, 0.0, -GRAVITY]))]
    info = {"G": CaseInfo("G", "self-weight (g = 9.81 m/s2)")}
    top = shell.group == 0
    if job.loads.code == "thesis":
        more, more_info = _thesis_cases(shell, job.loads, top)
    else:
        more, more_info = _snow_cases(shell, job.loads, top)
        wind, wind_info = _wind_cases(shell, job.loads, top)
        more, more_info = more + wind, {**more_info, **wind_info}
    cases += more
    info.update(more_info)
    return cases, info, _negligible(shell, cases, info)


# --------------------------------------------------------------------------------------------
# EN 1991
# --------------------------------------------------------------------------------------------
def principal_axes(
    points: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The plan's centroid (2,) and principal axes (2, 2) (rows, the major first) of
    ``points (n, 3)``, each weighted by ``weights (n,)`` (default equal); the major axis
    points along +x (or +y when it runs square to x)."""
    xy = points[:, :2]
    w = np.ones(len(xy)) if weights is None else np.asarray(weights, dtype=float)
    centre = (w[:, None] * xy).sum(axis=0) / w.sum()
    offsets = xy - centre
    _, vectors = np.linalg.eigh(
        (w[:, None, None] * offsets[:, :, None] * offsets[:, None, :]).sum(0)
    )
    axes = vectors[:, ::-1].T.copy()
    for k in range(2):
        lead = axes[k, 0] if abs(axes[k, 0]) > 1e-9 else axes[k, 1]
        if lead < 0:
            axes[k] *= -1
    return centre, axes


def plan_axes(shell: ShellModel, elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`principal_axes` of the plan the ``elements`` cover, each element weighted by its
    area in plan: the mesh's density does not tilt them (a roof meshed finer round its
    skylight had its axes 7 degrees off its rectangular plan when every element counted
    alike). A plan so steep that it has no area (a wall) weighs the elements by their area."""
    normals, areas = element_integrals(shell)
    area = areas.sum(axis=1)[elements]
    in_plan = area * np.abs(normals[elements, 2])
    weights = in_plan if in_plan.sum() > 1e-3 * area.sum() else area
    return principal_axes(_centres(shell)[elements], weights)


def _centres(shell: ShellModel) -> np.ndarray:
    return np.concatenate(
        [shell.nodes[shell.quads].mean(axis=1), shell.nodes[shell.triangles].mean(axis=1)]
    )[: shell.n_elements]


def _snow_cases(shell, loads, top) -> tuple[list[ccx.LoadCase], dict[str, CaseInfo]]:
    if loads.snow_ground <= 0:
        return [], {}
    normals, _ = element_integrals(shell)
    pitch = np.degrees(np.arccos(np.clip(normals[:, 2], -1.0, 1.0)))
    mu = snow_shape(pitch, loads.snow_fenced)
    s = snow_load(loads.snow_ground, loads.snow_exposure, loads.snow_thermal)
    base = f"C_e C_t s_k = {s * 1e3:.3g} kN/m2 x mu_1 by the pitch (0.8 up to 30 deg, 0 from 60)"
    cases = [ccx.LoadCase("S", forces=area_forces(shell, s * mu, (0, 0, -1), top, True))]
    info = {"S": CaseInfo("snow", f"snow, undrifted: {base}, on the plan")}
    centres = _centres(shell)
    centre, axes = plan_axes(shell, top)
    across = (centres[:, :2] - centre) @ axes.T  # (E, 2)
    for k, (axis, which) in enumerate(
        ((0, "major"), (0, "major"), (1, "minor"), (1, "minor")), start=1
    ):
        lighter = across[:, axis] < 0 if k % 2 else across[:, axis] >= 0
        share = np.where(lighter, HALF_SPAN_SHARE, 1.0)
        side = "negative" if k % 2 else "positive"
        # the second case of a pair halves the other side: with the first it makes
        # (1 + HALF_SPAN_SHARE) S everywhere, so it is that less the first, not solved again
        mirrored = () if k % 2 else (("S", 1.0 + HALF_SPAN_SHARE), (f"S{k - 1}", -1.0))
        cases.append(
            ccx.LoadCase(
                f"S{k}",
                forces=area_forces(shell, s * mu * share, (0, 0, -1), top, True),
                superposed=mirrored,
            )
        )
        info[f"S{k}"] = CaseInfo(
            "snow",
            f"snow, half-span: as S with the half of the plan on the {side} side of its "
            f"{which} axis' normal ({axes[axis, 0] + 0.0:+.2f}, {axes[axis, 1] + 0.0:+.2f}) "
            "at half the load, the other half at the full load"
            + (
                f"; its results are {mirrored[0][1]:g} S - {mirrored[1][0]} (a linear model), "
                "not solved again"
                if mirrored
                else ""
            ),
        )
    return cases, info


#: degrees: principal axes this close to x or y are taken as x and y (the wind cases are then
#: named W0, W90, ... as a plan drawn along them leads its user to expect)
AXIS_SNAP_DEG = 1.0


def wind_directions(shell: ShellModel, loads) -> list[float]:
    """The wind directions, degrees from +x: the job's, else along and across the plan's
    principal axes, both ways."""
    if loads.wind_directions:
        return [_whole_turn(float(a)) for a in loads.wind_directions]
    _, axes = plan_axes(shell, np.flatnonzero(shell.group == 0))
    major = float(np.degrees(np.arctan2(axes[0, 1], axes[0, 0])))
    square = 90.0 * round(major / 90.0)
    if abs(major - square) <= AXIS_SNAP_DEG:
        major = square  # a plan drawn along x and y (a skylight off the middle tilts its axes)
    return [_whole_turn(major + 90.0 * k) for k in range(4)]


def _whole_turn(angle: float) -> float:
    """``angle`` in [0, 360) degrees, to 0.01 degree (359.999 is 0: the case is named W0)."""
    return round(angle, 2) % 360.0


def reference_height(shell: ShellModel, loads) -> float:
    """The height of the shell's top above the ground, m (z_e of a roof: its top)."""
    return float(np.ptp(shell.nodes[:, 2])) / 1000.0 + loads.base_height / 1000.0


def _wind_cases(shell, loads, top) -> tuple[list[ccx.LoadCase], dict[str, CaseInfo]]:
    profile = WindProfile(loads.wind_speed, loads.terrain, c_dir=loads.wind_factor)
    z = reference_height(shell, loads)
    q_p = profile.peak_pressure(z)  # kN/m2
    z_min = TERRAIN[loads.terrain][1]
    zmin_note = f" (taken at z_min = {z_min:g} m)" if z < z_min else ""
    normals, _ = element_integrals(shell)
    cases, info = [], {}
    c_up, c_down = max(loads.internal_pressure), min(loads.internal_pressure)
    for angle in wind_directions(shell, loads):
        rad = np.radians(angle)
        wind = np.array([np.cos(rad), np.sin(rad), 0.0])
        c_pe = external_coefficients(normals, wind)
        label = f"{round(angle) % 360:d}"
        for suffix, column, c_pi in (("up", 0, c_up), ("down", 1, c_down)):
            net = q_p * (c_pe[:, column] - c_pi) * 1e-3  # N/mm2, positive towards the sheet
            name = f"W{label}{suffix}"
            cases.append(ccx.LoadCase(name, forces=normal_forces(shell, net, top)))
            info[name] = CaseInfo(
                "wind",
                (
                    f"wind blowing towards {angle:.0f} deg ({wind[0] + 0.0:+.2f}, "
                    f"{wind[1] + 0.0:+.2f}): q_p = {q_p:.3g} kN/m2 at z = {z:.1f} m"
                    f"{zmin_note} (v_b = {profile.v_b:g} m/s, terrain {loads.terrain}), c_pe,10 "
                    f"{'suction' if column == 0 else 'pressure'} values by the local pitch "
                    f"(approximate), c_pi = {c_pi:+g}"
                ),
            )
    return cases, info


# --------------------------------------------------------------------------------------------
# thesis §7.3
# --------------------------------------------------------------------------------------------
def _thesis_cases(shell, loads, top) -> tuple[list[ccx.LoadCase], dict[str, CaseInfo]]:
    cases, info = [], {}
    if loads.snow > 0:
        cases.append(
            ccx.LoadCase("S", forces=area_forces(shell, loads.snow, (0, 0, -1), top, True))
        )
        info["S"] = CaseInfo(
            "snow", f"snow {loads.snow * 1e3:g} kN/m2 on the horizontal projection"
        )
    if loads.wind > 0:
        d = np.r_[np.asarray(loads.wind_direction, float), 0.0]
        if np.linalg.norm(d) == 0:
            raise InputError("[loads] wind_direction must not be (0, 0)")
        d /= np.linalg.norm(d)
        directions = (("W1", 1.0), ("W2", -1.0)) if loads.wind_opposite else (("W", 1.0),)
        for name, sign in directions:
            exposed = wind_exposed(shell, top, sign * d)
            cases.append(
                ccx.LoadCase(
                    name, forces=area_forces(shell, loads.wind, sign * d, exposed, projected=True)
                )
            )
            info[name] = CaseInfo(
                "wind",
                f"wind {loads.wind * 1e3:g} kN/m2 blowing along ({sign * d[0]:+.2f}, "
                f"{sign * d[1]:+.2f}), projected, on {int(exposed.sum())} exposed "
                f"top-sheet elements; combined as pressure (+) and suction (-)",
            )
    return cases, info


def _negligible(
    shell: ShellModel, cases: list[ccx.LoadCase], info: dict[str, CaseInfo]
) -> list[Issue]:
    """Warnings for variable cases whose resultant is below ``NEGLIGIBLE`` of the self-weight."""
    from .loads import gravity_forces

    weight = float(np.linalg.norm(gravity_forces(shell).sum(axis=0)))
    issues = []
    for case in cases:
        if case.forces is None or weight <= 0:
            continue
        resultant = float(np.linalg.norm(case.forces.sum(axis=0)))
        if resultant >= NEGLIGIBLE * weight:
            continue
        why = (
            "the wind in that direction meets almost nothing of the shape (check "
            "[loads] wind_direction)"
            if info[case.name].action == "wind"
            else "the top sheet is too steep to hold snow almost everywhere, or s_k is 0"
        )
        issues.append(
            Issue(
                "load-case-negligible",
                (
                    f"load case {case.name} ({info[case.name].description}) has a resultant of "
                    f"{resultant / 1e3:.3g} kN, {resultant / weight:.2%} of the self-weight: {why}"
                ),
                severity="warning",
            )
        )
    return issues
