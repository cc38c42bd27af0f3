"""Coarse quad decomposition of a planar domain with holes along its medial axis ("skeleton").

Method: Tam & Armstrong (1991) medial-axis subdivision, as used by Oval et al., *Topology finding
of structural patterns* (AAG 2018) and Oval's thesis ch. 4; our own implementation of the recipe in
shared/notes/quadmesh.md §6:

1. validate and orient the loops, resample them (corners kept), conforming Delaunay of the
   samples (:mod:`.skeleton_input`);
2. cluster adjacent triangles with coincident circumcentres (cocircular samples) into one skeleton
   node; node type = number of interior chords (1 terminal, 2 sleeve, >= 3 junction);
3. prune terminal branches: a branch ending at a convex corner is removed but still counts at its
   junction ("corner port"); any other terminal branch is noise and demotes its junction;
4. graft every junction to one boundary sample between each pair of consecutive ports;
5. corrections: reflex corners, branches turning more than 90 degrees, >= 3 split points a loop;
6. patches = faces of the graph (boundary + live skeleton + grafts). They are found without
   angles: the triangulation is refined into small faces around every node whose adjacency is
   known by construction, and faces are merged across every edge that is not kept;
7. if every patch is a quad (and no two share their vertices) they are the layout; otherwise one
   global midpoint subdivision turns every k-sided patch into k quads (Catmull-Clark topology).

Vertices are integer ids throughout; coordinates are never compared.
"""

from __future__ import annotations

import logging
import math
from collections import defaultdict

import numpy as np
from scipy.spatial import ConvexHull
from shapely.geometry import Polygon

from ..errors import GeometryError
from .coarse import CoarseLayout
from .skeleton_input import (
    _LoopCurve,
    conforming_delaunay,
    sample_loops,
    turning_angles,
    validate_loops,
)
from .skeleton_patches import build_layout, smallest_member_labels

log = logging.getLogger(__name__)

#: default sample spacing as a share of the bbox diagonal (RV2 recommends 1–5 %)
SPACING_SHARE = 0.01
#: circumcentres closer than this share of the spacing are one skeleton node (cocircular samples)
CLUSTER_SHARE = 1e-3
#: a terminal branch whose boundary turns by this much in all (degrees) ends at a rounded
#: corner: kept as a corner branch, not pruned as noise
SIGNIFICANT_TURN = 60.0
#: a skeleton branch is cut every this many degrees of turning (flipped-patch correction)
MAX_TURN = 90.0


def _circumcentres(P, tris):
    a, b, c = P[tris[:, 0]], P[tris[:, 1]], P[tris[:, 2]]
    b = b - a
    c = c - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    bb = (b**2).sum(1)
    cc = (c**2).sum(1)
    ux = (c[:, 1] * bb - b[:, 1] * cc) / d
    uy = (b[:, 0] * cc - c[:, 0] * bb) / d
    return a + np.stack([ux, uy], 1)


def _polyline_area(pl):
    x, y = pl[:, 0], pl[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


class _Skeleton:
    """Clusters of Delaunay triangles (skeleton nodes) with their polygons and chords."""

    def __init__(self, points, tris, bnd_keys, spacing):
        self.P = points
        self.n = sample_count = len(points)
        edge_tris = self._edge_triangles(points, tris, bnd_keys)
        centres = _circumcentres(points, tris)
        cluster_of = self._cluster_triangles(tris, edge_tris, centres, CLUSTER_SHARE * spacing)
        self.ncl = len(set(cluster_of.tolist()))
        triangles_of = defaultdict(list)
        for triangle, cluster in enumerate(cluster_of):
            triangles_of[cluster].append(triangle)
        self.poly = []  # CCW vertex ids of every cluster
        self.eside = []  # per polygon edge i (poly[i] -> poly[i+1]): -1 boundary or chord key
        self.pos = np.zeros((self.ncl, 2))
        self.chord = {}  # chord key -> (cluster, cluster)
        self.bnd_owner = {}  # boundary key -> (cluster, polygon edge index)
        for cluster in range(self.ncl):
            triangles = triangles_of[cluster]
            verts = self._outline(tris, triangles, list(cluster_of), edge_tris)
            corner_count = len(verts)
            sides = []
            for side in range(corner_count):
                start, end = verts[side], verts[(side + 1) % corner_count]
                key = min(start, end) * sample_count + max(start, end)
                if key in bnd_keys:
                    sides.append(-1)
                    self.bnd_owner[key] = (cluster, side)
                else:
                    sides.append(key)
                    self.chord.setdefault(key, [])
                    self.chord[key].append(cluster)
            self.poly.append(verts)
            self.eside.append(sides)
            self.pos[cluster] = self._node_position(verts, centres[triangles].mean(0))
        # polygon edge indices of the chords of every cluster
        self.ports = [
            [side for side, chord in enumerate(sides) if chord != -1] for sides in self.eside
        ]

    @staticmethod
    def _edge_triangles(points, tris, bnd_keys):
        """Triangles on every edge (key ``min * n + max``); checks that every boundary segment
        has one triangle and every other edge two."""
        sample_count = len(points)
        edge_tris = defaultdict(list)
        for triangle in range(len(tris)):
            for corner in range(3):
                start, end = int(tris[triangle, corner]), int(tris[triangle, (corner + 1) % 3])
                edge_tris[min(start, end) * sample_count + max(start, end)].append(triangle)
        for key, triangles in edge_tris.items():
            first = points[key // sample_count]
            if key in bnd_keys:
                if len(triangles) != 1:
                    raise GeometryError(
                        "boundary samples are not triangulated consistently near "
                        f"({first[0]:.6g}, {first[1]:.6g}); pass a smaller sample_spacing"
                    )
            elif len(triangles) != 2:
                raise GeometryError(
                    "the triangulation leaks across the boundary near "
                    f"({first[0]:.6g}, {first[1]:.6g}); pass a smaller sample_spacing"
                )
        for key in bnd_keys:
            if key not in edge_tris:
                first = points[key // sample_count]
                raise GeometryError(
                    "a boundary segment is not covered by the triangulation near "
                    f"({first[0]:.6g}, {first[1]:.6g})"
                )
        return edge_tris

    @classmethod
    def _cluster_triangles(cls, tris, edge_tris, centres, tolerance) -> np.ndarray:
        """Cluster id of every triangle: neighbours with circumcentres closer than ``tolerance``
        are one cluster, numbered by its smallest triangle id."""
        close_pairs = []
        for key in sorted(edge_tris):
            triangles = edge_tris[key]
            if len(triangles) == 2:
                first, second = triangles
                if np.linalg.norm(centres[first] - centres[second]) < tolerance:
                    close_pairs.append((first, second))
        roots = smallest_member_labels(len(tris), close_pairs)
        # a cluster whose outline is not one simple cycle is broken back into triangles
        members = defaultdict(list)
        for triangle, root in enumerate(roots):
            members[root].append(triangle)
        for triangles in members.values():
            if len(triangles) > 1 and cls._outline(tris, triangles, roots, edge_tris) is None:
                for triangle in triangles:
                    roots[triangle] = triangle
        # renumber clusters by their smallest triangle id (deterministic)
        cluster_id: dict[int, int] = {}
        for root in roots:
            cluster_id.setdefault(root, len(cluster_id))
        return np.array([cluster_id[root] for root in roots])

    @staticmethod
    def _outline(tris, ts, roots, edge_tris):
        """CCW boundary vertex ids of a set of triangles, or None if not one simple cycle."""
        directed = set()
        for t in ts:
            for i in range(3):
                directed.add((int(tris[t, i]), int(tris[t, (i + 1) % 3])))
        out = {}
        for a, b in sorted(directed):
            if (b, a) not in directed:
                if a in out:
                    return None
                out[a] = b
        if not out:
            return None
        start = min(out)
        verts = [start]
        cur = out[start]
        while cur != start:
            if cur not in out or len(verts) > len(out):
                return None
            verts.append(cur)
            cur = out[cur]
        if len(verts) != len(out):
            return None
        return verts

    def _node_position(self, verts, centre):
        Q = self.P[verts]
        k = len(Q)
        area = _polyline_area(Q)
        d = np.roll(Q, -1, axis=0) - Q
        ln = np.linalg.norm(d, axis=1)
        rel = centre - Q
        sd = (d[:, 0] * rel[:, 1] - d[:, 1] * rel[:, 0]) / np.maximum(ln, 1e-300)
        if sd.min() > 0.05 * math.sqrt(abs(area)):
            return centre
        x, y = Q[:, 0], Q[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cr = x * yn - xn * y
        if abs(area) < 1e-300 or k < 3:
            return Q.mean(0)
        return np.array([((x + xn) * cr).sum(), ((y + yn) * cr).sum()]) / (6.0 * area)


def skeleton_layout(
    loops: list[np.ndarray],
    corner_angle: float = 35.0,
    sample_spacing: float | None = None,
    point_features: np.ndarray | None = None,
) -> CoarseLayout:
    """Coarse quad layout of a planar domain with holes by medial-axis decomposition.

    loops : list of (k, 2) float
        closed polylines in millimetres, first point not repeated; loop 0 is the outer boundary,
        the others are openings. Orientation is fixed here (outer CCW, openings CW).
    corner_angle : float
        degrees; a vertex whose turning angle exceeds it is a corner (kept as a coarse vertex).
    sample_spacing : float, optional
        boundary sample spacing in mm; default 1 % of the domain's diameter (at least 12 samples a loop).
    point_features : (p, 2) float, optional
        points that should become vertices. Only accepted when they coincide with a produced
        vertex (within 1e-6 of the diagonal); others are ignored with a warning (not supported).

    Raises :class:`GeometryError` for invalid loops or domains the method cannot decompose.
    """
    oloops = validate_loops(loops)
    domain = Polygon(oloops[0], [h for h in oloops[1:]])
    allp = np.vstack(oloops)
    diag = float(np.linalg.norm(allp.max(0) - allp.min(0)))
    # the diameter (not the bbox diagonal) so that the default spacing is rotation invariant
    hull = allp[ConvexHull(allp).vertices]
    diameter = float(np.max(np.linalg.norm(hull[:, None, :] - hull[None, :, :], axis=2)))
    h = float(sample_spacing) if sample_spacing else SPACING_SHARE * diameter
    if not (h > 0 and math.isfinite(h)):
        raise GeometryError(f"sample_spacing {sample_spacing!r} is not a positive length in mm")
    smp, curves = sample_loops(oloops, corner_angle, h)
    smp, tris = conforming_delaunay(smp, curves, domain)
    P = smp.points
    n = len(P)
    bnd_keys = set()
    bnd_dir = []
    for o in smp.order:
        for k, a in enumerate(o):
            b = o[(k + 1) % len(o)]
            bnd_keys.add(min(a, b) * n + max(a, b))
            bnd_dir.append((a, b))
    sk = _Skeleton(P, tris, bnd_keys, h)
    info = {"samples": int(n), "triangles": len(tris), "skeleton_nodes": int(sk.ncl)}
    dec = _Decomposition(sk, smp, info, curves)
    dec.prune()
    dec.graft()
    dec.correct()
    return dec.layout(bnd_dir, point_features, diag)


class _Decomposition:
    def __init__(self, sk: _Skeleton, smp, info, curves: list[_LoopCurve]):
        self.sk = sk
        self.smp = smp
        self.info = info
        self.curves = curves  # loop index -> arc-length parametrised loop
        self.live_chords = set(sk.chord)
        self.live_nodes = set(range(sk.ncl))
        # cluster -> polygon edge indices
        self.corner_ports: defaultdict[int, set[int]] = defaultdict(set)
        # cluster -> polygon vertex indices
        self.spokes: defaultdict[int, set[int]] = defaultdict(set)
        self.info["junctions"] = int(sum(1 for c in range(sk.ncl) if len(sk.ports[c]) >= 3))
        self.corrections = {"reflex_corner": 0, "turning": 0, "loop_splits": 0}

    # -- live graph -------------------------------------------------------------------------
    def live_ports(self, c):
        return [i for i in self.sk.ports[c] if self.sk.eside[c][i] in self.live_chords]

    def eff(self, c):
        return len(self.live_ports(c)) + len(self.corner_ports[c])

    def other(self, key, c):
        a, b = self.sk.chord[key]
        return b if a == c else a

    def _net_turn(self, samples: set, apex: list) -> float:
        """Net turning (degrees, positive = convex) of the boundary run made of ``samples``
        on the apex's loop, between the run's two end tangents."""
        smp = self.smp
        loop = int(smp.loop[apex[0]])
        order = smp.order[loop]
        position = {v: k for k, v in enumerate(order)}
        idx = np.sort([position[v] for v in samples if smp.loop[v] == loop])
        if len(idx) < 3:
            return 0.0
        m = len(order)
        gaps = np.diff(np.concatenate([idx, [idx[0] + m]]))
        start = (int(np.argmax(gaps)) + 1) % len(idx)
        run = np.roll(idx, -start)
        if loop not in self._turning:
            self._turning[loop] = turning_angles(smp.points[order])
        return float(self._turning[loop][run[1:-1]].sum())

    def _terminal_branches(self):
        """Every live terminal branch: (length, leaf, path nodes, chord keys, root, root key)."""
        sk = self.sk
        out = []
        for leaf in sorted(self.live_nodes):
            lp = self.live_ports(leaf)
            if len(lp) != 1 or self.eff(leaf) >= 3:
                continue
            path = [leaf]
            key = sk.eside[leaf][lp[0]]
            cur = self.other(key, leaf)
            keys = [key]
            while True:
                clp = self.live_ports(cur)
                if len(clp) == 2 and self.eff(cur) < 3:
                    key = next(sk.eside[cur][i] for i in clp if sk.eside[cur][i] != key)
                    path.append(cur)
                    keys.append(key)
                    cur = self.other(key, cur)
                    continue
                break
            if len(self.live_ports(cur)) == 1 and self.eff(cur) < 3:
                continue  # the whole live graph is a path: keep it
            nodes = sk.pos[path + [cur]]
            length = float(np.linalg.norm(np.diff(nodes, axis=0), axis=1).sum())
            out.append((length, leaf, path, keys, cur, key))
        return out

    def prune(self):
        """Remove terminal branches, shortest first (so that the noise branches of a sampled
        curve are gone before the branch of the rounded corner they sit on is judged)."""
        sk = self.sk
        self.rounded_corners = 0
        self._turning = {}
        absorbed = defaultdict(set)  # node -> boundary samples of branches pruned into it
        pruned_corner = pruned_noise = 0
        while True:
            branches = self._terminal_branches()
            if not branches:
                break
            _, leaf, path, keys, cur, key = min(branches, key=lambda b: (b[0], b[1]))
            is_corner = any(self.corner_ports[c] for c in path)
            verts = sk.poly[leaf]
            i0 = self.live_ports(leaf)[0]
            k = len(verts)
            apex = [verts[j] for j in range(k) if j not in (i0, (i0 + 1) % k)]
            if any(self.smp.corner[v] and self.smp.convex[v] for v in apex):
                is_corner = True
            samples = {v for c in path for v in sk.poly[c]}
            for c in path:
                samples |= absorbed.pop(c, set())
            # a rounded corner (no sample turns by corner_angle, but the boundary the branch
            # reaches into turns by SIGNIFICANT_TURN in all): its apex becomes a corner, as a
            # sharp one would be; a bump on a straight side turns ~0 net
            if not is_corner and apex and self._net_turn(samples, apex) >= SIGNIFICANT_TURN:
                v = apex[len(apex) // 2]
                self.smp.corner[v] = self.smp.convex[v] = True
                self.rounded_corners += 1
                is_corner = True
            for kk in keys:
                self.live_chords.discard(kk)
            for c in path:
                self.live_nodes.discard(c)
                self.corner_ports.pop(c, None)
            if is_corner:
                root_i = next(i for i in sk.ports[cur] if sk.eside[cur][i] == key)
                self.corner_ports[cur].add(root_i)
                pruned_corner += 1
            else:
                absorbed[cur] |= samples
                pruned_noise += 1
        self.info["pruned_corner_branches"] = pruned_corner
        self.info["rounded_corners"] = self.rounded_corners
        self.info["pruned_noise_branches"] = pruned_noise

    @staticmethod
    def _pick(run, q):
        m = len(run)
        return [run[((j + 1) * m) // (q + 1) if q > 1 else (m - 1) // 2] for j in range(q)]

    def _gaps(self, c, ports):
        k = len(self.sk.poly[c])
        ports = sorted(ports)
        gaps = []
        for g, i in enumerate(ports):
            j = ports[(g + 1) % len(ports)]
            run = []
            v = (i + 1) % k
            while True:
                run.append(v)
                if v == j:
                    break
                v = (v + 1) % k
            gaps.append(run)
        return gaps

    def graft(self):
        sk = self.sk
        njun = 0
        if (
            self.live_nodes
            and all(self.eff(c) < 3 for c in self.live_nodes)
            and len(self.live_chords) == len(self.live_nodes) - 1
        ):
            # the pruned skeleton is a bare path (disc-like domain): keep its widest node only,
            # grafted to three boundary samples (one valence-3 singularity)
            def radius(c):
                return float(np.min(np.linalg.norm(sk.P[sk.poly[c]] - sk.pos[c], axis=1)))

            keep = max(sorted(self.live_nodes), key=radius)
            self.live_nodes = {keep}
            self.live_chords = set()
            self.corner_ports = defaultdict(set)
            self.info["collapsed_path_skeleton"] = True
        for c in sorted(self.live_nodes):
            lp = self.live_ports(c)
            ports = lp + sorted(self.corner_ports[c])
            E = len(ports)
            if E >= 3 or len(lp) <= 1:
                s = max(E, 3 - len(lp))
                k = len(sk.poly[c])
                if E == 0:
                    idx = [(j * k) // s for j in range(s)]
                else:
                    gaps = self._gaps(c, ports)
                    q = [1] * len(gaps)
                    for _ in range(s - E):
                        g = max(range(len(gaps)), key=lambda g: (len(gaps[g]) / (q[g] + 1), -g))
                        q[g] += 1
                    idx = []
                    for g, run in enumerate(gaps):
                        idx += self._pick(run, min(q[g], len(run)))
                self.spokes[c].update(idx)
                njun += 1
        self.info["grafted_nodes"] = njun

    # -- corrections ----------------------------------------------------------------------------
    def _is_plain(self, c):
        return len(self.live_ports(c)) == 2 and not self.spokes[c] and self.eff(c) == 2

    def _cross_cut(self, c, prefer_vertex=None):
        gaps = self._gaps(c, self.live_ports(c))
        verts = self.sk.poly[c]
        for run in gaps:
            if prefer_vertex is not None and any(verts[i] == prefer_vertex for i in run):
                self.spokes[c].add(next(i for i in run if verts[i] == prefer_vertex))
            else:
                self.spokes[c].add(self._pick(run, 1)[0])

    def _split_vertices(self):
        out = set()
        for c, idx in self.spokes.items():
            for i in idx:
                out.add(self.sk.poly[c][i])
        return out

    def correct(self):
        sk, smp = self.sk, self.smp
        # 1. reflex corners
        split = self._split_vertices()
        containing = defaultdict(list)
        for c in sorted(self.live_nodes):
            for v in sk.poly[c]:
                containing[v].append(c)
        for v in np.flatnonzero(smp.corner & ~smp.convex):
            v = int(v)
            if v in split or not containing[v]:
                continue
            cands = containing[v]
            o = smp.order[smp.loop[v]]
            nxt = o[(o.index(v) + 1) % len(o)]
            d0 = sk.P[nxt] - sk.P[v]
            a0 = math.atan2(d0[1], d0[0])
            cands = sorted(
                cands,
                key=lambda c: ((math.atan2(*(sk.pos[c] - sk.P[v])[::-1]) - a0) % (2 * math.pi), c),
            )
            c = cands[len(cands) // 2]
            if self._is_plain(c):
                self._cross_cut(c, prefer_vertex=v)
            else:
                self.spokes[c].add(sk.poly[c].index(v))
            self.corrections["reflex_corner"] += 1
            split = self._split_vertices()
        # 2. branches turning more than MAX_TURN
        for chain, closed in self._branches():
            mids = [self._chord_mid(k) for k in chain["keys"]]
            if len(mids) < 3:
                continue
            M = np.array(mids + ([mids[0], mids[1]] if closed else []))
            d = np.diff(M, axis=0)
            ang = np.arctan2(d[:, 1], d[:, 0])
            turn = np.degrees((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)
            # turn[j] is the turning at the node between chord j and chord j+1
            nodes = chain["nodes"]
            if closed:
                turn = turn[: len(nodes)]
                # nodes[j] sits between keys[j] and keys[j+1]
            else:
                turn = turn[: len(nodes)]
            total = float(np.sum(turn))
            if closed:
                ncut = max(4, math.ceil(abs(total) / MAX_TURN - 0.05))
                picks = sorted({(j * len(nodes)) // ncut for j in range(ncut)})
            else:
                if abs(total) <= MAX_TURN:
                    continue
                ncut = math.ceil(abs(total) / MAX_TURN - 0.05) - 1
                cum = np.cumsum(turn) * np.sign(total)
                picks = sorted(
                    {
                        int(np.argmin(np.abs(cum - abs(total) * (j + 1) / (ncut + 1))))
                        for j in range(ncut)
                    }
                )
            for i in picks:
                c = nodes[min(i, len(nodes) - 1)]
                if self._is_plain(c):
                    self._cross_cut(c)
                    self.corrections["turning"] += 1
        # 3. every loop needs at least 3 split points
        for li, o in enumerate(smp.order):
            L = smp.lengths[li]
            for _ in range(3):
                split = self._split_vertices() | {v for v in o if smp.corner[v]}
                ss = sorted(float(smp.s[v]) for v in split if smp.loop[v] == li)
                if len(ss) >= 3:
                    break
                if not ss:
                    target = 0.0
                elif len(ss) == 1:
                    target = ss[0] + L / 3.0
                else:
                    a, b = ss
                    target = (a + b) / 2 if b - a >= L - (b - a) else (b + (a + L)) / 2
                target %= L
                best = None
                for c in sorted(self.live_nodes):
                    plain = self._is_plain(c)
                    for i, v in enumerate(sk.poly[c]):
                        if smp.loop[v] != li or v in split:
                            continue
                        dist = abs(float(smp.s[v]) - target)
                        dist = min(dist, L - dist)
                        score = (0 if plain else 1, dist, c, i)
                        if best is None or score < best:
                            best = score
                if best is None:
                    raise GeometryError(
                        f"loop {li} cannot be split into 3 sides by the skeleton; "
                        "pass a smaller sample_spacing"
                    )
                _, _, c, i = best
                if self._is_plain(c):
                    self._cross_cut(c, prefer_vertex=sk.poly[c][i])
                else:
                    self.spokes[c].add(i)
                self.corrections["loop_splits"] += 1
        self.info["corrections"] = dict(self.corrections)

    def _chord_mid(self, key):
        n = self.sk.n
        return 0.5 * (self.sk.P[key // n] + self.sk.P[key % n])

    def _branches(self):
        """Chains of plain live nodes: [({'nodes', 'keys'}, closed)]."""
        sk = self.sk
        seen = set()
        out = []
        plain = {c for c in self.live_nodes if self._is_plain(c)}
        for start in sorted(plain):
            if start in seen:
                continue
            # walk back to an end of the chain
            lp = self.live_ports(start)
            key = sk.eside[start][lp[0]]
            cur = start
            closed = False
            while True:
                nb = self.other(key, cur)
                if nb not in plain:
                    break
                if nb == start:
                    closed = True
                    break
                nk = next(sk.eside[nb][i] for i in self.live_ports(nb) if sk.eside[nb][i] != key)
                cur, key = nb, nk
            # now walk forward from cur, entering through key
            first = cur if not closed else start
            if closed:
                key = sk.eside[start][lp[0]]
            nodes, keys = [], [key]
            cur = first
            while True:
                seen.add(cur)
                nodes.append(cur)
                nk = [sk.eside[cur][i] for i in self.live_ports(cur) if sk.eside[cur][i] != key]
                key = nk[0]
                keys.append(key)
                nb = self.other(key, cur)
                if nb not in plain or nb == first:
                    break
                cur = nb
            if closed:
                keys = keys[:-1]
            out.append(({"nodes": nodes, "keys": keys}, closed))
        return out

    # -- patches and layout -------------------------------------------------------------------
    def layout(self, bnd_dir, point_features, diag):
        return build_layout(self, bnd_dir, point_features, diag)
