"""Build stage: B-spline sheets, ribs, OCCT solids and their STEP/GLB assembly.

OCCT is driven from :mod:`fabpanel.model.occ` only; :func:`build` makes the parts per panel in
worker processes, :mod:`fabpanel.model.export` writes and re-reads the assembly files.
"""

from .build import build
from .export import read_step_parts, write_glb, write_panel_steps, write_step_assembly

__all__ = ["build", "read_step_parts", "write_glb", "write_panel_steps", "write_step_assembly"]
