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
    return {
        "min": round(float(values.min()), digits),
        "mean": round(float(values.mean()), digits),
        "max": round(float(values.max()), digits),
    }


def gauss_image_areas(samples: np.ndarray) -> np.ndarray:
    """(m,) float: sum of absolute angle defects of each panel grid (discrete integral of |K|)."""
    return np.abs(angle_defects(samples)).reshape(len(samples), -1).sum(axis=1)


#: a developable panel is conical when its normals lie on a small circle of the Gauss sphere
#: whose plane is off the centre by at least CONE_OFFSET (the sine of the generators' angle to the
#: circle plane: 3 degrees), the circle holds them within CONE_FIT (share of their spread), no
#: great circle (a cylinder) holds them within CONE_DISTINCT times that or GREAT_CIRCLE_FIT
#: (0.06 degrees: a short arc of normals cannot tell the two apart), and they spread by at least
#: CONE_SPREAD_DEG
CONE_OFFSET = np.sin(np.radians(3.0))
CONE_FIT = 0.05
CONE_DISTINCT = 3.0
GREAT_CIRCLE_FIT = 1e-3
CONE_SPREAD_DEG = 2.0
#: advised panel sizes are rounded down to this (mm) and kept below the strain law's estimate
#: by ADVICE_MARGIN: the unroll strain of a doubly curved patch grows with the square of its size
ADVICE_ROUNDING = 50.0
ADVICE_MARGIN = 0.9


def conical(normals: np.ndarray) -> np.ndarray:
    """(m,) bool: the panel normals (m, k, k, 3) lie on a small circle of the Gauss sphere."""
    m = len(normals)
    flat = normals.reshape(m, -1, 3)
    _, offset, residual = bestfit_planes(flat)
    mean = flat.mean(axis=1)
    mean /= np.linalg.norm(mean, axis=1, keepdims=True)
    spread = np.arccos(np.clip(np.einsum("mki,mi->mk", flat, mean), -1, 1)).max(axis=1)
    great = np.linalg.svd(flat, full_matrices=False)[2][:, -1]  # plane through 0
    great_residual = np.abs(np.einsum("mki,mi->mk", flat, great)).max(axis=1)
    return (
        (np.abs(offset) >= CONE_OFFSET)
        & (residual <= CONE_FIT * np.sin(spread))
        & (great_residual > np.maximum(CONE_DISTINCT * residual, GREAT_CIRCLE_FIT))
        & (np.degrees(spread) >= CONE_SPREAD_DEG)
    )


def advised_panel_size(samples: np.ndarray, measure: np.ndarray, tolerance: float) -> np.ndarray:
    """(m,) mm: the panel size at which each panel's ``measure`` would meet ``tolerance``.

    The measure grows with the panel's size squared: the unroll strain of a doubly curved patch
    flattened isometrically (metric distortion ~ K L^2), or how far a developable panel leaves
    a doubly curved design (the sagittas of its two directions differ by ~ K L^2). So the size
    scales with sqrt(tolerance / measure); panels within tolerance keep their own size.
    """
    corners = samples[:, [0, -1, -1, 0], [0, 0, -1, -1]]
    size = np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=-1).mean(axis=1)
    ratio = np.sqrt(tolerance / np.maximum(measure, tolerance))
    return np.floor(ADVICE_MARGIN * size * ratio / ADVICE_ROUNDING) * ADVICE_ROUNDING


def _deviation_issues(
    panel_ids: tuple[str, ...],
    samples: np.ndarray,
    deviation: np.ndarray,
    job: Job,
) -> list[Issue]:
    """A warning for every panel farther than ``[develop] deviation_tolerance`` from the design
    surface (``deviation (m,)`` mm), with the panel size that would keep it within."""
    tolerance = float(job.develop.deviation_tolerance)
    far = np.flatnonzero(deviation > tolerance)
    if not len(far):
        return []
    advice = advised_panel_size(samples, deviation, tolerance)
    return [
        Issue(
            "panel-off-design",
            f"panel {panel_ids[i]} lies up to {deviation[i]:.0f} mm from the design surface "
            f"(tolerance {tolerance:g} mm): to be developable it had to leave the doubly "
            f"curved design, by about its size squared times the curvature; panels of about "
            f"{advice[i]:.0f} mm here would stay within it, or raise [develop] "
            "deviation_tolerance if the design allows",
            panel_ids[i],
            "warning",
        )
        for i in far
    ]


def classify_and_measure(
    panel_ids: tuple[str, ...],
    samples: np.ndarray,
    normals: np.ndarray,
    edge_residuals: np.ndarray,
    normal_angles: np.ndarray,
    bevel_twist: np.ndarray,
    boundary_sides: np.ndarray,
    query: SurfaceQuery,
    job: Job,
):
    """Class, smallest bending radius, metrics, issues and sample deviations of every panel.

    samples, normals : (m, k, k, 3); edge_residuals : (m, 4) mm (side samples from their rib
    plane); normal_angles, bevel_twist : (m, 4) degrees (normals along a side against its rib
    plane: largest angle, and its variation along the side; see ``sides.side_planes``);
    boundary_sides : (m, 4) bool, sides on the design boundary (held there, so their ribs are as
    planar as the design's edge)
    Returns ``classes, radius (m,), metrics, issues, deviation (m, k, k) mm``.
    """
    m, k = samples.shape[:2]
    strain = np.array([flatten_grid(grid)[1] for grid in samples])
    gauss_area = gauss_image_areas(samples)
    _, _, flatness = bestfit_planes(samples.reshape(m, -1, 3))
    radius = np.minimum(
        circumradii(samples).reshape(m, -1).min(axis=1),
        circumradii(samples.transpose(0, 2, 1, 3)).reshape(m, -1).min(axis=1),
    )
    centres = cell_centres(samples).reshape(-1, 3)
    # continued over openings: a side cutting the chord across a rim is measured against the
    # surface it continues, not against the rim (that is the boundary deviation)
    _, _, centre_dist = query.closest_continued(centres)
    _, _, sample_dist = query.closest_continued(samples.reshape(-1, 3))
    deviation = np.maximum(
        centre_dist.reshape(m, -1).max(axis=1), sample_dist.reshape(m, -1).max(axis=1)
    )
    mean_deviation = 0.5 * (
        centre_dist.reshape(m, -1).mean(axis=1) + sample_dist.reshape(m, -1).mean(axis=1)
    )
    span = np.linalg.norm(samples[:, -1, -1] - samples[:, 0, 0], axis=1)
    tolerance = job.develop.strain_tolerance
    cones = conical(normals)
    advice = advised_panel_size(samples, strain, tolerance)

    classes: list[PanelClass] = []
    issues: list[Issue] = []
    for i, pid in enumerate(panel_ids):
        if flatness[i] <= TOLERANCES.planar_panel:
            classes.append("planar")
            radius[i] = np.inf
        elif strain[i] <= tolerance:
            classes.append("conical" if cones[i] else "single-curved")
        else:
            classes.append("not-developable")
            issues.append(
                Issue(
                    "not-developable",
                    f"panel {pid} unrolls with {strain[i]:.3%} strain, above the "
                    f"{tolerance:.3%} tolerance: it spans {gauss_area[i]:.2e} sr of "
                    f"the Gauss sphere (doubly curved); at a panel size of about "
                    f"{advice[i]:.0f} mm it would unroll within tolerance",
                    pid,
                    "warning",
                )
            )
        worst = int(np.argmax(edge_residuals[i]))
        worst_side = float(edge_residuals[i, worst])
        if worst_side > TOLERANCES.rib_edge:
            if boundary_sides[i, worst]:
                remedy = "it lies on the design boundary, which is not planar there"
            elif job.develop.method == "global":
                remedy = "raise [develop] rib_planarity or max_iterations"
            else:
                remedy = 'use [develop] method = "global"'
            issues.append(
                Issue(
                    "rib-not-planar",
                    f"panel {pid}: side {worst} leaves its rib plane by "
                    f"{worst_side:.3f} mm (tolerance {TOLERANCES.rib_edge} mm); "
                    f"{remedy}",
                    pid,
                    "warning",
                )
            )
    issues += _deviation_issues(panel_ids, samples, deviation, job)
    failing = strain > tolerance
    if failing.any():
        issues.append(
            Issue(
                "panel-size-advice",
                f"{int(failing.sum())} panels are too doubly curved to develop at "
                f"their size; --panel-size {advice[failing].min() / 1000:g}m would "
                f"bring the worst of them within the {tolerance:.3%} strain tolerance",
                "",
                "warning",
            )
        )
    forming = [
        "none" if c == "planar" else ("press" if r < TOLERANCES.press_forming_radius else "roll")
        for c, r in zip(classes, radius)
    ]
    per_panel = {
        pid: {
            "class": classes[i],
            "unroll_strain": float(strain[i]),
            "gauss_image_area": float(gauss_area[i]),
            "bending_radius_mm": None if not np.isfinite(radius[i]) else round(float(radius[i]), 1),
            "forming": forming[i],
            "deviation_max_mm": round(float(deviation[i]), 4),
            "deviation_mean_mm": round(float(mean_deviation[i]), 4),
            "deviation_max_pct_span": round(float(100 * deviation[i] / span[i]), 5),
            "deviation_mean_pct_span": round(float(100 * mean_deviation[i] / span[i]), 5),
            "rib_plane_residual_mm": round(float(edge_residuals[i].max()), 5),
            "rib_normal_angle_deg": round(float(normal_angles[i].max()), 4),
            "rib_bevel_twist_deg": round(float(bevel_twist[i].max()), 4),
            **({"advised_panel_size_mm": float(advice[i])} if failing[i] else {}),
        }
        for i, pid in enumerate(panel_ids)
    }
    finite_radius = radius[np.isfinite(radius)]
    metrics = {
        "samples_per_side": int(k),
        "classes": {c: classes.count(c) for c in sorted(set(classes))},
        "unroll_strain": _stats(strain, 8),
        "gauss_image_area": _stats(gauss_area, 8),
        "deviation_mm": {
            "max": round(float(deviation.max()), 4),
            "mean": round(float(mean_deviation.mean()), 4),
        },
        "deviation_pct_span_max": round(float(100 * (deviation / span).max()), 5),
        "deviation_pct_span_mean": round(float(100 * (mean_deviation / span).mean()), 5),
        "rib_plane_residual_mm_max": round(float(edge_residuals.max()), 5),
        "rib_plane_residual_mm_max_interior": round(
            float(edge_residuals[~boundary_sides].max(initial=0.0)), 5
        ),
        "rib_plane_residual_mm_max_boundary": round(
            float(edge_residuals[boundary_sides].max(initial=0.0)), 5
        ),
        "rib_normal_angle_deg_max": round(float(normal_angles.max()), 4),
        "rib_bevel_twist_deg_max": round(float(bevel_twist.max()), 4),
        "bending_radius_mm_min": (
            round(float(finite_radius.min()), 1) if len(finite_radius) else None
        ),
        "panels_not_developable": int(failing.sum()),
        "per_panel": per_panel,
    }
    return tuple(classes), radius, metrics, tuple(issues), sample_dist.reshape(m, k, k)
