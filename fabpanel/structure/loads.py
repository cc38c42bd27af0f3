"""Consistent nodal loads on shell models: area loads (true or projected area), edge loads,
self-weight shares, and the wind exposure of sheet elements.

CalculiX has no traction-vector load for shells (``*DLOAD P`` acts along the element normal only,
``GRAV`` per mass), so snow on the horizontal projection and wind as a projected load are
integrated here into consistent nodal forces, ``f_a = ∫ N_a q dA``, with the element's own
shape functions (S8R serendipity, 3 x 3 Gauss; S6 quadratic triangle, 7-point rule) and written
as ``*CLOAD``. Knowing every nodal force also gives the share that sits on supported nodes,
which CalculiX reports inside the reaction ``RF`` (its "external force"); the reaction check
subtracts it (``notes/fem.md`` §0.4).

Loads (thesis §7.3.2, after Derks 2012): snow 0.56 kN/m2 on the horizontal projection; wind
0.8 kN/m2 as a projected load on the sheet faces it reaches first, in both signs.
"""

from __future__ import annotations

import numpy as np

from .mesh import ShellModel
from .shapes import serendipity

#: standard gravity, mm/s2
GRAVITY = 9810.0


def _quad_rule():
    g = np.sqrt(0.6)
    x, w = np.array([-g, 0.0, g]), np.array([5, 8, 5]) / 9
    a, b = np.meshgrid(x, x, indexing="ij")
    return (*serendipity(a.ravel(), b.ravel()), np.outer(w, w).ravel())


def _tri_rule():
    """7-point (degree 5) rule on the unit triangle, 6-node shape functions."""
    a1, b1 = 0.059715871789770, 0.470142064105115
    a2, b2 = 0.797426985353087, 0.101286507323456
    r = np.array([1 / 3, a1, b1, b1, a2, b2, b2])
    s = np.array([1 / 3, b1, a1, b1, b2, a2, b2])
    w = np.r_[0.225, [0.132394152788506] * 3, [0.125939180544827] * 3] / 2
    t = 1 - r - s
    n = np.stack(
        [t * (2 * t - 1), r * (2 * r - 1), s * (2 * s - 1), 4 * t * r, 4 * r * s, 4 * s * t], 1
    )
    dr = np.stack([1 - 4 * t, 4 * r - 1, 0 * r, 4 * (t - r), 4 * s, -4 * s], 1)
    ds = np.stack([1 - 4 * t, 0 * r, 4 * s - 1, -4 * r, 4 * r, 4 * (t - s)], 1)
    return n, dr, ds, w


_RULES = {8: _quad_rule(), 6: _tri_rule()}


def integration_points(model: ShellModel):
    """Per element type: ``(conn (E, nn), N (g, nn), dA (E, g), normal (E, g, 3))`` for the
    quads, then the triangles (omitted when there are none); dA is the mid-surface area
    weight of each Gauss point, mm2."""
    out = []
    for conn in (model.quads, model.triangles):
        if len(conn) == 0:
            continue
        shape, d_a, d_b, weight = _RULES[conn.shape[1]]
        x = model.nodes[conn]
        t_a = np.einsum("gn,enk->egk", d_a, x)
        t_b = np.einsum("gn,enk->egk", d_b, x)
        cross = np.cross(t_a, t_b)
        jac = np.linalg.norm(cross, axis=-1)
        out.append((conn, shape, jac * weight, cross / jac[..., None]))
    return out


def element_integrals(model: ShellModel) -> tuple[np.ndarray, np.ndarray]:
    """``(normals (E, 3), dA (E, g))`` over all elements (quads first; triangles padded to the
    quad rule's point count with zero weights)."""
    blocks = integration_points(model)
    g = max(b[2].shape[1] for b in blocks)
    normals = np.concatenate([b[3].mean(axis=1) for b in blocks])
    areas = np.concatenate([np.pad(b[2], ((0, 0), (0, g - b[2].shape[1]))) for b in blocks])
    return normals, areas


def area_forces(
    model: ShellModel,
    pressure: float | np.ndarray,
    direction,
    elements: np.ndarray | None = None,
    projected: bool = False,
) -> np.ndarray:
    """(n, 3) float: consistent nodal forces of an area load, N.

    pressure : N/mm2 (1 kN/m2 = 1e-3), scalar or (E,) per element.
    direction : (3,) the load's direction (normalised here).
    elements : (E,) bool, the loaded elements (default all).
    projected : the load acts on the area projected onto the plane normal to ``direction`` and
        only on faces turned towards the load (element normal against ``direction``): snow on
        the horizontal projection (direction -z), wind on the faces it meets (direction = wind).
    """
    direction = np.asarray(direction, float)
    direction = direction / np.linalg.norm(direction)
    forces = np.zeros((len(model.nodes), 3))
    for conn, shape, weight, normal in _loaded_points(model, pressure, elements):
        if projected:
            weight = weight * np.maximum(0.0, -normal @ direction)
        nodal = weight @ shape  # (E, nn)
        np.add.at(forces, conn.ravel(), nodal.ravel()[:, None] * direction[None])
    return forces


def _loaded_points(model: ShellModel, pressure, elements: np.ndarray | None):
    """Per element type: ``(conn, N, pressure x dA (E, g), normal (E, g, 3))`` with the
    pressure ``(E,)`` or scalar, zero outside ``elements``."""
    mask = np.ones(model.n_elements, bool) if elements is None else np.asarray(elements, bool)
    pressure = np.broadcast_to(np.asarray(pressure, float), (model.n_elements,))
    if model.load_scale is not None:
        pressure = pressure * model.load_scale
    start = 0
    for conn, shape, area, normal in integration_points(model):
        sl = slice(start, start + len(conn))
        start += len(conn)
        yield conn, shape, area * (pressure[sl] * mask[sl])[:, None], normal


def normal_forces(
    model: ShellModel, pressure: np.ndarray, elements: np.ndarray | None = None
) -> np.ndarray:
    """(n, 3) float: consistent nodal forces of a pressure acting along each element's normal,
    N: ``pressure (E,)`` N/mm2, positive towards the surface (against its normal, which points
    out of the shell: up on a roof), as wind pressure is signed."""
    forces = np.zeros((len(model.nodes), 3))
    for conn, shape, weight, normal in _loaded_points(model, pressure, elements):
        nodal = np.einsum("eg,gn,egk->enk", weight, shape, -normal)
        np.add.at(forces, conn.ravel(), nodal.reshape(-1, 3))
    return forces


def gravity_forces(model: ShellModel, acceleration=(0.0, 0.0, -GRAVITY)) -> np.ndarray:
    """(n, 3) float: consistent nodal self-weight of the elements (as ``*DLOAD GRAV`` applies
    it to the mid-surface) plus the lumped masses, N."""
    acceleration = np.asarray(acceleration, float)
    g = np.linalg.norm(acceleration)
    # kg/mm3 * mm * mm/s2 = kg/(mm s2) per mm2 ... 1 kg mm/s2 = 1e-3 N
    per_area = model.density * model.thickness * g * 1e-3
    # the elements' own mass: no load scaling (that spreads area loads over a joint's strip)
    forces = area_forces(model.replace(load_scale=None), per_area, acceleration)
    if model.lumped_mass is not None:
        forces += model.lumped_mass[:, None] * acceleration[None] * 1e-3
    return forces


def edge_forces(nodes: np.ndarray, chain: np.ndarray, traction) -> np.ndarray:
    """(n, 3) float: consistent nodal forces of a line load ``traction (3,)`` N/mm along a chain
    of quadratic element edges ``chain (2k+1,)`` node ids (end, mid, end, mid, ..., end)."""
    traction = np.asarray(traction, float)
    chain = np.asarray(chain)
    seg = np.stack([chain[0:-1:2], chain[1::2], chain[2::2]], axis=1)  # (k, 3)
    g = np.sqrt(0.6)
    xi, w = np.array([-g, 0.0, g]), np.array([5, 8, 5]) / 9
    shape = np.stack([xi * (xi - 1) / 2, 1 - xi**2, xi * (xi + 1) / 2], 1)  # (3 pts, 3 nodes)
    dshape = np.stack([xi - 0.5, -2 * xi, xi + 0.5], 1)
    x = nodes[seg]  # (k, 3, 3)
    jac = np.linalg.norm(np.einsum("gn,knc->kgc", dshape, x), axis=-1)  # (k, g)
    nodal = (jac * w) @ shape  # (k, 3 nodes)
    forces = np.zeros((len(nodes), 3))
    np.add.at(forces, seg.ravel(), nodal.ravel()[:, None] * traction[None])
    return forces


def wind_exposed(model: ShellModel, elements: np.ndarray, direction) -> np.ndarray:
    """(E,) bool: the elements among ``elements`` that the wind blowing along ``direction``
    meets first: faces turned towards it (normal against the wind) whose centre has no other
    loaded element upwind of it. The shading test projects along the wind: a centre is shaded
    when it falls inside the projection of another element's triangle (corners and mid-sides)
    that lies further upwind.
    """
    from scipy.spatial import cKDTree

    direction = np.asarray(direction, float)
    direction = direction / np.linalg.norm(direction)
    elements = np.asarray(elements, bool)
    normals, _ = element_integrals(model)
    nq = len(model.quads)
    facing = elements & (normals @ direction < 0)
    # the shading surface: every loaded element as flat triangles through corners and mid-sides
    quad_ids = np.nonzero(elements[:nq])[0]
    tri_ids = np.nonzero(elements[nq:])[0]
    q, t = model.quads[quad_ids], model.triangles[tri_ids]
    face_blocks = [
        q[:, [0, 4, 7]],
        q[:, [4, 1, 5]],
        q[:, [5, 2, 6]],
        q[:, [6, 3, 7]],
        q[:, [4, 5, 7]],
        q[:, [5, 6, 7]],
        t[:, [0, 3, 5]],
        t[:, [3, 1, 4]],
        t[:, [4, 2, 5]],
        t[:, [3, 4, 5]],
    ]
    owner = np.concatenate([np.tile(quad_ids, 6), np.tile(tri_ids + nq, 4)])
    faces = np.concatenate(face_blocks)
    # frame: (u, v) across the wind, w along it
    helper = np.eye(3)[np.argmin(np.abs(direction))]
    u = np.cross(direction, helper)
    u /= np.linalg.norm(u)
    v = np.cross(direction, u)
    frame = np.stack([u, v, direction], 1)
    corners = model.nodes[faces] @ frame  # (T, 3, 3)
    centres = (
        np.concatenate(
            [model.nodes[model.quads].mean(axis=1), model.nodes[model.triangles].mean(axis=1)]
        )
        @ frame
    )
    candidates = np.nonzero(facing)[0]
    exposed = np.zeros(model.n_elements, bool)
    if len(candidates) == 0 or len(faces) == 0:
        return exposed
    mid = corners[:, :, :2].mean(axis=1)
    reach = float(np.linalg.norm(corners[:, :, :2] - mid[:, None], axis=-1).max())
    pairs = cKDTree(centres[candidates, :2]).query_ball_tree(cKDTree(mid), reach)
    ray = np.repeat(candidates, [len(p) for p in pairs])
    tri = np.concatenate([np.asarray(p, int) for p in pairs])
    keep = owner[tri] != ray
    ray, tri = ray[keep], tri[keep]
    a, b, c = corners[tri, 0], corners[tri, 1], corners[tri, 2]
    p = centres[ray]
    e1, e2, r = b[:, :2] - a[:, :2], c[:, :2] - a[:, :2], p[:, :2] - a[:, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    det = np.where(ok, det, 1.0)
    s1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
    s2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    inside = ok & (s1 >= 0) & (s2 >= 0) & (s1 + s2 <= 1)
    depth = a[:, 2] + s1 * (b[:, 2] - a[:, 2]) + s2 * (c[:, 2] - a[:, 2])
    size = float(np.ptp(model.nodes, axis=0).max())
    upwind = depth < p[:, 2] - 1e-6 * size
    shaded = np.zeros(model.n_elements, bool)
    shaded[ray[inside & upwind]] = True
    exposed[candidates] = ~shaded[candidates]
    return exposed
