"""The local frame: the design surface is moved near the origin on load, and back on output.

A shell modelled in site coordinates sits a kilometre or more from the origin. The stages solve
for planes (``n . x = d``), normals from cross products of differences, and least-squares fits;
with coordinates of 1e9 mm, ``d`` and the products lose the digits the geometry lives in
(measured: a vault moved by +1e6 m went from 12 to 45 mm deviation, rib normals from 12° to 90°
off). So every surface is recentred when it is read: the local frame's origin is the centre of
its bounding box in x and y and its lowest point in z, rounded to whole millimetres, and the
axes stay as they are. Everything downstream works in this frame; the writers of model files
(OBJ, STEP, GLB, 3DM) and the manifest add the origin back, so outputs lie where the design
does. Points the user gives in world coordinates (``singular_points``, a drawn layout) are moved
into the local frame where they are read.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..data import Surface
from .brep import brep_to_shape, shape_to_brep


def local_origin(vertices: np.ndarray) -> np.ndarray:
    """(3,) float, mm: bounding-box centre in x and y, lowest z, rounded to whole mm."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    return np.round(np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]]))


def recentred(surface: Surface) -> Surface:
    """``surface`` in its local frame (see the module docstring); ``origin`` says where it was."""
    origin = local_origin(surface.vertices) + surface.origin
    shift = origin - surface.origin
    if not shift.any():
        return surface
    brep = surface.brep
    if brep is not None:
        brep = shape_to_brep(translated_shape(brep_to_shape(brep, surface.source.name), -shift))
    return replace(surface, vertices=surface.vertices - shift, brep=brep, origin=origin)


def translated_shape(shape, offset: np.ndarray):
    """A copy of the OCCT ``shape`` with its geometry moved by ``offset`` (mm)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    trsf = gp_Trsf()
    trsf.SetTranslation(gp_Vec(*(float(v) for v in offset)))
    # copy: the geometry itself moves, not only a location on top of it, so the numbers the
    # exact queries see are small
    return BRepBuilderAPI_Transform(shape, trsf, True).Shape()


def to_world(points: np.ndarray, origin: np.ndarray | None) -> np.ndarray:
    """Local points (..., 3) mm to the design's frame."""
    return points if origin is None else np.asarray(points) + origin


def to_local(points: np.ndarray, origin: np.ndarray | None) -> np.ndarray:
    """Design-frame points (..., 3) mm to the local frame."""
    return points if origin is None else np.asarray(points) - origin


__all__ = ["local_origin", "recentred", "to_local", "to_world", "translated_shape"]
