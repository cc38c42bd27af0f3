"""The field method's quads placed on the design surface, and edited where that helps.

gmsh's quads of the flat domain (:class:`FlatQuads`) are smoothed there and mapped onto the
surface (:func:`placed_with_edits`): squared, boundary nodes sliding along the outline, then
held in the gates' bands where squaring alone fails them (:mod:`.gate_band`), nodes pinned
where a panel leaves the plate; then two edits of the topology, each placed again and kept
only where the gates' measures say it is better: false corners dissolved
(:mod:`.false_corners`) and edges rotated towards the panel counts the vertices' angles ask for
(:mod:`.rotate`). :func:`polished` gives a layout's vertices as the stage's last touch
(:mod:`.polish`) will leave them, so that layouts are compared as the user gets them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geom.polygon import closest_on_polylines
from ..job import Job
from ..surface import SurfaceQuery
from ..surface.design_boundary import DesignBoundary
from .decompose import oversize_panels
from .false_corners import dissolve_corners, one_panel_nodes
from .gate_band import band_measures
from .gates import CORNER_LIMITS
from .lift import FlatMesh, barycentric_weights
from .polish import PolishLimits, polish_layout
from .quality import corner_angles
from .rotate import MEASURES, rotate_towards_ideal
from .slide import BoundaryTrack, SlidingNodes

#: tries with boundary nodes sliding, each pinning the nodes of panels that left the plate
SLIDE_ATTEMPTS = 2

#: a boundary node this close to a corner of the outline (x the panel size) is that corner
CORNER_TOLERANCE = 1e-3

#: outer iterations of the smoothing that holds the gates' bands: it starts from the squared
#: nodes, unfolded; a second round changed no gate on four test shapes and cost 0.5 s at
#: a thousand panels
BAND_OUTER = 1


def polished(domain: Domain, job: Job, mesh: FlatQuads, vertices: np.ndarray) -> np.ndarray:
    """The layout's vertices after the stage's last touch (:mod:`.polish`), which
    :func:`fabpanel.panelize.panelize` gives every field layout: layouts and edits are
    compared as the stage will leave them."""
    polished, _ = polish_layout(
        vertices,
        mesh.quads,
        domain.query,
        domain.boundary,
        PolishLimits.of(job),
        fixed_nodes(domain, mesh.nodes),
    )
    return polished


#: a flat node this close to a fold line (x the panel size there) is on it
FOLD_NODE_TOLERANCE = 0.005


@dataclass(frozen=True)
class Domain:
    """The flattened design surface and what placing quads on it needs, made once."""

    flat_mesh: FlatMesh
    #: flat length per surface length of a panel of the asked size at each flat vertex: the
    #: flattening's own scale (``flat_scale``), smaller where a plate round asks for smaller
    #: panels (:func:`.field._smaller_near_misses`)
    scale: np.ndarray
    flat_scale: np.ndarray
    points: np.ndarray  # the singular points, flat
    track: BoundaryTrack
    boundary: DesignBoundary
    query: SurfaceQuery
    target: float  # the asked panel size, mm, which the gates measure against
    punches: tuple[np.ndarray, ...] = ()  # small openings punched out of the mesh (:mod:`.punch`)
    longest_edge: float = np.inf  # mm: the plate's usable width, which the band smoothing holds
    #: the surface's fold lines (:mod:`fabpanel.surface.folds`), flat and on the surface: gmsh
    #: puts nodes on them, which stay there (:func:`fixed_nodes`) and go onto the fold
    folds: tuple[np.ndarray, ...] = ()
    folds3d: tuple[np.ndarray, ...] = ()


@dataclass(frozen=True)
class FlatQuads:
    """gmsh's quads of the flat domain, with the panel size they were made for."""

    nodes: np.ndarray
    quads: np.ndarray
    on_curve: np.ndarray
    size: float


def _place(
    domain: Domain, mesh: FlatQuads, slide: bool, job: Job, pinned: np.ndarray
) -> tuple[np.ndarray, dict]:
    """The quads' nodes smoothed in the flat domain (boundary nodes sliding along the
    boundary, except ``pinned`` ones, if ``slide``) and put on the surface; boundary nodes
    exactly on the design boundary.

    The smoothing squares the panels. Where that fails a gate on corners or edges or a panel
    misses the plate, a second one from there also holds corners and edges in the gates' bands
    (:mod:`.gate_band`); it is kept where every panel fits and it scores better on the gates'
    own measures; otherwise, where the first missed the plate, the caller pins nodes or makes
    the layout again, smaller (where the flattening's scale changes fast, on a trumpet, the two
    pull against each other and the first is better). A layout that passes is left as it is:
    the second smoothing costs a second at a thousand panels, and trades the smallest corner
    for the share in the band."""
    relaxed, relaxation = _relax(domain, mesh, slide, pinned, mesh.nodes, band=False)
    vertices = _on_surface(domain, mesh, relaxed)
    before = band_measures(vertices, mesh.quads, domain.target)
    missed = bool(oversize_panels(vertices, mesh.quads, job).any())
    if before.passes and not missed:
        return vertices, relaxation
    # the bands also hold every edge under 1.25 x panel_size (and the plate's usable width),
    # which often brings a squared boundary panel that misses the plate back onto it (else
    # the caller pins or shrinks)
    banded, band_relaxation = _relax(domain, mesh, slide, pinned, relaxed, band=True)
    in_band = _on_surface(domain, mesh, banded)
    after = band_measures(in_band, mesh.quads, domain.target)
    fits = not oversize_panels(in_band, mesh.quads, job).any()
    better = fits and after.score > before.score
    relaxation["gate_band"] = {
        "score_before": round(before.score, 4),
        "score_after": round(after.score, 4),
        "kept": bool(better),
        "outer_iterations": band_relaxation["outer_iterations"],
    }
    return (in_band if better else vertices), relaxation


def _on_surface(domain: Domain, mesh: FlatQuads, nodes: np.ndarray) -> np.ndarray:
    """Flat nodes mapped onto the surface, boundary nodes exactly onto the design boundary,
    nodes on a fold line onto the fold."""
    vertices = domain.flat_mesh.interpolate(nodes)
    vertices[mesh.on_curve] = domain.boundary.closest(vertices[mesh.on_curve])
    vertices[~mesh.on_curve], _, _ = domain.query.closest(vertices[~mesh.on_curve])
    for flat, fold in zip(domain.folds, domain.folds3d, strict=True):
        on = ~mesh.on_curve & _near_polyline(nodes, flat, fold_tolerance(domain))
        vertices[on] = closest_on_polylines(vertices[on], fold, closed=False)
    return vertices


def fold_tolerance(domain: Domain) -> float:
    """Flat distance within which a node lies on a fold line: gmsh's nodes lie on the spline
    through the fold's flat points, within a hair of their polyline."""
    return FOLD_NODE_TOLERANCE * domain.target * float(np.median(domain.flat_scale))


def _near_polyline(points: np.ndarray, polyline: np.ndarray, tolerance: float) -> np.ndarray:
    if not len(points):
        return np.zeros(0, dtype=bool)
    foot = closest_on_polylines(points, polyline, closed=False)
    return np.linalg.norm(points - foot, axis=1) < tolerance


def placed_with_edits(
    domain: Domain, mesh: FlatQuads, job: Job
) -> tuple[FlatQuads, np.ndarray, dict, bool]:
    """:func:`_placed_on_plate`, then two edits of the quads, each placed again and kept if
    it has fewer corners and edges past the gates' hard limits, or as many and scores better
    on the gates' measures, and fits the plate as well: where a corner of the layout on a
    smooth stretch of the outline stays wider than the gates' 135°, that corner dissolved
    (:mod:`.false_corners`); where a vertex has more or fewer panels than its angle can take,
    edges rotated (:mod:`.rotate`). Returns the mesh used with the results."""
    placed = _placed_on_plate(domain, mesh, job)
    mesh, placed = _kept_if_better(domain, job, mesh, placed, _dissolved(domain, mesh, placed[0]))
    for measure in MEASURES:
        edited = _rotated(domain, mesh, placed[0], measure)
        mesh, placed = _kept_if_better(domain, job, mesh, placed, edited)
    return (mesh, *placed)


def _kept_if_better(
    domain: Domain,
    job: Job,
    mesh: FlatQuads,
    placed: tuple[np.ndarray, dict, bool],
    edit: tuple[str, FlatQuads, dict] | None,
) -> tuple[FlatQuads, tuple[np.ndarray, dict, bool]]:
    """The edited mesh placed, where ``edit`` (its name, the mesh, what was changed) makes
    it better (:func:`placed_with_edits`), else the mesh as ``placed``."""
    if edit is None:
        return mesh, placed
    name, edited, changes = edit
    vertices, relaxation, fits = placed
    again, again_relaxation, again_fits = _placed_on_plate(domain, edited, job)
    before = band_measures(vertices, mesh.quads, domain.target)
    after = band_measures(again, edited.quads, domain.target)
    # fewer corners past the hard limits first: a dissolved corner of 150° is worth a
    # percent of corners in the band
    if (after.hard, -after.score) >= (before.hard, -before.score) or (fits and not again_fits):
        relaxation[name] = {**changes, "kept": False}
        return mesh, placed
    again_relaxation = {**relaxation, **again_relaxation, name: {**changes, "kept": True}}
    return edited, (again, again_relaxation, again_fits)


def _dissolved(
    domain: Domain, mesh: FlatQuads, vertices: np.ndarray
) -> tuple[str, FlatQuads, dict] | None:
    """The mesh with its wide false corners dissolved, or None where there are none."""
    wide = _wide_false_corners(domain, mesh, vertices)
    if not len(wide):
        return None
    movable = mesh.on_curve & ~fixed_nodes(domain, mesh.nodes)
    _, on_corner = domain.track.locate(mesh.nodes[movable], CORNER_TOLERANCE * mesh.size)
    movable[np.flatnonzero(movable)[on_corner]] = False
    nodes, quads, on_curve, dissolved = dissolve_corners(
        mesh.nodes, mesh.quads, mesh.on_curve, wide, movable
    )
    if not dissolved:
        return None
    edited = FlatQuads(nodes, quads, on_curve, mesh.size)
    return "false_corners", edited, {"dissolved": dissolved}


def _rotated(
    domain: Domain, mesh: FlatQuads, vertices: np.ndarray, measure: str
) -> tuple[str, FlatQuads, dict] | None:
    """The mesh with edges rotated towards the counts of panels its vertices' angles ask
    for, by ``measure`` (:func:`.rotate._gain`), or None where the layout passes the gates'
    bands or nothing was rotated."""
    if band_measures(vertices, mesh.quads, domain.target).passes:
        return None
    angles = corner_angles(vertices[mesh.quads])
    sums = np.bincount(mesh.quads.ravel(), weights=angles.ravel(), minlength=len(vertices))
    quads, rotated = rotate_towards_ideal(mesh.quads, mesh.on_curve, sums, measure)
    if not rotated:
        return None
    edited = FlatQuads(mesh.nodes, quads, mesh.on_curve, mesh.size)
    name = "edge_rotations" if measure == "counts" else f"edge_rotations_by_{measure}"
    return name, edited, {"rotated": rotated}


def _wide_false_corners(domain: Domain, mesh: FlatQuads, vertices: np.ndarray) -> np.ndarray:
    """Ids of the layout's corners (boundary nodes of one panel) whose angle on the surface
    is over the gates' hard limit and that are not corners of the outline."""
    corners = one_panel_nodes(mesh.quads, mesh.on_curve)
    if not len(corners):
        return corners
    _, on_corner = domain.track.locate(mesh.nodes[corners], CORNER_TOLERANCE * mesh.size)
    corners = corners[~on_corner]
    quad, at = np.nonzero(mesh.quads[:, :, None] == corners[None, None, :])[:2]
    angle = corner_angles(vertices[mesh.quads[quad]])[np.arange(len(quad)), at]
    return mesh.quads[quad, at][angle > CORNER_LIMITS[1]]


def fixed_nodes(domain: Domain, nodes: np.ndarray) -> np.ndarray:
    """(n,) bool: the nodes nearest the singular points, which stay where they were asked,
    and the nodes on fold lines, which stay on them (where gmsh spaced them along the fold)."""
    fixed = np.zeros(len(nodes), dtype=bool)
    for point in domain.points:
        fixed[int(np.argmin(np.linalg.norm(nodes - point, axis=1)))] = True
    for flat in domain.folds:
        fixed |= _near_polyline(nodes, flat, fold_tolerance(domain))
    return fixed


def _placed_on_plate(domain: Domain, mesh: FlatQuads, job: Job) -> tuple[np.ndarray, dict, bool]:
    """The layout's vertices, the smoothing's report and whether every panel fits the plate.

    Boundary nodes sliding square leaning boundary panels, but can lengthen a boundary side:
    the nodes of a panel that no longer fits the plate are pinned where gmsh put them and the
    smoothing is run again; if that does not fit either, no boundary node slides. Where an
    interior panel misses the plate, only smaller panels help (the caller's next round)."""
    pinned = np.zeros(len(mesh.nodes), dtype=bool)
    for attempt in range(SLIDE_ATTEMPTS + 1):
        slide = attempt < SLIDE_ATTEMPTS
        vertices, relaxation = _place(domain, mesh, slide, job, pinned)
        oversize = oversize_panels(vertices, mesh.quads, job)
        boundary_panel = mesh.on_curve[mesh.quads].any(axis=1)
        if not oversize.any() or (oversize & ~boundary_panel).any():
            break  # fits, or an interior panel misses the plate: sliding did not cause that
        pinned[mesh.quads[oversize].ravel()] = True
    return vertices, {**relaxation, "sliding": slide}, not oversize.any()


def _relax(
    domain: Domain,
    mesh: FlatQuads,
    slide: bool,
    pinned: np.ndarray,
    nodes: np.ndarray,
    band: bool,
) -> tuple[np.ndarray, dict]:
    """Nodes moved to right-angled panels of the asked size (fold-free smoothing,
    :mod:`.untangle`, with each quad's reference size the panel size times the flattening's
    scale there); boundary nodes slide along the boundary (:mod:`.slide`), corners of the
    outline and the singular points stay. gmsh's own cavity remeshing would do similar work
    but runs against a time budget, so its result changes from run to run; this does not."""
    from .gate_band import gate_band
    from .untangle import MAX_OUTER, corner_determinants, untangle

    quads, on_curve, size = mesh.quads, mesh.on_curve, mesh.size
    flat_mesh, track = domain.flat_mesh, domain.track if slide else None
    if corner_determinants(nodes, quads).sum() < 0:
        quads = quads[:, [0, 3, 2, 1]]  # counter-clockwise in the flat domain
    centres = nodes[quads].mean(axis=1)
    local = interpolate_scale(flat_mesh, domain.scale, centres)
    fixed = fixed_nodes(domain, nodes)
    sliding = None
    if track is not None:
        candidates = np.flatnonzero(on_curve & ~fixed & ~pinned)
        edges, quad_of_edge = _boundary_edges(quads)
        sliding = SlidingNodes.on_track(
            track, nodes, candidates, CORNER_TOLERANCE * size, edges, size * local[quad_of_edge]
        )
    relaxed, info = untangle(
        nodes,
        quads,
        ~on_curve & ~fixed,
        reference=size * local,
        sliding=sliding,
        band=gate_band(
            nodes,
            flat_mesh.interpolate(nodes),
            quads,
            np.repeat(size * local, 4),
            domain.target,
            sliding=None if sliding is None else sliding.ids,
            longest=domain.longest_edge,
        )
        if band
        else None,
        max_outer=BAND_OUTER if band else MAX_OUTER,
    )
    if info["folded_after"] > info["folded_before"]:
        return nodes, {**info, "kept": "gmsh"}
    return relaxed, info


def _boundary_edges(quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The quad sides used by one quad only, (k, 2) node ids, and the quad of each."""
    sides = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    _, index, counts = np.unique(
        np.sort(sides, axis=1), axis=0, return_index=True, return_counts=True
    )
    once = index[counts == 1]
    return sides[once], once // 4


def interpolate_scale(flat_mesh: FlatMesh, scale: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The flattening's scale at flat points (barycentric in the nearest flat triangle)."""
    p = np.column_stack([points, np.zeros(len(points))])
    foot, _, tri = flat_mesh.locator.nearest(p)
    weights = barycentric_weights(foot[:, :2], flat_mesh.flat[flat_mesh.faces[tri]])
    return np.einsum("pk,pk->p", weights, scale[flat_mesh.faces[tri]])
