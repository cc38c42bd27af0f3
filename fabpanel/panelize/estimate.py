"""Sanity before work: how many panels the job asks for, from the surface area alone.

A mesh in millimetres declared ``--units m`` is a thousand times too large: the layout would ask
for millions of panels and run for minutes past gigabytes before anything is said. A surface in
metres declared in millimetres, or a STEP written 1000x too small, is smaller than one panel and
fails deep in the build. Both are unit mistakes the area shows at once: the estimate
``area / panel_size²`` (a quad layout of near-uniform panels covers the area with about that
many) is checked against ``[panelize] max_panels`` and against one panel before any layout work.
"""

from __future__ import annotations

import math

import numpy as np

from ..data import Surface
from ..errors import InputError
from ..job import Job
from ..units import UNITS, plausible_length_unit


def estimated_panels(surface: Surface, job: Job) -> float:
    """Panels the job asks for: ``grid_u x grid_v`` where both are set, else area / size²."""
    settings = job.panelize
    if settings.grid_u and settings.grid_v:
        return float(settings.grid_u * settings.grid_v)
    return surface.area / settings.panel_size**2


def _in_input_units(values_mm: np.ndarray, units: str) -> str:
    scale = UNITS["length"].get(units, 1.0)
    return " x ".join(f"{v / scale:.4g}" for v in values_mm) + f" {units}"


def _unit_hint(surface: Surface, larger: bool) -> str:
    """The likely unit mistake, as the start of the fix: meshes declare units (in the job's
    ``[input] units`` or ``--units``), B-reps carry them. The unit suggested is the one under
    which the surface's extent is that of a building shell (``units.PLAUSIBLE_EXTENT_M``), with the
    extent it would then have; the next unit the right way where none is."""
    if surface.format in ("step", "iges", "brep"):
        return "check the units the file was exported in, or "
    lengths = UNITS["length"]
    size = surface.bounds[1] - surface.bounds[0]
    as_given = size / lengths.get(surface.units, 1.0)  # in the declared unit
    wanted = plausible_length_unit(float(as_given.max()), surface.units)
    if wanted is None:
        wanted = "m" if larger else "mm"
        if surface.units == wanted:
            return ""
    extent = " x ".join(f"{v * lengths[wanted] / 1000:.3g}" for v in as_given)
    return (
        f'if the coordinates are in {wanted} ({extent} m then), declare units = "{wanted}" '
        f"([input] units in the job, or --units {wanted}), or "
    )


def check_panel_count(surface: Surface, job: Job) -> float:
    """Refuse (:class:`InputError`) a job whose panel count shows a unit or size mistake.

    Returns the estimate. Layouts drawn by the user (``method = "layout"``) are not estimated:
    their panel count is what the user drew.
    """
    if job.panelize.method == "layout":
        return math.nan
    estimate = estimated_panels(surface, job)
    size = surface.bounds[1] - surface.bounds[0]
    name = surface.source.name if surface.source else "the surface"
    extent = _in_input_units(size, surface.units)
    panel = f"{job.panelize.panel_size / 1000:g} m"
    limit = job.panelize.max_panels
    if estimate > limit:
        raise InputError(
            f"{name}: {extent} ({surface.area / 1e6:.4g} m2) needs about {estimate:.0f} panels "
            f"of {panel}, more than [panelize] max_panels = {limit}; "
            f"{_unit_hint(surface, larger=False)}choose a larger --panel-size (or raise "
            f"max_panels)"
        )
    if estimate < 1.0:
        largest = math.sqrt(surface.area)
        raise InputError(
            f"{name}: {extent} ({surface.area / 1e6:.4g} m2) is smaller than one panel of "
            f"{panel}; {_unit_hint(surface, larger=True)}choose a --panel-size of at most "
            f"{largest / 1000:.3g} m"
        )
    return estimate


__all__ = ["check_panel_count", "estimated_panels"]
