"""Panelise: cover the design surface with a quad panel layout.

Methods: ``grid`` (a structured grid for four-sided surfaces; B-rep faces are gridded in their own
parameters). ``auto`` picks the method from the surface's topology.
"""

from .grid import panelize

__all__ = ["panelize"]
