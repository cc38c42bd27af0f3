"""The ``global`` method: one optimisation moves every panel at once towards developability.

All panels are sampled k x k as **one** mesh: neighbouring panels share their side samples (the
same unknowns), so they stay joined whatever the solver does. The unknowns are

* ``x`` — every sample point (shared along panel sides and at corners);
* ``n`` — a unit normal per panel sample (a panel's own, so kinks between panels are measured,
  not hidden);
* ``h, d`` — per panel, the plane ``n . h = d`` of its Gauss image (Gavriil, Schiftner & Pottmann,
  *Optimizing B-spline surfaces for developability and paneling architectural freeform surfaces*,
  CAD 111, 2019): normals on one plane lie on one circle of the sphere, which admits cylinders
  (great circles), cones (small circles) and planes (a point);
* ``g, c`` — per panel side (shared by the two panels), the rib plane ``g . x = c``;
* ``s`` — per panel side, the sine of the angle at which the panel meets its rib plane.

Residuals, every one at most quadratic in the unknowns (so the Jacobian is exact and cheap):

======================  ====================================================  ===============
term                    residual                                              weight (job)
======================  ====================================================  ===============
normal consistency      ``n . (x[i+1] - x[i-1]) / |.|`` along both grid lines  ``residuals.NORMAL_WEIGHT``
unit vectors            ``|n|^2 - 1``, ``|h|^2 - 1``, ``|g|^2 - 1``            ``residuals.NORMAL_WEIGHT``
developability          ``n . h - d``                                         1 (reference)
intrinsic flatness      ``2 pi -`` angle sum at interior samples, both grid     ``DEFECT_WEIGHT``
                        triangulations
rib planarity           ``(g . x - c) / L`` on the side's samples,             ``rib``
                        ``g . n - s`` for both panels' normals along it        ``rib`` x 0.01
square ribs             ``s x depth / L`` (the bevel's sideways step at the     ``rib`` x 0.01
                        bottom sheet)
closeness               ``(x - f) . nu / L`` (foot point ``f`` and normal      ``closeness``
                        ``nu`` on the design surface, re-linearised every
                        iteration)
fairness                change of ``(x[i-1] - 2 x[i] + x[i+1]) / L`` along    ``fairness``
                        grid lines against the design's (a mesh design
                        smoothed to one bicubic a panel first)
boundary                ``(x - x0) / L`` for samples on the design boundary    ``BOUNDARY_WEIGHT``
layout hold             ``(I - nu0 nu0') (x - x0) / L`` at the layout's inner     ``layout_hold``
                        vertices (panel corners): their slide along the
                        design surface (normal ``nu0`` at the start)
======================  ====================================================  ===============

``L`` is the mean panel edge length, so every residual is dimensionless and the weights do not
depend on the units. The solver is Levenberg-Marquardt with a sparse Jacobian (scipy.sparse);
each step is solved by LSMR on the column-scaled Jacobian with the damping as its Tikhonov term
(25x faster than a sparse LU of J'J here, and exact enough for a Gauss-Newton step). It stops
when an iteration lowers the energy by less than ``tolerance`` relative, when two iterations
in a row move no sample further than ``step_tolerance`` (0.01 mm) and lower the energy by
less than ``TAIL_RATE`` (1 %) (the slow tail: on a 252-panel roof it traded 0.07 mm of
deviation for a strain far below the tolerance over 50 iterations), or after
``max_iterations``.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import lsmr, spsolve

from ..buildup import Buildup
from ..data import PanelLayout
from ..errors import SolverError
from ..geom.fitting import bestfit_planes
from ..geom.quads import side_index
from ..surface import SurfaceQuery
from .residuals import (
    ResidualSystem,
    Unknowns,
    angle_defects,
    developability,
    fairness,
    normal_consistency,
    rib_normals,
    rib_planes,
    square_ribs,
    unit_rib_plane_normals,
)
from .sample_grid import design_second_differences, grid_normals, sample_mesh

log = logging.getLogger(__name__)

#: weight of the angle defects (radians) at the interior samples of every panel: a defect of
#: 1e-4 rad is what a 1 m panel of a 20 m sphere carries; this makes it count like a 1 mm rib step
DEFECT_WEIGHT = 30.0
#: samples on the design boundary (supports, free edges) stay there
BOUNDARY_WEIGHT = 1000.0
#: the design surface's foot points are recomputed once a sample has moved this far (share of
#: the mean panel edge) since they were last computed; in between the tangent planes stand in
RELINEARISE = 2e-3
#: residuals this small (root mean square, dimensionless: 1e-5 is 0.01 mm on a 1 m panel) are
#: solved: stop
NEGLIGIBLE_RMS = 1e-5
#: inner solve of every LM step: a sparse direct solve of the normal equations up to this many
#: unknowns (fast while the fill-in is small), LSMR beyond (an inexact Gauss-Newton step is
#: enough there)
DIRECT_LIMIT = 30_000
LSMR_TOLERANCE, LSMR_ITERATIONS = 1e-4, 300
#: an iteration lowering the energy by less than this share, with no sample moving further than
#: ``step_tolerance``, is in the optimum's slow tail (two in a row stop the solver)
TAIL_RATE = 1e-2
#: LM damping: start, and the factors applied after a rejected / accepted step
DAMPING_START, DAMPING_UP, DAMPING_DOWN = 1e-3, 8.0, 3.0


class GlobalOptimiser:
    """Levenberg-Marquardt on all panels at once (see the module docstring)."""

    def __init__(
        self,
        layout: PanelLayout,
        samples: np.ndarray,
        normals: np.ndarray,
        query: SurfaceQuery,
        *,
        closeness: float,
        fairness: float,
        rib: float,
        depth: float,
        layout_hold: float = 0.0,
    ):
        self.layout = layout
        self.query = query
        self.mesh = sample_mesh(layout, samples)
        m, k = samples.shape[:2]
        self.m, self.k = m, k
        edge_vectors = np.diff(
            np.concatenate(
                [layout.vertices[layout.quads], layout.vertices[layout.quads[:, :1]]], axis=1
            ),
            axis=1,
        )
        self.scale = float(np.linalg.norm(edge_vectors, axis=2).mean())
        self.weights = {
            "closeness": closeness,
            "fairness": fairness,
            "rib": rib,
            "defect": DEFECT_WEIGHT,
            "layout_hold": layout_hold,
        }
        # both triangulations of the grid: the unroll strain measures both diagonals of every
        # cell, so the grid must be flat across either
        grid = np.arange(k * k).reshape(k, k)
        v00, v10 = grid[:-1, :-1].ravel(), grid[1:, :-1].ravel()
        v11, v01 = grid[1:, 1:].ravel(), grid[:-1, 1:].ravel()
        self._triangulations = (
            np.concatenate([np.stack([v00, v10, v11], 1), np.stack([v00, v11, v01], 1)]),
            np.concatenate([np.stack([v00, v10, v01], 1), np.stack([v10, v11, v01], 1)]),
        )
        interior = np.full((k, k), -1, dtype=np.int64)
        interior[1:-1, 1:-1] = np.arange((k - 2) ** 2).reshape(k - 2, k - 2)
        self._interior_row = interior.ravel()
        self.depth = depth
        self.unknowns = Unknowns(m, k, len(self.mesh.points), len(self.mesh.edge_ids))
        self.off_n, self.size = self.unknowns.off_n, self.unknowns.size
        self.start_points = self.mesh.points / self.scale
        self.design_second_differences = design_second_differences(
            self.start_points[self.mesh.ids], faceted=not query.exact
        )
        self.start_normals = normals  # outward: orient the results like them
        # the layout's inner vertices (sample ids 0..nv-1, :func:`sample_mesh`) and the
        # projections onto the design's tangent planes there, which the layout hold measures
        vertices = np.arange(len(layout.vertices))
        self.held = vertices[~self.mesh.boundary[vertices]]
        _, foot_normal, _ = query.closest(self.mesh.points[self.held])
        self.held_tangent = np.eye(3) - foot_normal[:, :, None] * foot_normal[:, None, :]
        self.z = self._initial(normals)

    # -- unknowns ---------------------------------------------------------------------------
    def _initial(self, normals: np.ndarray) -> np.ndarray:
        m, k = self.m, self.k
        x = self.start_points
        cells = (
            normals[:, :-1, :-1] + normals[:, 1:, :-1] + normals[:, 1:, 1:] + normals[:, :-1, 1:]
        )
        n = (cells / np.linalg.norm(cells, axis=-1, keepdims=True)).reshape(m, -1, 3)
        # Gauss-image plane: total least squares of the normals (d = mean . h)
        h, d, _ = bestfit_planes(n)
        # rib planes through each side's samples and the samples moved along the normals
        sides_x = x[self.mesh.edge_ids]  # (E, k, 3)
        first_panel = np.full(len(self.mesh.edge_ids), -1, dtype=np.int64)
        first_side = np.zeros(len(self.mesh.edge_ids), dtype=np.int64)
        for side in range(4):
            first_panel[self.mesh.side_edge[:, side]] = np.arange(m)
            first_side[self.mesh.side_edge[:, side]] = side
        side_normals = np.empty_like(sides_x)
        for side in range(4):
            chosen = first_side == side
            i, j = side_index(k, side)
            own = normals[first_panel[chosen]][:, i, j]
            # side runs from corner `side` of its panel; edge rows run low -> high vertex
            start = self.layout.quads[first_panel[chosen], side]
            end = self.layout.quads[first_panel[chosen], (side + 1) % 4]
            side_normals[chosen] = np.where((start < end)[:, None, None], own, own[:, ::-1])
        cloud = np.concatenate(
            [sides_x, sides_x - (self.depth / self.scale) * side_normals], axis=1
        )
        g, c, _ = bestfit_planes(cloud)
        # bevel of every panel side against its rib plane: start from square ribs
        return np.concatenate([x.ravel(), n.ravel(), h.ravel(), d, g.ravel(), c, np.zeros(4 * m)])

    def unpack(self, z: np.ndarray):
        return self.unknowns.unpack(z)

    # -- residuals ----------------------------------------------------------------------------
    def _foot_points(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        foot, normal, _ = self.query.closest(x * self.scale)
        return foot / self.scale, normal

    def system(
        self, z: np.ndarray, foot: np.ndarray, foot_normal: np.ndarray, jacobian: bool = True
    ) -> ResidualSystem:
        """Every residual block of the module docstring's table at ``z``, closeness
        linearised at the design's ``foot`` points and normals."""
        x, n, h, d, g, offsets, bevel = self.unpack(z)
        ids, unknowns, weights = self.mesh.ids, self.unknowns, self.weights
        system = ResidualSystem(jacobian)
        normal_consistency(system, unknowns, x, n, ids)
        developability(system, unknowns, n, h, d)
        angle_defects(system, x, ids, self._triangulations, self._interior_row, weights["defect"])
        rib_planes(system, unknowns, x, g, offsets, self.mesh.edge_ids, weights["rib"])
        rib_normals(system, unknowns, x, g, bevel, self.mesh, weights["rib"])
        square_ribs(system, unknowns, bevel, self.depth, self.scale, weights["rib"])
        unit_rib_plane_normals(system, unknowns, g)
        # closeness to the design surface, linearised at the foot points
        xcol = unknowns.x_columns
        system.add(
            ((x - foot) * foot_normal).sum(-1),
            [(xcol(np.arange(len(x))), foot_normal)],
            weights["closeness"],
        )
        fairness(system, x, ids, self.design_second_differences, weights["fairness"])
        # the panel corners stay where the layout put them along the surface (their distance
        # from it is the closeness term's)
        held = self.held
        if len(held) and weights["layout_hold"] > 0:
            system.add(
                self._slides(x).ravel(),
                [
                    (
                        np.broadcast_to(xcol(held)[:, None, :], self.held_tangent.shape),
                        self.held_tangent,
                    )
                ],
                weights["layout_hold"],
            )
        # boundary samples stay where they are
        on = np.flatnonzero(self.mesh.boundary)
        if len(on):
            moved = x[on] - self.start_points[on]
            system.add(
                moved.ravel(), [(xcol(on).reshape(-1), np.ones(3 * len(on)))], BOUNDARY_WEIGHT
            )
        return system

    def energy(self, z: np.ndarray, foot: np.ndarray, foot_normal: np.ndarray) -> float:
        residual = np.concatenate(self.system(z, foot, foot_normal, jacobian=False).residuals)
        return float(residual @ residual)

    # -- solve --------------------------------------------------------------------------------
    def solve(self, max_iterations: int, tolerance: float, step_tolerance: float = 0.0) -> dict:
        """Levenberg-Marquardt until an iteration lowers the energy by less than ``tolerance``
        (relative), two in a row move no sample further than ``step_tolerance`` (mm), or
        ``max_iterations``; the report says which (``stopped_by``)."""
        started = time.perf_counter()
        small_steps = 0
        stopped_by = "max_iterations"
        z = self.z
        x, *_ = self.unpack(z)
        foot, foot_normal = self._foot_points(x)
        linearised_at = x.copy()
        damping = DAMPING_START
        energy = self.energy(z, foot, foot_normal)
        history = [energy]
        iterations = rejected = 0
        converged = False
        for iterations in range(1, max_iterations + 1):
            residual, jacobian = self.system(z, foot, foot_normal).matrices(self.size)
            # columns scaled to unit norm: the damping (J'J + mu diag J'J) becomes a plain
            # Tikhonov term that LSMR takes directly, and the iterative solve is well conditioned
            norms = np.sqrt(np.asarray(jacobian.multiply(jacobian).sum(axis=0)).ravel()) + 1e-12
            scaled = (jacobian @ sp.diags(1.0 / norms)).tocsr()
            direct = self.size <= DIRECT_LIMIT
            if direct:
                normal_matrix = (scaled.T @ scaled).tocsc()
                rhs = -(scaled.T @ residual)
            accepted = False
            for _ in range(12):
                if direct:
                    solution = spsolve(
                        normal_matrix + damping * sp.identity(self.size, format="csc"), rhs
                    )
                else:
                    solution = lsmr(
                        scaled,
                        -residual,
                        damp=np.sqrt(damping),
                        atol=LSMR_TOLERANCE,
                        btol=LSMR_TOLERANCE,
                        maxiter=LSMR_ITERATIONS,
                    )[0]
                step = solution / norms
                if not np.all(np.isfinite(step)):
                    raise SolverError(
                        "the developability solver produced non-finite values; "
                        "check the layout for degenerate panels"
                    )
                trial = z + step
                trial_energy = self.energy(trial, foot, foot_normal)
                if trial_energy < energy:
                    accepted = True
                    break
                rejected += 1
                damping *= DAMPING_UP
            if not accepted:
                converged = True  # no descent left at any damping: a (local) minimum
                stopped_by = "no_descent"
                break
            # the tail: samples hardly moving while the energy falls slowly. Small moves alone
            # do not tell (on a cone the normals and planes still change, 8 % an iteration,
            # with the samples moving 0.003 mm), nor steps shortened by a large damping
            moved = np.abs(step[: self.off_n]).max() * self.scale
            tail = (
                damping <= DAMPING_START
                and moved < step_tolerance
                and energy - trial_energy < TAIL_RATE * energy
            )
            small_steps = small_steps + 1 if tail else 0
            log.debug("LM %d: energy %.6g, largest move %.4f mm", iterations, trial_energy, moved)
            damping = max(damping / DAMPING_DOWN, 1e-12)
            z = trial
            x, *_ = self.unpack(z)
            new_energy = trial_energy
            if np.abs(x - linearised_at).max() > RELINEARISE:
                # closest points are the expensive query (exact on B-reps): re-linearise only
                # once the samples have moved noticeably since the last time
                foot, foot_normal = self._foot_points(x)
                linearised_at = x.copy()
                new_energy = self.energy(z, foot, foot_normal)
            history.append(new_energy)
            if abs(energy - new_energy) <= tolerance * max(
                energy, 1e-300
            ) or new_energy <= NEGLIGIBLE_RMS**2 * len(residual):
                energy = new_energy
                converged = True
                stopped_by = "energy"
                break
            if small_steps >= 2:
                energy = new_energy
                converged = True
                stopped_by = "step"
                break
            energy = new_energy
        self.z = z
        return {
            "iterations": iterations,
            "rejected_steps": rejected,
            "converged": converged,
            "stopped_by": stopped_by,
            "energy_start": history[0],
            "energy_end": energy,
            "seconds": round(time.perf_counter() - started, 3),
            "unknowns": int(self.size),
        }

    # -- results ------------------------------------------------------------------------------
    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """samples (m, k, k, 3) mm; own normals (m, k, k, 3) unit (of the samples, by second-
        order differences); Gauss-image planes (m, 4) (h, d) of the cell normals; rib planes
        (E, 4) (g, c) in mm; cell normals (m, k-1, k-1, 3)."""
        x, n, h, d, g, c, _ = self.unpack(self.z)
        samples = x[self.mesh.ids] * self.scale
        normals = grid_normals(samples, self.start_normals)
        g_norm = np.linalg.norm(g, axis=1)
        ribs = np.concatenate([g / g_norm[:, None], (c * self.scale / g_norm)[:, None]], axis=1)
        cells = n / np.linalg.norm(n, axis=-1, keepdims=True)
        return samples, normals, np.concatenate([h, d[:, None]], axis=1), ribs, cells

    def _slides(self, x: np.ndarray) -> np.ndarray:
        """(h, 3) the held vertices' moves from the start in the design's tangent planes
        there (units of L)."""
        return np.einsum(
            "nab,nb->na", self.held_tangent, x[self.held] - self.start_points[self.held]
        )

    def corner_slides(self) -> np.ndarray:
        """How far each inner vertex of the layout (a panel corner) has slid along the design
        surface (in its tangent plane at the start), mm."""
        return np.linalg.norm(self._slides(self.unpack(self.z)[0]), axis=1) * self.scale


def shared_side_normals(layout: PanelLayout, normals: np.ndarray) -> np.ndarray:
    """Own normals with every shared side set to the bisector of the two panels' normals, so
    that neighbouring sheets are offset identically along their common side."""
    from .sides import across_sides

    own, theirs = across_sides(layout, normals)
    bisector = np.where(np.isnan(theirs), own, own + np.nan_to_num(theirs))
    bisector /= np.linalg.norm(bisector, axis=-1, keepdims=True)
    out = normals.copy()
    k = normals.shape[1]
    for side in range(4):
        i, j = side_index(k, side)
        out[:, i, j] = bisector[:, side]
    # a corner belongs to two sides of a panel and to more panels: use the mean of all the
    # normals that meet there, identical for every panel at that vertex
    corners = layout.quads
    corner_index = [(0, 0), (k - 1, 0), (k - 1, k - 1), (0, k - 1)]
    total = np.zeros((len(layout.vertices), 3))
    for c, (i, j) in enumerate(corner_index):
        np.add.at(total, corners[:, c], normals[:, i, j])
    total /= np.linalg.norm(total, axis=1, keepdims=True)
    for c, (i, j) in enumerate(corner_index):
        out[:, i, j] = total[corners[:, c]]
    return out


def develop_global(layout: PanelLayout, surface, job, query: SurfaceQuery):
    """The ``global`` method: see the module docstring. Returns :class:`DevelopedPanels`."""
    from ..errors import Issue
    from .measure import gauss_image_areas
    from .project import developed_panels, sample_panels
    from .sides import folded_sides, side_gaps_and_kinks

    settings = job.develop
    design = sample_panels(layout, query, settings.samples)
    samples0, normals0 = design.samples, design.normals
    optimiser = GlobalOptimiser(
        layout,
        samples0,
        normals0,
        query,
        closeness=settings.closeness,
        fairness=settings.fairness,
        rib=settings.rib_planarity,
        depth=Buildup.of(job).total_depth,
        layout_hold=settings.layout_hold,
    )
    report = optimiser.solve(
        settings.max_iterations, settings.tolerance, float(settings.step_tolerance)
    )
    samples, own_normals, gauss_planes, _, cells = optimiser.result()
    normals = shared_side_normals(layout, own_normals)
    gaps, kinks = side_gaps_and_kinks(layout, samples, own_normals)
    # residual of the Gauss-image plane per panel, as an angle (degrees)
    h = gauss_planes[:, :3] / np.linalg.norm(gauss_planes[:, :3], axis=1, keepdims=True)
    offsets = np.einsum("mkld,md->mkl", cells, h)
    circle = np.degrees(np.ptp(np.arcsin(np.clip(offsets, -1, 1)).reshape(len(h), -1), axis=1)) / 2
    before = gauss_image_areas(samples0)
    after = gauss_image_areas(samples)
    extra = {
        "solver": report,
        "gauss_image_area_before": {"max": float(before.max()), "mean": float(before.mean())},
        "gauss_image_area_after": {"max": float(after.max()), "mean": float(after.mean())},
        "kink_deg": {
            "max": round(float(kinks.max()), 4),
            "p95": round(
                float(np.percentile(kinks[layout.side_neighbours >= 0], 95))
                if (layout.side_neighbours >= 0).any()
                else 0.0,
                4,
            ),
        },
        "gap_mm_max": round(float(gaps.max()), 6),
        # the panel corners' slide along the surface, which the layout hold keeps small
        "corner_slide_mm": _spread(optimiser.corner_slides()),
        "gauss_circle_residual_deg_max": round(float(circle.max()), 4),
    }
    issues = list(folded_sides(layout, kinks))
    # raising the iterations was the advice; on a curved fold, 200 of them (103 steps
    # rejected) took 3x the time and moved a fold corner from 6.5 to 9.4 mm off the design
    if not report["converged"]:
        issues.append(
            Issue(
                "develop-not-converged",
                f"the developability solver stopped after {report['iterations']} "
                f"iterations without converging ({report['rejected_steps']} trial steps "
                f"rejected): the panels are checked as they are (strain, deviation, rib "
                f"planarity above); raising [develop] max_iterations helps while its steps "
                f"are still accepted, and where most are rejected more iterations can move "
                f"panels further off the design",
                "",
                "warning",
            )
        )
    result = developed_panels(
        layout,
        samples,
        normals,
        query,
        job,
        "global",
        design.chords,
        extra,
        tuple(issues),
        design_samples=samples0,
    )
    for i, pid in enumerate(layout.panel_ids):
        panel = result.metrics["per_panel"][pid]
        panel["kink_deg"] = round(float(kinks[i].max()), 4)
        panel["gauss_image_area_before"] = float(before[i])
        panel["gauss_circle_residual_deg"] = round(float(circle[i]), 4)
    return result


def _spread(values: np.ndarray) -> dict[str, float]:
    """Median, 90th percentile and largest of ``values`` (zeros where there are none)."""
    if not len(values):
        return {"median": 0.0, "p90": 0.0, "max": 0.0}
    return {
        "median": round(float(np.median(values)), 3),
        "p90": round(float(np.percentile(values, 90)), 3),
        "max": round(float(values.max()), 3),
    }
