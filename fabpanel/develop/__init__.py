"""Develop: give every panel a developable surface (a k x k sample grid) and measure it.

Methods (``[develop] method``): ``global`` optimises all panels at once (:mod:`.optimise`);
``loft`` is the thesis's per-panel ruled-surface baseline (:mod:`.loft`); ``project`` samples
each panel on the design surface and only measures it (:mod:`.project`).
"""

from __future__ import annotations

from ..data import DevelopedPanels, PanelLayout, Surface
from ..job import Job
from ..surface import SurfaceQuery


def develop(
    layout: PanelLayout, surface: Surface, job: Job, query: SurfaceQuery | None = None
) -> DevelopedPanels:
    """Developed panels of ``layout`` by the job's ``[develop] method``."""
    query = query or SurfaceQuery(surface)
    method = job.develop.method
    if method == "global":
        from .optimise import develop_global

        return develop_global(layout, surface, job, query)
    if method == "loft":
        from .loft import develop_loft

        return develop_loft(layout, surface, job, query)
    from .project import develop as develop_project

    return develop_project(layout, surface, job, query)


__all__ = ["develop"]
