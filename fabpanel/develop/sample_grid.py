"""The global optimiser's samples as one mesh, and the grid kernels its residuals use.

Neighbouring panels share their side samples (the same unknowns) by topology, so they stay
joined whatever the solver does; the grid's sides follow :func:`fabpanel.geom.quads.side_index`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data import PanelLayout
from ..geom.quads import side_index


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


def tangent_stencil(k: int) -> tuple[np.ndarray, np.ndarray]:
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
    index, weight = tangent_stencil(samples.shape[1])
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
