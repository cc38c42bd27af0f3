"""Corner stiffeners in the shell model: one S8 plate per built stiffener, tied to its ribs and
sheets.

A corner stiffener (:func:`fabpanel.model.plates.stiffener`) is a flat plate across a panel's
corner, its ends welded to the two ribs at ``stiffener_offset`` from the corner along each side,
standing between the sheets. It braces the corner: it keeps the two ribs' angle and carries
part of the shear round the corner. Its ends lie between the nodes of the structured rib mesh
(a panel side has 1-4 elements), so the plate gets nodes of its own and each is tied to the
part it is welded to by a linear constraint (``*EQUATION`` on the three translations): its
displacement is that element's, interpolated by the element's own S8R shape functions at the
node. The ends' nodes (top, mid-depth, bottom) follow the two ribs, the middles of the top and
bottom edges the two sheets (with the ends, the quadratic edges lie on the sheets all along).
The rotations are not tied, so the weld lines act as hinges, which leaves out the little
bending the fillet welds pass on. The plate runs from the top sheet's mid-surface to the
bottom one's, as the ribs do, and its group's density is scaled so that the elements weigh
what the stiffener parts weigh. (Tied at its ends alone, a plate with free top and bottom
edges buckled first in the vault example at one element per side: a mode the welded plate
has not.) Each plate is one fully integrated S8 element: as an S8R, with every translation
tied, its free rotations kept a zero-energy mode that buckled first (0.62 on a hyperbolic
paraboloid, where the shell's own first mode is at 5.59).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from ..errors import GeometryError
from .shapes import serendipity

#: Gauss-Newton iterations of the inverse S8R map (a flat element converges in two or three)
INVERSE_ITERATIONS = 12


@dataclass(frozen=True)
class Ties:
    """Nodes whose translations follow other nodes' linearly: ``u[nodes[k]] =
    sum_j weights[k, j] u[masters[k, j]]`` for each of the three translations (``*EQUATION``).

    nodes : (k,) int; masters : (k, 8) int; weights : (k, 8) float, each row summing to 1.
    """

    nodes: np.ndarray
    masters: np.ndarray
    weights: np.ndarray


def inverse_map(
    element_nodes: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each of ``m`` S8R elements (``(m, 8, 3)`` node positions) the point nearest the
    matching one of ``points`` (m, 3): its shape-function weights (m, 8), the point itself
    (m, 3) and its distance (m,), mm. Gauss-Newton on the local coordinates, all pairs at once,
    clipped to the element."""
    local = np.zeros((len(points), 2))
    for _ in range(INVERSE_ITERATIONS):
        n, d_xi, d_eta = serendipity(local[:, 0], local[:, 1])
        residual = points - np.einsum("mk,mkd->md", n, element_nodes)
        jacobian = np.stack(
            [
                np.einsum("mk,mkd->md", d_xi, element_nodes),
                np.einsum("mk,mkd->md", d_eta, element_nodes),
            ],
            axis=2,
        )  # (m, 3, 2)
        # least squares, minimum norm where an element is degenerate (as lstsq per point was)
        step = np.linalg.pinv(jacobian) @ residual[..., None]
        local = np.clip(local + step[..., 0], -1.0, 1.0)
        if not len(step) or np.abs(step).max() < 1e-10:
            break
    n, _, _ = serendipity(local[:, 0], local[:, 1])
    nearest = np.einsum("mk,mkd->md", n, element_nodes)
    return n, nearest, np.linalg.norm(points - nearest, axis=1)


def _along(line: np.ndarray, distance: float) -> tuple[int, float]:
    """Where ``distance`` along the polyline of station points ``line`` (k, 3) falls: the
    station interval and the fraction along it (the last interval beyond the end)."""
    steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
    ends = np.cumsum(steps)
    a = min(int(np.searchsorted(ends, distance)), len(steps) - 1)
    start = ends[a] - steps[a]
    return a, float(np.clip((distance - start) / max(steps[a], 1e-300), 0.0, 1.0))


def _corner_stations(model, neighbours: np.ndarray, p: int, side: int, at_start: bool):
    """(n + 1, 3) node ids (top, mid, bottom) of the rib along ``side`` of panel ``p``, from the
    corner (the side's start or end) inwards; the neighbour's rib where the side has none of
    its own (a rigid model's shared rib), None on a side without rib nodes."""
    stations = model.rib_stations[p, side]
    if stations[0, 0] < 0:
        other = int(neighbours[p, side])
        if other < 0:
            return None
        back = np.flatnonzero(neighbours[other] == p)
        if not len(back):
            return None
        stations, at_start = model.rib_stations[other, int(back[0])], not at_start
        if stations[0, 0] < 0:
            return None
    return stations if at_start else stations[::-1]


def _rib_element_index(model, rib_groups: np.ndarray) -> dict[frozenset, int]:
    """Rib elements by each pair of their corner nodes."""
    found: dict[frozenset, int] = {}
    for e in np.flatnonzero(np.isin(model.group[: len(model.quads)], rib_groups)):
        corners = model.quads[e, :4]
        for i in range(4):
            found[frozenset((int(corners[i]), int(corners[(i + 1) % 4])))] = int(e)
    return found


def _end_query(model, stations, offset: float, index) -> tuple[np.ndarray, int]:
    """The stiffener end's three points (top, mid, bottom) ``offset`` along the rib from the
    corner, on the chord between stations (:func:`inverse_map` moves them onto the rib
    element's curved surface), and that rib element."""
    top_line = model.nodes[stations[:, 0]]
    a, f = _along(top_line, offset)
    chord = (1 - f) * model.nodes[stations[a]] + f * model.nodes[stations[a + 1]]  # (3, 3)
    return chord, index[frozenset((int(stations[a, 0]), int(stations[a + 1, 0])))]


def _nearest_of(model, candidates: list[np.ndarray], points: np.ndarray):
    """For each point (q, 3) the nearest point of its candidate elements (the first of equal
    ones): ``(weights (q, 8), that point (q, 3), the element (q,))``."""
    if any(not len(c) for c in candidates):
        raise GeometryError(
            "a corner stiffener's panel has no top or bottom sheet elements to tie it to"
        )
    owner = np.repeat(np.arange(len(points)), [len(c) for c in candidates])
    elements = np.concatenate(candidates).astype(int)
    w, nearest, distance = inverse_map(model.nodes[model.quads[elements]], points[owner])
    order = np.lexsort((np.arange(len(owner)), distance, owner))
    first = order[np.searchsorted(owner[order], np.arange(len(points)))]
    return w[first], nearest[first], elements[first]


def stiffener_plates(model, neighbours: np.ndarray, corners: list[tuple[int, int]], offset: float):
    """The S8 plates of the stiffeners at ``corners`` ((panel, corner) pairs): ``(nodes (s*8,
    3), quads (s, 8) numbered from len(model.nodes), made (len(corners),) bool, ties)`` (see the
    module docstring). Corner ``c`` lies between sides ``c - 1`` and ``c`` of its panel; a
    corner without rib nodes on both sides gets no plate (``made`` False)."""
    names = [g.name for g in model.groups]
    groups = np.array([i for i, name in enumerate(names) if name in ("RIB", "RIB2")])
    index = _rib_element_index(model, groups)
    nq = len(model.quads)
    own = model.panel[:nq, 0]
    sheet_group = model.group[:nq]
    made, chords, ribs, panels = [], [], [], []
    for p, c in corners:
        after = _corner_stations(model, neighbours, p, c, True)
        before = _corner_stations(model, neighbours, p, (c - 1) % 4, False)
        made.append(after is not None and before is not None)
        if made[-1]:
            for stations in (before, after):  # end A, end B
                chord, e = _end_query(model, stations, offset, index)
                chords.append(chord)
                ribs.append(e)
            panels.append(p)
    s = len(panels)
    if not s:
        return np.zeros((0, 3)), np.zeros((0, 8), int), np.array(made, bool), _no_ties()
    rib_elements = np.repeat(np.array(ribs, int), 3)
    w_end, end, _ = inverse_map(
        model.nodes[model.quads[rib_elements]], np.concatenate(chords).reshape(-1, 3)
    )
    w_end, end = w_end.reshape(s, 2, 3, 8), end.reshape(s, 2, 3, 3)
    m_end = model.quads[rib_elements].reshape(s, 2, 3, 8)
    # the top and bottom edges' middles on the sheets the plate is welded to
    sheets = [names.index("TOP"), names.index("BOT")]
    candidates = [np.flatnonzero((own == p) & (sheet_group == g)) for p in panels for g in sheets]
    middles = 0.5 * (end[:, 0, [0, 2]] + end[:, 1, [0, 2]])  # (s, 2, 3): top, bottom
    w_mid, mid, e_mid = _nearest_of(model, candidates, middles.reshape(-1, 3))
    w_mid, mid = w_mid.reshape(s, 2, 8), mid.reshape(s, 2, 3)
    m_mid = model.quads[e_mid].reshape(s, 2, 8)
    # corners A top, B top, B bottom, A bottom; mid-sides top, B mid, bottom, A mid
    ends = ((0, 0), (1, 0), (1, 2), (0, 2))
    nodes = np.stack(
        [end[:, a, r] for a, r in ends] + [mid[:, 0], end[:, 1, 1], mid[:, 1], end[:, 0, 1]],
        axis=1,
    )
    masters = np.stack(
        [m_end[:, a, r] for a, r in ends]
        + [m_mid[:, 0], m_end[:, 1, 1], m_mid[:, 1], m_end[:, 0, 1]],
        axis=1,
    )
    weights = np.stack(
        [w_end[:, a, r] for a, r in ends]
        + [w_mid[:, 0], w_end[:, 1, 1], w_mid[:, 1], w_end[:, 0, 1]],
        axis=1,
    )
    first = len(model.nodes)
    quads = first + np.arange(8 * s).reshape(s, 8)
    ties = Ties(quads.ravel(), masters.reshape(-1, 8), weights.reshape(-1, 8))
    return nodes.reshape(-1, 3), quads, np.array(made, bool), ties


def _no_ties() -> Ties:
    return Ties(np.zeros(0, int), np.zeros((0, 8), int), np.zeros((0, 8)))


def with_stiffeners(model, developed, parts, settings) -> tuple:
    """The model with a plate per stiffener part (:func:`stiffener_plates`) in a group ``STF`` whose
    density gives the parts' mass, and the stiffener parts that got none (their mass is lumped
    by the caller)."""
    stiffeners = [p for p in parts if p.kind == "stiffener"]
    if not stiffeners:
        return model, []
    index = {pid: i for i, pid in enumerate(developed.panel_ids)}
    corners = [(index[p.panel_id], int(p.id.rsplit("-", 1)[-1])) for p in stiffeners]
    neighbours = np.asarray(developed.layout.side_neighbours)
    nodes, quads, made, ties = stiffener_plates(
        model, neighbours, corners, settings.stiffener_offset
    )
    if not len(quads):
        return model, stiffeners
    nq, g = len(model.quads), len(model.groups)
    panels = np.array([c[0] for c, m in zip(corners, made) if m])

    def inserted(values, new):
        return None if values is None else np.insert(values, nq, new, axis=0)

    stiffened = model.replace(
        nodes=np.concatenate([model.nodes, nodes]),
        quads=np.concatenate([model.quads, quads]),
        group=inserted(model.group, np.full(len(quads), g)),
        # a group like the others (its class is the mesh's ShellGroup)
        groups=(
            *model.groups,
            replace(model.groups[0], name="STF", thickness=settings.t_stf, element="S8"),
        ),
        panel=inserted(model.panel, np.stack([panels, np.full(len(panels), -1)], axis=1)),
        side=inserted(model.side, np.full(len(quads), -1)),
        load_scale=inserted(model.load_scale, np.ones(len(quads))),
        ties=ties,
    )
    area = float(stiffened.element_areas()[nq : nq + len(quads)].sum())
    mass = sum(p.mass for p, m in zip(stiffeners, made) if m)
    factor = mass / (settings.material.density * settings.t_stf * area)
    groups = list(stiffened.groups)
    groups[g] = replace(groups[g], density_factor=factor)
    left = [p for p, m in zip(stiffeners, made) if not m]
    return stiffened.replace(groups=tuple(groups)), left


def stiffener_masses(model, developed, parts, grid, nrm, settings) -> np.ndarray | None:
    """(n,) kg: the mass of every stiffener part in ``parts`` on its panel's corner line (top
    1/6, mid 2/3, bottom 1/6); ``None`` without any."""
    stiffeners = [p for p in parts if p.kind == "stiffener"]
    if not stiffeners:
        return None
    index = {pid: i for i, pid in enumerate(developed.panel_ids)}
    q = grid.shape[1]
    corner_ij = [(0, 0), (q - 1, 0), (q - 1, q - 1), (0, q - 1)]
    off = settings.offsets
    top_mid = off["top_outer"] - settings.t_top / 2
    bot_mid = off["bottom_upper"] - settings.t_bot / 2
    points, weights = [], []
    for part in stiffeners:
        corner = int(part.id.rsplit("-", 1)[-1])
        i, j = corner_ij[corner]
        p = index[part.panel_id]
        g, nv = grid[p, i, j], nrm[p, i, j]
        for depth, share in ((top_mid, 1 / 6), ((top_mid + bot_mid) / 2, 2 / 3), (bot_mid, 1 / 6)):
            points.append(g + depth * nv)
            weights.append(share * part.mass)
    _, hit = cKDTree(model.nodes).query(np.array(points))
    lumped = np.zeros(len(model.nodes))
    np.add.at(lumped, hit, weights)
    return lumped
