"""The global optimiser's residual blocks (see :mod:`.optimise` for the table of terms).

Each block adds its residuals and their exact Jacobian entries to one
:class:`ResidualSystem`; every residual is at most quadratic in the unknowns, so the
derivatives are short closed forms. Lengths are in units of the mean panel edge ``L``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..geom.quads import side_index
from .sample_grid import SampleMesh, tangent_stencil

#: share of the rib weight for the normals along a side at one angle to its rib plane: that
#: makes the side a planar curvature line (Joachimsthal), which a layout not drawn along
#: curvature lines can only approach. Measured on the sphere cap test (16 panels, R 5 m): 0.1
#: folds panels over (kinks of 160 degrees) to force it, 0.01 keeps the strain at 0.02 % and
#: the sides within 0.07 mm of their planes
RIB_NORMAL_SHARE = 0.01
#: share of the rib weight for square ribs (bevel 0): without it the bevel is free, so where a
#: side is nearly straight its plane tips about it at no cost, and the rib planes of a vertex
#: no longer share one axis (see fabpanel.model.nodes). On a domed plate round a round opening
#: (tests/test_boundary_chords.py) the interior ribs leaned 6.8 degrees, now 0.1; on the
#: examples it changes strain and deviation by under 1 % (0.1 cost the plate 2.5x its mean
#: deviation)
SQUARE_RIB_SHARE = 0.01
#: normals must be normals: this weight makes the consistency terms nearly hard constraints
NORMAL_WEIGHT = 10.0


class ResidualSystem:
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


@dataclass(frozen=True)
class Unknowns:
    """Where each unknown sits in the solver's vector:
    x (3P) | n (3 m c c) | h (3m) | d (m) | g (3E) | c (E) | s (4m), with ``c = k - 1`` cells
    a side, ``P`` samples and ``E`` layout edges (ribs)."""

    m: int
    k: int
    points: int
    edges: int

    @property
    def off_n(self) -> int:
        return 3 * self.points

    @property
    def off_h(self) -> int:
        return self.off_n + 3 * self.m * (self.k - 1) ** 2

    @property
    def off_d(self) -> int:
        return self.off_h + 3 * self.m

    @property
    def off_g(self) -> int:
        return self.off_d + self.m

    @property
    def off_c(self) -> int:
        return self.off_g + 3 * self.edges

    @property
    def off_s(self) -> int:
        return self.off_c + self.edges

    @property
    def size(self) -> int:
        return self.off_s + 4 * self.m

    def unpack(self, z: np.ndarray):
        """Views ``x, n, h, d, g, c, s`` of ``z``."""
        m, c = self.m, self.k - 1
        return (
            z[: self.off_n].reshape(-1, 3),
            z[self.off_n : self.off_h].reshape(m, c, c, 3),
            z[self.off_h : self.off_d].reshape(m, 3),
            z[self.off_d : self.off_g],
            z[self.off_g : self.off_c].reshape(-1, 3),
            z[self.off_c : self.off_s],
            z[self.off_s :].reshape(m, 4),
        )

    @staticmethod
    def x_columns(points: np.ndarray) -> np.ndarray:
        """(..., 3) the columns of sample points ``points`` (any int array)."""
        return 3 * points[..., None] + np.arange(3)

    def n_columns(self) -> np.ndarray:
        c = self.k - 1
        return (self.off_n + np.arange(3 * self.m * c * c)).reshape(self.m, c, c, 3)

    def h_columns(self) -> np.ndarray:
        return (self.off_h + np.arange(3 * self.m)).reshape(self.m, 3)

    def g_columns(self) -> np.ndarray:
        return (self.off_g + np.arange(3 * self.edges)).reshape(-1, 3)


def normal_consistency(
    system: ResidualSystem, unknowns: Unknowns, x: np.ndarray, n: np.ndarray, ids: np.ndarray
) -> None:
    """Every cell normal perpendicular to both cell diagonals (all four corners take part, so
    no odd-even zig-zag of the samples goes unseen), and of unit length."""
    ncol, xcol = unknowns.n_columns(), unknowns.x_columns
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


def developability(
    system: ResidualSystem, unknowns: Unknowns, n: np.ndarray, h: np.ndarray, d: np.ndarray
) -> None:
    """The cell normals of panel p on one plane ``n . h_p = d_p`` of its Gauss image, ``h``
    of unit length."""
    m, c = unknowns.m, unknowns.k - 1
    hcol = unknowns.h_columns()
    h_b = np.broadcast_to(h[:, None, None, :], n.shape)
    system.add(
        ((n * h_b).sum(-1) - d[:, None, None]).ravel(),
        [
            (unknowns.n_columns(), h_b),
            (np.broadcast_to(hcol[:, None, None, :], n.shape), n),
            (
                np.broadcast_to((unknowns.off_d + np.arange(m))[:, None, None], (m, c, c)),
                -np.ones((m, c, c)),
            ),
        ],
        1.0,
    )
    system.add((h * h).sum(-1) - 1.0, [(hcol, 2 * h)], NORMAL_WEIGHT)


def angle_defects(
    system: ResidualSystem,
    x: np.ndarray,
    ids: np.ndarray,
    triangulations: tuple[np.ndarray, ...],
    interior_row: np.ndarray,
    weight: float,
) -> None:
    """Intrinsic flatness: the angles around every interior sample of a panel's grid ``ids``
    (m, k, k) sum to 2 pi, in each of the grid's ``triangulations`` ((t, 3) grid indices;
    the unroll strain measures both diagonals). ``interior_row`` (k k,) numbers the interior
    grid points, -1 elsewhere."""
    for tris in triangulations:
        _angle_defects_of(system, x, ids, tris, interior_row, weight)


def _angle_defects_of(
    system: ResidualSystem,
    x: np.ndarray,
    ids: np.ndarray,
    tris: np.ndarray,
    interior_row: np.ndarray,
    weight: float,
) -> None:
    m, k = ids.shape[:2]
    corners = ids.reshape(m, k * k)[:, tris]  # (m, t, 3)
    rows_local = interior_row[tris]  # (t, 3), -1 outside
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
        weight,
    )


def rib_planes(
    system: ResidualSystem,
    unknowns: Unknowns,
    x: np.ndarray,
    g: np.ndarray,
    offsets: np.ndarray,
    edge_ids: np.ndarray,
    weight: float,
) -> None:
    """Every side's samples ``edge_ids`` (E, k) in its rib plane ``g . x = c``."""
    k = edge_ids.shape[1]
    gcol = unknowns.g_columns()
    ccol = unknowns.off_c + np.arange(len(offsets))
    g_b = np.broadcast_to(g[:, None, :], (len(g), k, 3))
    system.add(
        ((x[edge_ids] * g_b).sum(-1) - offsets[:, None]).ravel(),
        [
            (unknowns.x_columns(edge_ids), g_b),
            (np.broadcast_to(gcol[:, None, :], g_b.shape), x[edge_ids]),
            (np.broadcast_to(ccol[:, None], edge_ids.shape), -np.ones(edge_ids.shape)),
        ],
        weight,
    )


def unit_rib_plane_normals(system: ResidualSystem, unknowns: Unknowns, g: np.ndarray) -> None:
    """Every rib plane's normal ``g`` of unit length."""
    system.add((g * g).sum(-1) - 1.0, [(unknowns.g_columns(), 2 * g)], NORMAL_WEIGHT)


def rib_normals(
    system: ResidualSystem,
    unknowns: Unknowns,
    x: np.ndarray,
    g: np.ndarray,
    bevel: np.ndarray,
    mesh: SampleMesh,
    weight: float,
) -> None:
    """The surface normals along each side at one constant angle to its rib plane,
    ``g . (t_i x t_j) / |.| = s`` (the sine of the side's bevel, an unknown per panel side),
    with the second-order tangents of the grid (the normals the sheets are built with).

    By Joachimsthal's theorem a planar curve on a surface is a curvature line exactly when the
    surface meets its plane at a constant angle: the parallels of a cone or of any surface of
    revolution satisfy it with s != 0, so it holds wherever it can. Then the rib is one flat
    plate cut with one bevel, and the offset (bottom sheet) edge lies in a parallel plane. Not
    at the panel corners: there two rib planes would each have to hold the normal (a
    torsion-free node), which the solver can only meet by folding the corner; the ribs are
    trimmed against each other there anyway. ``weight`` is the rib weight, of which this term
    takes ``RIB_NORMAL_SHARE``."""
    ids, m, k = mesh.ids, unknowns.m, unknowns.k
    xcol, gcol = unknowns.x_columns, unknowns.g_columns()
    index, stencil = tangent_stencil(k)
    for side in range(4):
        i, j = (a[1:-1] for a in side_index(k, side))
        edge = mesh.side_edge[:, side]
        ids_i = ids[:, index[i], j[:, None]]  # (m, k, 3)
        ids_j = ids[:, i[:, None], index[j]]
        t_i = np.einsum("ks,mksc->mkc", stencil[i], x[ids_i])
        t_j = np.einsum("ks,mksc->mkc", stencil[j], x[ids_j])
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
        scol = np.broadcast_to((unknowns.off_s + 4 * np.arange(m) + side)[:, None], sine.shape[:2])
        terms = [
            (np.broadcast_to(gcol[edge][:, None, :], normal.shape), normal / size),
            (scol, -np.ones(scol.shape)),
        ]
        for t in range(3):
            terms.append((xcol(ids_i[..., t]), stencil[i][None, :, t, None] * d_ti))
            terms.append((xcol(ids_j[..., t]), stencil[j][None, :, t, None] * d_tj))
        system.add(residual.ravel(), terms, RIB_NORMAL_SHARE * weight)


def square_ribs(
    system: ResidualSystem,
    unknowns: Unknowns,
    bevel: np.ndarray,
    depth: float,
    scale: float,
    weight: float,
) -> None:
    """Square ribs where the shape allows: a bevel s moves the rib's bottom edge s x ``depth``
    (mm; ``scale`` is L in mm) sideways (see ``SQUARE_RIB_SHARE`` of the rib ``weight``)."""
    scol = unknowns.off_s + np.arange(4 * unknowns.m)
    system.add(
        bevel.ravel() * depth / scale,
        [(scol, np.full(4 * unknowns.m, depth / scale))],
        SQUARE_RIB_SHARE * weight,
    )


def fairness(
    system: ResidualSystem,
    x: np.ndarray,
    ids: np.ndarray,
    references: tuple[np.ndarray, np.ndarray],
    weight: float,
) -> None:
    """Second differences along both grid directions inside every panel, against the design's
    own (``references``, :func:`.sample_grid.design_second_differences`): fairness keeps the
    grid lines smooth (no zig-zag) without pulling a curved surface flat."""
    for (a, b, e), reference in zip(
        (
            (ids[:, :-2, :], ids[:, 1:-1, :], ids[:, 2:, :]),
            (ids[:, :, :-2], ids[:, :, 1:-1], ids[:, :, 2:]),
        ),
        references,
        strict=True,
    ):
        second = (x[a] - 2 * x[b] + x[e]) - reference
        one = np.ones(a.shape)
        for comp in range(3):
            system.add(
                second[..., comp].ravel(),
                [(3 * a + comp, one), (3 * b + comp, -2 * one), (3 * e + comp, one)],
                weight,
            )
