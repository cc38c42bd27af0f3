"""Closest points and normals on the design surface, on its mesh or exactly on its B-rep.

Mesh surfaces: the closest point on the triangles (candidates from a k-d tree of triangle
centroids, widened until the nearest is certain), with a smooth normal interpolated
barycentrically from area-weighted vertex normals (Phong-style shading normals; they vary
continuously across triangle edges, which the next stages need to place ribs without kinks).

B-rep surfaces: the closest point is an exact orthogonal projection onto the nearest OCCT face
(``GeomAPI_ProjectPointOnSurf`` on the face's surface within its parameter bounds, falling back
to ``BRepExtrema_DistShapeShape`` when the foot lies outside the trimmed face), and the normal is
the exact surface normal there. The nearest face is taken from the query's own tessellation,
good to its deflection: a point within that distance of a seam between two faces can be
projected onto the farther of the two (the result is then still exact on that face).
Exact normals are turned to agree, face by face, with the outward orientation of the Surface's
mesh (see :mod:`.mesh`), judged on the triangles of each face.
"""

from __future__ import annotations

import logging

import numpy as np

from ..data import Surface
from ..errors import GeometryError, KernelError

log = logging.getLogger(__name__)

#: candidate triangles tried first per point; widened x4 until the nearest is certain
CANDIDATES = 8
#: most (point, triangle) pairs evaluated at once, to bound memory
MAX_PAIRS = 2_000_000
#: finest split of a large triangle into search samples (level**2 sub-triangles)
MAX_LEVEL = 16


# --------------------------------------------------------------------------------------------
# mesh kernels
# --------------------------------------------------------------------------------------------
def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n, 3) float: unit vertex normals, sum of the adjacent triangles' normals x area."""
    tri = vertices[faces]
    # the cross product's length is twice the area: weighting by area comes for free
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n = len(vertices)
    flat = faces.ravel()
    sums = np.stack(
        [np.bincount(flat, weights=np.repeat(cross[:, c], 3), minlength=n) for c in range(3)],
        axis=1,
    )
    length = np.linalg.norm(sums, axis=1, keepdims=True)
    return np.divide(sums, length, out=np.zeros_like(sums), where=length > 0)


def triangle_samples(
    triangles: np.ndarray, max_level: int = MAX_LEVEL
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Points covering each triangle, for nearest-triangle searches with a k-d tree.

    triangles : (m, 3, 3) float, mm.
    Each triangle is split into ``L x L`` similar sub-triangles so that no sub-triangle reaches
    farther than about the median triangle's radius from its centroid; the centroids are the
    samples. Without the split one long sliver (BRepMesh makes them along straight trimmed
    edges) would force a huge search radius on every query. Triangles that would need more
    than ``max_level`` splits per side are left out and returned as ``large``, to be checked
    against every query point.
    Returns ``samples (s, 3)``, ``owner (s,) int`` (the triangle of each sample), ``radius``
    (the largest distance from a sample to a point of its sub-triangle, mm) and
    ``large (l,) int``.
    """
    centroids = triangles.mean(axis=1)
    radii = np.linalg.norm(triangles - centroids[:, None], axis=2).max(axis=1)
    target = max(float(np.median(radii)), 1e-12)
    level = np.maximum(np.ceil(radii / target), 1).astype(np.int64)
    samples, owner, radius = [np.zeros((0, 3))], [np.zeros(0, dtype=np.int64)], 0.0
    for count in np.unique(level[level <= max_level]):  # a handful of distinct levels
        selected = np.flatnonzero(level == count)
        bary = _subdivision_centroids(int(count))
        samples.append(np.einsum("sk,tkc->tsc", bary, triangles[selected]).reshape(-1, 3))
        owner.append(np.repeat(selected, len(bary)))
        radius = max(radius, float(radii[selected].max()) / count)
    return np.vstack(samples), np.concatenate(owner), radius, np.flatnonzero(level > max_level)


def _subdivision_centroids(level: int) -> np.ndarray:
    """(level**2, 3) float: barycentric centroids of the regular split of a triangle."""
    i, j = np.meshgrid(np.arange(level), np.arange(level), indexing="ij")
    up = (i + j) <= level - 1
    down = (i + j) <= level - 2
    a = np.concatenate([i[up] + 1 / 3, i[down] + 2 / 3]) / level
    b = np.concatenate([j[up] + 1 / 3, j[down] + 2 / 3]) / level
    return np.stack([1.0 - a - b, a, b], axis=1)


class MeshLocator:
    """Closest points on a triangle mesh.

    vertices : (n, 3) float, mm; faces : (m, 3) int.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        from scipy.spatial import cKDTree

        self.vertices = np.asarray(vertices, dtype=float)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.triangles = self.vertices[self.faces]
        samples, self._owner, self.radius, self._large = triangle_samples(self.triangles)
        self.tree = cKDTree(samples)
        self.vertex_normals = vertex_normals(self.vertices, self.faces)

    def nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest point on the mesh for each point.

        points : (p, 3) float, mm.
        Returns ``closest (p, 3)``, ``distances (p,)`` mm and ``triangle (p,) int``.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        p, m = len(points), len(self._owner)
        best_d = np.full(p, np.inf)
        best_t = np.zeros(p, dtype=np.int64)
        best_x = np.zeros((p, 3))
        if len(self._large):
            # the few oversized triangles: against every point, in chunks
            large = len(self._large)
            chunk = max(1, MAX_PAIRS // large)
            for start in range(0, p, chunk):
                ids = np.arange(start, min(start + chunk, p))
                self._update(
                    points,
                    ids,
                    np.broadcast_to(self._large, (len(ids), large)),
                    best_d,
                    best_t,
                    best_x,
                )
        todo, k = np.arange(p), min(CANDIDATES, m)
        while len(todo) and m:
            unresolved = []
            chunk = max(1, MAX_PAIRS // k)
            for start in range(0, len(todo), chunk):
                ids = todo[start : start + chunk]
                dist_s, near = self.tree.query(points[ids], k=k)
                dist_s, near = dist_s.reshape(len(ids), k), near.reshape(len(ids), k)
                self._update(points, ids, self._owner[near], best_d, best_t, best_x)
                # every point of a sampled triangle is within `radius` of one of its samples, so
                # sampled triangles without a sample among the k nearest are at least this far
                bound = dist_s[:, -1] - self.radius
                if k < m:
                    unresolved.append(ids[best_d[ids] > bound])
            todo = np.concatenate(unresolved) if unresolved else np.zeros(0, dtype=np.int64)
            k = min(4 * k, m)
        return best_x, best_d, best_t

    def _update(
        self,
        points: np.ndarray,
        ids: np.ndarray,
        cand: np.ndarray,
        best_d: np.ndarray,
        best_t: np.ndarray,
        best_x: np.ndarray,
    ) -> None:
        """Keep, per point ``ids``, the closest of the candidate triangles ``cand (i, k)``."""
        import trimesh

        k = cand.shape[1]
        foot = trimesh.triangles.closest_point(
            self.triangles[cand].reshape(-1, 3, 3), np.repeat(points[ids], k, axis=0)
        ).reshape(len(ids), k, 3)
        dist = np.linalg.norm(foot - points[ids, None], axis=2)
        pick = np.argmin(dist, axis=1)
        rows = np.arange(len(ids))
        better = dist[rows, pick] < best_d[ids]
        ids, pick, rows = ids[better], pick[better], rows[better]
        best_d[ids] = dist[rows, pick]
        best_t[ids] = cand[rows, pick]
        best_x[ids] = foot[rows, pick]

    def normals_at(self, points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
        """(p, 3) float: smooth unit normals at points lying on the given triangles."""
        import trimesh

        bary = trimesh.triangles.points_to_barycentric(self.triangles[triangles], points)
        normals = np.einsum("pk,pkc->pc", bary, self.vertex_normals[self.faces[triangles]])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)

    def face_normals(self, triangles: np.ndarray) -> np.ndarray:
        """(p, 3) float: unit normals of the given triangles."""
        tri = self.triangles[triangles]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(cross, axis=1, keepdims=True)
        return np.divide(cross, length, out=np.zeros_like(cross), where=length > 0)


# --------------------------------------------------------------------------------------------
# the query object
# --------------------------------------------------------------------------------------------
class SurfaceQuery:
    """Closest-point and normal queries on a :class:`Surface`, exact for B-rep input.

    Build once per surface and reuse: construction builds the search trees (and, for B-reps,
    reads the shape and tessellates it once more to know which triangle lies on which face).
    """

    def __init__(self, surface: Surface):
        self.surface = surface
        self.mesh = MeshLocator(surface.vertices, surface.faces)
        self._faces: list = []
        if surface.brep is not None:
            self._init_brep(surface.brep)

    # ---------------------------------------------------------------- public
    @property
    def face_count(self) -> int:
        """Number of B-rep faces (0 for mesh input)."""
        return len(self._faces)

    @property
    def exact(self) -> bool:
        """True when queries are answered on the exact B-rep."""
        return bool(self._faces)

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest points on the surface, outward unit normals there, and distances.

        points : (n, 3) float, mm (any array-like).
        Returns ``closest (n, 3)`` mm, ``normals (n, 3)`` unit, ``distances (n,)`` mm
        (unsigned; the side is ``sign((points - closest) . normals)``).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if len(points) == 0:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
        if not self._faces:
            foot, dist, tri = self.mesh.nearest(points)
            return foot, self.mesh.normals_at(foot, tri), dist
        return self._closest_exact(points)

    def closest_continued(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`closest` on the surface continued beyond its boundary by the tangent plane at
        the nearest boundary point: a point over an opening lands on that plane, not on the
        opening's rim. Returns ``points (n, 3)``, ``normals (n, 3)``, ``distances (n,)`` mm.

        A point whose closest-point offset runs more along the surface than across it lies
        beyond the boundary (inside the surface the offset is along the normal)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        foot, normals, distance = self.closest(points)
        offset = points - foot
        across = (offset * normals).sum(axis=1)
        along = offset - across[:, None] * normals
        beyond = np.linalg.norm(along, axis=1) > np.abs(across)
        foot = np.where(beyond[:, None], points - across[:, None] * normals, foot)
        return foot, normals, np.where(beyond, np.abs(across), distance)

    def uv_bounds(self) -> tuple[float, float, float, float]:
        """``(umin, umax, vmin, vmax)`` of the single B-rep face's parameter domain."""
        face = self._single_face("uv_bounds")
        umin, umax, vmin, vmax = face.bounds
        return umin, umax, vmin, vmax

    def evaluate_uv(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact points and outward unit normals at parameters of the single B-rep face.

        u, v : (n,) float, the face's own parameters (see :meth:`uv_bounds`).
        Returns ``points (n, 3)`` mm and ``normals (n, 3)``.
        """
        face = self._single_face("evaluate_uv")
        u = np.asarray(u, dtype=float).ravel()
        v = np.asarray(v, dtype=float).ravel()
        if u.shape != v.shape:
            raise GeometryError(f"evaluate_uv: u and v differ in length ({len(u)} != {len(v)})")
        return face.evaluate(u, v, self.mesh)

    def project_uv(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parameters ``(u (n,), v (n,))`` of the exact closest points on the single face."""
        face = self._single_face("project_uv")
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        uv = np.array([face.project(p)[0] for p in points]).reshape(-1, 2)
        return uv[:, 0], uv[:, 1]

    # ---------------------------------------------------------------- B-rep
    def _single_face(self, what: str) -> _Face:
        if len(self._faces) != 1:
            kind = "a mesh" if not self._faces else f"a B-rep with {len(self._faces)} faces"
            raise GeometryError(
                f"{self.surface.source.name}: {what} needs a B-rep surface of a "
                f"single face, this is {kind}; export the design surface as one "
                f"untrimmed NURBS face"
            )
        return self._faces[0]

    def _init_brep(self, data: bytes) -> None:
        from .brep import brep_to_shape, linear_deflection, shape_faces, tessellate

        shape = brep_to_shape(data)
        self._shape = shape
        faces = shape_faces(shape)
        deflection = linear_deflection(shape)
        vertices, triangles, face_ids = tessellate(shape, deflection)
        self._slack = 2.0 * deflection + 1e-9 * float(np.ptp(vertices, axis=0).max())
        self._own = MeshLocator(vertices, triangles)
        self._own_face_ids = face_ids
        # orientation of each face relative to the Surface mesh, judged on the face's own
        # triangles (wound like the OCCT face) against the nearest Surface triangles
        # (a strided subset of at most ~4000 triangles is plenty to vote on)
        voters = np.arange(0, len(triangles), max(1, len(triangles) // 4000))
        voters = np.union1d(voters, np.unique(face_ids, return_index=True)[1])
        tri = vertices[triangles[voters]]
        _, _, nearest = self.mesh.nearest(tri.mean(axis=1))
        own_normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        agreement = np.einsum("ij,ij->i", own_normals, self.mesh.face_normals(nearest))
        votes = np.bincount(face_ids[voters], weights=agreement, minlength=len(faces))
        self._faces = [_Face(face, 1.0 if votes[i] >= 0 else -1.0) for i, face in enumerate(faces)]

    def _closest_exact(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        _, mesh_distance, tri = self._own.nearest(points)
        face_of = self._own_face_ids[tri]
        # an interior foot is the answer only if no boundary point can be closer: the face's
        # boundary is at least (distance to its nearest edge sample - margin) away. The
        # tessellation's distance plus its chord error bounds the answer as well.
        limit = mesh_distance + self._slack
        for index in np.unique(face_of):
            mine = face_of == index
            limit[mine] = np.minimum(limit[mine], self._faces[index].boundary_bound(points[mine]))
        foot = np.empty_like(points)
        normals = np.empty_like(points)
        for i, point in enumerate(points):  # OCCT calls per point
            face = self._faces[face_of[i]]
            uv, foot[i] = face.project(point, limit[i])
            normals[i] = face.normal(uv[0], uv[1])
        missing = ~np.isfinite(normals).all(axis=1)
        if missing.any():
            # singular points (apex, pole): the smooth mesh normal there
            near_foot, _, near = self.mesh.nearest(foot[missing])
            normals[missing] = self.mesh.normals_at(near_foot, near)
        return foot, normals, np.linalg.norm(points - foot, axis=1)


class _Face:
    """One OCCT face prepared for repeated projections and evaluations (mm, world frame)."""

    def __init__(self, face, sign: float):
        from OCP.BRep import BRep_Tool
        from OCP.BRepTools import BRepTools
        from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
        from OCP.IntTools import IntTools_FClass2d
        from OCP.TopAbs import TopAbs_REVERSED

        self.face = face
        # BRep_Tool.Surface_s(face) returns the surface with the face's location applied
        self.surface = BRep_Tool.Surface_s(face)
        self.bounds = tuple(float(x) for x in BRepTools.UVBounds_s(face))
        self.tolerance = max(BRep_Tool.Tolerance_s(face), 1e-7)
        umin, umax, vmin, vmax = self.bounds
        self.projector = GeomAPI_ProjectPointOnSurf()
        self.projector.Init(self.surface, umin, umax, vmin, vmax)
        self.classifier = IntTools_FClass2d(face, self.tolerance)
        # outward = face normal (with the face's orientation) times the per-face sign
        self.sign = sign * (-1.0 if face.Orientation() == TopAbs_REVERSED else 1.0)
        self._edge_tree, self._edge_margin = _edge_samples(face)

    def boundary_bound(self, points: np.ndarray) -> np.ndarray:
        """(n,) float: a lower bound of the distance from each point to the face's boundary."""
        if self._edge_tree is None:
            return np.full(len(points), np.inf)
        distance, _ = self._edge_tree.query(points)
        return distance - self._edge_margin

    def project(
        self, point: np.ndarray, limit: float = np.inf
    ) -> tuple[tuple[float, float], np.ndarray]:
        """Exact closest point on the (trimmed) face: ``((u, v), point (3,))``.

        The nearest orthogonal foot inside the face is the answer unless it is farther than
        ``limit`` (mm, from the tessellation): then the closest point lies on the face's
        boundary, where no orthogonal foot exists, and the boundary search decides.
        """
        from OCP.gp import gp_Pnt, gp_Pnt2d
        from OCP.TopAbs import TopAbs_OUT

        pnt = gp_Pnt(*map(float, point))
        self.projector.Perform(pnt)
        if self.projector.IsDone() and self.projector.NbPoints() > 0:
            u, v = self.projector.LowerDistanceParameters()
            if (
                self.projector.LowerDistance() <= limit
                and self.classifier.Perform(gp_Pnt2d(u, v)) != TopAbs_OUT
            ):
                return (u, v), np.array(self.projector.NearestPoint().Coord())
        return self._project_on_boundary(pnt)

    def _project_on_boundary(self, pnt) -> tuple[tuple[float, float], np.ndarray]:
        """Closest point of the face when the orthogonal foot is outside it (on an edge)."""
        from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
        from OCP.BRepExtrema import BRepExtrema_DistShapeShape
        from OCP.ShapeAnalysis import ShapeAnalysis_Surface

        extrema = BRepExtrema_DistShapeShape(BRepBuilderAPI_MakeVertex(pnt).Vertex(), self.face)
        if not extrema.IsDone() or extrema.NbSolution() == 0:
            raise KernelError("OCCT could not find the closest point on a face")
        foot = extrema.PointOnShape2(1)
        uv = ShapeAnalysis_Surface(self.surface).ValueOfUV(foot, self.tolerance)
        return (uv.X(), uv.Y()), np.array(foot.Coord())

    def normal(self, u: float, v: float) -> np.ndarray:
        """(3,) outward unit normal at (u, v); NaN where the normal is undefined."""
        from OCP.GeomLProp import GeomLProp_SLProps

        props = GeomLProp_SLProps(self.surface, u, v, 1, 1e-9)
        if not props.IsNormalDefined():
            return np.full(3, np.nan)
        return self.sign * np.array(props.Normal().Coord())

    def evaluate(
        self, u: np.ndarray, v: np.ndarray, mesh: MeshLocator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Points and outward normals at parameter arrays ``u, v (n,)``."""
        from OCP.gp import gp_Pnt, gp_Vec

        points = np.empty((len(u), 3))
        normals = np.empty((len(u), 3))
        pnt, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
        for i, (a, b) in enumerate(zip(u.tolist(), v.tolist())):  # OCCT calls per point
            self.surface.D1(a, b, pnt, du, dv)
            points[i] = pnt.Coord()
            normals[i] = np.cross(du.Coord(), dv.Coord())
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        scale = np.linalg.norm(points, axis=1, keepdims=True) + 1.0
        singular = (length < 1e-12 * scale**2).ravel()
        normals = self.sign * np.divide(
            normals, length, out=np.zeros_like(normals), where=length > 0
        )
        if singular.any():
            foot, _, tri = mesh.nearest(points[singular])
            normals[singular] = mesh.normals_at(foot, tri)
        return points, normals


#: boundary samples per face edge set: total count aimed at, and the most per edge
EDGE_SAMPLES = 20_000


def _edge_samples(face):
    """k-d tree of points along the face's edges and the margin that makes it a lower bound.

    Points are spaced evenly in each edge's parameter; the margin is half the largest gap
    between consecutive points plus the largest sagitta allowance (chord / 4 is generous for
    any curve sampled this finely). Returns ``(None, 0)`` for a face without edges.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from scipy.spatial import cKDTree

    curves = []
    explorer = TopExp_Explorer(face, TopAbs_EDGE)
    while explorer.More():
        edge = TopoDS.Edge(explorer.Current())
        explorer.Next()
        if BRep_Tool.Degenerated_s(edge):
            continue
        curve = BRepAdaptor_Curve(edge)
        curves.append((curve, GCPnts_AbscissaPoint.Length_s(curve)))
    total = sum(length for _, length in curves)
    if not curves or total <= 0:
        return None, 0.0
    spacing = total / EDGE_SAMPLES
    points, margin = [], 0.0
    for curve, length in curves:
        count = int(np.clip(np.ceil(length / spacing), 2, EDGE_SAMPLES)) + 1
        ts = np.linspace(curve.FirstParameter(), curve.LastParameter(), count)
        pts = np.array([curve.Value(t).Coord() for t in ts.tolist()])
        gap = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).max())
        margin = max(margin, 0.75 * gap)
        points.append(pts)
    return cKDTree(np.vstack(points)), margin
