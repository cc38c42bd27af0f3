"""Panelise: cover the design surface with a quad panel layout.

Methods:

- ``grid``: a structured grid for four-sided surfaces; a single B-rep face is gridded in its own
  parameters.
- ``skeleton``: the medial-axis method (Tam & Armstrong 1991, Rigby 2003, Oval et al. 2018) for
  surfaces with openings and irregular outlines: a coarse quad decomposition of the boundary's
  projection, densified per strip to the target size, lifted onto the surface and relaxed there.
- ``layout``: a quad mesh drawn by hand, mapped onto the surface.

``auto`` picks ``grid`` for four-sided surfaces without openings and ``skeleton`` otherwise.
"""

from __future__ import annotations

from dataclasses import replace

from ..data import PanelLayout, Surface
from ..job import Job
from ..surface import SurfaceQuery
from .estimate import check_panel_count
from .grid import grid_panelize, is_four_sided


def choose_method(surface: Surface, job: Job) -> str:
    """The method ``auto`` stands for on this surface."""
    method = job.panelize.method
    if method != "auto":
        return method
    return "grid" if is_four_sided(surface, job.panelize.corner_angle) else "skeleton"


def panelize(surface: Surface, job: Job, query: SurfaceQuery | None = None) -> PanelLayout:
    """Cover ``surface`` with quad panels as ``job.panelize`` asks (see the module docstring).

    Raises :class:`~fabpanel.errors.GeometryError` when the chosen method cannot handle the
    surface, with a message that names the method to use instead, and
    :class:`~fabpanel.errors.InputError` when the panel count shows a unit or size mistake
    (:func:`~.estimate.check_panel_count`).
    """
    check_panel_count(surface, job)
    query = query or SurfaceQuery(surface)
    return replace(_layout_by_method(surface, job, query), origin=surface.origin)


def _layout_by_method(surface: Surface, job: Job, query: SurfaceQuery) -> PanelLayout:
    method = choose_method(surface, job)
    if method == "grid":
        return grid_panelize(surface, job, query)
    if method == "layout":
        from .user_layout import user_layout

        path = (job.base_dir / job.panelize.layout).resolve()
        return user_layout(path, job.input.units, surface, query, job)
    from .decompose import skeleton_panelize

    return skeleton_panelize(surface, job, query)


__all__ = ["choose_method", "panelize"]
