"""Build stage: B-spline sheets, ribs, stiffeners, holes, OCCT solids, their checks and the
STEP/GLB/3DM files.

OCCT is driven from :mod:`fabpanel.model.occ` only; :func:`build` makes the parts per panel in
worker processes, :mod:`fabpanel.model.export` writes and re-reads the assembly files.
"""

from .build import build
from .export import read_step_parts, write_glb, write_panel_steps, write_step_assembly
from .rhino import write_3dm

__all__ = [
    "build",
    "read_step_parts",
    "write_3dm",
    "write_glb",
    "write_panel_steps",
    "write_step_assembly",
]
