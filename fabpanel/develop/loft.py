"""The ``loft`` method: the thesis's per-panel baseline (Appendix D).

Each panel becomes a ruled surface between two opposite sides, ``x(s, t) = (1 - t) a(s) + t b(s)``
with ``a``, ``b`` the sides as they lie on the design surface; both pairs of opposite sides are
tried and the one closer to the design surface (mean deviation) is kept. Every panel is
rebuilt on its own, so a side that is a rail for one panel is a straight end ruling of its
neighbour: the panels no longer meet along their shared sides (the misalignment the thesis
reports). That gap, the deviation from the design surface (mm and % of the panel span, as the
thesis's Tables 8-9) and the unroll strain (a ruled surface is developable only where the tangent
plane is constant along each ruling) are what the baseline is measured by.
"""

from __future__ import annotations

import numpy as np

from ..data import DevelopedPanels, PanelLayout, Surface
from ..job import Job
from ..surface import SurfaceQuery
from .sides import folded_sides, side_gaps_and_kinks


def ruled_grids(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both ruled surfaces of every panel grid (m, k, k, 3): between sides 0 and 2 (rulings
    along j) and between sides 3 and 1 (rulings along i). Returns two (m, k, k, 3) arrays."""
    k = samples.shape[1]
    t = np.linspace(0.0, 1.0, k)
    along_j = (1 - t)[None, None, :, None] * samples[:, :, :1] + t[None, None, :, None] * samples[
        :, :, -1:
    ]
    along_i = (1 - t)[None, :, None, None] * samples[:, :1, :] + t[None, :, None, None] * samples[
        :, -1:, :
    ]
    return along_j, along_i


def develop_loft(
    layout: PanelLayout, surface: Surface, job: Job, query: SurfaceQuery
) -> DevelopedPanels:
    """Ruled panels between the closer pair of opposite sides; see the module docstring."""
    from .project import developed_panels, sample_panels
    from .sample_grid import grid_normals

    sampled = sample_panels(layout, query, job.develop.samples)
    design, design_normals = sampled.samples, sampled.normals
    m = len(design)
    candidates = ruled_grids(design)
    mean_distance = []
    for grid in candidates:
        _, _, distance = query.closest(grid.reshape(-1, 3))
        mean_distance.append(distance.reshape(m, -1).mean(axis=1))
    use_i = mean_distance[1] < mean_distance[0]
    samples = np.where(use_i[:, None, None, None], candidates[1], candidates[0])
    normals = grid_normals(samples, design_normals)
    gaps, kinks = side_gaps_and_kinks(layout, samples, normals)
    extra = {
        "loft_directions": {"sides 0-2": int((~use_i).sum()), "sides 3-1": int(use_i.sum())},
        "gap_mm_max": round(float(gaps.max()), 4),
        "gap_mm_mean_shared": round(float(gaps[layout.side_neighbours >= 0].mean()), 4)
        if (layout.side_neighbours >= 0).any()
        else 0.0,
        "kink_deg": {"max": round(float(kinks.max()), 4)},
    }
    result = developed_panels(
        layout,
        samples,
        normals,
        query,
        job,
        "loft",
        sampled.chords,
        extra,
        folded_sides(layout, kinks),
        design_samples=design,
    )
    for i, pid in enumerate(layout.panel_ids):
        result.metrics["per_panel"][pid]["gap_mm"] = round(float(gaps[i].max()), 4)
    return result
