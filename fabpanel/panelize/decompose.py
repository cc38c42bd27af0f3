"""The skeleton method end to end: plane projection, coarse quads, strip densification, lifting
onto the surface, relaxation, and the production limit (every panel must fit the stock plate).

Thesis §7.1 and Appendix B; Tam & Armstrong (1991), Rigby (2003), Oval et al. (2018). The thesis
subdivided every coarse face equally (Catmull-Clark), which made panels near narrow supports far
too narrow and those at the top far too large (§7.1.3). Here each strip of coarse quads gets its
own division count from its longest 3D edge, and panels that still exceed the plate get their
strips divided further.
"""

from __future__ import annotations

import logging

import numpy as np

from ..buildup import Buildup
from ..data import PanelLayout, Surface
from ..errors import GeometryError
from ..job import Job
from ..surface import SurfaceQuery
from ..units import length_scale
from .quality import layout_metrics, panel_extents

log = logging.getLogger(__name__)

#: how many times strips are divided further for panels that exceed the plate
PLATE_ROUNDS = 6


def outward_normal(surface: Surface) -> np.ndarray:
    """Area-weighted mean normal of the surface (its outer side), unit."""
    tri = surface.vertices[surface.faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).sum(axis=0)
    return normal / max(np.linalg.norm(normal), 1e-300)


def _check_size(surface: Surface, target: float) -> None:
    size = float(np.linalg.norm(np.ptp(surface.vertices, axis=0)))
    if target > size:
        raise GeometryError(
            f"{surface.source.name}: the panel size {target:g} mm is larger than "
            f"the surface ({size:.0f} mm across); lower [panelize] panel_size"
        )
    if target < size / 1000:
        raise GeometryError(
            f"{surface.source.name}: the panel size {target:g} mm is below "
            f"1/1000 of the surface ({size:.0f} mm across), which would give "
            f"millions of panels; raise [panelize] panel_size"
        )


def skeleton_panelize(surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    """Panel layout of a surface with openings or an irregular outline by the skeleton method."""
    from .densify import ARC_LENGTH_POINTS, catmull_clark, densify, refine_polyline, strip_counts
    from .lift import check_projection, lift, plane_frame, to_plane
    from .skeleton import skeleton_layout
    from .untangle import untangle

    settings = job.panelize
    target = settings.panel_size
    if not surface.boundary_loops:
        raise GeometryError(
            f"{surface.source.name}: the surface is closed (no boundary); the "
            f"skeleton method needs an open surface, cut it open first"
        )
    _check_size(surface, target)
    loops3d = [surface.vertices[loop] for loop in surface.boundary_loops]
    frame = plane_frame(np.concatenate(loops3d), outward_normal(surface))
    loops2d = [to_plane(loop, frame) for loop in loops3d]
    # refuse a surface that folds over in the projection before reading its projected loops
    # (their crossings would otherwise be reported as a bad boundary)
    check_projection(surface, frame)
    features = None
    if settings.singular_points:
        scale = length_scale(job.input.units or "mm")
        # given in the design's coordinates and the input's units; the surface is local
        points = np.asarray(settings.singular_points, dtype=float) * scale - surface.origin
        features = to_plane(points, frame)
    coarse = skeleton_layout(loops2d, corner_angle=settings.corner_angle, point_features=features)

    def arc_length(curve: np.ndarray) -> np.ndarray:
        """cumulative length on the surface of a plane polyline's points"""
        points, _ = lift(curve, surface, frame, query)
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])

    lengths = {
        key: float(arc_length(refine_polyline(curve, ARC_LENGTH_POINTS))[-1])
        for key, curve in coarse.edge_curves.items()
    }
    extra = np.zeros(0, dtype=int)
    for round_ in range(PLATE_ROUNDS + 1):
        if settings.density == "catmull-clark":
            levels = max(1, int(np.ceil(np.log2(max(max(lengths.values()) / target, 1.0)))))
            levels += round_
            dense = catmull_clark(coarse, levels)
        else:
            counts = np.asarray(strip_counts(coarse, lengths, target))
            if extra.size:
                counts = counts + extra
            dense = densify(coarse, counts, arc_length=arc_length)
        vertices2d, quads, loop_of_vertex, fixed = dense
        movable = (loop_of_vertex < 0) & ~fixed
        smoothing = {"folded_before": 0, "folded_after": 0, "outer_iterations": 0}
        if settings.relax or dense.info.get("inverted_quads", 0):
            # relaxation: right angles and even panels, fold-free by construction (the barrier),
            # boundary samples (evenly spaced on the surface) kept; without relaxation the Coons
            # patches stay as they are unless they fold
            vertices2d, smoothing = untangle(vertices2d, quads, movable)
        if smoothing["folded_after"]:
            # never hand on a silently folded mesh
            raise GeometryError(
                f"{surface.source.name}: the skeleton layout folds over at "
                f"{smoothing['folded_after']} panel corners even after untangling; use "
                f'[panelize] method = "layout" with a quad mesh drawn for the surface, or '
                f'"grid" for four-sided parts'
            )
        vertices, _ = lift(vertices2d, surface, frame, query)
        oversize = oversize_panels(vertices, quads, job)
        if not oversize.any():
            break
        if settings.density == "catmull-clark":
            continue
        extra = _more_divisions(coarse, counts, dense.face_of_quad, oversize, extra)
    layout = PanelLayout(
        vertices=vertices,
        quads=quads,
        panel_ids=tuple(f"P{i + 1:03d}" for i in range(len(quads))),
        method="skeleton",
    )
    metrics, found = layout_metrics(layout, query, target, job.cutting, loops3d)
    metrics["coarse"] = {
        "vertices": len(coarse.vertices),
        "quads": len(coarse.quads),
        **coarse.info,
    }
    metrics["plate_rounds"] = round_
    metrics["relaxation"] = smoothing
    log.info("skeleton panelisation: %d coarse quads -> %d panels", len(coarse.quads), len(quads))
    return PanelLayout(
        vertices=vertices,
        quads=quads,
        panel_ids=layout.panel_ids,
        method="skeleton",
        metrics=metrics,
        issues=found,
    )


def oversize_panels(vertices: np.ndarray, quads: np.ndarray, job: Job) -> np.ndarray:
    usable = np.array(Buildup.of(job).usable_plate)
    extents = np.sort(panel_extents(vertices[quads]), axis=1)[:, ::-1]
    return ~np.all(extents <= usable, axis=1)


def _more_divisions(
    coarse, counts: np.ndarray, face_of_quad: np.ndarray, oversize: np.ndarray, extra: np.ndarray
) -> np.ndarray:
    """One more division for both strips through every coarse face holding an oversize panel."""
    from .densify import collect_strips, quad_edges

    strip_of_edge, _ = collect_strips(coarse.quads)
    edges, edge_of_side = quad_edges(coarse.quads)
    faces = np.unique(face_of_quad[oversize])
    strips = {
        strip_of_edge[tuple(int(v) for v in edges[e])]
        for face in faces
        for e in edge_of_side[face, :2]
    }
    extra = extra.copy() if extra.size else np.zeros(len(counts), dtype=int)
    extra[sorted(strips)] += 1
    return extra
