"""Panelise: cover the design surface with a quad panel layout.

Methods:

- ``grid``: a structured grid for four-sided surfaces; a single B-rep face is gridded in its own
  parameters.
- ``skeleton``: the medial-axis method (Tam & Armstrong 1991, Rigby 2003, Oval et al. 2018) for
  surfaces with openings and irregular outlines: a coarse quad decomposition of the boundary's
  projection, densified per strip to the target size, lifted onto the surface and relaxed there.
- ``field``: a boundary-aligned cross field quantised into quads by gmsh's quasi-structured
  mesher, on a conformal flattening of the surface (:mod:`.field`).
- ``layout``: a quad mesh drawn by hand, mapped onto the surface.

``auto`` picks ``grid`` for four-sided surfaces without openings (and the field layout where
the grid fails a gate and the field scores better); otherwise the ``field`` layout where it
passes every gate, and where it fails one, the ``skeleton`` layout too (up to 500 field
panels), keeping the one with the better score by the layout gates
(:func:`.gates.layout_score`), recording the scores and the reason in ``metrics["auto"]``.
Where ``singular_points`` are given it picks ``field``, the one method that makes every point a
vertex. Every layout is measured against the gates (:mod:`.gates`), whatever made it, and a
singular point that did not become a vertex is a ``singular-point-missed`` warning.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from ..data import PanelLayout, Surface
from ..errors import GeometryError, Issue
from ..job import Job
from ..surface import SurfaceQuery
from ..surface.design_boundary import DesignBoundary
from ..units import length_scale
from .estimate import check_panel_count
from .folds import on_folds
from .gates import (
    failed_gates,
    gate_issues,
    gate_measures,
    layout_score,
    meets_every_gate,
    min_panel_width,
)
from .grid import grid_panelize, is_four_sided
from .quality import vertex_valences

log = logging.getLogger(__name__)


def choose_method(surface: Surface, job: Job) -> str:
    """The method ``auto`` stands for on this surface (``"compare"``: skeleton and field both
    made, the better kept)."""
    method = job.panelize.method
    if method != "auto":
        return method
    if job.panelize.singular_points:
        return "field"
    return "grid" if is_four_sided(surface, job.panelize.corner_angle) else "compare"


def panelize(surface: Surface, job: Job, query: SurfaceQuery | None = None) -> PanelLayout:
    """Cover ``surface`` with quad panels as ``job.panelize`` asks (see the module docstring).

    Raises :class:`~fabpanel.errors.GeometryError` when the chosen method cannot handle the
    surface, with a message that names the method to use instead, and
    :class:`~fabpanel.errors.InputError` when the panel count shows a unit or size mistake
    (:func:`~.estimate.check_panel_count`).
    """
    check_panel_count(surface, job)
    query = query or SurfaceQuery(surface)
    method = choose_method(surface, job)
    if method == "compare":
        layout = _first_passing(surface, job, query, ("field", "skeleton"))
    else:
        layout = _gated(_layout_by_method(method, surface, job, query), surface, job, query)
        asked_counts = job.panelize.grid_u is not None or job.panelize.grid_v is not None
        if job.panelize.method == "auto" and not asked_counts:
            # a four-sided outline can still be a poor grid (a wavy strip, a notch): then the
            # field layout is made too and the better one kept
            layout = _first_passing(surface, job, query, ("grid", "field"), layout)
    if job.panelize.method == "auto" and job.panelize.singular_points:
        auto = {
            "chosen": "field",
            "reason": "singular_points given: the field method makes each one a panel vertex",
        }
        layout = replace(layout, metrics={**layout.metrics, "auto": auto})
    missed = _missed_points(layout, job, query, surface.origin)
    return replace(layout, origin=surface.origin, issues=tuple(layout.issues) + missed)


#: a singular point farther than this from every layout vertex was not made a vertex, mm
POINT_TOLERANCE = 1.0


def _missed_points(
    layout: PanelLayout, job: Job, query: SurfaceQuery, origin: np.ndarray
) -> tuple[Issue, ...]:
    """A warning for the ``singular_points`` (input units, design coordinates) that are not a
    layout vertex: each point's foot on the surface against the nearest vertex."""
    if not job.panelize.singular_points:
        return ()
    gaps = _point_gaps(layout, job, query, origin).min(axis=1)
    missed = np.flatnonzero(gaps > POINT_TOLERANCE)
    if not len(missed):
        return ()
    listed = ", ".join(f"{k + 1} ({gaps[k]:.0f} mm)" for k in missed[:6])
    return (
        Issue(
            "singular-point-missed",
            f"{len(missed)} of {len(gaps)} singular_points are not panel vertices: point "
            f"{listed} from the nearest vertex; the {layout.method} method does not insert "
            f'them: use [panelize] method = "field" (or "auto")',
        ),
    )


def _point_gaps(
    layout: PanelLayout, job: Job, query: SurfaceQuery, origin: np.ndarray
) -> np.ndarray:
    """(p, n) mm: from each of the ``singular_points``' feet on the surface (the points in
    input units and design coordinates, ``origin`` the surface's) to each layout vertex."""
    scale = length_scale(job.input.units or "mm")
    points = np.asarray(job.panelize.singular_points, dtype=float) * scale - origin
    feet, _, _ = query.closest(points)
    return np.linalg.norm(feet[:, None] - layout.vertices[None], axis=2)


def _first_passing(
    surface: Surface,
    job: Job,
    query: SurfaceQuery,
    methods: tuple[str, str],
    first: PanelLayout | None = None,
) -> PanelLayout:
    """The first method's layout if it passes every gate, else the better of both."""
    if first is None:
        try:
            first = _gated(_layout_by_method(methods[0], surface, job, query), surface, job, query)
        except GeometryError:
            return _better_layout(surface, job, query, methods)
    if _fails_a_gate(first) and _worth_a_skeleton(first, methods):
        return _better_layout(surface, job, query, methods, {methods[0]: first})
    if _fails_a_gate(first):
        failed = ", ".join(_failed_gates(first))
        reason = (
            f"{methods[0]} fails {failed}; {methods[1]} not tried: on {len(first.quads)} panels "
            f"(more than {SKELETON_CHALLENGE_PANELS}) its fold-free smoothing takes 10-30 s, "
            f"and it met no gate that the field layout missed on any benchmark shape"
        )
        auto = {
            "chosen": methods[0],
            "scores": {methods[0]: first.metrics["gates"]["score"]},
            "failed": {},
            "gates_failed": {methods[0]: _failed_gates(first)},
            "reason": reason,
        }
        return replace(first, metrics={**first.metrics, "auto": auto})
    score = first.metrics["gates"]["score"]
    auto = {
        "chosen": methods[0],
        "scores": {methods[0]: score},
        "failed": {},
        "reason": f"{methods[0]} passes every layout gate (score {score:.3f}); "
        f"{methods[1]} not tried",
    }
    return replace(first, metrics={**first.metrics, "auto": auto})


#: above this many panels a field layout that fails a gate is not challenged by the skeleton
SKELETON_CHALLENGE_PANELS = 500


def _worth_a_skeleton(first: PanelLayout, methods: tuple[str, str]) -> bool:
    """Whether the second method is worth making beside a first layout that fails a gate: the
    skeleton beside a field layout only up to ``SKELETON_CHALLENGE_PANELS`` (its smoothing
    took 29 s on a 1000-panel crescent, and it scored lower wherever both were made)."""
    return methods != ("field", "skeleton") or len(first.quads) <= SKELETON_CHALLENGE_PANELS


def _failed_gates(layout: PanelLayout) -> list[str]:
    return failed_gates(layout.issues)


def _fails_a_gate(layout: PanelLayout) -> bool:
    return bool(_failed_gates(layout))


#: boundary vertices closer than this fraction of the panel size to the design boundary are
#: moved onto it (a lifted polyline point lies on a chord of the outline, up to a few mm in)
SNAP_TO_BOUNDARY = 0.05


def on_design_boundary(layout: PanelLayout, surface: Surface, panel_size: float) -> PanelLayout:
    """The layout with its boundary vertices on the design boundary's smooth curve."""
    if layout.parameters is not None or not surface.boundary_loops:
        return layout  # a B-rep grid is exact in the face's own parameters
    _, on_boundary = vertex_valences(layout.quads, len(layout.vertices))
    feet, distance, _, _ = DesignBoundary(surface).locate(layout.vertices[on_boundary])
    near = distance <= SNAP_TO_BOUNDARY * panel_size
    vertices = layout.vertices.copy()
    index = np.flatnonzero(on_boundary)[near]
    vertices[index] = feet[near]
    return replace(layout, vertices=vertices)


def _gated(layout: PanelLayout, surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    """The layout, polished (:func:`_polished`), with its gate measures in
    ``metrics["gates"]`` and the gates' issues."""
    made = layout
    layout = on_design_boundary(layout, surface, job.panelize.panel_size)
    measures = gate_measures(layout, surface, job.panelize.panel_size)
    if _worth_polishing(layout, measures, job):
        layout = _polished(layout, job, query)
        measures = gate_measures(layout, surface, job.panelize.panel_size)
    layout = _measured_again(made, layout, surface, job, query)
    measures["score"] = layout_score(measures, min_panel_width(job))
    found = gate_issues(layout, measures, job)
    # the verdict beside the figures: the gates failed, by their issue's code
    measures["failed"] = failed_gates(found)
    measures["passed"] = not measures["failed"]
    return replace(
        layout,
        metrics={**layout.metrics, "gates": measures},
        issues=tuple(layout.issues) + found,
    )


def _measured_again(
    made: PanelLayout, layout: PanelLayout, surface: Surface, job: Job, query: SurfaceQuery
) -> PanelLayout:
    """``layout`` with the method's measures (:func:`.quality.layout_metrics`: edge lengths,
    corners, plate fit...) and their issues taken again where its vertices moved since it
    was ``made`` (snapped onto the design boundary, polished): they described the layout
    before that (a new user's roof read a shortest edge of 429 mm and corners of 46-134° in
    the manifest, 358 mm and 48-123° in its gates and in the panels written)."""
    if np.array_equal(made.vertices, layout.vertices):
        return layout
    from .quality import layout_metrics

    loops = [surface.vertices[loop] for loop in surface.boundary_loops]
    fresh, found = layout_metrics(layout, query, job.panelize.panel_size, job.cutting, loops)
    kept = tuple(i for i in layout.issues if i.code != "panel-exceeds-plate")
    return replace(layout, metrics={**layout.metrics, **fresh}, issues=kept + found)


def _worth_polishing(layout: PanelLayout, measures: dict, job: Job) -> bool:
    """Field and skeleton layouts are polished; a grid only where it fails a gate (one that
    passes keeps its vertices on the surface's parameter lines, its panels sized by the counts
    asked or derived from the panel size), and never one in a B-rep face's own (u, v); a
    layout read from the user's file stays as drawn."""
    if layout.method in ("field", "skeleton"):
        return True
    return (
        layout.method == "grid"
        and layout.parameters is None
        and not meets_every_gate(measures, min_panel_width(job), tips_apart=True)
    )


def _polished(layout: PanelLayout, job: Job, query: SurfaceQuery) -> PanelLayout:
    """The layout's vertices nudged into the gates' bands (:mod:`.polish`), with the report in
    ``metrics["polish"]``; singular points stay on their vertex, vertices on a fold line on
    the fold."""
    from .polish import PolishLimits, polish_layout

    vertices, report = polish_layout(
        layout.vertices,
        layout.quads,
        query,
        DesignBoundary(query.surface),
        PolishLimits.of(job),
        _singular_vertices(layout, job, query) | on_folds(layout.vertices, query.surface),
    )
    return replace(layout, vertices=vertices, metrics={**layout.metrics, "polish": report})


def _singular_vertices(layout: PanelLayout, job: Job, query: SurfaceQuery) -> np.ndarray:
    """(n,) bool: the layout vertices within ``POINT_TOLERANCE`` of a singular point."""
    fixed = np.zeros(len(layout.vertices), dtype=bool)
    if not job.panelize.singular_points:
        return fixed
    gaps = _point_gaps(layout, job, query, query.surface.origin)
    fixed[np.argmin(gaps, axis=1)[gaps.min(axis=1) <= POINT_TOLERANCE]] = True
    return fixed


def _better_layout(
    surface: Surface,
    job: Job,
    query: SurfaceQuery,
    methods: tuple[str, str],
    made: dict[str, PanelLayout] | None = None,
) -> PanelLayout:
    """The layouts of both methods (those not already ``made``); the one with the higher gate
    score, the first method on a tie."""
    made = dict(made or {})
    failed: dict[str, str] = {}
    for method in methods:
        if method in made:
            continue
        try:
            made[method] = _gated(
                _layout_by_method(method, surface, job, query), surface, job, query
            )
        except GeometryError as err:
            failed[method] = str(err)
    if not made:
        raise GeometryError(" / ".join(failed.values()))
    scores = {m: layout.metrics["gates"]["score"] for m, layout in made.items()}
    best = max(scores, key=lambda m: (scores[m], m == methods[0]))
    gates_failed = {m: _failed_gates(layout) for m, layout in made.items()}
    if failed:
        reason = f"{best}: the other method failed ({next(iter(failed.values()))})"
    elif len(scores) > 1:
        reason = (
            f"{best} scores {scores[best]:.3f} against {min(scores.values()):.3f} "
            f"(edges in band + corners in 60-120°, less penalties for failed gates)"
        )
    else:
        reason = best
    chosen = made[best]
    auto = {
        "chosen": best,
        "scores": scores,
        "failed": failed,  # methods that raised (could not make a layout), with why
        "gates_failed": gates_failed,  # per method made, the layout gates it fails
        "reason": reason,
    }
    log.info("auto layout: %s", reason)
    return replace(chosen, metrics={**chosen.metrics, "auto": auto})


def _layout_by_method(method: str, surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    if method == "grid":
        return grid_panelize(surface, job, query)
    if method == "layout":
        from .user_layout import user_layout

        path = (job.base_dir / job.panelize.layout).resolve()
        return user_layout(path, job.input.units, surface, query, job)
    if method == "field":
        return _field_layout(surface, job, query)
    from .decompose import skeleton_panelize

    return skeleton_panelize(surface, job, query)


def _field_layout(surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    """The field layout along the surface's fold lines; where that one fails a gate (or
    cannot be made), also the one across them, the better kept by the gates' score, which
    counts the panels across a fold as a failed gate. A fold closer to the boundary or to
    another fold than a panel can be wide (the two seams of a chamfer face) would make a row
    of slivers, where smoothing across it costs a few millimetres of fit."""
    from .field import field_panelize

    if not surface.folds:
        return field_panelize(surface, job, query)
    min_width = min_panel_width(job)
    made: dict[str, PanelLayout] = {}
    scores: dict[str, float] = {}
    for way in ("along", "across"):
        try:
            layout = field_panelize(surface, job, query, follow_folds=way == "along")
        except GeometryError:
            if way == "across" and not made:
                raise
            continue
        measures = gate_measures(layout, surface, job.panelize.panel_size)
        made[way], scores[way] = layout, layout_score(measures, min_width)
        if way == "along" and meets_every_gate(measures, min_width, tips_apart=True):
            break
    best = max(made, key=lambda way: (scores[way], way == "along"))
    folds = {"followed": best == "along", "scores": scores}
    return replace(made[best], metrics={**made[best].metrics, "folds": folds})


__all__ = ["choose_method", "panelize"]
