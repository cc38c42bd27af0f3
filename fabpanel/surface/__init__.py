"""Read the design surface (meshes and B-reps), find its boundary loops, query it.

``load_surface`` dispatches on the file extension to :mod:`.mesh` (OBJ, STL, PLY, OFF, GLB/GLTF,
through trimesh) or :mod:`.brep` (STEP, IGES, BREP, through OCCT) and returns a
:class:`~fabpanel.data.Surface` in millimetres with outward normals. ``SurfaceQuery`` answers
closest-point and normal queries (exact on B-reps); ``describe_surface`` summarises a surface
for ``fabpanel inspect``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..data import Surface
from ..errors import InputError
from .boundary import boundary_loops, edge_use, loop_lengths
from .brep import BREP_FORMATS, brep_to_shape, read_brep, shape_to_brep
from .checks import CREASE_ANGLE
from .folds import fold_summary
from .frame import recentred
from .mesh import MESH_FORMATS, read_mesh
from .query import SurfaceQuery

log = logging.getLogger(__name__)

__all__ = [
    "CREASE_ANGLE",
    "SUPPORTED_EXTENSIONS",
    "SurfaceQuery",
    "boundary_loops",
    "brep_to_shape",
    "describe_surface",
    "load_surface",
    "shape_to_brep",
]

#: every file extension load_surface reads
SUPPORTED_EXTENSIONS = tuple(MESH_FORMATS) + tuple(BREP_FORMATS)


def load_surface(
    path: str | Path, units: str | None = None, *, crease_angle: float = CREASE_ANGLE
) -> Surface:
    """Read the design surface from ``path``.

    units : length unit of mesh coordinates (``"m"``, ``"mm"``, ``"cm"``); required for meshes,
        ignored for STEP/IGES/BREP, which carry their units.
    crease_angle : ``[input] crease_angle``, degrees: neighbouring triangles of the (welded)
        surface mesh folding more sharply than this are refused as a crease.
    Returns a :class:`Surface` in millimetres, moved into its local frame (``Surface.origin``
    says from where; :mod:`.frame`), so results do not depend on where the model sits. Raises :class:`InputError` with a one-line message
    (what, which file, where in the input's units, how to fix) for anything that cannot be read
    as a surface, and for what the later stages cannot handle: unwelded seams, separate pieces,
    creases and self-intersections (see :mod:`.checks`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_EXTENSIONS:
        raise InputError(
            f"{path.name}: unknown file type {suffix or '(no extension)'!r}; "
            f"supported: {', '.join(SUPPORTED_EXTENSIONS)}"
        )
    if not path.is_file():
        raise InputError(f"{path.name}: file not found ({path}); check the path")
    if path.stat().st_size == 0:
        raise InputError(
            f"{path.name}: the file is empty (0 bytes); export the design surface again"
        )
    if suffix in MESH_FORMATS:
        return recentred(read_mesh(path, units, crease_angle))
    return recentred(read_brep(path, units, crease_angle))


def describe_surface(surface: Surface) -> dict:
    """What ``fabpanel inspect`` prints about a surface (JSON-ready).

    Keys: format, units (declared), vertices, faces, bounds_mm, size_mm, area_m2,
    boundary_loops, openings, closed, manifold (every edge used by at most two triangles),
    watertight (every edge used by exactly two), exact_brep, loop_lengths_mm (outer first),
    fold_lines (per seam of a B-rep that kinks: length, largest fold, ends; the field layout
    runs panel sides along them, see :mod:`.folds`).
    """
    _, counts, _ = edge_use(surface.faces)
    bounds = surface.bounds
    loops = surface.boundary_loops
    return {
        "source": str(surface.source),
        "format": surface.format,
        "units": surface.units,
        "vertices": len(surface.vertices),
        "faces": len(surface.faces),
        "bounds_mm": np.round(bounds + surface.origin, 3).tolist(),
        "origin_mm": np.round(surface.origin, 3).tolist(),
        "size_mm": np.round(bounds[1] - bounds[0], 3).tolist(),
        "area_m2": round(surface.area / 1e6, 6),
        "boundary_loops": len(loops),
        "openings": surface.openings,
        "closed": len(loops) == 0,
        "manifold": bool(np.all(counts <= 2)),
        "watertight": bool(len(counts) > 0 and np.all(counts == 2)),
        "exact_brep": surface.brep is not None,
        "loop_lengths_mm": [round(x, 3) for x in loop_lengths(surface.vertices, loops)],
        "fold_lines": fold_summary(surface.vertices, surface.faces, surface.folds, surface.origin),
    }
