"""The single adapter to OCCT (OCP / build123d): everything the model stage asks of the kernel.

Functions take and return numpy arrays, OCCT shapes or BREP bytes; every kernel call is checked
(``IsDone``, ``BRepCheck_Analyzer``) and a failure raises :class:`~fabpanel.errors.KernelError`
naming the part ("thickening of P012-TOP failed").

Kernel behaviour relied on here is pinned in ``tests/test_kernel_quirks.py``:

- ``GeomAPI_PointsToBSplineSurface.Interpolate`` with ``Approx_IsoParametric`` builds a degree-3
  tensor-product interpolant whose boundary iso-curves depend on the boundary row only, so two
  panels sharing a side's samples get the same edge curve (to rounding), whatever their interior.
- ``BRepOffsetAPI_MakeThickSolid.MakeThickSolidBySimple`` offsets along the face normal, which for
  a surface fitted to ``grid[i, j]`` is ``dS/di x dS/dj``.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from OCP.Approx import Approx_ParametrizationType
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeWire,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepGProp import BRepGProp
from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeThickSolid
from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
from OCP.collections import Array2_gp_Pnt as TColgp_Array2OfPnt
from OCP.collections import HArray1_gp_Pnt
from OCP.Geom import Geom_BSplineSurface, Geom_OffsetSurface, Geom_Surface
from OCP.GeomAPI import (
    GeomAPI_Interpolate,
    GeomAPI_PointsToBSplineSurface,
    GeomAPI_ProjectPointOnSurf,
)
from OCP.gp import gp_Pnt, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.TopAbs import TopAbs_EDGE, TopAbs_SOLID, TopAbs_VERTEX
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Shape

from ..errors import KernelError
from ..surface.brep import brep_to_shape, shape_to_brep

#: tolerance of faces made from fitted surfaces, mm (OCCT's default Precision::Confusion is 1e-7)
FACE_TOLERANCE = 1e-6


# --------------------------------------------------------------------------------------------
# surfaces
# --------------------------------------------------------------------------------------------
def bspline_surface(grid: np.ndarray, name: str = "surface") -> tuple[Geom_BSplineSurface, float]:
    """Degree-3 B-spline surface interpolating a point grid, and its fit error.

    grid : (k, k2, 3) float
        points, mm; ``grid[i, j]`` lands at ``S(u_i, v_j)`` with uniform (iso-parametric)
        parameters, so an iso-curve along the grid boundary depends only on that boundary row and
        neighbouring panels sharing boundary samples get identical edge curves. The surface normal
        ``dS/du x dS/dv`` follows ``grid[i+1] - grid[i]`` x ``grid[:, j+1] - grid[:, j]``.
    Returns the surface and the fit error: the largest distance of a grid point to the surface, mm.
    """
    grid = np.asarray(grid, dtype=float)
    if grid.ndim != 3 or grid.shape[2] != 3 or min(grid.shape[:2]) < 2:
        raise KernelError(f"B-spline interpolation of {name}: grid must be (k, k, 3), "
                          f"got {grid.shape}")
    if not np.all(np.isfinite(grid)):
        raise KernelError(f"B-spline interpolation of {name}: grid has non-finite points")
    nu, nv = grid.shape[:2]
    points = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            points.SetValue(i + 1, j + 1, gp_Pnt(*grid[i, j]))
    maker = GeomAPI_PointsToBSplineSurface()
    try:
        maker.Interpolate(points, Approx_ParametrizationType.Approx_IsoParametric, False)
    except Exception as err:  # OCCT raises Standard_Failure subclasses through OCP
        raise KernelError(f"B-spline interpolation of {name} failed: {err}") from err
    if not maker.IsDone():
        raise KernelError(f"B-spline interpolation of {name} failed")
    surface = maker.Surface()
    return surface, fit_error(surface, grid.reshape(-1, 3))


def fit_error(surface: Geom_Surface, points: np.ndarray) -> float:
    """Largest distance of ``points (n, 3)`` to ``surface``, mm (orthogonal projection)."""
    worst = 0.0
    projector = GeomAPI_ProjectPointOnSurf()
    for p in np.asarray(points, dtype=float):
        projector.Init(gp_Pnt(*p), surface)
        if projector.NbPoints() == 0:
            # no orthogonal foot (a point on the boundary may miss it): fall back to the grid
            # distance of the nearest evaluated point, an upper bound
            worst = max(worst, _nearest_sample_distance(surface, p))
            continue
        worst = max(worst, projector.LowerDistance())
    return float(worst)


def _nearest_sample_distance(surface: Geom_Surface, point: np.ndarray) -> float:
    grid = sample_surface(surface, 33, 33)
    return float(np.linalg.norm(grid.reshape(-1, 3) - point, axis=1).min())


def offset_surface(surface: Geom_Surface, offset: float) -> Geom_Surface:
    """The surface moved by ``offset`` mm along its normal (the surface itself for 0)."""
    if offset == 0.0:
        return surface
    return Geom_OffsetSurface(surface, float(offset))


def sample_surface(surface: Geom_Surface, a: int, b: int, offset: float = 0.0) -> np.ndarray:
    """(a, b, 3) float: the surface (moved by ``offset`` mm along its normal) on a uniform grid of
    its parameter domain, ``[i, j]`` at ``(u_i, v_j)``."""
    u0, u1, v0, v1 = surface.Bounds()
    us, vs = np.meshgrid(np.linspace(u0, u1, a), np.linspace(v0, v1, b), indexing="ij")
    return surface_points(surface, us.ravel(), vs.ravel(), offset).reshape(a, b, 3)


def surface_points(surface: Geom_Surface, us: np.ndarray, vs: np.ndarray,
                   offset: float = 0.0) -> np.ndarray:
    """(n, 3) float: ``S(u, v) + offset * N(u, v)`` at the parameter pairs ``us, vs (n,)``, with
    ``N`` the unit normal ``dS/du x dS/dv``."""
    out = np.empty((len(us), 3))
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for i, (u, v) in enumerate(zip(us, vs)):
        surface.D1(float(u), float(v), p, du, dv)
        out[i] = (p.X(), p.Y(), p.Z())
        if offset:
            n = du.Crossed(dv)
            length = n.Magnitude()
            if length < 1e-12:
                raise KernelError(f"surface normal undefined at (u, v) = ({u:g}, {v:g})")
            out[i] += offset / length * np.array((n.X(), n.Y(), n.Z()))
    return out


def face_from_surface(surface: Geom_Surface, name: str = "face") -> TopoDS_Shape:
    """A face bounded by the surface's parameter domain."""
    u0, u1, v0, v1 = surface.Bounds()
    maker = BRepBuilderAPI_MakeFace(surface, u0, u1, v0, v1, FACE_TOLERANCE)
    if not maker.IsDone():
        raise KernelError(f"face of {name} could not be made (error {maker.Error()})")
    return maker.Face()


def face_area(face: TopoDS_Shape) -> float:
    """Area of a face or shell, mm2."""
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return float(props.Mass())


# --------------------------------------------------------------------------------------------
# solids
# --------------------------------------------------------------------------------------------
def thicken(face: TopoDS_Shape, thickness: float, name: str = "part") -> TopoDS_Shape:
    """A solid from a face moved by ``thickness`` mm along the face normal (negative: against it).

    Raises :class:`KernelError` when OCCT fails or the solid is not valid.
    """
    maker = BRepOffsetAPI_MakeThickSolid()
    try:
        maker.MakeThickSolidBySimple(face, float(thickness))
        maker.Build()
    except Exception as err:
        raise KernelError(f"thickening of {name} failed: {err}") from err
    if not maker.IsDone():
        raise KernelError(f"thickening of {name} failed")
    solid = _single_solid(maker.Shape(), f"thickening of {name}")
    check_valid(solid, f"thickening of {name}")
    if volume(solid) <= 0:
        raise KernelError(f"thickening of {name} gave a solid of non-positive volume")
    return solid


def prism(chains: list[np.ndarray], frame: np.ndarray, thickness: float,
          name: str = "part") -> TopoDS_Shape:
    """A planar plate extruded by ``thickness`` mm along the frame's +z.

    chains : list of (n_i, 2) float
        the closed outline in the frame's (x, y), mm, as consecutive chains (the last point of
        each is the first of the next, the last chain ends at the first point). A 2-point chain
        becomes a straight edge, a longer one a cubic B-spline interpolating its points (so a
        curved rib edge is one smooth edge, not a hundred facets).
    frame : (4, 4) float
        maps the plane's (x, y, 0) to world coordinates.
    """
    frame = np.asarray(frame, dtype=float)
    wire = BRepBuilderAPI_MakeWire()
    for index, chain in enumerate(chains):
        chain = np.asarray(chain, dtype=float)
        world = (np.c_[chain, np.zeros(len(chain)), np.ones(len(chain))] @ frame.T)[:, :3]
        wire.Add(_edge(world, f"{name} outline chain {index}"))
        if not wire.IsDone():
            raise KernelError(f"outline of {name} is not a connected wire (chain {index}, "
                              f"error {wire.Error()})")
    face = BRepBuilderAPI_MakeFace(wire.Wire(), True)
    if not face.IsDone():
        raise KernelError(f"outline of {name} is not a planar face (error {face.Error()})")
    direction = frame[:3, 2] * float(thickness)
    maker = BRepPrimAPI_MakePrism(face.Face(), gp_Vec(*direction))
    if not maker.IsDone():
        raise KernelError(f"extrusion of {name} failed")
    solid = _single_solid(maker.Shape(), f"extrusion of {name}")
    check_valid(solid, f"extrusion of {name}")
    if volume(solid) <= 0:
        raise KernelError(f"extrusion of {name} gave a solid of non-positive volume")
    return solid


def _edge(points: np.ndarray, what: str) -> TopoDS_Shape:
    """A straight edge (2 points) or an interpolating cubic B-spline edge (more points)."""
    if len(points) < 2:
        raise KernelError(f"{what}: fewer than two points")
    if len(points) == 2:
        maker = BRepBuilderAPI_MakeEdge(gp_Pnt(*points[0]), gp_Pnt(*points[1]))
    else:
        array = HArray1_gp_Pnt(1, len(points))
        for i, p in enumerate(points):
            array.SetValue(i + 1, gp_Pnt(*p))
        interpolate = GeomAPI_Interpolate(array, False, 1e-7)
        interpolate.Perform()
        if not interpolate.IsDone():
            raise KernelError(f"{what}: curve interpolation failed")
        maker = BRepBuilderAPI_MakeEdge(interpolate.Curve())
    if not maker.IsDone():
        raise KernelError(f"{what}: edge could not be made (error {maker.Error()})")
    return maker.Edge()


def _single_solid(shape: TopoDS_Shape, what: str) -> TopoDS_Shape:
    solids = list(_explore(shape, TopAbs_SOLID))
    if len(solids) != 1:
        raise KernelError(f"{what} gave {len(solids)} solids instead of one")
    return TopoDS.Solid(solids[0])


def _explore(shape: TopoDS_Shape, kind) -> Iterable[TopoDS_Shape]:
    explorer = TopExp_Explorer(shape, kind)
    while explorer.More():
        yield explorer.Current()
        explorer.Next()


# --------------------------------------------------------------------------------------------
# checks and measures
# --------------------------------------------------------------------------------------------
def is_valid(shape: TopoDS_Shape) -> bool:
    """BRepCheck_Analyzer's verdict."""
    return bool(BRepCheck_Analyzer(shape).IsValid())


def check_valid(shape: TopoDS_Shape, what: str) -> None:
    if shape is None or shape.IsNull() or not is_valid(shape):
        raise KernelError(f"{what} gave an invalid shape")


def volume(shape: TopoDS_Shape) -> float:
    """Volume, mm3."""
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def common_volume(a: TopoDS_Shape, b: TopoDS_Shape) -> float:
    """Volume of the boolean intersection of two solids, mm3 (0 when they only touch)."""
    op = BRepAlgoAPI_Common(a, b)
    if not op.IsDone():
        raise KernelError("boolean common failed")
    return abs(volume(op.Shape()))


def shape_points(shape: TopoDS_Shape, per_edge: int = 8) -> np.ndarray:
    """(n, 3) float: the shape's vertices and ``per_edge`` points along each of its edges, mm."""
    points = []
    for vertex in _explore(shape, TopAbs_VERTEX):
        p = BRep_Tool.Pnt_s(TopoDS.Vertex(vertex))
        points.append((p.X(), p.Y(), p.Z()))
    if per_edge > 0:
        points += [p for edge in edge_points(shape, per_edge) for p in edge[1:-1]]
    return np.array(points, dtype=float).reshape(-1, 3)


def edge_points(shape: TopoDS_Shape, per_edge: int = 8) -> list[np.ndarray]:
    """Per edge of the shape, (per_edge + 2, 3) float: its end points and ``per_edge`` points
    between, evenly in the curve parameter, mm."""
    out = []
    for edge in _explore(shape, TopAbs_EDGE):
        curve = BRepAdaptor_Curve(TopoDS.Edge(edge))
        ts = np.linspace(curve.FirstParameter(), curve.LastParameter(), per_edge + 2)
        out.append(np.array([_xyz(curve.Value(float(t))) for t in ts]))
    return out


def _xyz(p: gp_Pnt) -> tuple[float, float, float]:
    return (p.X(), p.Y(), p.Z())


def plane_distances(shape: TopoDS_Shape, plane: np.ndarray, per_edge: int = 8) -> np.ndarray:
    """(n,) float: signed distances of the shape's vertices and edge samples to
    ``plane (4,)`` = (nx, ny, nz, d) with ``n . x = d`` (n unit), mm."""
    plane = np.asarray(plane, dtype=float)
    return shape_points(shape, per_edge) @ plane[:3] - plane[3]


def max_distance_to_plane(shape: TopoDS_Shape, plane: np.ndarray, per_edge: int = 8) -> float:
    """Largest distance of the shape's vertices and edge samples to a plane, mm."""
    return float(np.abs(plane_distances(shape, plane, per_edge)).max())


# --------------------------------------------------------------------------------------------
# serialisation
# --------------------------------------------------------------------------------------------
def to_brep(shape: TopoDS_Shape) -> bytes:
    """The shape as OCCT BREP text (no triangulation): what crosses process boundaries."""
    return shape_to_brep(shape)


def from_brep(data: bytes, name: str = "shape") -> TopoDS_Shape:
    """Read BREP text bytes back into a shape (:class:`KernelError` naming ``name`` if not)."""
    return brep_to_shape(data, name)
