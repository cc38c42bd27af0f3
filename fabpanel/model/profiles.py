"""A flat plate's solid read back as a profile and a depth (for exact, compact exchange files).

Ribs, stiffeners and packing plates are outlines extruded square to their plane
(:func:`fabpanel.model.occ.prism`). :func:`prism_profile` recovers that from any solid: its two
largest faces are parallel planes the plate's thickness apart and its volume is the face's
area times the thickness (within ``PRISM_TOLERANCE``); the face's outer and inner wires, laid
out in the face's plane, are the profile. Anything else (a rolled sheet) returns None.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import occ

#: relative tolerance on volume = area x depth and on the faces' distance
PRISM_TOLERANCE = 1e-3
#: chord deflection of curved profile edges, mm
PROFILE_DEFLECTION = 0.05


@dataclass(frozen=True)
class PrismProfile:
    """origin (3,), x and z (3,) unit axes (z into the solid), the outer loop (n, 2) and inner
    loops (m_i, 2) in (x, z × x) coordinates, and the depth along z, mm."""

    origin: np.ndarray
    x_axis: np.ndarray
    z_axis: np.ndarray
    outer: np.ndarray
    inner: tuple[np.ndarray, ...]
    depth: float


def prism_profile(brep: bytes, thickness: float) -> PrismProfile | None:
    """The plate as profile and depth (module docstring), or None."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    shape = occ.from_brep(brep)
    faces = []
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(face, props)
        faces.append((props.Mass(), face))
        explorer.Next()
    faces.sort(key=lambda f: -f[0])
    if len(faces) < 2:
        return None
    (area, face), (area_b, face_b) = faces[:2]
    surfaces = [BRepAdaptor_Surface(f) for f in (face, face_b)]
    if any(s.GetType() != GeomAbs_Plane for s in surfaces):
        return None
    planes = [s.Plane() for s in surfaces]
    normal = _vector(planes[0].Axis().Direction())
    other = _vector(planes[1].Axis().Direction())
    origin = _vector(planes[0].Location())
    depth = float((_vector(planes[1].Location()) - origin) @ normal)
    parallel = abs(abs(normal @ other) - 1.0) < 1e-9
    volume = occ.volume(shape, adaptive=False)
    if (
        not parallel
        or abs(abs(depth) - thickness) > PRISM_TOLERANCE * thickness
        or abs(area - area_b) > PRISM_TOLERANCE * area
        or abs(volume - area * thickness) > PRISM_TOLERANCE * volume
    ):
        return None
    z_axis = normal if depth > 0 else -normal
    x_axis = _vector(planes[0].XAxis().Direction())
    y_axis = np.cross(z_axis, x_axis)
    loops = [_loop(wire) for wire in _wires(face)]
    flat = [np.column_stack([(p - origin) @ x_axis, (p - origin) @ y_axis]) for p in loops]
    outer = max(range(len(flat)), key=lambda i: abs(signed_area(flat[i])))
    return PrismProfile(
        origin=origin,
        x_axis=x_axis,
        z_axis=z_axis,
        outer=flat[outer],
        inner=tuple(f for i, f in enumerate(flat) if i != outer),
        depth=abs(depth),
    )


def prism_mesh(profile: PrismProfile) -> tuple[np.ndarray, np.ndarray]:
    """The plate's closed triangle mesh from its profile: ``vertices (n, 3)`` mm in the part's
    frame and ``triangles (m, 3)`` wound outwards. manifold3d extrudes the profile (its caps
    triangulated around the holes), in milliseconds where meshing the solid took several."""
    import manifold3d

    section = manifold3d.CrossSection([profile.outer, *profile.inner], manifold3d.FillRule.EvenOdd)
    mesh = manifold3d.Manifold.extrude(section, profile.depth).to_mesh()
    local = np.asarray(mesh.vert_properties, dtype=float)[:, :3]
    # (x, z x x, z) is right-handed, so the triangles stay wound outwards
    frame = np.stack([profile.x_axis, np.cross(profile.z_axis, profile.x_axis), profile.z_axis])
    return profile.origin + local @ frame, np.asarray(mesh.tri_verts, dtype=np.int64)


def _vector(value) -> np.ndarray:
    return np.array([value.X(), value.Y(), value.Z()])


def signed_area(loop: np.ndarray) -> float:
    """A closed 2D loop's area, positive when it runs counter-clockwise."""
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _wires(face) -> list:
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    found = []
    explorer = TopExp_Explorer(face, TopAbs_WIRE)
    while explorer.More():
        found.append(TopoDS.Wire(explorer.Current()))
        explorer.Next()
    return found


def _loop(wire) -> np.ndarray:
    """A wire's points in order, each edge once (its end is the next edge's start), (n, 3)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.GCPnts import GCPnts_QuasiUniformDeflection
    from OCP.GeomAbs import GeomAbs_Line
    from OCP.TopAbs import TopAbs_REVERSED

    points: list[np.ndarray] = []
    explorer = BRepTools_WireExplorer(wire)
    while explorer.More():
        edge = explorer.Current()
        curve = BRepAdaptor_Curve(edge)
        first, last = curve.FirstParameter(), curve.LastParameter()
        if curve.GetType() == GeomAbs_Line:
            params = [first, last]
        else:
            sampler = GCPnts_QuasiUniformDeflection(curve, PROFILE_DEFLECTION, first, last)
            params = [sampler.Parameter(i) for i in range(1, sampler.NbPoints() + 1)]
        if edge.Orientation() == TopAbs_REVERSED:
            params = params[::-1]
        edge_points = [_vector(curve.Value(t)) for t in params]
        points.extend(edge_points[:-1])
        explorer.Next()
    return np.array(points)
