"""``design.3dm``: the panels for Rhino and Grasshopper users (the thesis's users), via rhino3dm.

Layers (millimetres):

``panels``        each panel's developed design face as an exact NURBS surface (the B-spline
                  the sheets are built from, its knots and poles copied from OCCT), named by id
``outlines``      each panel's four sides as one closed polyline
``ribs``          every rib's flat outline in its plane, in place
``stiffeners``    every corner stiffener's outline, in place
``labels``        a text dot with the panel id at each panel's centre

Rhino's knot vectors omit the first and last knot of the clamped vectors OCCT (and the NURBS
book) use, so ``n + p - 1`` knots are written for ``n`` poles of degree ``p``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data import Model
from ..errors import KernelError
from . import occ

#: layer colours (RGBA 0-255), matching the STEP/GLB colours by kind
LAYERS = {
    "panels": (184, 189, 199, 255),
    "outlines": (40, 40, 40, 255),
    "ribs": (230, 140, 38, 255),
    "stiffeners": (204, 51, 38, 255),
    "labels": (20, 60, 160, 255),
}


def nurbs_surface(surface):
    """A ``rhino3dm.NurbsSurface`` equal to an OCCT ``Geom_BSplineSurface`` (non-rational)."""
    import rhino3dm

    nu, nv = surface.NbUPoles(), surface.NbVPoles()
    pu, pv = surface.UDegree(), surface.VDegree()
    result = rhino3dm.NurbsSurface.Create(3, False, pu + 1, pv + 1, nu, nv)
    for knots, sequence in ((result.KnotsU, surface.UKnotSequence()),
                            (result.KnotsV, surface.VKnotSequence())):
        flat = [sequence.Value(i) for i in range(sequence.Lower() + 1, sequence.Upper())]
        for i, value in enumerate(flat):
            knots[i] = value
    for i in range(nu):
        for j in range(nv):
            pole = surface.Pole(i + 1, j + 1)
            result.Points[i, j] = rhino3dm.Point4d(pole.X(), pole.Y(), pole.Z(), 1.0)
    if not result.IsValid:
        raise KernelError("NURBS surface for Rhino is not valid")
    return result


def write_3dm(model: Model, path: str | Path) -> Path:
    """Write ``design.3dm`` (see the module docstring)."""
    import rhino3dm

    path = Path(path)
    doc = rhino3dm.File3dm()
    doc.Settings.ModelUnitSystem = rhino3dm.UnitSystem.Millimeters
    layer_index = {}
    for name, colour in LAYERS.items():
        layer = rhino3dm.Layer()
        layer.Name = name
        layer.Color = colour
        layer_index[name] = doc.Layers.Add(layer)

    def attributes(layer: str, name: str):
        attr = rhino3dm.ObjectAttributes()
        attr.LayerIndex = layer_index[layer]
        attr.Name = name
        return attr

    developed = model.developed
    for p, pid in enumerate(developed.panel_ids):
        surface, _ = occ.bspline_surface(developed.samples[p], pid)
        doc.Objects.AddSurface(nurbs_surface(surface), attributes("panels", pid))
        ring = np.concatenate([developed.side_samples(p, s)[:-1] for s in range(4)])
        doc.Objects.AddPolyline(_points(np.r_[ring, ring[:1]]), attributes("outlines", pid))
        k = developed.samples.shape[1]
        centre = developed.samples[p, k // 2, k // 2]
        doc.Objects.AddTextDot(pid, rhino3dm.Point3d(*map(float, centre)),
                               attributes("labels", pid))
    for part in model.parts:
        if part.outline is None or part.frame is None:
            continue
        world = (np.c_[part.outline, np.zeros(len(part.outline)), np.ones(len(part.outline))]
                 @ part.frame.T)[:, :3]
        layer = "ribs" if part.kind == "rib" else "stiffeners"
        doc.Objects.AddPolyline(_points(np.r_[world, world[:1]]), attributes(layer, part.id))
    if not doc.Write(str(path), 8):
        raise KernelError(f"writing {path} failed")
    return path


def _points(points: np.ndarray):
    import rhino3dm

    return [rhino3dm.Point3d(*map(float, p)) for p in points]
