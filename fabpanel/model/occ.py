"""The single adapter to OCCT (OCP / build123d): everything the model stage asks of the kernel.

Functions take and return numpy arrays, OCCT shapes or BREP bytes; every kernel call is checked
(``IsDone``, ``BRepCheck_Analyzer``) and a failure raises :class:`~fabpanel.errors.KernelError`
naming the part ("sheet solid of P012-TOP is invalid").

Kernel behaviour relied on here is pinned in ``tests/test_kernel_quirks.py``:

- ``GeomAPI_PointsToBSplineSurface.Interpolate`` with ``Approx_IsoParametric`` builds a degree-3
  tensor-product interpolant whose boundary iso-curves depend on the boundary row only, so two
  panels sharing a side's samples get the same edge curve (to rounding), whatever their interior.
- Sewing two faces over the same parameter square with the ``BRepFill.Face_s`` ruled strips
  between their boundary iso-curves gives a valid closed solid (:func:`slab`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np
from OCP.Approx import Approx_ParametrizationType
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeSolid,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepFill import BRepFill
from OCP.BRepGProp import BRepGProp
from OCP.BRepLib import BRepLib
from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
from OCP.collections import (
    Array1_double,
    Array1_gp_Pnt,
    Array1_gp_Pnt2d,
    Array1_int,
    HArray1_double,
    HArray1_gp_Pnt,
    HArray1_gp_Pnt2d,
)
from OCP.collections import Array2_gp_Pnt as TColgp_Array2OfPnt
from OCP.Geom import Geom_BSplineCurve, Geom_BSplineSurface, Geom_Circle, Geom_Plane, Geom_Surface
from OCP.Geom2d import Geom2d_BSplineCurve
from OCP.Geom2dAPI import Geom2dAPI_Interpolate
from OCP.GeomAPI import (
    GeomAPI_Interpolate,
    GeomAPI_IntSS,
    GeomAPI_PointsToBSplineSurface,
    GeomAPI_ProjectPointOnSurf,
)
from OCP.gp import gp_Ax2, gp_Dir, gp_Pln, gp_Pnt, gp_Pnt2d, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.ShapeAnalysis import ShapeAnalysis_Surface
from OCP.TopAbs import TopAbs_EDGE, TopAbs_SHELL, TopAbs_SOLID, TopAbs_VERTEX
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Shape

from ..errors import KernelError
from ..geom.bspline_fit import (
    DEGREE,
    LOOP_TOLERANCE,
    LOOSE_LOOP_TOLERANCE,
    CubicFit,
    fit_cubic,
    fit_grid,
    fit_loop,
)
from ..surface.brep import brep_to_shape, shape_to_brep

#: tolerance of faces made from fitted surfaces, mm (OCCT's default Precision::Confusion is 1e-7)
FACE_TOLERANCE = 1e-6
#: tolerance of a hole's edges, mm: their 3D curve and their curve on the sheet's surface are
#: two interpolations through the same points, apart by far less between the points
EDGE_TOLERANCE = 1e-4
#: mm: how close the nearest point of a surface is found to a point beyond its edge
PROJECTION_TOLERANCE = 1e-4


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
        raise KernelError(
            f"B-spline interpolation of {name}: grid must be (k, k, 3), got {grid.shape}"
        )
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
    # the interpolation parameters are uniform on the unit square (pinned in the kernel quirk
    # tests), so the error at the samples is a direct evaluation, not a projection
    return surface, float(np.linalg.norm(sample_surface(surface, nu, nv) - grid, axis=2).max())


def fitted_surface(grid: np.ndarray, name: str = "surface") -> Geom_BSplineSurface:
    """The bicubic with the fewest poles within
    :data:`~fabpanel.geom.bspline_fit.SURFACE_TOLERANCE` of the point grid ``grid (k, k2, 3)``
    and of the cubic through it (:func:`~fabpanel.geom.bspline_fit.fit_grid`: a rolled sheet
    of the demo needs 7 x 4 poles, not 19 x 19; a boundary row in a plane keeps its edge in
    it), over the unit square with ``grid[i, j]`` at the same uniform parameters as
    :func:`bspline_surface`; that interpolation where no such fit holds."""
    fit = fit_grid(grid)
    if fit is None:
        return bspline_surface(grid, name)[0]
    a, b = fit.poles.shape[:2]
    poles = TColgp_Array2OfPnt(1, a, 1, b)
    for i in range(a):
        for j in range(b):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, fit.poles[i, j])))
    knots = []
    for curve in (fit.u, fit.v):
        values = Array1_double(1, len(curve.knots))
        mults = Array1_int(1, len(curve.knots))
        for i, (k, m) in enumerate(zip(curve.knots, curve.multiplicities, strict=True)):
            values.SetValue(i + 1, float(k))
            mults.SetValue(i + 1, int(m))
        knots.append((values, mults))
    (uk, um), (vk, vm) = knots
    try:
        return Geom_BSplineSurface(poles, uk, vk, um, vm, DEGREE, DEGREE)
    except Exception as err:  # OCCT raises Standard_Failure subclasses through OCP
        raise KernelError(f"B-spline surface of {name} failed: {err}") from err


def sample_surface(surface: Geom_Surface, a: int, b: int, offset: float = 0.0) -> np.ndarray:
    """(a, b, 3) float: the surface (moved by ``offset`` mm along its normal) on a uniform grid of
    its parameter domain, ``[i, j]`` at ``(u_i, v_j)``."""
    u0, u1, v0, v1 = surface.Bounds()
    us, vs = np.meshgrid(np.linspace(u0, u1, a), np.linspace(v0, v1, b), indexing="ij")
    return surface_points(surface, us.ravel(), vs.ravel(), offset).reshape(a, b, 3)


def surface_points(
    surface: Geom_Surface, us: np.ndarray, vs: np.ndarray, offset: float = 0.0
) -> np.ndarray:
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


def surface_derivatives(
    surface: Geom_Surface, uv: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, dS/du and dS/dv, each (n, 3) float, at the parameter pairs ``uv (n, 2)``.

    Parameters outside the domain extrapolate the boundary polynomial span (OCCT evaluates
    B-splines that way), which is what trimming a surface slightly beyond its samples needs.
    """
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    out = np.empty((3, len(uv), 3))
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for i, (u, v) in enumerate(uv):
        surface.D1(float(u), float(v), p, du, dv)
        out[0, i] = (p.X(), p.Y(), p.Z())
        out[1, i] = (du.X(), du.Y(), du.Z())
        out[2, i] = (dv.X(), dv.Y(), dv.Z())
    return out[0], out[1], out[2]


def surface_third_derivatives(surface: Geom_Surface, uv: np.ndarray) -> np.ndarray:
    """(10, n, 3) float at ``uv (n, 2)``: S; dS/du, dS/dv; d2S/du2, d2S/dv2, d2S/dudv;
    d3S/du3, d3S/dv3, d3S/du2dv, d3S/dudv2 (OCCT's ``D3`` order)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    out = np.empty((10, len(uv), 3))
    p = gp_Pnt()
    vecs = [gp_Vec() for _ in range(9)]
    for i, (u, v) in enumerate(uv):
        surface.D3(float(u), float(v), p, *vecs)
        out[0, i] = (p.X(), p.Y(), p.Z())
        for j, vec in enumerate(vecs, start=1):
            out[j, i] = (vec.X(), vec.Y(), vec.Z())
    return out


def plane_section(
    surface: Geom_Surface, plane: np.ndarray, per_curve: int = 257, name: str = "surface"
) -> np.ndarray:
    """(n, 3) float: points of the intersection of a surface with ``plane (4,)`` (unit normal,
    ``n . x = d``), ``per_curve`` per intersection curve, mm (empty when they do not meet)."""
    normal = np.asarray(plane[:3], dtype=float)
    origin = normal * float(plane[3])
    geom_plane = Geom_Plane(gp_Pln(gp_Pnt(*origin), gp_Dir(*normal)))
    try:
        section = GeomAPI_IntSS(surface, geom_plane, 1e-7)
    except Exception as err:
        raise KernelError(f"plane section of {name} failed: {err}") from err
    if not section.IsDone():
        raise KernelError(f"plane section of {name} failed")
    points = []
    for index in range(1, section.NbLines() + 1):
        curve = section.Line(index)
        t0, t1 = curve.FirstParameter(), curve.LastParameter()
        points += [_xyz(curve.Value(float(t))) for t in np.linspace(t0, t1, per_curve)]
    return np.array(points, dtype=float).reshape(-1, 3)


def project_to_surface(surface: Geom_Surface, points: np.ndarray) -> np.ndarray:
    """(n, 2) float: the (u, v) parameters of the orthogonal projections of ``points (n, 3)``;
    where a point has no foot on the surface (it lies beyond the surface's edge), those of
    the nearest point of the bounded surface, on its edge. (Seen on the pavilion: an access
    opening's centre at its reach beyond a sheet's edge had no foot, and the panel was not
    built; the projection is only the start of the opening's wall search, which says where
    an opening leaves its sheet.)"""
    out = np.empty((len(points), 2))
    projector = GeomAPI_ProjectPointOnSurf()
    nearest = None
    for i, p in enumerate(np.asarray(points, dtype=float)):
        projector.Init(gp_Pnt(*p), surface)
        if projector.NbPoints() > 0:
            out[i] = projector.LowerDistanceParameters()
            continue
        if nearest is None:
            nearest = ShapeAnalysis_Surface(surface)
        uv = nearest.ValueOfUV(gp_Pnt(*p), PROJECTION_TOLERANCE)
        u0, u1, v0, v1 = surface.Bounds()  # ValueOfUV may land 1e-7 outside them
        out[i] = np.clip(uv.X(), u0, u1), np.clip(uv.Y(), v0, v1)
    return out


def face_from_surface(surface: Geom_Surface, name: str = "face") -> TopoDS_Shape:
    """A face bounded by the surface's parameter domain."""
    u0, u1, v0, v1 = surface.Bounds()
    maker = BRepBuilderAPI_MakeFace(surface, u0, u1, v0, v1, FACE_TOLERANCE)
    if not maker.IsDone():
        raise KernelError(f"face of {name} could not be made (error {maker.Error()})")
    return maker.Face()


# --------------------------------------------------------------------------------------------
# solids
# --------------------------------------------------------------------------------------------
def slab(
    outer: Geom_BSplineSurface,
    inner: Geom_BSplineSurface,
    name: str = "sheet",
    holes: Iterable[tuple[np.ndarray, np.ndarray]] = (),
) -> TopoDS_Shape:
    """A closed sheet solid between two surfaces over the same parameter square: the two faces
    and four ruled side faces between their boundary iso-curves, sewn and made a solid.

    More robust than thickening a face (``BRepOffsetAPI_MakeThickSolid`` gave an invalid side
    face on a 330 mm radius cone panel), and the side faces are exactly the ruled
    strips between the two faces' edges, planar where both edges lie in one rib plane.

    holes : per hole, its boundary on the outer and on the inner face as closed loops of
        parameters, (n, 2) float each, sampled at the same angles around the hole axis. They
        become inner wires of the faces and a ruled wall between them (the rulings join equal
        angles, so they run along the hole axis): a drilled sheet without a boolean, which
        costs about 1 s per sheet on B-spline faces.
    """
    faces = [
        BRepBuilderAPI_MakeFace(surface, *surface.Bounds(), FACE_TOLERANCE)
        for surface in (outer, inner)
    ]
    walls = []
    for loops in holes:
        edges = _hole_edges((outer, inner), loops, name)
        for maker, edge, loop in zip(faces, edges, loops):
            wire = BRepBuilderAPI_MakeWire(edge).Wire()
            if _loop_area(loop) > 0:  # holes run clockwise in the parameter plane
                wire = TopoDS.Wire(wire.Reversed())
            maker.Add(wire)
        walls.append(BRepFill.Face_s(edges[0], edges[1]))
    sewing = BRepBuilderAPI_Sewing(1e-4)
    for maker in faces:
        if not maker.IsDone():
            raise KernelError(f"a face of {name} could not be made (error {maker.Error()})")
        sewing.Add(maker.Face())
    for wall in walls:
        sewing.Add(wall)
    for side in range(4):
        edges = [BRepBuilderAPI_MakeEdge(_iso_curve(surface, side)) for surface in (outer, inner)]
        if not all(edge.IsDone() for edge in edges):
            raise KernelError(f"side {side} edge of {name} could not be made")
        sewing.Add(BRepFill.Face_s(edges[0].Edge(), edges[1].Edge()))
    sewing.Perform()
    shells = list(_explore(sewing.SewedShape(), TopAbs_SHELL))
    if len(shells) != 1:
        raise KernelError(f"the faces of {name} did not sew into one shell ({len(shells)})")
    maker = BRepBuilderAPI_MakeSolid(TopoDS.Shell(shells[0]))
    if not maker.IsDone():
        raise KernelError(f"solid of {name} could not be made")
    solid = maker.Solid()
    BRepLib.OrientClosedSolid_s(solid)
    check_valid(solid, f"sheet solid of {name}")
    if volume(solid, adaptive=False) <= 0:  # the sign only: the fast rule
        raise KernelError(f"sheet solid of {name} has non-positive volume")
    return solid


def _loop_area(loop: np.ndarray) -> float:
    x, y = loop[:, 0], loop[:, 1]
    return float(0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1)))


def _hole_edges(
    surfaces: tuple[Geom_Surface, Geom_Surface], loops: tuple[np.ndarray, np.ndarray], name: str
) -> list[TopoDS_Shape]:
    """The closed edges of one hole on the sheet's two ``surfaces``, through the parameter
    pairs ``loops`` (each (n, 2), the same n, point i of both on one line along the hole
    axis). Each edge's 3D curve and p-curve, on both faces, share one knot vector and the same
    parameters (the mean chord length of the two loops), so the ruled wall between the edges
    has the poles of one curve twice and its rulings join points i: cubics fitted within
    :data:`~fabpanel.geom.bspline_fit.LOOP_TOLERANCE` with double knots where the outline's
    straight runs meet its rounds (:func:`~fabpanel.geom.bspline_fit.fit_loop`: a slot's 53
    points become 26 poles), else within ``LOOSE_LOOP_TOLERANCE`` (a merged opening's 126
    points, 48 poles), or, where no such fit holds, periodic cubics through every point.
    OCCT's own 3D curve of a p-curve (``BuildCurves3d``) came out at degree 14 with 400-2000
    poles, and the ruled wall between two of them with up to 8600: two thirds of a STEP file."""
    points = [surface_points(s, loop[:, 0], loop[:, 1]) for s, loop in zip(surfaces, loops)]
    chords = [np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1) for p in points]
    steps = 0.5 * (chords[0] + chords[1])
    scales = [np.ones_like(points[0]), np.ones_like(points[1])]
    for surface, loop in zip(surfaces, loops):
        _, du, dv = surface_derivatives(surface, loop)
        scales.append(np.c_[np.linalg.norm(du, axis=1), np.linalg.norm(dv, axis=1)])
    sets = [points[0], points[1], *loops]
    fit = fit_loop(sets, steps, scales, LOOP_TOLERANCE)
    if fit is None:
        fit = fit_loop(sets, steps, scales, LOOSE_LOOP_TOLERANCE)
    if fit is None:
        curves = _interpolated_loops(loops, points, steps, name)
    else:
        curves = [(bspline_curve(fit, k), bspline_curve(fit, k + 2)) for k in (0, 1)]
    edges = []
    for surface, (curve3d, curve2d) in zip(surfaces, curves):
        maker = BRepBuilderAPI_MakeEdge(curve3d)
        if not maker.IsDone():
            raise KernelError(f"hole edge of {name} could not be made (error {maker.Error()})")
        edge = maker.Edge()
        BRep_Builder().UpdateEdge(edge, curve2d, surface, TopLoc_Location(), EDGE_TOLERANCE)
        BRepLib.SameParameter_s(edge, EDGE_TOLERANCE)
        edges.append(edge)
    return edges


def _interpolated_loops(loops, points, steps: np.ndarray, name: str) -> list[tuple]:
    """Per face, the periodic cubics through every point of its loop: ``(3D curve, p-curve)``
    with the parameters of ``steps``."""
    params = HArray1_double(1, len(steps) + 1)
    for i, value in enumerate(np.concatenate([[0.0], np.cumsum(steps)])):
        params.SetValue(i + 1, float(value))
    curves = []
    for loop, xyz in zip(loops, points):
        flat = HArray1_gp_Pnt2d(1, len(loop))
        space = HArray1_gp_Pnt(1, len(loop))
        for i, ((u, v), p) in enumerate(zip(np.asarray(loop, dtype=float), xyz)):
            flat.SetValue(i + 1, gp_Pnt2d(float(u), float(v)))
            space.SetValue(i + 1, gp_Pnt(*map(float, p)))
        curve2d = Geom2dAPI_Interpolate(flat, params, True, 1e-9)
        curve3d = GeomAPI_Interpolate(space, params, True, 1e-7)
        curve2d.Perform()
        curve3d.Perform()
        if not (curve2d.IsDone() and curve3d.IsDone()):
            raise KernelError(f"hole outline of {name} could not be interpolated")
        curves.append((curve3d.Curve(), curve2d.Curve()))
    return curves


def _iso_curve(surface: Geom_Surface, side: int):
    u0, u1, v0, v1 = surface.Bounds()
    return {
        0: lambda: surface.VIso(v0),
        1: lambda: surface.UIso(u1),
        2: lambda: surface.VIso(v1),
        3: lambda: surface.UIso(u0),
    }[side]()


def prism(
    chains: list[np.ndarray],
    frame: np.ndarray,
    thickness: float,
    name: str = "part",
    holes: Iterable[tuple[np.ndarray, float]] = (),
) -> TopoDS_Shape:
    """A planar plate extruded by ``thickness`` mm along the frame's +z.

    chains : list of (n_i, 2) float
        the closed outline in the frame's (x, y), mm, as consecutive chains (the last point of
        each is the first of the next, the last chain ends at the first point). A 2-point chain
        becomes a straight edge, a longer one a cubic B-spline interpolating its points (so a
        curved rib edge is one smooth edge, not a hundred facets).
    frame : (4, 4) float
        maps the plane's (x, y, 0) to world coordinates.
    holes : (centre (2,), diameter) pairs
        round holes through the plate, in the frame's (x, y); made as inner wires of the face
        before the extrusion, so no boolean is needed.
    """
    frame = np.asarray(frame, dtype=float)
    wire = BRepBuilderAPI_MakeWire()
    for index, chain in enumerate(chains):
        wire.Add(_edge(np.asarray(chain, dtype=float), frame, f"{name} outline chain {index}"))
        if not wire.IsDone():
            raise KernelError(
                f"outline of {name} is not a connected wire (chain {index}, error {wire.Error()})"
            )
    face = BRepBuilderAPI_MakeFace(wire.Wire(), True)
    if not face.IsDone():
        raise KernelError(f"outline of {name} is not a planar face (error {face.Error()})")
    z = gp_Dir(*frame[:3, 2])
    for centre, diameter in holes:
        world = frame[:3, :3] @ np.r_[centre, 0.0] + frame[:3, 3]
        circle = Geom_Circle(gp_Ax2(gp_Pnt(*world), z, gp_Dir(*frame[:3, 0])), diameter / 2)
        ring = BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(circle).Edge())
        face.Add(TopoDS.Wire(ring.Wire().Reversed()))
        if not face.IsDone():
            raise KernelError(f"hole at {np.round(centre, 2).tolist()} in {name} failed")
    direction = frame[:3, 2] * float(thickness)
    maker = BRepPrimAPI_MakePrism(face.Face(), gp_Vec(*direction))
    if not maker.IsDone():
        raise KernelError(f"extrusion of {name} failed")
    solid = _single_solid(maker.Shape(), f"extrusion of {name}")
    check_valid(solid, f"extrusion of {name}")
    if volume(solid, adaptive=False) <= 0:
        raise KernelError(f"extrusion of {name} gave a solid of non-positive volume")
    return solid


def _edge(chain: np.ndarray, frame: np.ndarray, what: str) -> TopoDS_Shape:
    """The edge of a chain of points ``(n, 2)`` in the plane of ``frame`` (4, 4): a straight
    edge (2 points), or a cubic B-spline with the fewest poles that keeps within
    :data:`~fabpanel.geom.bspline_fit.FIT_TOLERANCE` of the points (through every point where
    no fit has fewer poles than points). Fitted in the plane's own (x, y) and mapped by the
    frame, so the poles lie in the plane to round-off and the outline makes a planar face."""
    if len(chain) < 2:
        raise KernelError(f"{what}: fewer than two points")

    def to_world(xy: np.ndarray) -> np.ndarray:
        return (np.c_[xy, np.zeros(len(xy)), np.ones(len(xy))] @ frame.T)[:, :3]

    fit = fit_cubic(chain) if len(chain) > 2 else None
    points = to_world(chain)
    if len(chain) == 2:
        maker = BRepBuilderAPI_MakeEdge(gp_Pnt(*points[0]), gp_Pnt(*points[1]))
    elif fit is not None:
        maker = BRepBuilderAPI_MakeEdge(bspline_curve(replace(fit, poles=to_world(fit.poles))))
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


def bspline_curve(fit: CubicFit, which: int = 0) -> Geom_BSplineCurve | Geom2d_BSplineCurve:
    """The OCCT curve of a :class:`~fabpanel.geom.bspline_fit.CubicFit`'s set ``which``: a 3D
    curve of 3D poles, a parameter-plane curve of 2D ones."""
    poles = fit.poles if which == 0 else fit.more[which - 1]
    knots = Array1_double(1, len(fit.knots))
    mults = Array1_int(1, len(fit.knots))
    for i, (k, m) in enumerate(zip(fit.knots, fit.multiplicities, strict=True)):
        knots.SetValue(i + 1, float(k))
        mults.SetValue(i + 1, int(m))
    if poles.shape[1] == 2:
        flat = Array1_gp_Pnt2d(1, len(poles))
        for i, p in enumerate(poles):
            flat.SetValue(i + 1, gp_Pnt2d(*map(float, p)))
        return Geom2d_BSplineCurve(flat, knots, mults, DEGREE)
    space = Array1_gp_Pnt(1, len(poles))
    for i, p in enumerate(poles):
        space.SetValue(i + 1, gp_Pnt(*map(float, p)))
    return Geom_BSplineCurve(space, knots, mults, DEGREE)


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


#: relative accuracy of the adaptive volume integration: the fixed Gauss rule OCCT uses by default
#: was 1 % off on a sheet drilled with one 40 mm hole (trimmed B-spline faces). 1e-4 gave the
#: same volume as 1e-6 to 1e-13 on a sheet with 18 access slots, in 0.3 s instead of 0.45 s;
#: 1e-3 the same as 1e-4 to 1e-14 on the demo's sheets and to 1e-9 on a sphere cap's doubly
#: curved ones (both 8.6e-7 from 1e-6; the Gauss rule 9e-3), in half the time (0.16 s a sheet
#: against 0.33 s): the integration's error estimate is far above its error
VOLUME_ACCURACY = 1e-3


def volume(shape: TopoDS_Shape, adaptive: bool = True) -> float:
    """Volume, mm3: adaptive integration to ``VOLUME_ACCURACY``, or OCCT's fixed Gauss rule
    (``adaptive=False``: exact and several times faster on planar plates)."""
    return mass_properties(shape, adaptive)[0]


def mass_properties(shape: TopoDS_Shape, adaptive: bool = True) -> tuple[float, np.ndarray]:
    """Volume, mm3, and centre of volume (3,), mm, from one integration (see :func:`volume`)."""
    props = GProp_GProps()
    if adaptive:
        BRepGProp.VolumeProperties_s(shape, props, VOLUME_ACCURACY, False)
    else:
        BRepGProp.VolumeProperties_s(shape, props)
    centre = props.CentreOfMass()
    return float(props.Mass()), np.array([centre.X(), centre.Y(), centre.Z()])


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
