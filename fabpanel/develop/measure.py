"""Developability measures and panel classes.

- unroll strain: the largest relative change of a sample-grid edge when the panel is flattened by
  an independent least-squares isometric flattening (:func:`fabpanel.geom.flatten.flatten_grid`);
- Gauss-image area: the sum of absolute angle defects, a discrete integral of |K| (Gauss-Bonnet);
- deviation: distance to the design surface of the samples and of the cell centres of a smooth
  (four-point) interpolation of them, i.e. of the panel surface between the samples;
- bending radius: the smallest circumradius along the sample grid lines.
"""

from __future__ import annotations

import numpy as np

from ..data import PanelClass
from ..errors import Issue
from ..geom.fitting import bestfit_planes
from ..geom.flatten import flatten_grid
from ..geom.quads import angle_defects, cell_centres, circumradii
from ..job import Job
from ..surface import SurfaceQuery
from ..tolerances import TOLERANCES


def _stats(values: np.ndarray, digits: int = 4) -> dict:
    return {"min": round(float(values.min()), digits), "mean": round(float(values.mean()), digits),
            "max": round(float(values.max()), digits)}


def gauss_image_areas(samples: np.ndarray) -> np.ndarray:
    """(m,) float: sum of absolute angle defects of each panel grid (discrete integral of |K|)."""
    return np.abs(angle_defects(samples)).reshape(len(samples), -1).sum(axis=1)


def classify_and_measure(panel_ids: tuple[str, ...], samples: np.ndarray, normals: np.ndarray,
                         plane_residuals: np.ndarray, query: SurfaceQuery, job: Job):
    """Class, smallest bending radius, metrics and issues of every panel.

    samples, normals : (m, k, k, 3); plane_residuals : (m, 4) mm (rib-plane fit per side).
    """
    m, k = samples.shape[:2]
    strain = np.array([flatten_grid(grid)[1] for grid in samples])
    gauss_area = gauss_image_areas(samples)
    _, _, flatness = bestfit_planes(samples.reshape(m, -1, 3))
    radius = np.minimum(circumradii(samples).reshape(m, -1).min(axis=1),
                        circumradii(samples.transpose(0, 2, 1, 3)).reshape(m, -1).min(axis=1))
    centres = cell_centres(samples).reshape(-1, 3)
    _, _, centre_dist = query.closest(centres)
    _, _, sample_dist = query.closest(samples.reshape(-1, 3))
    deviation = np.maximum(centre_dist.reshape(m, -1).max(axis=1),
                           sample_dist.reshape(m, -1).max(axis=1))
    mean_deviation = 0.5 * (centre_dist.reshape(m, -1).mean(axis=1)
                            + sample_dist.reshape(m, -1).mean(axis=1))
    span = np.linalg.norm(samples[:, -1, -1] - samples[:, 0, 0], axis=1)
    tolerance = job.develop.strain_tolerance

    classes: list[PanelClass] = []
    issues: list[Issue] = []
    for i, pid in enumerate(panel_ids):
        if flatness[i] <= TOLERANCES.planar_panel:
            classes.append("planar")
            radius[i] = np.inf
        elif strain[i] <= tolerance:
            classes.append("single-curved")
        else:
            classes.append("not-developable")
            issues.append(Issue("not-developable",
                                f"panel {pid} unrolls with {strain[i]:.2%} strain, above the "
                                f"{tolerance:.2%} tolerance", pid, "warning"))
        worst_side = float(plane_residuals[i].max())
        if worst_side > TOLERANCES.rib_planarity:
            issues.append(Issue("rib-not-planar",
                                f"panel {pid}: a side deviates {worst_side:.3f} mm from its rib "
                                f"plane (tolerance {TOLERANCES.rib_planarity} mm)", pid, "warning"))
    forming = ["none" if c == "planar" else
               ("press" if r < TOLERANCES.press_forming_radius else "roll")
               for c, r in zip(classes, radius)]
    per_panel = {
        pid: {"class": classes[i], "unroll_strain": float(strain[i]),
              "gauss_image_area": float(gauss_area[i]),
              "bending_radius_mm": None if not np.isfinite(radius[i]) else round(float(radius[i]), 1),
              "forming": forming[i],
              "deviation_max_mm": round(float(deviation[i]), 4),
              "deviation_mean_mm": round(float(mean_deviation[i]), 4),
              "deviation_max_pct_span": round(float(100 * deviation[i] / span[i]), 5),
              "rib_plane_residual_mm": round(float(plane_residuals[i].max()), 5)}
        for i, pid in enumerate(panel_ids)}
    finite_radius = radius[np.isfinite(radius)]
    metrics = {
        "samples_per_side": int(k),
        "classes": {c: classes.count(c) for c in sorted(set(classes))},
        "unroll_strain": _stats(strain, 8),
        "gauss_image_area": _stats(gauss_area, 8),
        "deviation_mm": {"max": round(float(deviation.max()), 4),
                         "mean": round(float(mean_deviation.mean()), 4)},
        "deviation_pct_span_max": round(float(100 * (deviation / span).max()), 5),
        "rib_plane_residual_mm_max": round(float(plane_residuals.max()), 5),
        "bending_radius_mm_min": (round(float(finite_radius.min()), 1)
                                  if len(finite_radius) else None),
        "panels_not_developable": int(sum(c == "not-developable" for c in classes)),
        "per_panel": per_panel,
    }
    return tuple(classes), radius, metrics, tuple(issues)
