"""Post-processing of linear shell results: load combinations, von Mises at the shell
surfaces, reaction and mass checks, span, buckling mode extent.

Combinations by EN 1990 (:func:`en1990_combinations`, each action leading in turn) or, for
``[loads] code = "thesis"``, the thesis's (§7.3.2): ULS ``gamma_g G + gamma_q sum(Q)`` (1.2 /
1.5), SLS unfactored, snow and wind (each direction in both signs) alone and together. Linear
static cases are combined here, not in CalculiX (one ``*STATIC`` step per characteristic case).
Stresses are read at the expanded top and bottom surface nodes (``OUTPUT=3D``), so the bending
part is included; utilisation = von Mises / f_y (gamma_M0 = 1.0, EN 1993-1-1 6.1).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy.spatial import cKDTree

from .mesh import ShellModel


# --------------------------------------------------------------------------------------------
# supports
# --------------------------------------------------------------------------------------------
def panel_labels(shell: ShellModel) -> tuple[np.ndarray, np.ndarray]:
    """``(panel, side)`` of a shell model made from panels (:func:`~.mesh.sandwich_model`);
    a :class:`ValueError` for one made without them (the validation patches)."""
    if shell.panel is None or shell.side is None:
        raise ValueError(
            "the shell model has no panel labels (panel / side); it was not made "
            "from developed panels"
        )
    return shell.panel, shell.side


def span_of(nodes: np.ndarray, supports: np.ndarray) -> float:
    """Span for the deflection limit: twice the largest plan distance from a node to its
    nearest support (a vault: its width; a dome on a ring: its diameter), mm."""
    dist, _ = cKDTree(nodes[supports, :2]).query(nodes[:, :2])
    return float(2 * dist.max())


# --------------------------------------------------------------------------------------------
# combinations
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Combination:
    """``sum(factors[i] * case i)``; ``kind`` is "ULS" or "SLS"."""

    name: str
    kind: str
    factors: np.ndarray


def combinations(cases: list[str], gamma_g: float, gamma_q: float) -> list[Combination]:
    """ULS and SLS combinations of the characteristic cases ``G`` (first), ``S`` and wind
    cases ``W...`` (each in both signs): every variable action alone, and snow with each wind
    case."""
    names = list(cases)
    winds = [c for c in names if c.startswith("W")]
    variable: list[list[tuple[str, float]]] = []
    if "S" in names:
        variable.append([("S", 1.0)])
    for w, sign in product(winds, (1.0, -1.0)):
        variable.append([(w, sign)])
        if "S" in names:
            variable.append([("S", 1.0), (w, sign)])
    if not variable:
        variable = [[]]
    out = []
    for kind, gg, gq in (("ULS", gamma_g, gamma_q), ("SLS", 1.0, 1.0)):
        for terms in variable:
            factors = np.zeros(len(names))
            factors[names.index("G")] = gg
            label = f"{gg:g}G" if gg != 1 else "G"
            for case, sign in terms:
                factors[names.index(case)] = sign * gq
                label += (
                    f"{'+' if sign > 0 else '-'}{gq:g}{case}"
                    if gq != 1
                    else f"{'+' if sign > 0 else '-'}{case}"
                )
            out.append(Combination(label, kind, factors))
    return out


def en1990_combinations(cases: list[str], loads) -> list[Combination]:
    """EN 1990 (6.10) ULS and (6.14b) characteristic SLS combinations of the characteristic
    cases ``G`` (first), snow ``S...`` and wind ``W...`` (each a pattern of its action: one of
    them at a time). Each variable action leads in turn (``gamma_q`` Q), the other accompanies
    it (``gamma_q psi_0`` Q) or is absent; G is taken at ``gamma_g_sup`` and, where it may be
    favourable (uplift), at ``gamma_g_inf`` too. SLS: G + Q_lead + psi_0 Q_other."""
    names = list(cases)
    actions = {
        "snow": ([c for c in names if c.startswith("S")], loads.psi0_snow),
        "wind": ([c for c in names if c.startswith("W")], loads.psi0_wind),
    }
    # (leading case, accompanying case or None, accompanying psi_0)
    terms: list[tuple[str | None, str | None, float]] = [(None, None, 0.0)]
    for lead_action, (leads, _) in actions.items():
        for other_action, (others, psi) in actions.items():
            if other_action == lead_action:
                continue
            for first in leads:
                terms += [(first, other, psi) for other in [None, *others]]
    g_factors = sorted({loads.gamma_g_sup, loads.gamma_g_inf}, reverse=True)
    out = []
    for kind, gammas, gq in (("ULS", g_factors, loads.gamma_q), ("SLS", [1.0], 1.0)):
        for gg in gammas:
            for lead, other, psi in terms:
                factors = np.zeros(len(names))
                factors[names.index("G")] = gg
                label = "G" if kind == "SLS" else "1.0G" if gg == 1 else f"{gg:g}G"
                for term, factor in ((lead, gq), (other, gq * psi)):
                    if term is None or factor == 0:
                        continue
                    factors[names.index(term)] = factor
                    label += f"+{factor:g}{term}" if factor != 1 else f"+{term}"
                out.append(Combination(label, kind, factors))
    return _unique(out)


def _unique(combos: list[Combination]) -> list[Combination]:
    """The combinations without repeats (same kind and factors), in order."""
    seen: set[tuple] = set()
    out = []
    for combo in combos:
        key = (combo.kind, tuple(np.round(combo.factors, 12)))
        if key not in seen:
            seen.add(key)
            out.append(combo)
    return out


# --------------------------------------------------------------------------------------------
# stresses
# --------------------------------------------------------------------------------------------
#: combinations evaluated at once (bounds the memory of the (K, E, 8, 6) stress stack)
COMBINATION_CHUNK = 16


def combined_von_mises(factors: np.ndarray, *faces: np.ndarray) -> np.ndarray:
    """(K, E) float: each element's largest von Mises stress over its nodes on ``faces``
    (each (C, E, 8, 6), the cases' stresses) under each combination's ``factors (K, C)``,
    evaluated a few combinations at a time."""
    out = np.empty((len(factors), faces[0].shape[1]))
    for start in range(0, len(factors), COMBINATION_CHUNK):
        chunk = factors[start : start + COMBINATION_CHUNK]
        out[start : start + len(chunk)] = np.max(
            [von_mises(np.einsum("kc,cesj->kesj", chunk, f)).max(axis=2) for f in faces], axis=0
        )
    return out


def combined_displacement(factors: np.ndarray, u_el: np.ndarray) -> np.ndarray:
    """(K, E, a) float: the displacement's length at each element node ``u_el (C, E, a, 3)``
    under each combination, a few at a time."""
    out = np.empty((len(factors), *u_el.shape[1:3]))
    for start in range(0, len(factors), COMBINATION_CHUNK):
        chunk = factors[start : start + COMBINATION_CHUNK]
        out[start : start + len(chunk)] = np.linalg.norm(
            np.einsum("kc,ceaj->keaj", chunk, u_el), axis=-1
        )
    return out


def von_mises(stress: np.ndarray) -> np.ndarray:
    """Von Mises stress of ``(..., 6)`` components in .frd order (xx, yy, zz, xy, yz, zx)."""
    sxx, syy, szz, sxy, syz, szx = np.moveaxis(stress, -1, 0)
    return np.sqrt(
        0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
        + 3.0 * (sxy**2 + syz**2 + szx**2)
    )


def membrane_compression(
    stress_bottom: np.ndarray, stress_top: np.ndarray, thickness: np.ndarray, areas: np.ndarray
) -> np.ndarray:
    """Compressive membrane force of every element: area x thickness x the most compressive
    principal stress of the mean of the surface stresses (0 in tension), N mm. Summed over
    the model it ranks combinations for the buckling analysis.

    stress_bottom, stress_top : (..., E, 8, 6); thickness, areas : (E,).
    """
    mean = 0.5 * (stress_bottom + stress_top).mean(axis=-2)  # (..., E, 6)
    s = np.stack([mean[..., [0, 3, 5]], mean[..., [3, 1, 4]], mean[..., [5, 4, 2]]], axis=-2)
    smallest = np.linalg.eigvalsh(s)[..., 0]
    return np.maximum(0.0, -smallest) * thickness * areas


def relative_error(found: np.ndarray, expected: np.ndarray) -> float:
    """|found - expected| / |expected| for vectors (0 when both vanish)."""
    scale = float(np.linalg.norm(expected))
    diff = float(np.linalg.norm(np.asarray(found) - np.asarray(expected)))
    return diff / scale if scale > 0 else diff


def mode_extent(
    amplitude: np.ndarray, panel: np.ndarray, n_panels: int, threshold: float = 0.5
) -> tuple[np.ndarray, np.ndarray]:
    """Panels a buckling mode involves: ``(panels, share)`` with each panel's largest modal
    amplitude relative to the mode's largest, for panels above ``threshold``, largest first.

    amplitude : (E,) per element; panel : (E, 2) panel indices (-1 where none)."""
    per_panel = np.zeros(n_panels)
    for column in range(panel.shape[1]):
        ok = panel[:, column] >= 0
        np.maximum.at(per_panel, panel[ok, column], amplitude[ok])
    share = np.round(per_panel / max(per_panel.max(), 1e-300), 2)
    involved = np.nonzero(share >= threshold)[0]
    involved = involved[np.argsort(-share[involved], kind="stable")]
    return involved, share[involved]


# --------------------------------------------------------------------------------------------
# failed checks
# --------------------------------------------------------------------------------------------
def failed_check_issues(summary: dict, one_sided: bool) -> list:
    """An error-level issue for each of the stage's own checks that fails (deflection, stress,
    buckling, GNIA), with the governing figure, combination and place, from the stage's
    ``summary``: a failed check is what an engineer cannot sign, so the run must not end
    clean. ``one_sided``: the supports hold the shell as a cantilever from one side
    (``supports-one-sided``); each message then says to name the real supports first."""
    from ..errors import Issue

    cause = (
        "; the supports hold the shell as a cantilever from one side (supports-one-sided): "
        "name its real supports before reading this"
        if one_sided
        else ""
    )
    issues = []
    d = summary["deflection"]
    if not d["ok"]:
        issues.append(
            Issue(
                "structure-deflection",
                f"the largest SLS deflection, {d['max_mm']:.1f} mm ({d['ratio']}) under "
                f"{d['combination']} at {d['panel']}, exceeds the limit of "
                f"{d['limit_mm']:.1f} mm over the {d['span_mm'] / 1000:.1f} m span{cause}",
                d["panel"],
                "error",
            )
        )
    st = summary["stress"]
    if not st["ok"]:
        issues.append(
            Issue(
                "structure-stress",
                f"the largest von Mises stress, {st['max_von_mises_MPa']:.0f} MPa under "
                f"{st['combination']} in {st['part']}, exceeds f_y = {st['fy_MPa']:g} MPa "
                f"(utilisation {st['utilisation']:.2f}){cause}",
                st["part"],
                "error",
            )
        )
    b = summary["buckling"]
    if not b["ok"]:
        panels = b["modes"][0]["panels"] if b.get("modes") else []
        where = (
            f"; its mode lies in {', '.join(panels[:4])}{' ...' if len(panels) > 4 else ''}"
            if panels
            else ""
        )
        issues.append(
            Issue(
                "structure-buckling",
                f"the first buckling factor, {b['checked']:g} under {b['combination']}, is "
                f"below the {b['required']:g} required (1 / [loads] buckling_knockdown)"
                f"{where}{cause}",
                panels[0] if len(panels) == 1 else "",
                "error",
            )
        )
    g = b.get("gnia")
    if g is not None and not summary["checks"].get("gnia", True):
        issues.append(
            Issue(
                "structure-gnia",
                f"the imperfect shell's limit load factor (GNIA), {g['factor']:g}, is below "
                f"the {g['required']:g} required{cause}",
                "",
                "error",
            )
        )
    return issues
