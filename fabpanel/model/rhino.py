"""``design.3dm``: the panels for Rhino and Grasshopper users (the thesis's users), via rhino3dm.

Layers (millimetres):

``panels``        each panel's developed design face as an exact NURBS surface (the B-spline
                  the sheets are built from, its knots and poles copied from OCCT), named by id
``outlines``      each panel's four sides as one closed polyline
``ribs``          every rib's flat outline in its plane, in place
``stiffeners``    every corner stiffener's outline, in place
``labels``        a text dot with the panel id at each panel's centre
``solids-sheets``, ``solids-ribs``, ``solids-stiffeners``, ``solids-packing``
                  every part's solid, named by part id: a flat plate (rib, stiffener, packing)
                  exactly, as a capped extrusion of its profile with its holes (a Rhino
                  extrusion object), a rolled sheet as the closed mesh the IFC carries

Every panel of the layout is drawn, also one the build stage could not build (its outline and
label; its surface too unless its developed grid admits no B-spline, which is then logged).

Rhino's knot vectors omit the first and last knot of the clamped vectors OCCT (and the NURBS
book) use, so ``n + p - 1`` knots are written for ``n`` poles of degree ``p``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import cast

import numpy as np

from ..data import Model
from ..errors import KernelError
from . import occ
from .profiles import PrismProfile, signed_area

log = logging.getLogger(__name__)

#: layer colours (RGBA 0-255), matching the STEP/GLB colours by kind
LAYERS = {
    "panels": (184, 189, 199, 255),
    "outlines": (40, 40, 40, 255),
    "ribs": (230, 140, 38, 255),
    "stiffeners": (204, 51, 38, 255),
    "packing": (77, 115, 204, 255),
    "labels": (20, 60, 160, 255),
    "solids-sheets": (184, 189, 199, 255),
    "solids-ribs": (230, 140, 38, 255),
    "solids-stiffeners": (204, 51, 38, 255),
    "solids-packing": (77, 115, 204, 255),
}
#: the solids' layer by part kind
SOLID_LAYER = {
    "sheet-top": "solids-sheets",
    "sheet-bottom": "solids-sheets",
    "rib": "solids-ribs",
    "stiffener": "solids-stiffeners",
    "packing": "solids-packing",
}


def nurbs_surface(surface, origin: np.ndarray | None = None):
    """A ``rhino3dm.NurbsSurface`` equal to an OCCT ``Geom_BSplineSurface`` (non-rational),
    moved by ``origin`` (mm; the local frame's origin, see :mod:`fabpanel.surface.frame`)."""
    import rhino3dm

    ox, oy, oz = (float(v) for v in (origin if origin is not None else np.zeros(3)))
    nu, nv = surface.NbUPoles(), surface.NbVPoles()
    pu, pv = surface.UDegree(), surface.VDegree()
    result = rhino3dm.NurbsSurface.Create(3, False, pu + 1, pv + 1, nu, nv)
    for knots, sequence in (
        (result.KnotsU, surface.UKnotSequence()),
        (result.KnotsV, surface.VKnotSequence()),
    ):
        flat = [sequence.Value(i) for i in range(sequence.Lower() + 1, sequence.Upper())]
        for i, value in enumerate(flat):
            knots[i] = value  # type: ignore[index]  # rhino3dm stubs lack the knot setter
    for i in range(nu):
        for j in range(nv):
            pole = surface.Pole(i + 1, j + 1)
            # rhino3dm stubs lack the point list's __setitem__ (it exists at runtime)
            result.Points[i, j] = rhino3dm.Point4d(  # type: ignore[index]
                pole.X() + ox, pole.Y() + oy, pole.Z() + oz, 1.0
            )
    if not result.IsValid:
        raise KernelError("NURBS surface for Rhino is not valid")
    return result


def write_3dm(model: Model, path: str | Path, solids: Mapping[str, object] | None = None) -> Path:
    """Write ``design.3dm`` (see the module docstring); ``solids`` (part id -> a flat plate's
    :class:`~fabpanel.model.profiles.PrismProfile` or a mesh (vertices mm, triangles), local
    frame; :func:`fabpanel.docs.ifc.solid_geometries`) adds the solids."""
    import rhino3dm

    path = Path(path)
    doc = rhino3dm.File3dm()
    # rhino3dm stubs declare these properties read-only; they are settable at runtime
    doc.Settings.ModelUnitSystem = rhino3dm.UnitSystem.Millimeters  # type: ignore[misc]
    layer_index = {}
    for name, colour in LAYERS.items():
        layer = rhino3dm.Layer()
        layer.Name = name
        layer.Color = colour
        layer_index[name] = doc.Layers.Add(layer)

    def attributes(layer: str, name: str):
        attr = rhino3dm.ObjectAttributes()
        attr.LayerIndex = layer_index[layer]  # type: ignore[misc]  # settable (stubs: read-only)
        attr.Name = name  # type: ignore[misc]  # settable (stubs: read-only)
        return attr

    developed = model.developed
    origin = developed.layout.origin  # written in the design's own frame

    def points(local: np.ndarray):
        return [rhino3dm.Point3d(*map(float, p)) for p in np.asarray(local) + origin]

    for p, pid in enumerate(developed.panel_ids):
        try:
            surface, _ = occ.bspline_surface(developed.samples[p], pid)
        except KernelError as err:
            # a panel the build stage could not build may have a degenerate grid
            log.warning("design.3dm: no surface for %s (%s)", pid, err)
        else:
            # rhino3dm stubs omit the optional attributes argument
            doc.Objects.AddSurface(
                nurbs_surface(surface, origin),  # type: ignore[call-arg]
                attributes("panels", pid),
            )
        ring = np.concatenate([developed.side_samples(p, s)[:-1] for s in range(4)])
        doc.Objects.AddPolyline(points(np.r_[ring, ring[:1]]), attributes("outlines", pid))
        k = developed.samples.shape[1]
        centre = developed.samples[p, k // 2, k // 2]
        # rhino3dm stubs omit the optional attributes argument
        doc.Objects.AddTextDot(
            pid,
            points(centre[None])[0],  # type: ignore[call-arg]
            attributes("labels", pid),
        )
    for part in model.parts:
        if part.outline is None or part.frame is None:
            continue
        world = (
            np.c_[part.outline, np.zeros(len(part.outline)), np.ones(len(part.outline))]
            @ part.frame.T
        )[:, :3]
        layer_name = {"rib": "ribs", "packing": "packing"}.get(part.kind, "stiffeners")
        doc.Objects.AddPolyline(points(np.r_[world, world[:1]]), attributes(layer_name, part.id))
    for part in model.parts:
        if solids is None or part.id not in solids:
            continue
        solid = solids[part.id]
        where = attributes(SOLID_LAYER.get(part.kind, "solids-stiffeners"), part.id)
        if isinstance(solid, PrismProfile):
            # rhino3dm stubs omit the optional attributes argument
            doc.Objects.AddExtrusion(extrusion(solid, origin), where)  # type: ignore[call-arg]
        else:
            vertices, triangles = cast(tuple[np.ndarray, np.ndarray], solid)
            doc.Objects.AddMesh(
                _mesh(np.asarray(vertices) + origin, triangles),  # type: ignore[call-arg]
                where,
            )
    if not doc.Write(str(path), 8):
        raise KernelError(f"writing {path} failed")
    return path


def extrusion(profile: PrismProfile, origin: np.ndarray):
    """A capped ``rhino3dm.Extrusion`` of a flat plate's profile and holes, moved by
    ``origin`` (mm). Rhino lays a profile's x along ``up x path`` and its y along ``up``: the
    path runs from the profile's origin along its z axis by the depth, ``up`` is z x x."""
    import rhino3dm

    def curve(loop: np.ndarray, counter_clockwise: bool):
        if (signed_area(loop) > 0) != counter_clockwise:
            loop = loop[::-1]
        closed = np.vstack([loop, loop[:1]]).tolist()
        # rhino3dm stubs lack the constructor from points (it exists at runtime)
        return rhino3dm.PolylineCurve(  # type: ignore[call-arg]
            [rhino3dm.Point3d(x, y, 0.0) for x, y in closed]
        )

    shape = rhino3dm.Extrusion()
    start = np.asarray(profile.origin, dtype=float) + origin
    end = start + profile.depth * profile.z_axis
    up = np.cross(profile.z_axis, profile.x_axis)
    placed = shape.SetOuterProfile(curve(profile.outer, True), True) and all(
        shape.AddInnerProfile(curve(loop, False)) for loop in profile.inner
    )
    placed = placed and shape.SetPathAndUp(
        rhino3dm.Point3d(*map(float, start)),
        rhino3dm.Point3d(*map(float, end)),
        rhino3dm.Vector3d(*map(float, up)),
    )
    if not placed or not shape.IsValid:
        raise KernelError("extrusion of a plate's profile for Rhino is not valid")
    return shape


def _mesh(vertices: np.ndarray, triangles: np.ndarray):
    """A ``rhino3dm.Mesh`` of triangles over ``vertices`` (mm)."""
    import rhino3dm

    mesh = rhino3dm.Mesh()
    for x, y, z in vertices.tolist():
        mesh.Vertices.Add(x, y, z)
    for a, b, c in np.asarray(triangles, dtype=int).tolist():
        mesh.Faces.AddFace(a, b, c)
    mesh.Normals.ComputeNormals()
    return mesh
