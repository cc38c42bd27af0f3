"""Build stage: the steel parts of every panel as exact OCCT solids, checked.

The parts of one panel are made by :func:`fabpanel.model.panel.build_panel` in worker processes
(only numpy arrays and BREP bytes cross the process boundary); this module sequences them and
runs the checks that need several panels: back-to-back ribs in contact, bolt holes of a joint
coaxial, neighbouring sheet edges identical, and the clash check (:mod:`fabpanel.model.clash`).

A panel that cannot be built (OCCT fails on one of its parts, a degenerate developed grid)
does not stop the stage: it becomes a ``panel-not-built`` error issue naming the panel, the part
and the reason, its parts are left out of the model, and the checks that need two panels skip
the joints and corners it shares. Only when no panel at all can be built does the stage raise.
A worker process that dies (``BrokenProcessPool``), Ctrl-C and ``MemoryError`` are not a bad
panel and propagate.

The build-up (faces, thicknesses, welds, bolts) is :class:`fabpanel.buildup.Buildup`.

Sandwich panels after the thesis (§6, §7.3.2); rib planes and bevels after Pottmann et al.,
"Architectural Geometry" (2007), chapter on support structures.
"""

from __future__ import annotations

import logging
import os
import time
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np

from ..buildup import Buildup
from ..data import DevelopedPanels, Model, Part
from ..errors import Issue, KernelError
from ..job import Job
from ..parallel import shared_pool, worker_pool
from ..tolerances import TOLERANCES
from .bolt_moves import MOVE_ROUNDS, Rooms, move_blocked_end_bolts
from .clash import Clash, SolidsOnDemand, find_clashes
from .nodes import node_planes
from .panel import build_panel
from .records import Failure, PanelPayload, PanelResult

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------------------------
# public stage
# --------------------------------------------------------------------------------------------
def build(
    developed: DevelopedPanels,
    job: Job,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Model:
    """Stage 3: the steel parts of every panel (:class:`~fabpanel.data.Model`).

    developed : the panels' sample grids, normals and rib planes.
    job : uses ``[sandwich]``, ``[material]`` and ``[cutting] neutral_fibre``.
    jobs : worker processes (default ``os.cpu_count()``); 1 builds inline.
    progress : called with 1 after each finished panel.

    A panel that cannot be built becomes a ``panel-not-built`` error in ``Model.issues`` (and
    ``metrics["not_built"]``), the others are built and checked; parts that miss a tolerance
    (sheet fit, rib planarity, rib contact) become ``Model.issues`` too. Raises
    :class:`~fabpanel.errors.KernelError` when no panel at all could be built, and lets
    ``BrokenProcessPool`` (a worker died), ``MemoryError`` and ``KeyboardInterrupt`` through.
    """
    started = time.perf_counter()
    buildup = Buildup.of(job)
    m = len(developed.panel_ids)
    neighbours = developed.layout.side_neighbours
    nodes = node_planes(developed.layout, developed.side_planes, buildup.welds.erection_gap)
    payloads = [
        PanelPayload(
            panel_id=developed.panel_ids[p],
            samples=np.asarray(developed.samples[p], float),
            normals=np.asarray(developed.normals[p], float),
            planes=np.asarray(developed.side_planes[p], float),
            interior=neighbours[p] >= 0,
            # one panel per joint supplies its packing plates: the one with the lower index
            packs=neighbours[p] > p,
            buildup=buildup,
            slide_limit=TOLERANCES.trim_slide * buildup.total_depth,
            fibre=job.cutting.neutral_fibre,
            origin=np.asarray(developed.layout.origin, float),
            nodes=nodes[p],
        )
        for p in range(m)
    ]
    workers = max(1, min(jobs or os.cpu_count() or 1, m))
    results: list[PanelResult | None] = [None] * m
    # one pool of fresh workers for the first pass and every round of moves: the moves run
    # manifold3d here, and its thread pool (TBB's) does not survive a fork
    with shared_pool(workers):
        _run_payloads(payloads, list(range(m)), results, workers, developed, progress)
        if buildup.access is not None:
            # end bolts the tool cannot reach are moved along their joint, both panels rebuilt
            rooms: Rooms = {}
            for _ in range(MOVE_ROUNDS):
                moved = move_blocked_end_bolts(developed, payloads, results, buildup, rooms)
                if not moved:
                    break
                _run_payloads(payloads, sorted(moved), results, workers, developed, None)

    # every panel was waited for: each result is a panel's parts or its failure
    done = [r for r in results if r is not None and r.failure is None]
    failed = [r for r in results if r is not None and r.failure is not None]
    for result in failed:
        assert result.failure is not None
        log.error("panel %s not built: %s", result.panel_id, result.failure.reason)
        log.debug("panel %s: %s", result.panel_id, result.failure.traceback)
    if failed and not done:
        first = failed[0]
        raise KernelError(f"no panel could be built; {first.panel_id}: {_failure_message(first)}")
    material, density = job.material.name, float(job.material.density)
    parts: list[Part] = []
    for result in done:
        for record in result.parts:
            parts.append(
                Part(
                    id=record["id"],
                    kind=record["kind"],
                    panel_id=result.panel_id,
                    material=material,
                    thickness=record["thickness"],
                    volume=record["volume"],
                    area=record["area"],
                    mass=record["volume"] * density,
                    centroid=record.get("centroid"),
                    brep=record["brep"],
                    surface_grid=record.get("surface_grid"),
                    outline=record.get("outline"),
                    frame=record.get("frame"),
                    holes=tuple(record.get("holes", ())),
                    openings=tuple(record.get("opening_loops", ())),
                    opening_area=float(record.get("opening_area", 0.0)),
                )
            )
    metrics, issues = _model_metrics(
        developed, parts, done, time.perf_counter() - started, buildup.welds.erection_gap
    )
    metrics["panels_built"] = len(done)
    metrics["panels_not_built"] = len(failed)
    metrics["not_built"] = {r.panel_id: _failure_message(r) for r in failed}
    issues = [
        Issue(
            "panel-not-built",
            f"panel {r.panel_id} not built: "
            f"{_failure_message(r)}; its parts are missing from every output",
            r.panel_id,
            "error",
        )
        for r in failed
    ] + issues
    hanging, below = _hanging_below(developed, buildup)
    metrics["below_design_mm"] = round(below, 1)
    issues += hanging
    log.info(
        "built %d parts of %d panels in %.1f s%s",
        len(parts),
        len(done),
        metrics["seconds"],
        f" ({len(failed)} panels not built)" if failed else "",
    )
    return Model(parts=tuple(parts), developed=developed, metrics=metrics, issues=tuple(issues))


#: mm: a build-up reaching further than this below the design's lowest point is said (the
#: foundations or the floor must take it)
BELOW_DESIGN = 10.0


def _hanging_below(developed: DevelopedPanels, buildup: Buildup) -> tuple[list[Issue], float]:
    """How far the build-up reaches below the design surface's lowest point, mm, and a note
    (info: a fact for the foundations, not a defect; most shells standing on their rim have it)
    where that is more than ``BELOW_DESIGN``: with the design on the top sheet, a vault whose
    sheets rise at 40 degrees from the ground has its bottom sheet 121 mm below the springing
    and its base ribs' anchor line half that, which the foundations must be set for."""
    samples, normals = developed.samples, developed.normals
    lowest = float(samples[..., 2].min())
    offsets = buildup.offset_map.values()
    reach = min(float((samples + o * normals)[..., 2].min()) for o in (min(offsets), max(offsets)))
    below = max(0.0, lowest - reach)
    if below <= BELOW_DESIGN:
        return [], below
    return [
        Issue(
            "below-design",
            f"the build-up reaches {below:.0f} mm below the design surface's lowest point "
            f"(design_face = {buildup.design_face!r}: the sheets and ribs are that far off the "
            "design along its normals): set the supports and foundations that much lower, or "
            'put the design on the bottom sheet ([sandwich] design_face = "bottom-outer")',
            "",
            "info",
        )
    ], below


def _run_payloads(
    payloads: list[PanelPayload],
    indices: list[int],
    results: list[PanelResult | None],
    workers: int,
    developed: DevelopedPanels,
    progress: Callable[[int], None] | None,
) -> None:
    """Build the panels ``indices`` (inline with one worker, else in worker processes) into
    ``results``."""
    if workers == 1 or len(indices) == 1:
        for p in indices:
            results[p] = _build_or_failure(payloads[p])
            if progress:
                progress(1)
        return
    # fresh workers (the shared pool's): this process may have run manifold3d or spyrrow
    with worker_pool(min(workers, len(indices)), fresh=True) as pool:
        futures = {pool.submit(_build_or_failure, payloads[p]): p for p in indices}
        for future in as_completed(futures):
            p = futures[future]
            try:
                results[p] = future.result()
            except (BrokenProcessPool, MemoryError):
                raise  # a worker died or memory ran out: stop the run
            except Exception as err:  # noqa: BLE001 - e.g. a result that did not unpickle
                results[p] = _failure(developed.panel_ids[p], developed.panel_ids[p], err)
            if progress:
                progress(1)


def _build_or_failure(payload: PanelPayload) -> PanelResult:
    """:func:`build_panel`, or when it raises a result whose ``failure`` names the part and the
    reason: plain data, so it crosses the process boundary whatever the exception (OCCT's own
    exceptions do not always pickle). Runs in the worker processes."""
    where = [payload.panel_id]
    try:
        return build_panel(payload, where)
    except MemoryError:
        raise
    except Exception as err:  # noqa: BLE001 - any failure of one panel is that panel's issue
        return _failure(payload.panel_id, where[-1], err)


def _failure(panel_id: str, part: str, err: BaseException) -> PanelResult:
    reason = str(err).strip() or "no message"
    if not isinstance(err, KernelError):
        reason = f"{type(err).__name__}: {reason}"
    trace = "".join(traceback.format_exception(err))
    return PanelResult(panel_id=panel_id, failure=Failure(part, reason, trace))


def _failure_message(result: PanelResult) -> str:
    """``part P012-BOT: <reason>``: the part being built when the panel failed, and why."""
    failure = result.failure
    assert failure is not None
    if failure.part == result.panel_id:
        return failure.reason
    return f"part {failure.part}: {failure.reason}"


# --------------------------------------------------------------------------------------------
# metrics
# --------------------------------------------------------------------------------------------
def _model_metrics(
    developed: DevelopedPanels,
    parts: list[Part],
    results: list[PanelResult],
    seconds: float,
    erection_gap: float,
) -> tuple[dict[str, Any], list[Issue]]:
    """Measures and issues of the built panels (``results``: :func:`build_panel`'s records of
    the panels that were built; joints and corners with a panel not built are skipped)."""
    tol = TOLERANCES
    issues: list[Issue] = []
    counts: dict[str, int] = {}
    for part in parts:
        counts[part.kind] = counts.get(part.kind, 0) + 1
    per_panel: dict[str, Any] = {}
    fit, planarity, slide = [0.0], [0.0], [0.0]
    for result in results:
        pid, meas = result.panel_id, result.measures
        per_panel[pid] = _jsonable({k: v for k, v in meas.items() if k not in HANDOVER})
        fit.append(meas["sheet_fit_error_mm"])
        slide.append(meas["sheet_trim_slide_mm"])
        if meas["sheet_fit_error_mm"] > tol.sheet_fit:
            issues.append(
                Issue(
                    "sheet-fit",
                    f"B-spline sheet faces miss the trimmed developed "
                    f"surface by {meas['sheet_fit_error_mm']:.3f} mm "
                    f"(> {tol.sheet_fit} mm)",
                    pid,
                )
            )
        for part_id, value in meas.get("plate_planarity_mm", {}).items():
            planarity.append(value)
            if value > tol.rib_planarity:
                issues.append(
                    Issue(
                        "plate-not-planar",
                        f"plate faces deviate {value:.3f} mm from flat (> {tol.rib_planarity} mm)",
                        part_id,
                    )
                )
        for finding in result.findings:
            code, part_id, message, *severity = finding
            issues.append(Issue(code, message, part_id, *severity))  # type: ignore[arg-type]
        if not meas["valid"]:
            issues.append(
                Issue("invalid-solid", "a solid of this panel is not valid in OCCT", pid, "error")
            )
    built = {result.panel_id for result in results}
    gap = _rib_contact_gap(developed, parts, built, issues, erection_gap)
    coaxial = _bolt_coaxiality(developed, results, issues)
    mismatch = _edge_mismatch(developed, results)
    clashes, clash_measures = _clash_check(developed, results)
    for a, b, shared, centre in clashes:
        where = ", ".join(f"{c:.0f}" for c in centre + developed.layout.origin)
        issues.append(
            Issue(
                "clash",
                f"{a} and {b} interpenetrate by {shared:.0f} mm3 at ({where}) mm",
                a,
                "error",
            )
        )
    volume = float(sum(p.volume for p in parts))
    metrics = {
        "parts": len(parts),
        "counts": counts,
        "total_mass_kg": round(float(sum(p.mass for p in parts)), 3),
        "total_volume_mm3": round(volume, 1),
        "bolt_holes": int(sum(len(p.holes) for p in parts if p.kind == "rib")),
        "access_openings": int(sum(len(p.openings) for p in parts if p.kind.startswith("sheet"))),
        **_bolt_counts(results),
        "max_sheet_fit_error_mm": float(max(fit)),
        "max_sheet_trim_slide_mm": float(max(slide)),
        "max_sheet_edge_mismatch_mm": mismatch,
        "max_plate_planarity_mm": float(max(planarity)),
        **_node_cuts(results),
        "max_rib_contact_gap_mm": gap,
        "max_bolt_coaxial_error_mm": coaxial,
        "clash": clash_measures,
        "all_valid": all(r.measures["valid"] for r in results),
        "seconds": round(seconds, 2),
        "panels": per_panel,
    }
    return metrics, issues


def _node_cuts(results: list[PanelResult]) -> dict[str, Any]:
    """How many rib ends the node cuts shortened (:mod:`fabpanel.model.nodes`) and by how
    much at most, mm (along an edge of the rib: the bottom edge, where the planes part)."""
    cuts = [v for r in results for v in r.measures.get("rib_node_cut_mm", {}).values()]
    return {"ribs_cut_at_nodes": len(cuts), "max_rib_node_cut_mm": max(cuts, default=0.0)}


def _bolt_counts(results: list[PanelResult]) -> dict[str, Any]:
    """``bolts_total``: the bolts of the built panels' joints, each once (the two ribs' holes
    of a bolt are coaxial: centres within 1 mm are one bolt); ``bolts_unreachable``: those the
    tool cannot reach from one side or the other (None when the job has no access sheet: not
    checked); ``bolts_unreachable_ids``: one rib's name for each."""
    from scipy.cluster.hierarchy import DisjointSet
    from scipy.spatial import cKDTree

    names, centres, flagged = [], [], []
    for result in results:
        marked = {tuple(b) for b in result.measures.get("bolts_unreachable", [])}
        for side, stack in result.bolts.items():
            for i, centre in enumerate(stack):
                names.append(f"{result.panel_id}-RIB-{side} bolt {i}")
                centres.append(centre)
                flagged.append((side, i) in marked)
    bolts = DisjointSet(range(len(names)))
    if centres:
        for a, b in cKDTree(np.array(centres)).query_pairs(1.0):
            bolts.merge(a, b)
    groups = bolts.subsets()
    blocked = [min(names[i] for i in g) for g in groups if any(flagged[i] for i in g)]
    checked = bool(results) and all(r.measures.get("bolts_checked") for r in results)
    return {
        "bolts_total": len(groups),
        "bolts_unreachable": len(blocked) if checked else None,
        "bolts_unreachable_ids": sorted(blocked),
    }


def _joints(
    developed: DevelopedPanels, built: set[str] | None = None
) -> Iterator[tuple[int, int, int, int]]:
    """Each interior joint once: (panel p, side s, panel q, side t); with ``built`` (panel
    ids), only the joints whose two panels are both in it."""
    neighbours = developed.layout.side_neighbours
    ids = developed.panel_ids
    for p in range(len(neighbours)):
        for s in range(4):
            q = int(neighbours[p, s])
            if q > p and (built is None or (ids[p] in built and ids[q] in built)):
                for t in np.flatnonzero(neighbours[q] == p):
                    yield p, s, q, int(t)


def _bolt_coaxiality(
    developed: DevelopedPanels, results: list[PanelResult], issues: list[Issue]
) -> float:
    """Largest distance between the hole centres of back-to-back ribs, mm (both in the shared
    plane; the axes are that plane's normal)."""
    by_panel = {r.panel_id: r.bolts for r in results}
    ids = developed.panel_ids
    worst = 0.0
    for p, s, q, t in _joints(developed, set(by_panel)):
        a, b = by_panel[ids[p]].get(s), by_panel[ids[q]].get(t)
        if a is None or b is None:
            continue
        if len(a) != len(b):
            issues.append(
                Issue(
                    "bolt-mismatch",
                    f"{len(a)} bolts against {len(b)} in {ids[q]}-RIB-{t}",
                    f"{ids[p]}-RIB-{s}",
                    "error",
                )
            )
            continue
        error = float(np.linalg.norm(a - b[::-1], axis=1).max())
        worst = max(worst, error)
        if error > TOLERANCES.bolt_coaxial:
            issues.append(
                Issue(
                    "bolt-mismatch",
                    f"bolt holes {error:.3f} mm off those of {ids[q]}-RIB-{t}",
                    f"{ids[p]}-RIB-{s}",
                    "error",
                )
            )
    return worst


def _edge_mismatch(developed: DevelopedPanels, results: list[PanelResult]) -> float:
    """Largest distance between a top sheet's outer edge and its neighbour's along their joint,
    mm (each point to the other's polyline)."""
    edges = {r.panel_id: r.top_edges for r in results}
    ids = developed.panel_ids
    worst = 0.0
    for p, s, q, t in _joints(developed, set(edges)):
        worst = max(worst, _polyline_distance(edges[ids[p]][s], edges[ids[q]][t][::-1]))
    return worst


def _polyline_distance(points: np.ndarray, line: np.ndarray) -> float:
    """Largest distance of ``points (n, 3)`` to the polyline ``line (m, 3)``, mm."""
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(
        np.einsum("nmd,md->nm", points[:, None] - a[None], ab)
        / np.maximum(np.einsum("md,md->m", ab, ab), 1e-300),
        0.0,
        1.0,
    )
    foot = a[None] + t[..., None] * ab[None]
    return float(np.linalg.norm(points[:, None] - foot, axis=2).min(axis=1).max())


def _clash_check(
    developed: DevelopedPanels, results: list[PanelResult]
) -> tuple[list[Clash], dict[str, Any]]:
    """Clashes between the parts of each built panel and between built panels that share a
    corner (and so possibly a side); see :func:`fabpanel.model.clash.find_clashes`."""
    shapes: dict[str, tuple] = {}
    groups: dict[str, list[str]] = {}
    for result in results:
        groups[result.panel_id] = [part["id"] for part in result.parts]
        for part in result.parts:
            shapes[part["id"]] = part["clash_shape"]
    quads = developed.layout.quads
    ids = developed.panel_ids
    # panels that share a corner (and so possibly a side)
    corner_panels: dict[int, list[int]] = {}
    for p, quad in enumerate(quads):
        for v in quad:
            corner_panels.setdefault(int(v), []).append(p)
    pairs = sorted(
        {
            (a, b)
            for around in corner_panels.values()
            for a in around
            for b in around
            if a < b and ids[a] in groups and ids[b] in groups
        }
    )
    return find_clashes(SolidsOnDemand(shapes), groups, [(ids[a], ids[b]) for a, b in pairs])


def _rib_contact_gap(
    developed: DevelopedPanels,
    parts: list[Part],
    built: set[str],
    issues: list[Issue],
    erection_gap: float = 0.0,
) -> float:
    """Largest distance between a rib's outer face corners and where they belong: its
    back-to-back neighbour's rib plane, or half the erection gap off it, mm (0 when there are
    no ribs; joints with a panel not built are skipped)."""
    ribs = {p.id: p for p in parts if p.kind == "rib"}
    if not ribs:
        return 0.0
    ids = developed.panel_ids
    worst = 0.0
    for p, s, q, t in _joints(developed, built):
        for (a, side_a), (b, side_b) in (((p, s), (q, t)), ((q, t), (p, s))):
            rib = ribs.get(f"{ids[a]}-RIB-{side_a}")
            if rib is None or rib.outline is None or rib.frame is None:
                continue
            plane = developed.side_planes[b, side_b]
            outline = np.asarray(rib.outline, dtype=float)
            world = np.c_[outline, np.zeros(len(outline)), np.ones(len(outline))] @ rib.frame.T
            off = (world[:, :3] @ plane[:3] - plane[3]) / np.linalg.norm(plane[:3])
            gap = float(np.abs(np.abs(off) - erection_gap / 2).max())
            worst = max(worst, gap)
            if gap > TOLERANCES.rib_contact_gap:
                issues.append(
                    Issue(
                        "rib-gap",
                        f"rib stands {gap:.3f} mm off its "
                        f"neighbour's rib plane (> "
                        f"{TOLERANCES.rib_contact_gap} mm)",
                        rib.id,
                    )
                )
    return worst


#: what a worker hands the main process for the bolt moves, not a measure of the panel (its
#: keys are tuples: no JSON)
HANDOVER = {"end_bolt_room"}


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    return value
