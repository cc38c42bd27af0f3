"""Barrel vault example: a semicircular cylinder shell, radius 4 m, length 12 m.

Writes the exact surface as STEP (millimetres, one cylindrical face) and a quad mesh as OBJ
(metres, as a designer's mesh export would be), so both input paths can be run:

    python -m fabpanel.examples.barrel_vault   # writes fabpanel/examples/barrel-vault.step (the
                                               # demo's, shipped) and examples/barrel-vault.obj
    python -m fabpanel.examples.barrel_vault some/folder   # ... both into another folder
    fabpanel demo                              # runs fabpanel/examples/barrel-vault.toml
    fabpanel export examples/barrel-vault.obj --units m
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

RADIUS_MM = 4000.0
LENGTH_MM = 12000.0


def write_barrel_vault_step(
    path: str | Path, radius: float = RADIUS_MM, length: float = LENGTH_MM
) -> Path:
    """One cylindrical face: axis along +x, springing lines at z = 0, crown at z = radius (mm)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_CylindricalSurface
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    # u = angle from +y through +z to -y, v = distance along +x: outward normals
    axis = gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(1, 0, 0), gp_Dir(0, 1, 0))
    surface = Geom_CylindricalSurface(axis, radius)
    face = BRepBuilderAPI_MakeFace(surface, 0.0, math.pi, 0.0, length, 1e-7).Face()
    writer = STEPControl_Writer()
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer.Transfer(face, STEPControl_AsIs)
    path = Path(path)
    if writer.Write(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"could not write {path}")
    return path


def write_barrel_vault_obj(
    path: str | Path,
    radius_m: float = RADIUS_MM / 1000,
    length_m: float = LENGTH_MM / 1000,
    arc_segments: int = 96,
    length_segments: int = 48,
) -> Path:
    """The same vault as a quad mesh in metres."""
    angles = np.linspace(0.0, math.pi, arc_segments + 1)
    xs = np.linspace(0.0, length_m, length_segments + 1)
    X, A = np.meshgrid(xs, angles, indexing="ij")
    vertices = np.stack([X, radius_m * np.cos(A), radius_m * np.sin(A)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(length_segments), np.arange(arc_segments), indexing="ij")
    v00 = (i * (arc_segments + 1) + j).ravel()
    # counter-clockwise seen from outside: along the arc first, then along x
    quads = np.stack([v00, v00 + 1, v00 + arc_segments + 2, v00 + arc_segments + 1], axis=1)
    path = Path(path)
    lines = ["# barrel vault, radius 4 m, length 12 m, units: metres"]
    lines += [f"v {x:.9f} {y:.9f} {z:.9f}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(q + 1) for q in quad) for quad in quads]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_barrel_vault(path: str | Path) -> Path:
    """Write the STEP (``.step``) or OBJ (``.obj``) version, by the suffix of ``path``."""
    path = Path(path)
    if path.suffix.lower() == ".obj":
        return write_barrel_vault_obj(path)
    return write_barrel_vault_step(path)


if __name__ == "__main__":
    # default: the STEP beside this module (package data of fabpanel demo), the OBJ (a test
    # fixture, not shipped) into the checkout's top-level examples/
    if len(sys.argv) > 1:
        step_folder = obj_folder = Path(sys.argv[1])
    else:
        step_folder = Path(__file__).resolve().parent
        obj_folder = step_folder.parents[1] / "examples"
    print(write_barrel_vault(step_folder / "barrel-vault.step"))
    print(write_barrel_vault(obj_folder / "barrel-vault.obj"))
