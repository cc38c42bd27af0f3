"""The structure stage: a preliminary structural check of the panelled shell with CalculiX.

After the thesis's check with Karamba3D (§7.3), on CalculiX: a shell model of all sheets and
ribs (:mod:`.mesh`) held at the anchor-bolt nodes of its supporting boundary ribs
(:mod:`.supports`); the characteristic cases of EN 1991 or the thesis (:mod:`.cases`); one linear
static step per case, combined by EN 1990 or the thesis (:mod:`.checks`); linear buckling
(``*BUCKLE``) of the ULS combination with the largest compressive membrane force, a factor of 6
required (knock-down 1/6, Hoogenboom), with a mesh study (:mod:`.convergence`); checks of mass,
reactions (in total and per support), deflection (span / 300), von Mises utilisation, sprung
sheets (:mod:`.forming`), the bolt layout (:mod:`.bolt_layout`) and buckling.

CalculiX runs: ``static.inp`` (all cases, or ``static-1.inp``... side by side:
:mod:`.static`) and ``buckle.inp`` (the governing combination),
kept with their results in the output folder's ``structure/``.
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FabpanelError, GeometryError, Issue
from . import ccx
from .assumptions import assumptions
from .balance import (
    case_reactions,
    mass_check,
    panels_built,
    stray_knots,
    support_sum_issues,
    support_summary,
    with_tie_pull,
)
from .bolt_checks import bolt_checks, corrected_reactions, write_bolts_csv
from .bolt_layout import bolt_layout
from .buckling import (
    MIN_POSITIVE_MODES,
    buckle_deck,
    buckle_results,
    linear_buckling,
    node_values,
    significant,
)
from .cases import load_cases, reference_height
from .checks import (
    combinations,
    combined_displacement,
    combined_von_mises,
    en1990_combinations,
    failed_check_issues,
    membrane_compression,
    panel_labels,
    span_of,
)
from .connectors import JointBolts, attach
from .convergence import MAX_REFINEMENTS, buckling_convergence, checked_factor
from .forming import sprung_sheet_findings
from .gnia import gnia
from .mesh import ShellModel, sandwich_model, sandwich_settings
from .static import run_static
from .supports import (
    anchor_nodes,
    cantilever_issues,
    check_supports,
    layout_boundary_loops,
    lowest_sides,
    near_points,
    range_sides,
    rib_elements_of_sides,
    support_reactions,
    surrounding_band,
    write_reactions_csv,
)
from .weld_checks import FilletWeld, weld_checks

log = logging.getLogger(__name__)

#: at most this many elements per panel side when the size is chosen automatically
AUTO_MAX_DIVISIONS = 4


@dataclass(frozen=True)
class Structure:
    """What the structure stage found.

    analysed : False when CalculiX is missing or failed (``summary["reason"]`` says why).
    summary : JSON-ready checks (the ``structure`` entry of ``report/summary.json``).
    shell : the shell model analysed.
    displacement : (n, 3) float, mm: shell node displacements of the SLS combination with the
        largest displacement.
    utilisation : (E,) float: largest ULS von Mises utilisation of every element.
    mode_shape : (n, 3) float: the first positive buckling mode, largest amplitude 1.
    panel_ids : the panels, for ``shell.panel`` indices.
    files : files written into the output folder's ``structure/``.
    """

    analysed: bool
    summary: dict
    shell: ShellModel | None = None
    displacement: np.ndarray | None = None
    utilisation: np.ndarray | None = None
    mode_shape: np.ndarray | None = None
    panel_ids: tuple[str, ...] = ()
    files: tuple[str, ...] = ()
    issues: tuple[Issue, ...] = ()
    metrics: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return self.summary


def not_analysed(reason: str, issue: Issue | None = None, **extra) -> Structure:
    return Structure(
        False, {"analysed": False, "reason": reason, **extra}, issues=(issue,) if issue else ()
    )


# --------------------------------------------------------------------------------------------
# model set-up
# --------------------------------------------------------------------------------------------
def side_lengths(developed) -> np.ndarray:
    """(m, 4) float: polyline length of every panel side, mm."""
    s = np.asarray(developed.samples, float)
    sides = [s[:, :, 0], s[:, -1, :], s[:, ::-1, -1], s[:, 0, ::-1]]
    return np.stack([np.linalg.norm(np.diff(x, axis=1), axis=-1).sum(axis=1) for x in sides], 1)


def choose_divisions(developed, job) -> int:
    """Elements per panel side: from ``[structure] element_size`` when given, otherwise the
    finest count up to :data:`AUTO_MAX_DIVISIONS` whose element count fits ``max_elements``
    (at least one)."""
    st = job.structure
    lengths = side_lengths(developed)
    if st.element_size is not None:
        return int(np.clip(math.ceil(float(np.median(lengths)) / st.element_size), 1, 32))
    best = 1
    for n in range(1, AUTO_MAX_DIVISIONS + 1):
        if element_count(developed, job, n) <= st.max_elements:
            best = n
    return best


def element_count(developed, job, n: int) -> int:
    """The shell model's element count at ``n`` elements per panel side."""
    m = len(developed.panel_ids)
    sandwich = job.sandwich.buildup == "sandwich"
    neighbours = np.asarray(developed.layout.side_neighbours)
    rib_sides = int(((neighbours < 0) | (np.arange(m)[:, None] < neighbours)).sum())
    return m * n * n * (2 if sandwich else 1) + (n * rib_sides if sandwich else 0)


def shell_of(model, job, divisions: int | None = None) -> ShellModel:
    """The shell model of a built :class:`~fabpanel.data.Model` held at its anchorages
    (:mod:`.supports`). Panels that were not built are meshed too (see :mod:`.mesh`)."""
    return shell_and_joints(model, job, divisions)[0]


def shell_and_joints(
    model, job, divisions: int | None = None
) -> tuple[ShellModel, JointBolts | None]:
    """:func:`shell_of`, and its joints' bolts where they are connectors
    (:func:`.connectors.attach`)."""
    developed = model.developed
    n = divisions or choose_divisions(developed, job)
    shell = sandwich_model(
        developed, sandwich_settings(job, n), model.parts, built=panels_built(model)
    )
    st = job.structure
    layout = developed.layout
    sides, what, _ = support_sides(developed, job)
    if job.sandwich.buildup == "sandwich":
        supports = anchor_nodes(shell, rib_elements_of_sides(shell, sides), st.support_fixity)
    else:
        supports = _sheet_edge_nodes(shell, developed, sides, n)
    if st.supports == "points":
        points = _local_points(job, st.support_points, layout)
        supports = near_points(shell.nodes, supports, points, st.support_radius)
        what += f" (radius {st.support_radius:g} mm)"
    check_supports(shell.nodes, supports, what)
    shell, joint = attach(shell, model, job)
    return shell.replace(supports=np.unique(supports)), joint


def support_sides(developed, job) -> tuple[np.ndarray, str, float]:
    """The boundary sides (k, 2) (panel, side) whose ribs stand on foundations by
    ``[structure] supports``, the words that name the choice, and for ``"lowest"`` the band
    used (:func:`.supports.surrounding_band`: raised from ``support_band`` where the lowest
    sides alone would hold the shell as a cantilever), else 0."""
    st = job.structure
    layout = developed.layout
    loops = layout_boundary_loops(
        np.asarray(layout.quads), np.asarray(layout.side_neighbours), np.asarray(layout.vertices)
    )
    what = f'[structure] supports = "{st.supports}"'
    chosen = loops[1:] if st.supports == "openings" else loops
    if not chosen:
        raise GeometryError(f'{what}: the layout has no openings; use "lowest" or "boundary"')
    sides = np.concatenate(chosen)
    band = 0.0
    if st.supports == "lowest":
        band = surrounding_band(developed, sides, st.support_band)
        sides = lowest_sides(developed, sides, band)
        what += f" (band {band:g} mm)"
    elif st.supports == "ranges":
        sides = range_sides(developed, loops, _local_points(job, st.support_ranges, layout))
    return sides, what, band


def _raised_band_issues(job, band: float) -> list[Issue]:
    """A warning where ``"lowest"`` had to raise its ``band`` (mm, :func:`support_sides`) to
    surround the shell's centre."""
    st = job.structure
    if st.supports != "lowest" or band <= st.support_band:
        return []
    return [
        Issue(
            "supports-raised",
            f"no boundary rib within support_band = {st.support_band:g} mm of the lowest "
            f"boundary point surrounds the shell's centre in plan (it would be checked as a "
            f"cantilever from one low stretch); the supports are the boundary ribs within "
            f"{band:.0f} mm of it. If the shell stands elsewhere, name its supports "
            f'([structure] supports = "ranges" or "points")',
        )
    ]


def _local_points(job, points, layout) -> np.ndarray:
    """Points given in the input's units (any nesting of x, y, z triples) in the layout's
    local frame, mm."""
    from ..units import length_scale

    scale = length_scale(job.input.units or "mm")
    return np.asarray(points, dtype=float) * scale - np.asarray(layout.origin)


def _sheet_edge_nodes(shell, developed, sides, n) -> np.ndarray:
    """Cladding (no ribs): the sheet nodes along the given panel sides."""
    from scipy.spatial import cKDTree

    pts = np.concatenate([developed.side_samples(p, s) for p, s in sides])
    d, idx = cKDTree(shell.nodes).query(pts)
    return np.unique(idx[d < 0.5 * float(np.ptp(shell.nodes, axis=0).max()) / max(n, 1)])


def _study_deck(model, job, governing, k: int, folder: Path) -> Path:
    """The mesh study's buckling deck at ``k`` elements per panel side (``buckle-k.inp``)."""
    finer = shell_of(model, job, k)
    finer_cases, _, _ = load_cases(finer, job)
    case = ccx.combine(finer_cases, list(governing.factors), governing.name)
    return buckle_deck(finer, case, folder, job.structure.buckling_modes, f"buckle-{k}")


def _mesh_study(
    model, job, governing, first: float, folder: Path, executable: str, done: dict[int, ccx.CcxRun]
):
    """The buckling mesh study (:mod:`.convergence`): the governing combination's first
    factor at one element per side fewer and, while it still changes, finer; ``done`` holds
    the runs already made (the coarser one runs beside the main buckling run)."""
    st, developed = job.structure, model.developed
    n = choose_divisions(developed, job)

    def first_at(k: int) -> float:
        run = done.get(k) or ccx.run_ccx(
            _study_deck(model, job, governing, k, folder), 1, st.timeout, executable
        )
        values, _ = buckle_results(run)
        positive = values[values > 0]
        return float(positive.min()) if len(positive) else math.inf

    return buckling_convergence(
        first_at,
        n,
        first,
        lambda k: k <= n + MAX_REFINEMENTS and element_count(developed, job, k) <= st.max_elements,
    )


# --------------------------------------------------------------------------------------------
# the stage
# --------------------------------------------------------------------------------------------
def analyse(
    model, job, folder: str | Path | None = None, threads: int | None = None, flat=None
) -> Structure:
    """Stage: the structural check of a built :class:`~fabpanel.data.Model` (module docstring).

    folder : where the decks and results are kept (created); default a temporary folder.
    threads : CalculiX threads (``[structure] threads`` wins; default all cores).
    flat : the cut stage's :class:`~fabpanel.data.FlatParts`: the sheets sprung onto their
        ribs are checked with the bending stress they keep (:mod:`.forming`).

    Without CalculiX, or when it fails, returns ``analysed = False`` with the reason and an
    issue, unless ``[structure] required``: then raises
    :class:`~fabpanel.structure.ccx.CcxMissing` / :class:`~fabpanel.errors.SolverError`.
    """
    st = job.structure
    executable = ccx.find_ccx()
    if executable is None:
        reason = f"CalculiX (ccx) was not found on the PATH; {ccx.INSTALL_HINT}"
        if st.required:
            raise ccx.CcxMissing(reason)
        log.warning("structure not analysed: %s", reason)
        return not_analysed(
            reason, Issue("ccx-missing", "structure not analysed: " + reason), ccx_found=False
        )
    # the thread count does not follow --jobs: SPOOLES's result may differ in the last digits
    # with the thread count, and a job must give the same output whatever --jobs is
    threads = st.threads or threads or os.cpu_count() or 1
    try:
        if folder is None:
            with tempfile.TemporaryDirectory(prefix="fabpanel-ccx-") as tmp:
                return _analyse(model, job, Path(tmp), threads, executable, False, flat)
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        since = time.time()
        try:
            return _analyse(model, job, folder, threads, executable, True, flat, since)
        finally:
            if not st.keep_results:  # a failed run's files too
                ccx.tidy_results(folder, since)
    except FabpanelError as err:
        if st.required:
            raise
        reason = f"{type(err).__name__}: {err}"
        log.error("structure not analysed: %s", reason)
        return not_analysed(
            reason,
            Issue("structure-failed", "structure not analysed: " + str(err), severity="error"),
            ccx_found=True,
        )


def _analyse(
    model, job, folder: Path, threads: int, executable: str, keep: bool, flat, since: float = 0.0
) -> Structure:
    """The stage's work in ``folder``; ``keep``: the folder is the output's, tidied (unless
    ``keep_results``) before its files are listed, ``since`` the time the stage began."""
    started = time.perf_counter()
    st, loads = job.structure, job.loads
    developed = model.developed
    panel_ids = tuple(developed.panel_ids)
    shell, joint = shell_and_joints(model, job)
    cases, case_info, issues = load_cases(shell, job)
    issues += cantilever_issues(shell, f'[structure] supports = "{st.supports}"')
    band = support_sides(developed, job)[2]  # the shell's supports chose the same
    issues += _raised_band_issues(job, band)
    names = [c.name for c in cases]

    # ---- static cases ----------------------------------------------------------------------
    run = run_static(shell, cases, folder, threads, st.timeout, executable)
    dat = with_tie_pull(shell, corrected_reactions(shell, run.dat), cases)
    disp, stress = run.displacement, run.stress
    bottom, top, knots = run.bottom, run.top, run.knots
    el_panel, _ = panel_labels(shell)
    stray, knot_issues = stray_knots(shell, knots)
    issues += knot_issues
    u_el = np.stack([0.5 * (d[bottom][..., :3] + d[top][..., :3]) for d in disp])  # (C,E,8,3)
    s_bot = np.stack([s[bottom] for s in stress])  # (C,E,8,6)
    s_top = np.stack([s[top] for s in stress])

    # ---- mass and reactions ----------------------------------------------------------------
    mass, mass_issues = mass_check(shell, model, dat, panel_ids)
    reactions, applied_loads, reaction_issues = case_reactions(shell, cases, case_info, dat)
    issues += mass_issues + reaction_issues

    # ---- combinations ----------------------------------------------------------------------
    combos = (
        combinations(names, loads.gamma_g, loads.gamma_q)
        if loads.code == "thesis"
        else en1990_combinations(names, loads)
    )
    uls = [c for c in combos if c.kind == "ULS"]
    sls = [c for c in combos if c.kind == "SLS"]
    f_uls = np.stack([c.factors for c in uls])
    f_sls = np.stack([c.factors for c in sls])
    origin = np.asarray(developed.layout.origin, dtype=float)
    per_support = support_reactions(shell, names, dat.node_forces, applied_loads, origin)
    issues += support_sum_issues(per_support, reactions)
    combined_supports = per_support.combined(
        [f"{c.kind} {c.name}" for c in uls + sls], np.concatenate([f_uls, f_sls])
    )
    if keep:
        write_reactions_csv(folder, per_support, combined_supports)
    vm_el = combined_von_mises(f_uls, s_bot, s_top)  # (K, E)
    fy = shell.material.fy
    disp_sls = combined_displacement(f_sls, u_el)  # (K, E, 8)
    k_u, e_u = np.unravel_index(np.argmax(vm_el), vm_el.shape)
    k_d, e_d, a_d = np.unravel_index(np.argmax(disp_sls), disp_sls.shape)
    span = st.span or span_of(shell.nodes, shell.supports)
    limit = span / loads.deflection_limit
    max_disp = float(disp_sls[k_d, e_d, a_d])
    max_vm = float(vm_el[k_u, e_u])
    areas = shell.element_areas()
    compression = np.stack(
        [
            membrane_compression(
                np.einsum("c,cesj->esj", c.factors, s_bot),
                np.einsum("c,cesj->esj", c.factors, s_top),
                shell.thickness,
                areas,
            ).sum()
            for c in uls
        ]
    )
    governing = uls[int(np.argmax(compression))]

    # ---- buckling --------------------------------------------------------------------------
    # the mesh study's coarser run goes beside the main one (one thread each) where the
    # memory held two static runs at once
    n = choose_divisions(developed, job)
    coarser = st.buckling_convergence and n > 1 and run.decks > 1
    beside = [_study_deck(model, job, governing, n - 1, folder)] if coarser else []
    buckled = linear_buckling(
        shell, cases, governing, (bottom, top), panel_ids, job, folder, executable, beside
    )
    issues += buckled.issues
    factors, modes, mode_shape, first = (
        buckled.factors,
        buckled.modes,
        buckled.mode_shape,
        buckled.first,
    )
    required, local_note, brun = buckled.required, buckled.note, buckled.run
    convergence: dict = {"checked": False}
    if st.buckling_convergence and math.isfinite(first):
        done = {n - 1: buckled.beside[0]} if coarser else {}
        convergence, found = _mesh_study(model, job, governing, first, folder, executable, done)
        issues += found

    imperfect = None
    if st.gnia and mode_shape is not None and math.isfinite(first):
        imperfect = gnia(
            shell,
            ccx.combine(cases, list(governing.factors), governing.name),
            mode_shape,
            (first, fy / max(float(vm_el[uls.index(governing)].max()), 1e-300)),
            job,
            folder,
            1,  # one thread, as the buckling runs: SPOOLES on two varies in the last digits
            executable,
        )
        issues += imperfect.issues

    # ---- bolts -----------------------------------------------------------------------------
    bolts_summary, bolt_issues = bolt_checks(
        shell, joint, dat, f_uls, [c.name for c in uls], job, origin
    )
    issues += bolt_issues
    if keep and joint is not None:
        write_bolts_csv(folder / "bolts.csv", bolts_summary)
    welds_summary, weld_issues = weld_checks(
        shell,
        s_bot,
        s_top,
        f_uls,
        [c.name for c in uls],
        FilletWeld.of(job),
        panel_ids,
        FilletWeld.stiffener_of(job),
        origin=origin,
    )
    issues += weld_issues

    # ---- per panel -------------------------------------------------------------------------
    util_el = vm_el.max(axis=0) / fy
    forming, forming_issues = sprung_sheet_findings(shell, util_el * fy, fy, flat, panel_ids)
    issues += forming_issues
    layout, layout_issues = bolt_layout(model.parts, job.sandwich.rib_thickness)
    issues += layout_issues
    disp_el = disp_sls.max(axis=(0, 2))
    per_panel = {}
    for p, pid in enumerate(panel_ids):
        mine = np.nonzero((el_panel[:, 0] == p) | (el_panel[:, 1] == p))[0]
        e = mine[np.argmax(util_el[mine])]
        per_panel[pid] = {
            "utilisation": round(float(util_el[e]), 4),
            "part": _part_of(shell, e, panel_ids, p),
            "displacement_mm": round(float(disp_el[mine].max()), 3),
            "buckling_modes": [m["mode"] for m in modes[:MIN_POSITIVE_MODES] if pid in m["panels"]],
        }
    reactions_ok = all(r["ok"] for r in reactions.values())
    checks = {
        "mass": mass["ok"],
        "reactions": reactions_ok,
        "deflection": max_disp <= limit,
        "stress": max_vm <= fy,
        "buckling": checked_factor(first, convergence) >= required,
        "sprung_sheets": not forming_issues,
        "bolt_layout": not layout_issues,
        "bolts": bool(bolts_summary.get("ok", True)),
        "welds": bool(welds_summary["ok"]),
    }
    if imperfect is not None:
        checks["gnia"] = imperfect.ok
    seconds = time.perf_counter() - started
    if keep and not st.keep_results:
        ccx.tidy_results(folder, since)
    files = tuple(sorted(p.name for p in folder.iterdir() if p.is_file())) if keep else ()
    summary = {
        "analysed": True,
        "ccx_found": True,
        "solver": {
            "program": "CalculiX",
            "path": executable,
            "version": ccx.ccx_version(executable),
            "threads": threads,
            "elements": "S8R (quadratic shells, reduced integration)",
        },
        # everything that depends on the machine, under "seconds" (as the other stages)
        "seconds": {
            "static": round(run.seconds, 2),
            "buckling": round(brun.seconds, 2),
            "gnia": None
            if imperfect is None
            else round(sum(p.seconds for p in imperfect.paths), 2),
            "total": round(seconds, 2),
        },
        "mesh": {
            "elements": shell.n_elements,
            "S8R": int((np.array([g.element for g in shell.groups])[shell.group] == "S8R").sum()),
            "S8": int((np.array([g.element for g in shell.groups])[shell.group] == "S8").sum()),
            "S6": len(shell.triangles),
            "nodes": len(shell.nodes),
            "elements_per_side": buckled.divisions,
            "knots": len(knots),
            "knots_off_junctions": len(stray),
            "groups": {
                g.name: {
                    "thickness_mm": g.thickness,
                    "density_factor": round(g.density_factor, 5),
                    "elements": int((shell.group == i).sum()),
                }
                for i, g in enumerate(shell.groups)
            },
            "stiffeners": _stiffeners_in(shell, mass["lumped_stiffeners_kg"]),
        },
        "forming": forming,
        "bolt_layout": layout,
        "bolts": {k: v for k, v in bolts_summary.items() if k != "rows"},
        "welds": welds_summary,
        "assumptions": assumptions(
            job,
            reference_height(shell, loads) if loads.code == "en1991" else None,
            int(forming.get("sprung", 0)),
            band,
        ),
        "supports": {
            "mode": st.supports,
            "nodes": len(shell.supports),
            "fixity": st.support_fixity,
            "fixed": (
                "translations of the boundary ribs' anchor-bolt nodes (pinned)"
                if st.support_fixity == "pinned"
                else "translations of every node of the boundary ribs (fixed)"
            ),
            "reactions": support_summary(per_support, combined_supports),
        },
        "mass": mass,
        "load_cases": reactions,
        "combinations": {"ULS": [c.name for c in uls], "SLS": [c.name for c in sls]},
        "deflection": {
            "max_mm": round(max_disp, 3),
            "combination": sls[k_d].name,
            "panel": panel_ids[el_panel[e_d, 0]],
            "at_mm": _r(shell.nodes[shell.quads[e_d, a_d]] + origin, 1),
            "span_mm": round(span, 1),
            "limit_mm": round(limit, 2),
            "ratio": f"L/{span / max_disp:.0f}" if max_disp > 0 else "L/inf",
            "ok": checks["deflection"],
        },
        "stress": {
            "max_von_mises_MPa": round(max_vm, 2),
            "fy_MPa": fy,
            "utilisation": round(max_vm / fy, 4),
            "combination": uls[k_u].name,
            "panel": panel_ids[el_panel[e_u, 0]],
            "part": _part_of(shell, int(e_u), panel_ids, int(el_panel[e_u, 0])),
            "at_mm": _r(shell.nodes[shell.quads[e_u]].mean(axis=0) + origin, 1),
            "ok": checks["stress"],
        },
        "buckling": {
            "combination": governing.name,
            "selected_by": "largest compressive membrane force of the ULS combinations",
            "factors": [m["factor"] for m in modes[:MIN_POSITIVE_MODES]],
            "all_factors": [significant(f, 4) for f in factors],
            "required": round(required, 3),
            "first": significant(first, 4),
            "checked": significant(checked_factor(first, convergence), 4),
            "convergence": convergence,
            "modes": modes[: max(MIN_POSITIVE_MODES, 10)],
            "note": local_note,
            "gnia": None if imperfect is None else imperfect.summary(),
            "ok": checks["buckling"],
        },
        "checks": checks,
        "ok": all(checks.values()),
        "panels": per_panel,
        "files": [f"structure/{name}" for name in files],
    }
    one_sided = any(i.code == "supports-one-sided" for i in issues)
    issues += failed_check_issues(summary, one_sided)
    displacement = node_values(shell, np.einsum("c,ceaj->eaj", f_sls[k_d], u_el))
    metrics = {
        "peak_memory_mb": max(run.peak_memory_mb, brun.peak_memory_mb),
        "seconds": seconds,
        "equations": _equations(run.log),
        "static_decks": run.decks,
    }
    return Structure(
        True,
        summary,
        shell,
        displacement,
        util_el,
        mode_shape,
        panel_ids,
        files,
        tuple(issues),
        metrics,
    )


def _equations(log_path: Path) -> int:
    """Number of equations CalculiX solved (from its log), 0 if not printed."""
    text = Path(log_path).read_text(errors="replace").split()
    for i, word in enumerate(text[:-1]):
        if word == "equations" and text[i + 1].isdigit():
            return int(text[i + 1])
    return 0


def element_counts(mesh: dict) -> str:
    """The summary's element counts by type, for a line of text: ``4800 S8R + 400 S8``."""
    counts = [(mesh.get(kind, 0), kind) for kind in ("S8R", "S8", "S6")]
    text = " + ".join(f"{n} {kind}" for n, kind in counts if n)
    return text or f"{mesh['elements']} S8R"


def _stiffeners_in(shell: ShellModel, lumped_kg: float) -> str:
    """How the corner stiffeners are in the model, for the summary."""
    names = [g.name for g in shell.groups]
    plates = int((shell.group == names.index("STF")).sum()) if "STF" in names else 0
    text = f"{plates} S8 plates tied to their ribs and sheets (hinged weld lines)" if plates else ""
    if lumped_kg > 0:
        text += ("; " if text else "") + f"{lumped_kg:g} kg lumped, stiffness not modelled"
    return text or "none in the model"


def _part_of(shell: ShellModel, e: int, panel_ids, p: int) -> str:
    name = shell.groups[shell.group[e]].name
    el_panel, el_side = panel_labels(shell)
    own, other = el_panel[e]
    if name in ("TOP", "BOT"):
        return f"{panel_ids[own]}-{name}"
    if name == "STF":
        return f"{panel_ids[own]} corner stiffener"
    side = int(el_side[e])
    label = f"{panel_ids[own]}-RIB-{side}"
    if other >= 0:
        label += f" + {panel_ids[other]} rib (back to back)"
    return label


def _r(values, digits: int) -> list:
    return np.round(np.asarray(values, float), digits).tolist()
