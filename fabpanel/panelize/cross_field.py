"""A cross field on the conformal flattening that follows the principal curvature directions
where the surface is clearly anisotropic and the boundary near it, for ``align = "curvature"``.

1. principal directions per triangle from the change of the vertex normals across it (the
   per-face shape operator of Rusinkiewicz 2004, fitted to the three edges by least squares);
   the shape operators are averaged over neighbouring triangles a few times, since a single
   triangle's estimate is noisy;
2. the maximum-curvature direction is mapped into the flat domain by each triangle's own
   linear map (the flattening is conformal, so the cross stays a right-angled cross);
3. one sparse solve for the smoothest 4-fold field (``z = e^{4 i theta}``, the representation of
   Knöppel et al. 2013; on a plane the connection is trivial) that meets the boundary tangents
   on boundary triangles and the curvature directions with weight ``CURVATURE_WEIGHT x a²``,
   ``a = (|k1| - |k2|) / (|k1| + |k2|)`` the anisotropy. Where ``a`` is small (a sphere, a
   plane) the field is the boundary-aligned one.

Returns one angle per triangle (radians, flat domain); :mod:`.gmsh_quads` hands it to gmsh as
its guiding field.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

#: weight of the curvature directions against smoothness, times the anisotropy squared
CURVATURE_WEIGHT = 10.0
#: weight of the boundary tangents on boundary triangles
BOUNDARY_WEIGHT = 100.0
#: averaging rounds of the per-triangle shape operators over edge neighbours
SMOOTHING_ROUNDS = 4


def _face_frames(vertices: np.ndarray, faces: np.ndarray):
    p0, p1, p2 = (vertices[faces[:, i]] for i in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    u = p1 - p0
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    return u, np.cross(normal, u), normal


def _vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    p0, p1, p2 = (vertices[faces[:, i]] for i in range(3))
    weighted = np.cross(p1 - p0, p2 - p0)  # area-weighted
    normals = np.zeros_like(vertices)
    for corner in range(3):
        np.add.at(normals, faces[:, corner], weighted)
    return normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)


def shape_operators(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, tuple]:
    """(m, 3) symmetric 2x2 shape operators ``(s11, s12, s22)`` per triangle in its frame."""
    u, v, _ = _face_frames(vertices, faces)
    normals = _vertex_normals(vertices, faces)
    rows_a, rhs = [], []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        edge = vertices[faces[:, j]] - vertices[faces[:, i]]
        dn = normals[faces[:, j]] - normals[faces[:, i]]
        eu, ev = np.einsum("ij,ij->i", edge, u), np.einsum("ij,ij->i", edge, v)
        # S (eu, ev) = (dn.u, dn.v): two equations in s11, s12, s22
        rows_a.append(np.stack([eu, ev, np.zeros_like(eu)], axis=1))
        rhs.append(np.einsum("ij,ij->i", dn, u))
        rows_a.append(np.stack([np.zeros_like(eu), eu, ev], axis=1))
        rhs.append(np.einsum("ij,ij->i", dn, v))
    a = np.stack(rows_a, axis=1)  # (m, 6, 3)
    b = np.stack(rhs, axis=1)  # (m, 6)
    ata = np.einsum("mki,mkj->mij", a, a) + 1e-12 * np.eye(3)
    atb = np.einsum("mki,mk->mi", a, b)
    return np.linalg.solve(ata, atb[..., None])[..., 0], (u, v)


def _smoothed(values: np.ndarray, faces: np.ndarray, frames, rounds: int) -> np.ndarray:
    """Shape operators averaged with their edge neighbours, moved between frames in 3D."""
    u, v = frames
    tensor = (
        values[:, 0, None, None] * np.einsum("mi,mj->mij", u, u)
        + values[:, 1, None, None] * (np.einsum("mi,mj->mij", u, v) + np.einsum("mi,mj->mij", v, u))
        + values[:, 2, None, None] * np.einsum("mi,mj->mij", v, v)
    )
    adjacency = _face_adjacency(faces)
    degree = np.asarray(adjacency.sum(axis=1)).ravel() + 1.0
    for _ in range(rounds):
        tensor = (tensor + (adjacency @ tensor.reshape(len(faces), 9)).reshape(-1, 3, 3)) / degree[
            :, None, None
        ]
    s11 = np.einsum("mi,mij,mj->m", u, tensor, u)
    s12 = np.einsum("mi,mij,mj->m", u, tensor, v)
    s22 = np.einsum("mi,mij,mj->m", v, tensor, v)
    return np.stack([s11, s12, s22], axis=1)


def _face_adjacency(faces: np.ndarray) -> sp.csr_matrix:
    sides = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces)), 3)
    key = np.sort(sides, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, owner = key[order], owner[order]
    same = np.flatnonzero((key[1:] == key[:-1]).all(axis=1))
    a, b = owner[same], owner[same + 1]
    n = len(faces)
    data = np.ones(2 * len(a))
    return sp.csr_matrix((data, (np.r_[a, b], np.r_[b, a])), shape=(n, n))


def curvature_cross_field(
    vertices: np.ndarray, faces: np.ndarray, flat: np.ndarray, boundary_loops
) -> tuple[np.ndarray, dict]:
    """Angle (radians, flat domain) of a cross per triangle, and a summary of the field."""
    operators, frames = shape_operators(vertices, faces)
    operators = _smoothed(operators, faces, frames, SMOOTHING_ROUNDS)
    s11, s12, s22 = operators.T
    mean = 0.5 * (s11 + s22)
    radius = np.sqrt(0.25 * (s11 - s22) ** 2 + s12**2)
    k1, k2 = mean + radius, mean - radius
    angle_in_frame = 0.5 * np.arctan2(2 * s12, s11 - s22)  # direction of k1 in (u, v)
    u, v = frames
    direction3d = np.cos(angle_in_frame)[:, None] * u + np.sin(angle_in_frame)[:, None] * v
    flat_direction = _to_flat(vertices, faces, flat, direction3d)
    theta_curvature = np.arctan2(flat_direction[:, 1], flat_direction[:, 0])
    anisotropy = (np.abs(k1) - np.abs(k2)) / np.maximum(np.abs(k1) + np.abs(k2), 1e-300)
    anisotropy = np.abs(anisotropy)
    theta = _solve_field(faces, flat, boundary_loops, theta_curvature, anisotropy)
    summary = {
        "anisotropy_median": round(float(np.median(anisotropy)), 3),
        "anisotropic_share": round(float(np.mean(anisotropy > 0.3)), 3),
    }
    return theta, summary


def boundary_cross_field(faces: np.ndarray, flat: np.ndarray, boundary_loops) -> np.ndarray:
    """Angle (radians, flat domain) per triangle of the smoothest cross field that follows the
    given boundary loops (vertex ids; loops left out do not steer it)."""
    zero = np.zeros(len(faces))
    return _solve_field(faces, flat, boundary_loops, zero, zero)


def _to_flat(vertices, faces, flat, direction3d) -> np.ndarray:
    """Each triangle's 3D tangent direction through its own map to the flat triangle."""
    p0, p1, p2 = (vertices[faces[:, i]] for i in range(3))
    q0, q1, q2 = (flat[faces[:, i]] for i in range(3))
    e1, e2 = p1 - p0, p2 - p0
    # direction = a e1 + b e2 (least squares in 3D), then the same combination of flat edges
    g11, g12, g22 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = np.einsum("ij,ij->i", direction3d, e1), np.einsum("ij,ij->i", direction3d, e2)
    det = np.maximum(g11 * g22 - g12 * g12, 1e-300)
    a = (g22 * r1 - g12 * r2) / det
    b = (g11 * r2 - g12 * r1) / det
    return a[:, None] * (q1 - q0) + b[:, None] * (q2 - q0)


def _solve_field(faces, flat, boundary_loops, theta_curvature, anisotropy) -> np.ndarray:
    """The smoothest 4-fold field meeting boundary tangents and weighted curvature angles."""
    n = len(faces)
    adjacency = sp.triu(_face_adjacency(faces)).tocoo()
    rows = np.arange(len(adjacency.row))
    difference = sp.csr_matrix(
        (
            np.r_[np.ones(len(rows)), -np.ones(len(rows))],
            (np.r_[rows, rows], np.r_[adjacency.row, adjacency.col]),
        ),
        shape=(len(rows), n),
    )
    laplacian = (difference.T @ difference).tocsr()
    weight = CURVATURE_WEIGHT * anisotropy**2
    target = weight * np.exp(4j * theta_curvature)
    boundary_faces, boundary_angles = _boundary_tangents(faces, flat, boundary_loops)
    weight = weight.copy()
    np.add.at(weight, boundary_faces, BOUNDARY_WEIGHT)
    np.add.at(target, boundary_faces, BOUNDARY_WEIGHT * np.exp(4j * boundary_angles))
    system = (laplacian + sp.diags(weight + 1e-9)).tocsc()
    z = spla.spsolve(system, target.real) + 1j * spla.spsolve(system, target.imag)
    return np.angle(z) / 4.0


def _boundary_tangents(faces, flat, boundary_loops) -> tuple[np.ndarray, np.ndarray]:
    """Triangles holding a boundary edge, and that edge's direction in the flat domain."""
    edge_face: dict[tuple[int, int], int] = {}
    for face, tri in enumerate(faces.tolist()):
        for i in range(3):
            edge_face[(tri[i], tri[(i + 1) % 3])] = face
    found_faces, angles = [], []
    for loop in boundary_loops:
        loop = [int(v) for v in loop]
        for a, b in zip(loop, loop[1:] + loop[:1]):
            owner = edge_face.get((a, b), edge_face.get((b, a)))
            if owner is None:
                continue
            d = flat[b] - flat[a]
            found_faces.append(owner)
            angles.append(np.arctan2(d[1], d[0]))
    return np.asarray(found_faces, dtype=int), np.asarray(angles)


def principal_directions(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m, 3) maximum-curvature direction per triangle and (m,) anisotropy in [0, 1]."""
    operators, frames = shape_operators(vertices, faces)
    s11, s12, s22 = _smoothed(operators, faces, frames, SMOOTHING_ROUNDS).T
    radius = np.sqrt(0.25 * (s11 - s22) ** 2 + s12**2)
    mean = 0.5 * (s11 + s22)
    k1, k2 = mean + radius, mean - radius
    angle = 0.5 * np.arctan2(2 * s12, s11 - s22)
    u, v = frames
    direction = np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * v
    anisotropy = np.abs(np.abs(k1) - np.abs(k2)) / np.maximum(np.abs(k1) + np.abs(k2), 1e-300)
    return direction, anisotropy


def curvature_alignment(layout_vertices, layout_edges, vertices, faces, locator) -> dict:
    """How far panel edges run from the nearest principal direction where the surface is
    clearly anisotropic (anisotropy > 0.3), degrees: median and 90th percentile (random
    directions would give a median of 22.5)."""
    direction, anisotropy = principal_directions(vertices, faces)
    a, b = layout_vertices[layout_edges[:, 0]], layout_vertices[layout_edges[:, 1]]
    mids = 0.5 * (a + b)
    _, _, tri = locator.nearest(mids)
    edge = b - a
    edge /= np.maximum(np.linalg.norm(edge, axis=1, keepdims=True), 1e-300)
    cos = np.abs(np.einsum("ij,ij->i", edge, direction[tri]))
    off = np.degrees(np.arccos(np.clip(cos, 0, 1)))
    off = np.minimum(off, 90.0 - off)  # either principal direction
    keep = anisotropy[tri] > 0.3
    if not keep.any():
        return {"anisotropic_edges": 0}
    return {
        "anisotropic_edges": int(keep.sum()),
        "median_deg": round(float(np.median(off[keep])), 2),
        "p90_deg": round(float(np.percentile(off[keep], 90)), 2),
    }
