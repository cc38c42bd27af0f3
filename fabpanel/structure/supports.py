"""Where the shell is held, and what each support carries.

**Supports at the anchorages.** A sandwich shell stands on its boundary ribs: the rib at a
support is the base plate, bolted to the foundation along its middle. The model restrains only
those anchor-bolt nodes: the boundary ribs' nodes at mid-depth (between the two sheets, one at
every element edge along the rib), translations only (``support_fixity = "pinned"``: the rib may
turn about its bolt line), or every node of those ribs (``"fixed"``: two rows of bolts clamp
it). Which ribs: ``supports = "lowest"`` those whose whole design edge lies within
``support_band`` of the lowest boundary point (the springing lines of a vault, the ring of a
dome; when none does, those reaching into the band; the band raised until they surround the
shell's centre in plan, :func:`surrounding_band`), ``"boundary"`` every
boundary rib, ``"openings"`` the ribs round the openings (support rims), ``"points"`` the boundary ribs'
anchor nodes within ``support_radius`` of each of ``support_points`` (columns),
``"ranges"`` the boundary ribs between the two points of each of ``support_ranges``, along
the boundary (the shorter way round). A shell without ribs
(``buildup = "cladding"``) is held at its sheet's edge nodes along those sides.

**Supports.** The restrained nodes fall into supports: the runs of them joined through their
elements (a vault's two springing lines are two supports), named ``R1``, ``R2``, ... in the
order of their centroids (x, then y). Each support's reaction is the sum of CalculiX's RF over
its nodes less the load applied straight to them (CalculiX counts that in RF), and its moment
about the support's centroid; combinations combine them linearly.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import GeometryError, Issue
from .mesh import ShellModel

#: columns of ``structure/reactions.csv`` (a contract: foundation engineers' scripts read it,
#: by name or by position, so nothing goes before or between them)
REACTION_COLUMNS = (
    "support",
    "case",
    "fx_kN",
    "fy_kN",
    "fz_kN",
    "mx_kNm",
    "my_kNm",
    "mz_kNm",
)
#: columns of ``structure/supports.csv``: where each support is, the point its moments are about
SUPPORT_COLUMNS = ("support", "x_mm", "y_mm", "z_mm")
#: the supports' plan hull is grown by this share of the shell's plan diameter before the
#: centre of mass is looked for in it (a vault on its two springing lines holds it well inside)
CANTILEVER_MARGIN = 0.05


def layout_boundary_loops(
    quads: np.ndarray, neighbours: np.ndarray, vertices: np.ndarray
) -> list[np.ndarray]:
    """Boundary loops of a quad layout as arrays of (panel, side) pairs, the loop with the
    largest area projected on the best-fitting plane first (the outer boundary)."""
    boundary = np.argwhere(neighbours < 0)
    start = {int(quads[p, s]): (int(p), int(s)) for p, s in boundary}
    loops, seen = [], set()
    for p, s in boundary:
        if (p, s) in seen:
            continue
        loop, key = [], (int(p), int(s))
        while key not in seen:
            seen.add(key)
            loop.append(key)
            end = int(quads[key[0], (key[1] + 1) % 4])
            if end not in start:
                break
            key = start[end]
        loops.append(np.array(loop))
    centre = vertices.mean(axis=0)
    _, _, vt = np.linalg.svd(vertices - centre, full_matrices=False)

    def area(loop):
        pts = (vertices[quads[loop[:, 0], loop[:, 1]]] - centre) @ vt[:2].T
        return abs(
            0.5 * np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
        )

    return sorted(loops, key=area, reverse=True)


def rib_elements_of_sides(shell: ShellModel, sides: np.ndarray) -> np.ndarray:
    """(E,) bool: the rib elements on the given (panel, side) pairs."""
    if shell.panel is None or shell.side is None:
        raise ValueError("the shell model has no panel labels: it was not made from panels")
    key = set(map(tuple, np.asarray(sides).tolist()))
    return np.array([(p, s) in key for p, s in zip(shell.panel[:, 0], shell.side)])


def anchor_nodes(shell: ShellModel, ribs: np.ndarray, fixity: str) -> np.ndarray:
    """(s,) int: the nodes restrained on the rib elements ``ribs`` (E,) bool: their nodes
    between the sheets (``pinned``), or all their nodes (``fixed``)."""
    quads = shell.quads[ribs[: len(shell.quads)]]
    nodes = np.unique(quads)
    if fixity == "fixed":
        return nodes
    assert shell.side is not None
    sheets = shell.side[: len(shell.quads)] < 0
    on_sheets = np.zeros(len(shell.nodes), bool)
    on_sheets[np.unique(shell.quads[sheets])] = True
    return nodes[~on_sheets[nodes]]


def lowest_sides(developed, sides: np.ndarray, band: float) -> np.ndarray:
    """The boundary ``sides`` (k, 2) whose design edge (its two corners, which lie on the
    design boundary) lies within ``band`` mm of the lowest boundary corner; when no side lies
    wholly within it, those that reach into it.

    On the design, not the developed panels: a level springing line is level there, while
    its anchor nodes (half the core along the sloping normal) are not, and a doubly curved
    shell's developed sheets leave the design by up to ``[develop] deviation_tolerance``
    (20 mm on a 10 x 7 m dome whose rim is level, so a 10 mm band on the developed samples
    held one 1 m stretch of its rim and made the shell a cantilever)."""
    layout = developed.layout
    quads = np.asarray(layout.quads)
    z = np.asarray(layout.vertices, float)[:, 2]
    sides = np.asarray(sides)
    ends = z[np.stack([quads[sides[:, 0], sides[:, 1]], quads[sides[:, 0], (sides[:, 1] + 1) % 4]])]
    lowest = float(ends.min())
    whole = ends.max(axis=0) <= lowest + band
    if not whole.any():
        whole = ends.min(axis=0) <= lowest + band
    return sides[whole]


def surrounding_band(developed, sides: np.ndarray, band: float) -> float:
    """The band (mm) for :func:`lowest_sides` from ``band`` up: the smallest at which the
    chosen sides' corners, in plan, surround the design's centre of area (their hull grown by
    ``CANTILEVER_MARGIN`` of the plan diameter), so that the shell is not checked as a
    cantilever from one low corner; ``band`` where it already does, the whole rise where none
    does. A shell stands on its low edges: a saddle on its two low corners, a canopy sloping
    to one end on that end and the next lowest stretches round to the other side (the
    engineer names the real ones with ``"ranges"`` or ``"points"``)."""
    from shapely.geometry import MultiPoint, Point

    layout = developed.layout
    quads = np.asarray(layout.quads)
    vertices = np.asarray(layout.vertices, float)
    corners = vertices[quads]  # (m, 4, 3)
    # each panel's plan area as two triangles, its centre the mean of its corners
    a = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    b = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0])
    area = np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1)
    centre = Point(*(corners.mean(axis=1)[:, :2] * area[:, None]).sum(axis=0) / area.sum())
    diameter = float(np.linalg.norm(np.ptp(vertices[:, :2], axis=0)))
    sides = np.asarray(sides)
    ends = vertices[
        np.stack([quads[sides[:, 0], sides[:, 1]], quads[sides[:, 0], (sides[:, 1] + 1) % 4]])
    ]
    lowest = float(ends[..., 2].min())
    top = ends[..., 2].max(axis=0) - lowest  # (k,) each side's band to be taken whole
    for height in [band, *np.unique(top[top > band])]:
        chosen = lowest_sides(developed, sides, float(height))
        points = vertices[quads[chosen[:, 0], chosen[:, 1]], :2]
        points = np.concatenate([points, vertices[quads[chosen[:, 0], (chosen[:, 1] + 1) % 4], :2]])
        hull = MultiPoint([tuple(p) for p in points]).convex_hull
        if hull.buffer(CANTILEVER_MARGIN * diameter).contains(centre):
            return float(height)
    return float(top.max())


def near_points(nodes: np.ndarray, candidates: np.ndarray, points: np.ndarray, radius: float):
    """(s,) int: the ``candidates`` (node ids) within ``radius`` mm of any of ``points``
    (p, 3); a :class:`GeometryError` for a point with none (it is not on a supported
    boundary)."""
    distance = np.linalg.norm(nodes[candidates][:, None, :] - points[None, :, :], axis=2)
    for k in np.flatnonzero((distance > radius).all(axis=0)):
        raise GeometryError(
            f"[structure] support_points {k + 1} lies {float(distance[:, k].min()):.0f} mm from "
            f"the nearest boundary rib's anchor node, beyond support_radius "
            f"({radius:g} mm): put the point on the boundary or raise support_radius"
        )
    return candidates[(distance <= radius).any(axis=1)]


def range_sides(developed, loops: list[np.ndarray], pairs: np.ndarray) -> np.ndarray:
    """(k, 2) int: the boundary (panel, side) pairs between the two points of each pair
    (``pairs`` (r, 2, 3), mm, local), along the loop nearest both, the shorter way round: each
    point is placed on the loop at its nearest design-edge sample, and a side belongs to the
    range where more than half of it lies between the two (a point at a corner of the
    outline takes neither side of the corner by halves)."""
    chosen = []
    for start, end in pairs:
        found = [_loop_positions(developed, loop, (start, end)) for loop in loops]
        _, loop, bounds, (a, b) = min(found, key=lambda f: f[0])
        total = bounds[-1]
        forward = (b - a) % total
        if forward > total / 2:  # the shorter way round
            a, forward = b, total - forward
        middle = 0.5 * (bounds[:-1] + bounds[1:])
        inside = (middle - a) % total < forward
        chosen.append(loop[inside])
    return np.unique(np.concatenate(chosen), axis=0)


def _loop_positions(developed, loop: np.ndarray, points) -> tuple:
    """How far the points lie from the loop's design edge (summed), the loop, the arc
    lengths at its sides' ends (len + 1,), and the points' arc-length positions."""
    samples = [np.asarray(developed.side_samples(p, s)) for p, s in loop]
    lengths = np.array([np.linalg.norm(np.diff(x, axis=0), axis=1).sum() for x in samples])
    bounds = np.concatenate([[0.0], np.cumsum(lengths)])
    along = np.concatenate(
        [
            bounds[k]
            + np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
            for k, x in enumerate(samples)
        ]
    )
    polyline = np.concatenate(samples)
    miss, positions = 0.0, []
    for point in points:
        distance = np.linalg.norm(polyline - point, axis=1)
        nearest = int(np.argmin(distance))
        miss += float(distance[nearest])
        positions.append(float(along[nearest]))
    return miss, loop, bounds, positions


def check_supports(nodes: np.ndarray, supports: np.ndarray, what: str) -> None:
    """Raise :class:`GeometryError` for fewer than three or collinear support nodes (the shell
    would turn about them; CalculiX would stop on a singular matrix)."""
    if len(supports) < 3:
        raise GeometryError(
            f"{what} selects {len(supports)} node(s); pinned supports need at "
            f"least three nodes not in a line: raise [structure] support_band "
            f"or choose another [structure] supports"
        )
    pts = nodes[supports] - nodes[supports].mean(axis=0)
    sv = np.linalg.svd(pts, compute_uv=False)
    if sv[1] < 1e-6 * max(sv[0], 1e-9):
        raise GeometryError(
            f"{what} selects nodes on one line; the shell could turn about it: "
            f"raise [structure] support_band or choose another [structure] "
            f"supports"
        )


def cantilever_issues(shell: ShellModel, what: str) -> list[Issue]:
    """A warning when the shell's centre of mass (in plan) lies outside the plan hull of its
    supported nodes: the shell is carried as a cantilever from them. Usually the supports
    chosen do not say where the shell stands (``"lowest"`` on a shape whose lowest point is
    one corner), and every check then fails on bending the design never meant; the checks'
    own messages (a stronger bolt, a thicker sheet) do not point at the cause."""
    from shapely.geometry import MultiPoint, Point

    plan = shell.nodes[:, :2]
    centre = plan.mean(axis=0)  # the nodes lie about evenly over the shell
    supported = plan[shell.supports]
    diameter = float(np.linalg.norm(np.ptp(plan, axis=0)))
    hull = MultiPoint([tuple(p) for p in supported]).convex_hull
    if hull.buffer(CANTILEVER_MARGIN * diameter).contains(Point(*centre)):
        return []
    extent = np.ptp(supported, axis=0) / 1000.0
    reach = float(hull.distance(Point(*centre))) / 1000.0
    return [
        Issue(
            "supports-one-sided",
            f"{what} holds {len(shell.supports)} nodes within {extent[0]:.1f} m x "
            f"{extent[1]:.1f} m of plan, all to one side of the shell's centre of mass "
            f"({reach:.1f} m away in plan): the shell is checked as a cantilever from them. "
            f"If it stands elsewhere too, name its supports ([structure] supports = "
            f'"ranges" or "points", or a wider support_band)',
        )
    ]


# --------------------------------------------------------------------------------------------
# supports and their reactions
# --------------------------------------------------------------------------------------------
def support_regions(shell: ShellModel) -> tuple[np.ndarray, np.ndarray]:
    """The support of each supported node ``(s,)`` int (0-based, ordered by centroid) in the
    order of ``shell.supports``, and the supports' centroids ``(k, 3)``: the supported nodes
    joined by elements or by a bolted joint's springs."""
    supports = np.asarray(shell.supports)
    index = np.full(len(shell.nodes), -1)
    index[supports] = np.arange(len(supports))
    conn = np.concatenate([shell.quads.reshape(-1), shell.triangles.reshape(-1)])
    owner = np.concatenate(
        [
            np.repeat(np.arange(len(shell.quads)), shell.quads.shape[1]),
            np.repeat(np.arange(len(shell.triangles)) + len(shell.quads), 6)
            if len(shell.triangles)
            else np.zeros(0, int),
        ]
    )
    keep = index[conn] >= 0
    incidence = coo_matrix(
        (np.ones(int(keep.sum())), (owner[keep], index[conn[keep]])),
        shape=(shell.n_elements, len(supports)),
    ).tocsr()
    linked = incidence.T @ incidence
    if shell.springs is not None and len(shell.springs.nodes):
        # a bolted joint's springs tie the two panels' ribs: one support runs across it
        a, b = index[shell.springs.nodes[:, 0]], index[shell.springs.nodes[:, 1]]
        both = (a >= 0) & (b >= 0)
        tied = coo_matrix(
            (np.ones(int(both.sum())), (a[both], b[both])), shape=(len(supports),) * 2
        )
        linked = linked + tied + tied.T
    _, labels = connected_components(linked, directed=False)
    centroids = np.array(
        [shell.nodes[supports[labels == k]].mean(axis=0) for k in range(labels.max() + 1)]
    )
    order = np.lexsort((np.round(centroids[:, 1], 3), np.round(centroids[:, 0], 3)))
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels], centroids[order]


@dataclass(frozen=True)
class SupportReactions:
    """The reactions of every support: ``force (cases, k, 3)`` N and ``moment (cases, k, 3)``
    N mm about each support's ``centroid (k, 3)`` (mm, in the design's own frame: where the
    foundation engineer places the support), one row per case in ``cases``."""

    names: tuple[str, ...]
    centroids: np.ndarray
    cases: tuple[str, ...]
    force: np.ndarray
    moment: np.ndarray

    def combined(self, names: list[str], factors: np.ndarray) -> SupportReactions:
        """The same supports under combinations: ``factors (K, cases)``."""
        return SupportReactions(
            self.names,
            self.centroids,
            tuple(names),
            np.einsum("kc,csj->ksj", factors, self.force),
            np.einsum("kc,csj->ksj", factors, self.moment),
        )

    def rows(self) -> list[list[str]]:
        """``REACTION_COLUMNS`` rows: per support, per case; kN and kN m."""
        out = []
        for s, name in enumerate(self.names):
            for c, case in enumerate(self.cases):
                values = np.r_[self.force[c, s] / 1e3, self.moment[c, s] / 1e6]
                # + 0.0 turns a rounded -0.0 into 0.0: no "-0.000"
                out.append([name, case, *(f"{round(float(v), 3) + 0.0:.3f}" for v in values)])
        return out

    def places(self) -> list[list[str]]:
        """``SUPPORT_COLUMNS`` rows: each support's centroid, mm."""
        return [
            [name, *(f"{round(float(v), 1) + 0.0:.1f}" for v in self.centroids[s])]
            for s, name in enumerate(self.names)
        ]


def support_reactions(
    shell: ShellModel,
    cases: list[str],
    node_forces: list[tuple[np.ndarray, np.ndarray]],
    applied: list[np.ndarray],
    origin: np.ndarray,
) -> SupportReactions:
    """Each support's reaction per case from CalculiX's RF per supported node (``node_forces``:
    ids (model index + 1) and RF per case) less the load ``applied (n, 3)`` on those nodes;
    ``origin``: the design frame's origin in the model's local frame's terms (added to the
    centroids)."""
    supports = np.asarray(shell.supports)
    labels, centroids = support_regions(shell)
    k = len(centroids)
    force = np.zeros((len(cases), k, 3))
    moment = np.zeros((len(cases), k, 3))
    for c, ((ids, rf), load) in enumerate(zip(node_forces, applied, strict=True)):
        nodes = ids - 1
        at = np.searchsorted(supports, nodes)
        if not np.array_equal(supports[np.minimum(at, len(supports) - 1)], nodes):
            raise ValueError("CalculiX printed reactions for nodes that are not supported")
        reaction = rf - load[nodes]
        for r in range(k):
            mine = labels[at] == r
            force[c, r] = reaction[mine].sum(axis=0)
            moment[c, r] = np.cross(shell.nodes[nodes[mine]] - centroids[r], reaction[mine]).sum(0)
    names = tuple(f"R{r + 1}" for r in range(k))
    return SupportReactions(names, centroids + origin, tuple(cases), force, moment)


def write_reactions_csv(folder: Path, *tables: SupportReactions) -> list[Path]:
    """``reactions.csv`` (``REACTION_COLUMNS``: the characteristic cases then the combinations)
    and ``supports.csv`` (``SUPPORT_COLUMNS``: where the moments are taken about) in ``folder``."""
    reactions, places = folder / "reactions.csv", folder / "supports.csv"
    with open(reactions, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(REACTION_COLUMNS)
        for table in tables:
            writer.writerows(table.rows())
    with open(places, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(SUPPORT_COLUMNS)
        writer.writerows(tables[0].places())
    return [reactions, places]
