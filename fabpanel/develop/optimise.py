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
normal consistency      ``n . (x[i+1] - x[i-1]) / |.|`` along both grid lines  ``NORMAL_WEIGHT``
unit vectors            ``|n|^2 - 1``, ``|h|^2 - 1``, ``|g|^2 - 1``            ``NORMAL_WEIGHT``
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
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import lsmr, spsolve

from ..buildup import Buildup
from ..data import PanelLayout
from ..errors import SolverError
from ..geom.fitting import bestfit_planes
from ..surface import SurfaceQuery

log = logging.getLogger(__name__)

#: share of the rib weight for the normals along a side at one angle to its rib plane: that
#: makes the side a planar curvature line (Joachimsthal), which a layout not drawn along
#: curvature lines can only approach. Measured on the sphere cap test (16 panels, R 5 m): 0.1
#: folds panels over (kinks of 160 degrees) to force it, 0.01 keeps the strain at 0.02 % and
#: the sides within 0.07 mm of their planes
RIB_NORMAL_SHARE = 0.01
#: weight of the angle defects (radians) at the interior samples of every panel: a defect of
#: 1e-4 rad is what a 1 m panel of a 20 m sphere carries; this makes it count like a 1 mm rib step
DEFECT_WEIGHT = 30.0
#: share of the rib weight for square ribs (bevel 0): without it the bevel is free, so where a
#: side is nearly straight its plane tips about it at no cost, and the rib planes of a vertex
#: no longer share one axis (see fabpanel.model.nodes). On a domed plate round a round opening
#: (tests/test_boundary_chords.py) the interior ribs leaned 6.8 degrees, now 0.1; on the
#: examples it changes strain and deviation by under 1 % (0.1 cost the plate 2.5x its mean
#: deviation)
SQUARE_RIB_SHARE = 0.01
#: normals must be normals: this weight makes the consistency terms nearly hard constraints
NORMAL_WEIGHT = 10.0
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


@dataclass(frozen=True)
class SampleMesh:
    """All panel samples as one mesh: ``ids[p, i, j]`` is the point of panel p's sample (i, j).

    ids : (m, k, k) int; points : (P, 3) float mm; boundary : (P,) bool, on the design boundary;
    side_edge : (m, 4) int, the layout edge (rib) of every panel side (``PanelLayout.edges`` row);
    edge_ids : (e, k) int, the samples of every layout edge from its lower to its higher vertex.
    """

    ids: np.ndarray
    points: np.ndarray
    boundary: np.ndarray
    side_edge: np.ndarray
    edge_ids: np.ndarray


def side_index(k: int, side: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid indices (i, j) of one side, from corner ``side`` to corner ``side + 1``."""
    r, last = np.arange(k), np.full(k, k - 1)
    first = np.zeros(k, dtype=int)
    return [(r, first), (last, r), (r[::-1], last), (first, r[::-1])][side]


def sample_mesh(layout: PanelLayout, samples: np.ndarray) -> SampleMesh:
    """Shared sample ids by topology (layout vertices and edges), never by coordinates."""
    quads = layout.quads
    m, k = samples.shape[:2]
    nv = len(layout.vertices)
    edges = layout.edges
    inner = k - 2
    ids = np.empty((m, k, k), dtype=np.int64)
    ids[:, 1:-1, 1:-1] = (
        nv + len(edges) * inner + np.arange(m * inner * inner).reshape(m, inner, inner)
    )
    side_edge = layout.side_edges
    edge_inner = nv + np.arange(len(edges) * inner).reshape(len(edges), inner)
    for side in range(4):
        a, b = quads[:, side], quads[:, (side + 1) % 4]
        edge = side_edge[:, side]
        along = edge_inner[edge]  # (m, inner), low -> high
        along = np.where((a < b)[:, None], along, along[:, ::-1])
        i, j = side_index(k, side)
        ids[:, i[1:-1], j[1:-1]] = along
        ids[:, i[0], j[0]] = a
    edge_ids = np.concatenate([edges[:, :1], edge_inner, edges[:, 1:]], axis=1)
    count = nv + len(edges) * inner + m * inner * inner
    points = np.zeros((count, 3))
    points[ids.reshape(-1)] = samples.reshape(-1, 3)
    faces_per_edge = np.bincount(side_edge.ravel(), minlength=len(edges))
    boundary = np.zeros(count, dtype=bool)
    boundary[edge_ids[faces_per_edge == 1].ravel()] = True
    return SampleMesh(ids, points, boundary, side_edge, edge_ids)


class _System:
    """Residual blocks and their sparse Jacobian, assembled from vectorised pieces; with
    ``jacobian=False`` the residuals only (the energy of a trial step needs no more)."""

    def __init__(self, jacobian: bool = True) -> None:
        self.residuals: list[np.ndarray] = []
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.count = 0
        self.jacobian = jacobian

    def add(
        self, residual: np.ndarray, terms: list[tuple[np.ndarray, np.ndarray]], weight: float
    ) -> None:
        """residual (r,); terms: (columns (r, c), values (r, c)) pairs of Jacobian entries."""
        r = len(residual)
        rows = self.count + np.arange(r)
        self.residuals.append(weight * residual)
        self.count += r
        if not self.jacobian:
            return
        for columns, values in terms:
            columns = columns.reshape(r, -1)
            values = values.reshape(r, -1)
            self.rows.append(np.repeat(rows, columns.shape[1]))
            self.cols.append(columns.ravel())
            self.vals.append(weight * values.ravel())

    def add_summed(
        self,
        residual: np.ndarray,
        rows: np.ndarray,
        columns: np.ndarray,
        values: np.ndarray,
        weight: float,
    ) -> None:
        """residual (r,) whose Jacobian entries come as (row in 0..r, column, value) triplets
        (repeated entries add up)."""
        self.residuals.append(weight * residual)
        if not self.jacobian:
            self.count += len(residual)
            return
        self.rows.append(self.count + rows)
        self.cols.append(columns)
        self.vals.append(weight * values)
        self.count += len(residual)

    def matrices(self, size: int) -> tuple[np.ndarray, sp.csr_matrix]:
        residual = np.concatenate(self.residuals)
        jacobian = sp.csr_matrix(
            (np.concatenate(self.vals), (np.concatenate(self.rows), np.concatenate(self.cols))),
            shape=(self.count, size),
        )
        return residual, jacobian


def _tangent_stencil(k: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (k, 3) and weights (k, 3) of a second-order first difference along a grid line:
    central inside, the three-point one-sided rule at both ends (exact for quadratics, so the
    samples of a circle arc already satisfy ``n . tangent = 0`` everywhere)."""
    idx = np.arange(k)
    index = np.stack([np.maximum(idx - 1, 0), idx, np.minimum(idx + 1, k - 1)], axis=1)
    weight = np.tile([-1.0, 0.0, 1.0], (k, 1))
    index[0], weight[0] = [0, 1, 2], [-3.0, 4.0, -1.0]
    index[-1], weight[-1] = [k - 3, k - 2, k - 1], [1.0, -4.0, 3.0]
    return index, weight


def grid_normals(samples: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(m, k, k, 3) unit normals of sample grids from second-order differences along both grid
    lines, turned to agree with ``reference`` normals (any (m, a, b, 3) on the same side)."""
    index, weight = _tangent_stencil(samples.shape[1])
    along_i = np.einsum("is,misjc->mijc", weight, samples[:, index])
    along_j = np.einsum("js,mijsc->mijc", weight, samples[:, :, index])
    normals = np.cross(along_i, along_j)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    side = np.sign(np.einsum("mijc,mc->m", normals, reference.reshape(len(samples), -1, 3).sum(1)))
    return normals * np.where(side == 0, 1.0, side)[:, None, None, None]


def design_second_differences(grids: np.ndarray, faceted: bool) -> tuple[np.ndarray, np.ndarray]:
    """The fairness term's reference: the second differences along both grid directions,
    ``(m, k - 2, k, 3)`` and ``(m, k, k - 2, 3)``, of each panel's design grid
    ``grids (m, k, k, 3)``. A ``faceted`` design (a mesh) is first smoothed to one bicubic per
    panel (least squares): its samples' own second differences carry the facets (a 96-gon vault
    sampled every 150 mm: 0.5 mm in 5.6), and a fairness strong enough to keep the grid lines
    even would keep the facets too, which leaves the bicubic sheets through the samples far
    less developable than the samples (a 12 m dome at 1.2 m: 46 of 166 panels over the strain
    tolerance against none). An exact design keeps its own: one cubic cannot follow a 45°
    arc closely enough to keep a cylinder exact."""
    raw = grids
    if faceted:
        k = grids.shape[1]
        basis = np.polynomial.legendre.legvander(np.linspace(-1.0, 1.0, k), min(3, k - 1))
        smoothing = basis @ np.linalg.pinv(basis)  # (k, k): least-squares projection on cubics
        raw = np.einsum("ia,mabd,jb->mijd", smoothing, grids, smoothing)
    return (
        raw[:, :-2] - 2 * raw[:, 1:-1] + raw[:, 2:],
        raw[:, :, :-2] - 2 * raw[:, :, 1:-1] + raw[:, :, 2:],
    )


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
        n_points = len(self.mesh.points)
        n_edges = len(self.mesh.edge_ids)
        # unknown layout: x (3P) | n (3 m k k) | h (3m) | d (m) | g (3E) | c (E) | s (4m)
        self.off_n = 3 * n_points
        self.off_h = self.off_n + 3 * m * (k - 1) ** 2
        self.off_d = self.off_h + 3 * m
        self.off_g = self.off_d + m
        self.off_c = self.off_g + 3 * n_edges
        self.off_s = self.off_c + n_edges
        self.size = self.off_s + 4 * m
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
        m, k = self.m, self.k
        x = z[: self.off_n].reshape(-1, 3)
        n = z[self.off_n : self.off_h].reshape(m, k - 1, k - 1, 3)
        h = z[self.off_h : self.off_d].reshape(m, 3)
        d = z[self.off_d : self.off_g]
        g = z[self.off_g : self.off_c].reshape(-1, 3)
        c = z[self.off_c : self.off_s]
        s = z[self.off_s :].reshape(m, 4)
        return x, n, h, d, g, c, s

    # -- residuals ----------------------------------------------------------------------------
    def _foot_points(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        foot, normal, _ = self.query.closest(x * self.scale)
        return foot / self.scale, normal

    def system(
        self, z: np.ndarray, foot: np.ndarray, foot_normal: np.ndarray, jacobian: bool = True
    ) -> _System:
        m, k = self.m, self.k
        x, n, h, d, g, offsets, bevel = self.unpack(z)
        ids = self.mesh.ids
        system = _System(jacobian)
        xcol = lambda pid: 3 * pid[..., None] + np.arange(3)
        ncol = (self.off_n + np.arange(3 * m * k * k)).reshape(m, k, k, 3)
        # normal consistency: every cell normal is perpendicular to both cell diagonals (all
        # four corners take part, so no odd-even zig-zag of the samples goes unseen)
        c = k - 1
        ncol = (self.off_n + np.arange(3 * m * c * c)).reshape(m, c, c, 3)
        for start, end in ((ids[:, :-1, :-1], ids[:, 1:, 1:]), (ids[:, :-1, 1:], ids[:, 1:, :-1])):
            diagonal = x[end] - x[start]  # (m, c, c, 3)
            length = np.linalg.norm(diagonal, axis=-1, keepdims=True)
            residual = (n * diagonal).sum(-1, keepdims=True) / length
            # d/d diagonal of n . d / |d| = (n - r d/|d|) / |d|
            d_diag = (n - residual * diagonal / length) / length
            system.add(
                residual.ravel(),
                [(ncol, diagonal / length), (xcol(end), d_diag), (xcol(start), -d_diag)],
                NORMAL_WEIGHT,
            )
        system.add(((n * n).sum(-1) - 1.0).ravel(), [(ncol, 2 * n)], NORMAL_WEIGHT)
        # developability: the cell normals of panel p on one plane n . h_p = d_p
        hcol = (self.off_h + np.arange(3 * m)).reshape(m, 3)
        h_b = np.broadcast_to(h[:, None, None, :], n.shape)
        system.add(
            ((n * h_b).sum(-1) - d[:, None, None]).ravel(),
            [
                (ncol, h_b),
                (np.broadcast_to(hcol[:, None, None, :], n.shape), n),
                (
                    np.broadcast_to((self.off_d + np.arange(m))[:, None, None], (m, c, c)),
                    -np.ones((m, c, c)),
                ),
            ],
            1.0,
        )
        system.add((h * h).sum(-1) - 1.0, [(hcol, 2 * h)], NORMAL_WEIGHT)
        self._angle_defects(system, x)
        # rib planes: side samples in the plane, both panels' normals along the side in it
        edge_ids = self.mesh.edge_ids  # (E, k)
        gcol = (self.off_g + np.arange(g.size)).reshape(-1, 3)
        ccol = self.off_c + np.arange(len(offsets))
        g_b = np.broadcast_to(g[:, None, :], (len(g), k, 3))
        system.add(
            ((x[edge_ids] * g_b).sum(-1) - offsets[:, None]).ravel(),
            [
                (xcol(edge_ids), g_b),
                (np.broadcast_to(gcol[:, None, :], g_b.shape), x[edge_ids]),
                (np.broadcast_to(ccol[:, None], edge_ids.shape), -np.ones(edge_ids.shape)),
            ],
            self.weights["rib"],
        )
        # ... and the surface normals along the side at one constant angle to it,
        # g . (t_i x t_j) / |.| = s (the sine of the side's bevel, an unknown per panel side),
        # with the second-order tangents of the grid (the normals the sheets are built with).
        # By Joachimsthal's theorem a planar curve on a surface is a curvature line exactly when
        # the surface meets its plane at a constant angle: the parallels of a cone or of any
        # surface of revolution satisfy it with s != 0, so it holds wherever it can. Then the
        # rib is one flat plate cut with one bevel, and the offset (bottom sheet) edge lies in a
        # parallel plane. Not at the panel corners: there two rib planes would each have to
        # hold the normal (a torsion-free node), which the solver can only meet by folding the
        # corner; the ribs are trimmed against each other there anyway
        index, weight = _tangent_stencil(k)
        for side in range(4):
            i, j = (a[1:-1] for a in side_index(k, side))
            edge = self.mesh.side_edge[:, side]
            ids_i = ids[:, index[i], j[:, None]]  # (m, k, 3)
            ids_j = ids[:, i[:, None], index[j]]
            t_i = np.einsum("ks,mksc->mkc", weight[i], x[ids_i])
            t_j = np.einsum("ks,mksc->mkc", weight[j], x[ids_j])
            normal = np.cross(t_i, t_j)
            size = np.linalg.norm(normal, axis=-1, keepdims=True)
            g_s = np.broadcast_to(g[edge][:, None, :], normal.shape)
            sine = (normal * g_s).sum(-1, keepdims=True) / size
            residual = sine - bevel[:, side, None, None]
            # r = g . N / |N| - s, N = t_i x t_j: dr/dN = v = (g - (g.N/|N|) N/|N|) / |N|,
            # dr/dt_i = t_j x v, dr/dt_j = v x t_i
            v = (g_s - sine * normal / size) / size
            d_ti = np.cross(t_j, v)
            d_tj = np.cross(v, t_i)
            scol = np.broadcast_to((self.off_s + 4 * np.arange(m) + side)[:, None], sine.shape[:2])
            terms = [
                (np.broadcast_to(gcol[edge][:, None, :], normal.shape), normal / size),
                (scol, -np.ones(scol.shape)),
            ]
            for t in range(3):
                terms.append((xcol(ids_i[..., t]), weight[i][None, :, t, None] * d_ti))
                terms.append((xcol(ids_j[..., t]), weight[j][None, :, t, None] * d_tj))
            system.add(residual.ravel(), terms, RIB_NORMAL_SHARE * self.weights["rib"])
        # square ribs where the shape allows: a bevel s moves the rib's bottom edge s x depth
        # sideways (in units of L); see SQUARE_RIB_SHARE
        scol = self.off_s + np.arange(4 * m)
        system.add(
            bevel.ravel() * self.depth / self.scale,
            [(scol, np.full(4 * m, self.depth / self.scale))],
            SQUARE_RIB_SHARE * self.weights["rib"],
        )
        system.add((g * g).sum(-1) - 1.0, [(gcol, 2 * g)], NORMAL_WEIGHT)
        # closeness to the design surface, linearised at the foot points
        points = np.arange(len(x))
        system.add(
            ((x - foot) * foot_normal).sum(-1),
            [(xcol(points), foot_normal)],
            self.weights["closeness"],
        )
        # fairness: second differences along both grid directions inside every panel
        for (a, b, e), reference in zip(
            (
                (ids[:, :-2, :], ids[:, 1:-1, :], ids[:, 2:, :]),
                (ids[:, :, :-2], ids[:, :, 1:-1], ids[:, :, 2:]),
            ),
            self.design_second_differences,
            strict=True,
        ):
            # against the design's own second differences: fairness keeps the grid lines
            # smooth (no zig-zag) without pulling a curved surface flat
            second = (x[a] - 2 * x[b] + x[e]) - reference
            for comp in range(3):
                one = np.ones(a.shape)
                system.add(
                    second[..., comp].ravel(),
                    [(3 * a + comp, one), (3 * b + comp, -2 * one), (3 * e + comp, one)],
                    self.weights["fairness"],
                )
        # the panel corners stay where the layout put them along the surface (their distance
        # from it is the closeness term's)
        held = self.held
        if len(held) and self.weights["layout_hold"] > 0:
            system.add(
                self._slides(x).ravel(),
                [
                    (
                        np.broadcast_to(xcol(held)[:, None, :], self.held_tangent.shape),
                        self.held_tangent,
                    )
                ],
                self.weights["layout_hold"],
            )
        # boundary samples stay where they are
        on = np.flatnonzero(self.mesh.boundary)
        if len(on):
            moved = x[on] - self.start_points[on]
            system.add(
                moved.ravel(), [(xcol(on).reshape(-1), np.ones(3 * len(on)))], BOUNDARY_WEIGHT
            )
        return system

    def _angle_defects(self, system: _System, x: np.ndarray) -> None:
        """Intrinsic flatness: the angles around every interior sample of a panel's grid sum to
        2 pi, in both triangulations of the grid (the unroll strain measures both diagonals)."""
        for tris in self._triangulations:
            self._angle_defects_of(system, x, tris)

    def _angle_defects_of(self, system: _System, x: np.ndarray, tris: np.ndarray) -> None:
        m, k = self.m, self.k
        corners = self.mesh.ids.reshape(m, k * k)[:, tris]  # (m, t, 3)
        rows_local = self._interior_row[tris]  # (t, 3), -1 outside
        count = m * (k - 2) ** 2
        angle_sum = np.zeros(count)
        rows, cols, vals = [], [], []
        panel_offset = (np.arange(m) * (k - 2) ** 2)[:, None]
        for corner in range(3):
            inside = rows_local[:, corner] >= 0  # only angles at interior samples count
            a = corners[:, inside, corner]
            b = corners[:, inside, (corner + 1) % 3]
            c = corners[:, inside, (corner + 2) % 3]
            u, v = x[b] - x[a], x[c] - x[a]
            theta = np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), (u * v).sum(-1))
            r = (panel_offset + rows_local[inside, corner][None, :]).ravel()  # (m t_in,)
            angle_sum += np.bincount(r, weights=theta.ravel(), minlength=count)
            if not system.jacobian:
                continue
            lu = np.linalg.norm(u, axis=-1, keepdims=True)
            lv = np.linalg.norm(v, axis=-1, keepdims=True)
            # d theta / d b = -(unit vector in the plane, perpendicular to u, towards v) / |u|
            uh, vh = u / lu, v / lv
            wb = vh - (vh * uh).sum(-1, keepdims=True) * uh
            wc = uh - (uh * vh).sum(-1, keepdims=True) * vh
            wb /= np.linalg.norm(wb, axis=-1, keepdims=True)
            wc /= np.linalg.norm(wc, axis=-1, keepdims=True)
            d_b, d_c = -wb / lu, -wc / lv
            d_a = -(d_b + d_c)
            for point, grad in ((a, d_a), (b, d_b), (c, d_c)):
                # the residual is 2 pi - sum: its derivative is minus the angle's
                rows.append(np.repeat(r, 3))
                cols.append((3 * point[..., None] + np.arange(3)).ravel())
                vals.append(-grad.reshape(-1))
        empty = np.zeros(0, dtype=np.int64)
        system.add_summed(
            2 * np.pi - angle_sum,
            np.concatenate(rows) if rows else empty,
            np.concatenate(cols) if cols else empty,
            np.concatenate(vals) if vals else np.zeros(0),
            self.weights["defect"],
        )

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
    from .sides import side_gaps_and_kinks

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
    issues = []
    if not report["converged"]:
        issues.append(
            Issue(
                "develop-not-converged",
                f"the developability solver stopped after {report['iterations']} "
                f"iterations without converging; raise [develop] max_iterations",
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
