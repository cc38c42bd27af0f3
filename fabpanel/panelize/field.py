"""The ``field`` method: a cross field quantised into quads by gmsh, on a conformal flattening.

1. flatten the design surface conformally (:mod:`fabpanel.geom.conformal`): angles are kept and
   lengths scale by the same factor in every direction at each point, so the size field
   ``panel_size x scale`` is exact in every direction (a plane projection stretches along the
   slope only);
2. gmsh's quasi-structured quad mesher (Reberol et al. 2021) meshes the flat domain: a
   boundary-aligned cross field by heat diffusion, parallelograms packed along it, midpoint
   subdivision into quads, the irregular vertices moved and merged by local remeshing. The
   boundary loops are splines through the flattened design boundary, split at its corners
   (turning more than ``[panelize] corner_angle``); ``singular_points`` are embedded as mesh
   vertices; the domain is split along the surface's fold lines (:mod:`fabpanel.surface.folds`),
   so panel sides run along them, and the nodes there stay on the fold. It runs in a child process (:mod:`.gmsh_quads`), which also calibrates the size
   (layout.md §2.3); on a domain without openings whose layout fails a gate, a second mesh
   without QQS's pattern-based faces is made as well and the better layout kept
   (``TOPOLOGIES``);
3. the quads are smoothed, edited where that helps and mapped back onto the surface through
   the flattening's triangles (:mod:`.field_place`), and the boundary vertices are put on the
   design boundary exactly; where that layout fails a gate,
   small openings (about a panel across) are filled in for gmsh and the quad over each
   punched out afterwards (:mod:`.punch`), and the better layout kept;
4. while a panel does not fit the usable plate, gmsh's next finer meshes at the same size are
   placed (small layouts), then the layout is made again with the size field 12 % smaller
   near the panels that miss (up to three rounds), and where that layout fails a gate, also
   with panels 12 % smaller everywhere, as the skeleton method divides its strips again, and
   the better kept.

Any count of openings works; the surface must be one piece with a boundary (a closed surface
has no loop to flatten from) of disc-like topology with holes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from ..buildup import Buildup
from ..data import PanelLayout, Surface
from ..errors import GeometryError, Issue
from ..geom.conformal import conformal_flattening
from ..job import Job
from ..surface import SurfaceQuery
from ..surface.design_boundary import DesignBoundary
from ..units import length_scale
from .corners import ROUNDING_TURN, OutlineCorners, outline_corners, small_openings
from .decompose import oversize_panels
from .densify import Strip, quad_edges
from .field_mesh import Meshed, gmsh_quads
from .field_place import (
    CORNER_TOLERANCE,
    Domain,
    FlatQuads,
    fixed_nodes,
    placed_with_edits,
    polished,
)
from .gates import (
    EDGE_BAND,
    MIN_BAND_SHARE,
    MIN_EDGE,
    gate_measures,
    layout_score,
    meets_every_gate,
    min_panel_width,
)
from .lift import FlatMesh, barycentric_weights
from .punch import PunchFailed, punched
from .quality import layout_metrics
from .slide import BoundaryTrack
from .strip_ops import (
    EditedMesh,
    collapse_strip,
    split_strip,
    strips_to_collapse,
    strips_to_split,
)

log = logging.getLogger(__name__)

#: rounds of smaller panels while some panel does not fit the usable plate, and the factor
#: of each round near the panels that miss (:func:`_smaller_near_misses`)
PLATE_ROUNDS = 3
PLATE_SHRINK = 0.88
#: ... fully within the first many panel sizes of a missing panel's centre, not at all beyond
#: the second
NEAR_MISS = (1.0, 2.5)

#: a second layout (small openings punched or squared, another topology step) is made only
#: beside one of at most this many panels that fails a gate: an opening about a panel across
#: matters in a coarse layout, and a second layout doubled the pavilion's 25 s
SECOND_LAYOUT_UP_TO_PANELS = 500

#: QQS's topology steps (``Mesh.QuadqsTopologyOptimizationMethods``), tried in turn: first
#: pattern-based faces and disk quadrangulation, but no cavity remeshing (that step runs
#: against a time budget and gave different meshes run to run, up to 1 mm); then, on a domain
#: without openings where the first layout misses the plate or fails a gate, disk
#: quadrangulation alone, the better layout kept. The pattern-based step can mesh a smooth
#: outline as a disk, four valence-3 vertices deep inside and the same count on every ring of
#: panels out to the boundary: on a 12 m rounded square, boundary edges twice as long as the
#: inner ones, and twice the panel count once the boundary panels were made to fit the plate
#: (disk quadrangulation alone: 114 panels, every gate passed); on an ellipse at 0.35 m, a
#: quarter of the panel count. On domains with openings both gave the same meshes. (A domain
#: whose only openings are small ones filled in for punching is one without openings here.)
TOPOLOGIES = (110, 10)
#: ... beyond ``SECOND_LAYOUT_UP_TO_PANELS`` only where the first layout is as far off as this: a
#: share of edges in the gates' band under ``FAR_OFF_BAND``, or a count ratio outside
#: ``FAR_OFF_COUNT``
FAR_OFF_BAND = 0.8
FAR_OFF_COUNT = (0.7, 1.3)

#: gmsh's finer meshes are placed where the chosen one misses the plate while they have at
#: most this many times its quads: a plate round adds 1 / 0.88² = 1.29 times in the size
#: field, more where QQS's count jumps (34 quads, then 52 and 62 after two rounds, on a hypar)
FINER_AT_MOST = 1.5
#: ... on layouts of up to this many panels (area / size²): there QQS's steps are coarse; on
#: the pavilion (407) each finer mesh placed cost 10 s and none fitted (its trumpets)
FINER_UP_TO_PANELS = 300
#: ... where the first fits the plate but fails a gate, this many finer meshes are placed
#: beside it and the best kept
FINER_FOR_GATES = 2

#: strips split or collapsed in a layout that fails the gates on edge lengths
#: (:mod:`.strip_ops`): at most this many edits kept, each round placing the best this many
#: strips of each kind in turn
STRIP_ROUNDS = 3
STRIP_TRIES = 2


def field_panelize(
    surface: Surface, job: Job, query: SurfaceQuery, follow_folds: bool = True
) -> PanelLayout:
    """Panel layout by the field method (see the module docstring); ``follow_folds`` False
    meshes across the surface's fold lines as if they were not there."""
    settings = job.panelize
    name = surface.source.name
    if not surface.boundary_loops:
        raise GeometryError(
            f"{name}: the surface is closed (no boundary); the field method flattens it "
            f"from a boundary, cut it open first"
        )
    flat, scale = conformal_flattening(surface.vertices, surface.faces, surface.boundary_loops[0])
    flat_mesh = FlatMesh(flat, surface.faces, surface.vertices)
    # corners closer than the shortest edge the gates allow are one corner
    outline = outline_corners(
        surface, flat, settings.corner_angle, MIN_EDGE * settings.panel_size, settings.panel_size
    )
    points = _singular_points(surface, job, query, flat_mesh)
    boundary = DesignBoundary(surface)
    followed = surface.folds if follow_folds else ()
    min_width = min_panel_width(job)
    best: _Candidate | None = None
    punched_made = False
    scores: dict[str, float] = {}
    ways = _ways_with_small_openings(outline, surface, flat, job)
    for way, kept, mesher, punches in ways:
        if best is not None and (
            meets_every_gate(best.placed.measures, min_width, tips_apart=True)
            or len(best.placed.mesh.quads) > SECOND_LAYOUT_UP_TO_PANELS
        ):
            break
        if way == "squared" and punched_made:
            continue  # only where no quad could be punched: punched scored as well or better
        domain = Domain(
            flat_mesh=flat_mesh,
            scale=scale,
            flat_scale=scale,
            points=points,
            track=_boundary_track(kept, flat),
            boundary=boundary,
            query=query,
            target=settings.panel_size,
            punches=punches,
            longest_edge=min(Buildup.of(job).usable_plate),
            folds=tuple(flat[chain] for chain in followed),
            folds3d=tuple(surface.vertices[chain] for chain in followed),
        )
        try:
            # strips split or collapsed where it fails the gates on edge lengths
            fitted, domain = _fitted_layout(surface, mesher, domain, job)
            placed = _with_strip_edits(surface, domain, job, fitted)
        except PunchFailed as failed:
            log.info("small openings not punched: %s", failed)
            continue
        punched_made |= way == "punched"
        # the ways are compared as the stage leaves them, polished: a way ahead before the
        # polish can be behind after it (another way is made only where the best so far
        # fails a gate before it, as before the polish was measured here)
        final = _polished_measures(surface, placed, domain, job) if len(ways) > 1 else None
        candidate = _Candidate(placed, domain, final)
        scores[way] = round(layout_score(candidate.measures, min_width), 4)
        if best is None or scores[way] > layout_score(best.measures, min_width):
            placed.info["small_openings"] = way
            best = candidate
            outline = kept
    assert best is not None
    placed = best.placed
    vertices, quads, info = placed.vertices, placed.mesh.quads, placed.info
    info["small_openings_scores"] = scores  # each way made, by the gates' score
    layout = _layout(vertices, _orient_outwards(vertices, quads, query))
    loops3d = [surface.vertices[loop] for loop in surface.boundary_loops]
    metrics, found = layout_metrics(layout, query, settings.panel_size, job.cutting, loops3d)
    from .cross_field import curvature_alignment

    info["curvature_alignment"] = curvature_alignment(
        vertices, layout.edges, surface.vertices, surface.faces, query.mesh
    )
    info["align"] = settings.align
    metrics["field"] = info
    found = (*found, *_cut_corner_issues(surface, outline))
    log.info("field panelisation: %d panels", len(quads))
    return replace(layout, metrics=metrics, issues=found)


def _ways_with_small_openings(
    outline: OutlineCorners, surface: Surface, flat: np.ndarray, job: Job
) -> list[tuple[str, OutlineCorners, OutlineCorners, tuple[np.ndarray, ...]]]:
    """The ways of meshing the outline, tried in turn while the best so far fails a gate: as
    it is (``plain``); with the small openings (:mod:`.corners`) filled in and the quad over
    each punched out afterwards (``punched``, :mod:`.punch`); where no quad could be punched,
    with them as squares of four straight lines (``squared``: each side gets two edges, and
    on 24 random shapes and the benchmark's it never scored above the punched layout). Each
    as (name, outline kept, outline meshed, the punched openings' four flat corners each)."""
    ways: list[tuple[str, OutlineCorners, OutlineCorners, tuple[np.ndarray, ...]]] = [
        ("plain", outline, outline, ())
    ]
    small = small_openings(outline, surface, flat, job.panelize.panel_size)
    if small is None:
        return ways
    punches = tuple(flat[small.kept.loops[i][small.kept.corners[i]]] for i in small.indices)
    ways.append(("punched", small.kept, small.filled, punches))
    ways.append(("squared", small.kept, small.squared, ()))
    return ways


@dataclass(frozen=True)
class _Candidate:
    """One way of meshing the outline, placed, and the domain it was placed on."""

    placed: _Placed
    domain: Domain
    polished: dict | None = None  # the gates' measures after the polish, where compared

    @property
    def measures(self) -> dict:
        return self.placed.measures if self.polished is None else self.polished


def _polished_measures(surface: Surface, placed: _Placed, domain: Domain, job: Job) -> dict:
    """The gates' measures of a placed layout after the stage's last touch."""
    vertices = polished(domain, job, placed.mesh, placed.vertices)
    return gate_measures(_layout(vertices, placed.mesh.quads), surface, domain.target)


def _layout(vertices: np.ndarray, quads: np.ndarray) -> PanelLayout:
    ids = tuple(f"P{i + 1:03d}" for i in range(len(quads)))
    return PanelLayout(vertices=vertices, quads=quads, panel_ids=ids, method="field")


def _fitted_layout(
    surface: Surface, mesher: OutlineCorners, domain: Domain, job: Job
) -> tuple[_Placed, Domain]:
    """gmsh's quads of the outline ``mesher`` placed on the surface (the better of two
    topology settings where the first fails, ``TOPOLOGIES``), and the domain whose size field
    made it; while a panel misses the plate, made again with smaller panels (module
    docstring, step 4): near those that miss first, and where that layout still misses the
    plate, or fails a gate on at most ``SECOND_LAYOUT_UP_TO_PANELS`` panels, everywhere as
    well, the better kept.
    Raises :class:`.punch.PunchFailed` where the first mesh has a small opening no quad can
    be punched for."""
    min_width = min_panel_width(job)
    near, rounds = _plate_rounds(surface, mesher, domain, job, everywhere=False)
    placed = near[0]
    if rounds == 0 or (
        placed.fits
        and (
            len(placed.mesh.quads) > SECOND_LAYOUT_UP_TO_PANELS
            or meets_every_gate(placed.measures, min_width, True)
        )
    ):
        return near
    try:
        everywhere, _ = _plate_rounds(surface, mesher, domain, job, everywhere=True)
    except PunchFailed:
        return near
    placed.info["plate_rounds_everywhere"] = {
        "score_near": round(layout_score(placed.measures, min_width), 4),
        "score_everywhere": round(layout_score(everywhere[0].measures, min_width), 4),
    }
    return max(near, everywhere, key=lambda f: (f[0].fits, layout_score(f[0].measures, min_width)))


def _plate_rounds(
    surface: Surface, mesher: OutlineCorners, domain: Domain, job: Job, everywhere: bool
) -> tuple[tuple[_Placed, Domain], int]:
    """The layout of :func:`_fitted_layout` with its domain, and the rounds it took: while a
    panel misses the plate, made again with panels ``PLATE_SHRINK`` x smaller ``everywhere``
    or near those that miss (:func:`_smaller_near_misses`). A finer mesh of gmsh's that fits
    at the size before (:func:`_placed_mesh`) is kept beside one more round's result, and
    the better scoring layout taken (hypar_hole at 1.2 m, its opening meshed as a loop: 42
    panels at the asked size against 58 and 62 after one and two rounds everywhere). Where a
    later round's mesh has a small opening no quad can be punched for, the rounds stop."""
    size = job.panelize.panel_size
    min_width = min_panel_width(job)
    fitted: list[tuple[_Placed, Domain]] = []  # layouts of earlier rounds that fit
    best: tuple[_Placed, Domain] | None = None
    rounds = 0
    for rounds in range(PLATE_ROUNDS + 1):
        try:
            placed = _round_of_layouts(surface, mesher, domain, job, size, min_width)
        except PunchFailed:
            if best is None:
                raise
            break
        smallest = size / job.panelize.panel_size * np.min(domain.scale / domain.flat_scale)
        for layout in placed:
            layout.info.update(
                plate_rounds=rounds,
                plate_rounds_where="everywhere" if everywhere else "near",
                smallest_size_factor=round(float(smallest), 3),
            )
        # fits first, then the score; the first topology on a tie
        chosen = max(placed, key=lambda p: (p.fits, layout_score(p.measures, min_width)))
        best = (chosen, domain)
        done = chosen.fits and "finer_mesh" not in chosen.info
        if done or rounds == PLATE_ROUNDS or fitted:
            break  # (one round after a finer mesh that fitted, to compare)
        fitted += [(layout, domain) for layout in placed if layout.fits]
        if everywhere:
            size *= PLATE_SHRINK
            continue
        smaller = _smaller_near_misses(domain, chosen, job)
        if smaller is None:
            break  # no panel misses once placed (a finer mesh fitted): nothing to make smaller
        domain = smaller
    assert best is not None
    kept = max([best, *fitted], key=lambda f: (f[0].fits, layout_score(f[0].measures, min_width)))
    return kept, rounds


def _smaller_near_misses(domain: Domain, placed: _Placed, job: Job) -> Domain | None:
    """``domain`` with its size field ``PLATE_SHRINK`` x smaller near the panels of ``placed``
    that miss the plate (within ``NEAR_MISS[0]`` panel sizes of a missing panel's centre,
    blending to unchanged at ``NEAR_MISS[1]``), where it was the same everywhere: one
    oversize panel at a tip of seed 63 of ``benchmarks/random_shapes.py`` made its 35 m² 53
    panels, not 42. The size field is the panel size x ``domain.scale``, the flat length per
    surface length, for gmsh and for the smoothing alike: a smaller scale asks for smaller
    panels there. None where no panel of ``placed`` misses the plate (it fitted with a finer
    mesh of gmsh's, or its miss was measured before the last smoothing)."""
    from scipy.spatial import cKDTree

    mesh = placed.mesh
    missing = oversize_panels(placed.vertices, mesh.quads, job)
    if not missing.any():
        return None
    centres = mesh.nodes[mesh.quads[missing]].mean(axis=1)
    flat = domain.flat_mesh.flat
    # surface distance in panel sizes: flat distance over the flattening's own scale
    reach = cKDTree(centres).query(flat)[0] / domain.flat_scale / job.panelize.panel_size
    near, far = NEAR_MISS
    weight = np.clip((far - reach) / (far - near), 0.0, 1.0)
    return replace(domain, scale=domain.scale * (1.0 - (1.0 - PLATE_SHRINK) * weight))


def _round_of_layouts(
    surface: Surface,
    mesher: OutlineCorners,
    domain: Domain,
    job: Job,
    size: float,
    min_width: float,
) -> list[_Placed]:
    """The layouts of one size: QQS's first topology setting, and its second where the first
    is worth another (:func:`_worth_another_topology`; a second that cannot be punched is
    left out)."""
    first, alone = TOPOLOGIES
    placed = [_placed_mesh(surface, mesher, domain, job, size, first)]
    if len(mesher.loops) == 1 and _worth_another_topology(placed[0], min_width):
        try:
            placed.append(_placed_mesh(surface, mesher, domain, job, size, alone))
        except PunchFailed as failed:
            log.info("second topology not punched: %s", failed)
    return placed


def _worth_another_topology(placed: _Placed, min_width: float) -> bool:
    """Whether a layout of a domain without openings is worth making again with the second
    of ``TOPOLOGIES``: where it fails a gate (the design's tips apart), on a small layout, or
    on any layout where it is far off (misses the plate, or its count or edge lengths are far
    from the asked size: the disk pattern's symptom). A thousand-panel layout that misses by
    a corner or two is not worth the second mesh, which doubles the time."""
    measures = placed.measures
    if placed.fits and meets_every_gate(measures, min_width, tips_apart=True):
        return False
    far_off = (
        not placed.fits
        or measures["edges_in_band"] < FAR_OFF_BAND
        or not FAR_OFF_COUNT[0] <= measures["count_ratio"] <= FAR_OFF_COUNT[1]
    )
    return far_off or measures["panels_for_area"] <= SECOND_LAYOUT_UP_TO_PANELS


def _better_of_finer(
    surface: Surface, domain: Domain, job: Job, meshes: list[Meshed], first: _Placed
) -> _Placed:
    """Where the first mesh fits the plate but fails a gate, gmsh's next ``FINER_FOR_GATES``
    finer meshes (up to ``FINER_AT_MOST`` x the quads) placed too, and the one that fits and
    scores best on the gates kept (``info["finer_mesh_for_gates"]``): QQS's meshes at the
    next size factors differ in topology, not only in count (random seed 57 at 1 m: its
    punched mesh left a rectangular opening two corners of two panels, 147°; the next finer
    one has three at each and passes every gate)."""
    min_width = min_panel_width(job)
    if meets_every_gate(first.measures, min_width, tips_apart=True):
        return first
    best, best_key = first, layout_score(first.measures, min_width)
    for tried, placed in _finer_placed(surface, domain, job, meshes[: 1 + FINER_FOR_GATES]):
        key = layout_score(placed.measures, min_width)
        if placed.fits and key > best_key:
            placed.info["finer_mesh_for_gates"] = tried
            best, best_key = placed, key
    return best


@dataclass(frozen=True)
class _Placed:
    """One of gmsh's meshes placed on the surface, measured by the gates."""

    vertices: np.ndarray
    mesh: FlatQuads
    info: dict
    fits: bool
    measures: dict


def _placed_mesh(
    surface: Surface, mesher: OutlineCorners, domain: Domain, job: Job, size: float, topology: int
) -> _Placed:
    """gmsh's quads at panel ``size`` with QQS's ``topology`` steps, placed on the surface;
    where a panel misses the plate, gmsh's next finer meshes at the same size are placed in
    turn (up to ``FINER_AT_MOST`` x the quads, on small layouts; one that cannot be punched is
    passed over), the first that fits kept: QQS's count moves in steps (34, 42, 50, 58 quads
    on a hypar at 1.2 m), and a step finer often fits where the caller's plate round, 12 %
    smaller everywhere, would add a third more panels."""
    meshes = gmsh_quads(
        surface,
        domain.flat_mesh.flat,
        domain.scale,
        mesher,
        domain.points,
        job,
        size,
        topology,
        domain.folds,
    )
    first = _placed(surface, domain, job, meshes[0])
    if surface.area / size**2 > FINER_UP_TO_PANELS:
        return first
    if first.fits:
        return _better_of_finer(surface, domain, job, meshes, first)
    for tried, placed in _finer_placed(surface, domain, job, meshes):
        if placed.fits:
            placed.info["finer_mesh"] = tried
            return placed
    return first


def _finer_placed(surface: Surface, domain: Domain, job: Job, meshes: list[Meshed]):
    """``(k, placed)`` for gmsh's finer meshes ``meshes[1:]`` in turn, placed as the caller
    asks, up to ``FINER_AT_MOST`` x the first's quads; one that cannot be punched is passed
    over."""
    for tried, finer in enumerate(meshes[1:], start=1):
        if len(finer.quads) > FINER_AT_MOST * len(meshes[0].quads):
            return
        try:
            yield tried, _placed(surface, domain, job, finer)
        except PunchFailed:
            continue


def _placed(surface: Surface, domain: Domain, job: Job, meshed: Meshed) -> _Placed:
    """One of gmsh's meshes punched (small openings) and placed on the surface."""
    nodes, quads, on_curve = meshed.nodes, meshed.quads, meshed.on_curve
    if domain.punches:
        nodes, quads, on_curve = punched(
            nodes, quads, on_curve, domain.punches, fixed_nodes(domain, nodes)
        )
    mesh = FlatQuads(nodes, quads, on_curve, meshed.size)
    info = dict(meshed.info)
    mesh, vertices, info["relaxation"], fits = placed_with_edits(domain, mesh, job)
    measures = gate_measures(_layout(vertices, mesh.quads), surface, domain.target)
    return _Placed(vertices, mesh, info, fits, measures)


def _with_strip_edits(surface: Surface, domain: Domain, job: Job, placed: _Placed) -> _Placed:
    """Where a layout of at most ``SECOND_LAYOUT_UP_TO_PANELS`` fails the edge band or the
    shortest edge, strips split or collapsed (:mod:`.strip_ops`) and the layout placed again,
    an edit kept where every panel still fits (if it did) and the gates' score rises; up to
    ``STRIP_ROUNDS`` edits, each round trying the ``STRIP_TRIES`` best strips of each kind (the
    kind with more edges out of the band first). ``info["strip_edits"]`` says what was tried,
    refused and kept, with the panels and the share in band before and after."""
    target = domain.target
    min_width = min_panel_width(job)
    if _edges_pass(placed.measures) or len(placed.mesh.quads) > SECOND_LAYOUT_UP_TO_PANELS:
        return placed
    best = placed
    report = {"tried": 0, "refused": 0, "split": 0, "collapsed": 0}
    for _ in range(STRIP_ROUNDS):
        better = None
        for kind, edited in _strip_edits(domain, best, report):
            mesh = FlatQuads(edited.nodes, edited.quads, edited.on_curve, best.mesh.size)
            mesh, vertices, relaxation, fits = placed_with_edits(domain, mesh, job)
            measures = gate_measures(_layout(vertices, mesh.quads), surface, target)
            if (fits or not best.fits) and layout_score(measures, min_width) > layout_score(
                best.measures, min_width
            ):
                info = {**best.info, "relaxation": relaxation}
                better = _Placed(vertices, mesh, info, fits, measures)
                report[kind] += 1
                break
        if better is None:
            break
        best = better
        if _edges_pass(best.measures):
            break
    best.info["strip_edits"] = {
        **report,
        "panels": [len(placed.mesh.quads), len(best.mesh.quads)],
        "edges_in_band": [placed.measures["edges_in_band"], best.measures["edges_in_band"]],
    }
    return best


def _edges_pass(measures: dict) -> bool:
    """Whether a layout passes the two gates on edge lengths (band and shortest edge)."""
    return (
        measures["edges_in_band"] >= MIN_BAND_SHARE
        and measures["shortest_edge_vs_panel_size"] >= MIN_EDGE
    )


def _strip_edits(domain: Domain, placed: _Placed, report: dict):
    """The meshes of :func:`_with_strip_edits`'s round, made one by one as the caller asks:
    ``(kind, EditedMesh)`` with ``kind`` "split" or "collapsed"; refused collapses counted in
    ``report``. The kind with more edges out of the band on its side comes first."""
    mesh, target, track = placed.mesh, domain.target, domain.track
    edges, _ = quad_edges(mesh.quads)
    lengths = np.linalg.norm(placed.vertices[edges[:, 0]] - placed.vertices[edges[:, 1]], axis=1)
    splits = strips_to_split(mesh.quads, lengths, target, EDGE_BAND)[:STRIP_TRIES]
    collapses = strips_to_collapse(mesh.quads, lengths, target, EDGE_BAND)[:STRIP_TRIES]
    fixed = fixed_nodes(domain, mesh.nodes)
    t, on_corner = track.locate(mesh.nodes[mesh.on_curve], CORNER_TOLERANCE * mesh.size)
    fixed[np.flatnonzero(mesh.on_curve)[on_corner]] = True
    loop = np.full(len(mesh.nodes), -1)
    loop[mesh.on_curve] = track.loop_of(t)
    long_first = np.sum(lengths > EDGE_BAND[1] * target) >= np.sum(lengths < EDGE_BAND[0] * target)

    def edited(kind: str, strip: Strip) -> EditedMesh | None:
        if kind == "split":
            on_track = lambda points: track.at(track.locate(points, 0.0)[0])[0]
            return split_strip(mesh.nodes, mesh.quads, mesh.on_curve, strip, on_track)
        return collapse_strip(
            mesh.nodes, mesh.quads, mesh.on_curve, strip, fixed, lambda ids: loop[ids]
        )

    for kind in ("split", "collapsed") if long_first else ("collapsed", "split"):
        for strip in splits if kind == "split" else collapses:
            report["tried"] += 1
            made = edited(kind, strip)
            if made is None:
                report["refused"] += 1
            else:
                yield kind, made


def _singular_points(
    surface: Surface, job: Job, query: SurfaceQuery, flat_mesh: FlatMesh
) -> np.ndarray:
    """The job's singular points in the flat domain (each becomes a layout vertex)."""
    if not job.panelize.singular_points:
        return np.zeros((0, 2))
    scale = length_scale(job.input.units or "mm")
    points = np.asarray(job.panelize.singular_points, dtype=float) * scale - surface.origin
    on_surface, _, triangles = query.mesh.nearest(points)
    faces = surface.faces[triangles]
    corners = surface.vertices[faces]
    weights = barycentric_weights(on_surface, corners)
    return np.einsum("pk,pkc->pc", weights, flat_mesh.flat[faces])


def _cut_corner_issues(surface: Surface, outline: OutlineCorners) -> tuple[Issue, ...]:
    """A warning for the corners of the outline that the design mesh cut into a short facet."""
    if not len(outline.cut_corners):
        return ()
    at = surface.vertices[outline.cut_corners] + surface.origin
    tight = 1.0 / np.radians(ROUNDING_TURN)  # the radius that turns ROUNDING_TURN per panel
    where = ", ".join(f"({x:.0f}, {y:.0f}, {z:.0f})" for x, y, z in at[:4])
    more = f" and {len(at) - 4} more" if len(at) > 4 else ""
    return (
        Issue(
            "outline-cut-corner",
            f"{len(at)} corner(s) of the outline turn through short facets or a tight "
            f"rounding (more than {ROUNDING_TURN:.0f}° within one panel_size of arc, a radius "
            f"under about {tight:.2f} x panel_size), at {where}{more} mm; each is taken as one "
            f"sharp corner of the layout, so the sheets do not follow the facets or the "
            f"rounding exactly (boundary_deviation_mm, after the develop stage, shows by how "
            f"much); if the corner is meant sharp, give the mesh a vertex at it; a rounding "
            f"this tight cannot be followed by the corner of a panel, whose two sides meet in "
            f"its two rib planes: give it a radius of a panel_size or more (the panels then "
            f"follow it), or trim the corner after",
        ),
    )


def _boundary_track(outline: OutlineCorners, flat: np.ndarray) -> BoundaryTrack:
    """The flat boundary loops, kinked at the outline's corners, for the sliding nodes."""
    return BoundaryTrack.from_loops([flat[loop] for loop in outline.loops], list(outline.corners))


def _orient_outwards(vertices: np.ndarray, quads: np.ndarray, query: SurfaceQuery) -> np.ndarray:
    """Quads counter-clockwise seen from the outer side (all of gmsh's quads turn one way)."""
    corners = vertices[quads]
    normals = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    _, surface_normals, _ = query.closest(corners.mean(axis=1))
    agree = np.einsum("ij,ij->i", normals, surface_normals)
    return quads if np.sum(agree > 0) >= np.sum(agree < 0) else quads[:, [0, 3, 2, 1]]
