"""The projection plane of a surface, and lifting plane points back onto the surface.

The skeleton method works in the best-fitting plane of the surface's boundary (total least
squares). A plane point is lifted onto the surface along the plane normal: the surface mesh is
projected onto the plane, the point is located in that flat triangulation (closest point on the
flat triangles, so points rounded just outside the boundary go to the nearest triangle), the 3D
point is interpolated barycentrically and finally moved to the closest point of the surface
(exact on B-reps). This is well defined only where the surface is a graph over the plane: a
surface whose projection folds over itself (a vault bent by more than 180 degrees, a wall seen
edge-on) is refused with a :class:`GeometryError`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..data import Surface
from ..errors import GeometryError
from ..surface import SurfaceQuery

log = logging.getLogger(__name__)

#: share of the projected area that may be covered twice (folds, flipped slivers) before the
#: projection is refused; a clean graph surface has 0, a tessellation of a steep rim a little
FOLD_FRACTION = 1e-3


@dataclass(frozen=True)
class PlaneFrame:
    """An orthonormal frame of the projection plane, mm.

    origin : (3,) float; x_axis, y_axis : (3,) float in-plane unit axes; normal : (3,) float,
    ``x_axis x y_axis``, agreeing with the surface's outer side (so counter-clockwise in the plane
    is counter-clockwise seen from outside).
    """

    origin: np.ndarray
    x_axis: np.ndarray
    y_axis: np.ndarray
    normal: np.ndarray
    cache: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) float: rows x_axis, y_axis, normal."""
        return np.stack([self.x_axis, self.y_axis, self.normal])


def plane_frame(points3d: np.ndarray, outward_hint: np.ndarray) -> PlaneFrame:
    """Best-fitting plane through points (the surface boundary) as a :class:`PlaneFrame`.

    points3d : (n, 3) float, mm, at least 3 not collinear.
    outward_hint : (3,) float, the surface's mean outward normal; the frame normal is turned to
        agree with it (when it is perpendicular to the plane normal, the normal is kept as SVD
        gives it).
    """
    points = np.asarray(points3d, dtype=float).reshape(-1, 3)
    if len(points) < 3:
        raise GeometryError(f"plane_frame needs at least 3 points, got {len(points)}")
    origin = points.mean(axis=0)
    _, sing, vt = np.linalg.svd(points - origin, full_matrices=False)
    if sing[1] <= 1e-12 * max(sing[0], 1e-300):
        raise GeometryError("the surface boundary is a straight line; no projection plane")
    x_axis, normal = vt[0], vt[2]
    if float(np.dot(normal, np.asarray(outward_hint, dtype=float))) < 0:
        normal = -normal
    y_axis = np.cross(normal, x_axis)
    return PlaneFrame(origin, x_axis, y_axis / np.linalg.norm(y_axis), normal)


def to_plane(points3d: np.ndarray, frame: PlaneFrame) -> np.ndarray:
    """(n, 2) float: plane coordinates of points (orthogonal projection), mm."""
    rel = np.asarray(points3d, dtype=float).reshape(-1, 3) - frame.origin
    return np.stack([rel @ frame.x_axis, rel @ frame.y_axis], axis=1)


def from_plane(points2d: np.ndarray, frame: PlaneFrame) -> np.ndarray:
    """(n, 3) float: the 3D points of plane coordinates (in the plane), mm."""
    p = np.asarray(points2d, dtype=float).reshape(-1, 2)
    return frame.origin + p[:, :1] * frame.x_axis + p[:, 1:] * frame.y_axis


class FlatMesh:
    """A triangle mesh with 2D coordinates per vertex (a projection or a flattening), and a
    locator of its flat triangles: maps 2D points back onto the 3D mesh."""

    def __init__(self, flat: np.ndarray, faces: np.ndarray, vertices: np.ndarray):
        from ..surface.query import MeshLocator

        self.flat = np.asarray(flat, dtype=float)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.vertices = np.asarray(vertices, dtype=float)
        self.locator = MeshLocator(np.column_stack([self.flat, np.zeros(len(flat))]), self.faces)

    def interpolate(self, points2d: np.ndarray) -> np.ndarray:
        """(p, 3) float: mesh points at 2D points (points outside: the nearest flat triangle)."""
        p = np.column_stack([points2d, np.zeros(len(points2d))])
        foot, _, tri = self.locator.nearest(p)
        bary = barycentric_weights(foot[:, :2], self.flat[self.faces[tri]])
        return np.einsum("pk,pkc->pc", bary, self.vertices[self.faces[tri]])


def barycentric_weights(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(p, 3) barycentric weights of points in their triangles ``corners (p, 3, d)``, any
    dimension, clipped to the triangle (a point outside takes the nearest edge's mix);
    degenerate triangles give their first corner."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1, v2 = b - a, c - a, points - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    denom = d00 * d11 - d01 * d01
    ok = np.abs(denom) > 1e-18 * np.maximum(d00 * d11, 1e-300)
    safe = np.where(ok, denom, 1.0)
    v = np.where(ok, (d11 * d20 - d01 * d21) / safe, 0.0)
    w = np.where(ok, (d00 * d21 - d01 * d20) / safe, 0.0)
    bary = np.clip(np.stack([1.0 - v - w, v, w], axis=1), 0.0, 1.0)
    return bary / bary.sum(axis=1, keepdims=True)


class _Projector(FlatMesh):
    """The surface mesh flattened onto the plane, with a locator of its triangles."""

    def __init__(self, surface: Surface, frame: PlaneFrame):
        flat = to_plane(surface.vertices, frame)
        _check_fold(surface, flat, signed_triangle_areas(flat, surface.faces))
        super().__init__(flat, surface.faces, surface.vertices)


def signed_triangle_areas(flat: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) float: signed areas of 2D triangles (positive counter-clockwise)."""
    tri = flat[faces]
    return 0.5 * (
        (tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1])
        - (tri[:, 2, 0] - tri[:, 0, 0]) * (tri[:, 1, 1] - tri[:, 0, 1])
    )


def _check_fold(surface: Surface, flat: np.ndarray, signed: np.ndarray) -> None:
    """Raise GeometryError when the projection of the surface overlaps itself."""
    from ..geom.polygon import polygon_area

    total = float(np.abs(signed).sum())
    if total <= 0:
        raise GeometryError(
            f"{surface.source.name}: the surface projects onto a line in its "
            f'best-fitting plane; use [panelize] method = "grid" or a user '
            f'layout (method = "layout")'
        )
    negative = float(-signed[signed < 0].sum())
    covered = None
    if surface.boundary_loops:
        loops = [abs(polygon_area(flat[loop])) for loop in surface.boundary_loops]
        covered = loops[0] - sum(loops[1:])
    overlap = negative / total
    if covered is not None and covered > 0:
        overlap = max(overlap, (total - covered) / total)
    if overlap > FOLD_FRACTION:
        raise GeometryError(
            f"{surface.source.name}: the surface folds over itself when projected onto its "
            f"best-fitting plane ({100 * overlap:.1f}% of its projected area is covered twice), so "
            f"the skeleton method cannot map a plane layout onto it; use [panelize] method = "
            f'"grid" (four-sided surfaces) or draw a layout (method = "layout")'
        )


def check_projection(surface: Surface, frame: PlaneFrame) -> _Projector:
    """The surface flattened onto the frame's plane (cached on ``frame`` per surface); raises
    :class:`GeometryError` when that projection folds over itself."""
    key = id(surface)
    cached = frame.cache.get(key)
    if cached is None or cached[0] is not surface:
        cached = (surface, _Projector(surface, frame))
        frame.cache[key] = cached
    return cached[1]


def lift(
    points2d: np.ndarray, surface: Surface, frame: PlaneFrame, query: SurfaceQuery
) -> tuple[np.ndarray, np.ndarray]:
    """Map plane points onto the surface along the plane normal.

    points2d : (p, 2) float, plane coordinates, mm (see :func:`to_plane`).
    surface : the design surface; frame : its projection plane; query : its closeness queries.
    Returns ``points3d (p, 3)`` on the surface (exactly, up to the query: mesh or B-rep) and
    ``normals (p, 3)`` unit outward normals there. Points outside the projected surface go to
    the nearest projected triangle. The flattened triangulation is cached on ``frame`` per
    surface. Raises :class:`GeometryError` when the surface's projection folds over.
    """
    points2d = np.asarray(points2d, dtype=float).reshape(-1, 2)
    if len(points2d) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    above = check_projection(surface, frame).interpolate(points2d)
    points3d, normals, _ = query.closest(above)
    return points3d, normals
