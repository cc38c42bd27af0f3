"""Structured grid panelisation of four-sided surfaces.

A single B-rep face is gridded in its own (u, v) parameters, spaced by arc length along the
face's middle iso-curves. A mesh is gridded through a Coons patch (Coons 1967) spanned by the
four sides of its boundary, whose points are then projected onto the mesh. Both keep the panel
counts per direction uniform, so opposite panel sides match across the whole grid.
"""

from __future__ import annotations

import logging

import numpy as np

from ..data import PanelLayout, Surface
from ..errors import GeometryError
from ..geom.fitting import bestfit_planes
from ..job import Job
from ..surface import SurfaceQuery
from ..surface.query import vertex_normals
from .quality import layout_metrics

log = logging.getLogger(__name__)


def grid_panelize(surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    """Structured grid of a four-sided surface (see the module docstring).

    Raises :class:`GeometryError` for surfaces with openings or without four corners.
    """
    settings = job.panelize
    if len(surface.boundary_loops) != 1:
        raise GeometryError(
            f"{surface.source.name}: the grid method needs a four-sided surface with one boundary "
            f"loop, this one has {len(surface.boundary_loops)} (closed surfaces have none, "
            f'openings add loops); use [panelize] method = "skeleton" or split the surface'
        )
    if surface.brep is not None and query.face_count == 1:
        vertices, quads, parameters = _parameter_grid(query, settings)
    else:
        vertices, quads = _coons_grid(surface, query, settings)
        parameters = None
    quads, parameters = _orient_outwards(vertices, quads, parameters, query)
    ids = tuple(f"P{i + 1:03d}" for i in range(len(quads)))
    layout = PanelLayout(
        vertices=vertices, quads=quads, panel_ids=ids, method="grid", parameters=parameters
    )
    loops = [surface.vertices[loop] for loop in surface.boundary_loops]
    metrics, issues = layout_metrics(layout, query, settings.panel_size, job.cutting, loops)
    log.info("grid panelisation: %d panels", len(quads))
    return PanelLayout(
        vertices=vertices,
        quads=quads,
        panel_ids=ids,
        method="grid",
        parameters=parameters,
        metrics=metrics,
        issues=issues,
    )


def is_four_sided(surface: Surface, corner_angle: float) -> bool:
    """Whether the surface has one boundary loop with (at least) four corners."""
    if len(surface.boundary_loops) != 1:
        return False
    try:
        _outline_corners(surface, corner_angle)
    except GeometryError:
        return False
    return True


def _outline_corners(surface: Surface, corner_angle: float) -> np.ndarray:
    """The four corners of the surface's one boundary loop, turning in its tangent planes."""
    loop = surface.boundary_loops[0]
    normals = vertex_normals(surface.vertices, surface.faces)[loop]
    return boundary_corners(surface.vertices[loop], corner_angle, normals)


def _divisions(length: float, target: float, explicit: int | None) -> int:
    return explicit if explicit is not None else max(1, round(length / target))


def _arc_length_parameters(curve: np.ndarray, t: np.ndarray, count: int) -> np.ndarray:
    """Parameters that split a densely sampled curve (points ``curve`` at ``t``) evenly."""
    cumulative = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))])
    return np.interp(np.linspace(0.0, cumulative[-1], count + 1), cumulative, t)


def _parameter_grid(query: SurfaceQuery, settings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    umin, umax, vmin, vmax = query.uv_bounds()
    dense = np.linspace(0.0, 1.0, 401)
    us, vs = umin + dense * (umax - umin), vmin + dense * (vmax - vmin)
    u_curve, _ = query.evaluate_uv(us, np.full_like(us, 0.5 * (vmin + vmax)))
    v_curve, _ = query.evaluate_uv(np.full_like(vs, 0.5 * (umin + umax)), vs)
    u_len = float(np.linalg.norm(np.diff(u_curve, axis=0), axis=1).sum())
    v_len = float(np.linalg.norm(np.diff(v_curve, axis=0), axis=1).sum())
    nu = _divisions(u_len, settings.panel_size, settings.grid_u)
    nv = _divisions(v_len, settings.panel_size, settings.grid_v)
    u_knots = _arc_length_parameters(u_curve, us, nu)
    v_knots = _arc_length_parameters(v_curve, vs, nv)
    U, V = np.meshgrid(u_knots, v_knots, indexing="ij")
    vertices, _ = query.evaluate_uv(U.ravel(), V.ravel())
    quads = _grid_quads(nu, nv)
    uv = np.stack([U.ravel(), V.ravel()], axis=1)
    return vertices, quads, uv[quads]


def _grid_quads(nu: int, nv: int) -> np.ndarray:
    """(nu nv, 4) int: quads of an (nu+1) x (nv+1) vertex grid with index ``i * (nv + 1) + j``."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    v00 = (i * (nv + 1) + j).ravel()
    return np.stack([v00, v00 + nv + 1, v00 + nv + 2, v00 + 1], axis=1)


def boundary_corners(
    points: np.ndarray, corner_angle: float, normals: np.ndarray | None = None
) -> np.ndarray:
    """Indices of the four corners of a closed boundary polyline, in loop order.

    points : (n, 3) float, the loop. A corner is a vertex whose turning angle in the surface's
    tangent plane there (``normals`` (n, 3), the surface's unit normals at the loop's
    vertices; default the loop's best-fitting plane) exceeds ``corner_angle`` degrees; the
    four sharpest are taken. The tangent plane matters on a tall vault: its outline's
    best-fitting plane is the one its two end arches lie in, which sees its long straight
    sides end on.
    """
    if normals is None:
        normals = np.broadcast_to(bestfit_planes(points[None])[0][0], points.shape)
    incoming = points - np.roll(points, 1, axis=0)
    outgoing = np.roll(points, -1, axis=0) - points
    incoming -= np.einsum("ij,ij->i", incoming, normals)[:, None] * normals
    outgoing -= np.einsum("ij,ij->i", outgoing, normals)[:, None] * normals
    cos = np.einsum("ij,ij->i", incoming, outgoing) / (
        np.linalg.norm(incoming, axis=1) * np.linalg.norm(outgoing, axis=1)
    )
    turning = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    candidates = np.flatnonzero(turning > corner_angle)
    if len(candidates) < 4:
        raise GeometryError(
            f"the boundary has {len(candidates)} corners sharper than {corner_angle:g} degrees, "
            f"the grid method needs 4; lower [panelize] corner_angle or use a four-sided surface"
        )
    sharpest = candidates[np.argsort(-turning[candidates], kind="stable")[:4]]
    return np.sort(sharpest)


def _resample(polyline: np.ndarray, count: int) -> np.ndarray:
    """``count`` points evenly spaced by arc length along a polyline, ends kept."""
    cumulative = np.concatenate(
        [[0.0], np.cumsum(np.linalg.norm(np.diff(polyline, axis=0), axis=1))]
    )
    targets = np.linspace(0.0, cumulative[-1], count)
    return np.stack([np.interp(targets, cumulative, polyline[:, c]) for c in range(3)], axis=1)


def _coons_grid(surface: Surface, query: SurfaceQuery, settings) -> tuple[np.ndarray, np.ndarray]:
    loop = surface.vertices[surface.boundary_loops[0]]
    corners = _outline_corners(surface, settings.corner_angle)
    closed = np.vstack([loop, loop[:1]])
    sides = []
    for a, b in zip(corners, np.roll(corners, -1)):
        sides.append(closed[a : b + 1] if b > a else np.vstack([loop[a:], loop[: b + 1]]))
    lengths = [float(np.linalg.norm(np.diff(s, axis=0), axis=1).sum()) for s in sides]
    nu = _divisions(0.5 * (lengths[0] + lengths[2]), settings.panel_size, settings.grid_u)
    nv = _divisions(0.5 * (lengths[1] + lengths[3]), settings.panel_size, settings.grid_v)
    bottom = _resample(sides[0], nu + 1)  # c0 -> c1
    right = _resample(sides[1], nv + 1)  # c1 -> c2
    top = _resample(sides[2], nu + 1)[::-1]  # c3 -> c2
    left = _resample(sides[3], nv + 1)[::-1]  # c0 -> c3
    s = np.linspace(0.0, 1.0, nu + 1)[:, None, None]
    t = np.linspace(0.0, 1.0, nv + 1)[None, :, None]
    ruled_s = (1 - t) * bottom[:, None] + t * top[:, None]
    ruled_t = (1 - s) * left[None] + s * right[None]
    bilinear = (
        (1 - s) * (1 - t) * bottom[0]
        + s * (1 - t) * bottom[-1]
        + (1 - s) * t * top[0]
        + s * t * top[-1]
    )
    patch = (ruled_s + ruled_t - bilinear).reshape(-1, 3)
    interior_grid = np.ones((nu + 1, nv + 1), dtype=bool)
    interior_grid[[0, -1], :] = False
    interior_grid[:, [0, -1]] = False
    interior = interior_grid.ravel()
    # boundary points already lie on the boundary polyline; only interior points are projected
    projected, _, _ = query.closest(patch[interior])
    patch[interior] = projected
    return patch, _grid_quads(nu, nv)


def _orient_outwards(
    vertices: np.ndarray, quads: np.ndarray, parameters: np.ndarray | None, query: SurfaceQuery
) -> tuple[np.ndarray, np.ndarray | None]:
    """Reverse the corner order when the grid's right-hand normal points inwards."""
    corners = vertices[quads]
    normals_rh = np.cross(corners[:, 1] - corners[:, 0], corners[:, 3] - corners[:, 0])
    centres = corners.mean(axis=1)
    _, surface_normals, _ = query.closest(centres)
    if np.einsum("ij,ij->i", normals_rh, surface_normals).sum() >= 0:
        return quads, parameters
    flip = [0, 3, 2, 1]
    return quads[:, flip], None if parameters is None else parameters[:, flip]
