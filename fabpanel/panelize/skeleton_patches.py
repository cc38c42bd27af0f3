"""Patch graph of the skeleton decomposition and its conversion into a coarse quad layout.

Helper of :mod:`fabpanel.panelize.skeleton`. The kept graph (boundary segments, live skeleton
chords, grafts) lives on a refinement of the Delaunay clusters whose small faces and their
adjacency are known by construction: around every cluster node, one face per boundary edge of its
polygon and two half-kites per chord. Patches are the classes of small faces merged across every
edge that is not kept, so no angle sorting or coordinate matching is needed.
"""

from __future__ import annotations

import logging
from collections import Counter, defaultdict

import numpy as np
from shapely.geometry import Polygon

from ..errors import GeometryError
from .coarse import CoarseLayout

log = logging.getLogger(__name__)


def _area(pl):
    x, y = pl[:, 0], pl[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _join(parts):
    out = [parts[0]]
    for p in parts[1:]:
        out.append(p[1:])
    return np.vstack(out)


def _halves(pl):
    seg = np.linalg.norm(np.diff(pl, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    half = cum[-1] / 2.0
    i = int(np.searchsorted(cum, half, side="right") - 1)
    i = min(max(i, 0), len(pl) - 2)
    t = (half - cum[i]) / max(seg[i], 1e-300)
    m = pl[i] + t * (pl[i + 1] - pl[i])
    first = [pl[j] for j in range(i + 1)]
    second = [pl[j] for j in range(i + 1, len(pl))]
    eps = 1e-9 * max(cum[-1], 1e-300)
    if np.linalg.norm(first[-1] - m) < eps and len(first) > 1:
        first.pop()
    if np.linalg.norm(second[0] - m) < eps and len(second) > 1:
        second.pop(0)
    return np.array(first + [m]), m, np.array([m] + second)


def _side_polyline(geoms: list, nodes: tuple, n: int) -> np.ndarray:
    """Polyline of a patch side from its half-edge geometries.

    Along a skeleton branch the circumcentres of the sleeve triangles zig-zag back and forth
    when the two boundaries are sampled out of phase (nearly parallel sides: the circumcentres
    all lie near the axis, but not in order), which folds every patch built on the branch. The
    chord midpoints (Prasad's chordal axis) advance monotonically along the sleeve, so the
    interior skeleton nodes (cluster ids >= n) are dropped and only the chord midpoints and the
    side's two end nodes are kept; boundary samples (ids < n) are all kept.
    """
    points = [geoms[0][0]]
    for k, g in enumerate(geoms):
        points.extend(g[1:-1])
        if k == len(geoms) - 1 or nodes[k + 1] < n:
            points.append(g[-1])
    return np.asarray(points, dtype=float)


def _quad_ok(poly):
    if _area(poly) <= 0:
        return False
    try:
        return Polygon(poly).is_valid
    except Exception:  # noqa: BLE001 - shapely raises several types on degenerate rings
        return False


def build_layout(dec, bnd_dir, point_features, diag) -> CoarseLayout:
    sk, smp, info = dec.sk, dec.smp, dec.info
    n = sk.n
    P = sk.P

    def face_at(c, j, v):
        k = len(sk.poly[c])
        j %= k
        s = sk.eside[c][j]
        return ("B", c, j) if s == -1 else ("H", s, v)

    fid: dict[tuple[str, int, int], int] = {}

    def F(f):
        if f not in fid:
            fid[f] = len(fid)
        return fid[f]

    for c in range(sk.ncl):
        vs = sk.poly[c]
        k = len(vs)
        for i in range(k):
            F(face_at(c, i, vs[i]))
            F(face_at(c, i, vs[(i + 1) % k]))
    parent = list(range(len(fid)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    def union(a, b):
        a, b = find(a), find(b)
        if a != b:
            parent[max(a, b)] = min(a, b)

    live = dec.live_nodes
    for c in range(sk.ncl):
        vs = sk.poly[c]
        kept = dec.spokes[c] if c in live else set()
        for i, v in enumerate(vs):
            if i not in kept:
                union(F(face_at(c, i, v)), F(face_at(c, i - 1, v)))
    for key, (c, u) in sorted(sk.chord.items()):
        if key not in dec.live_chords:
            union(F(("H", key, key // n)), F(("H", key, key % n)))

    # kept half-edges: (from, to, left patch, geometry), P-node ids: sample v, cluster n + c
    def X(node):
        return P[node] if node < n else sk.pos[node - n]

    halfedges = []
    for a, b in bnd_dir:
        c, i = sk.bnd_owner[min(a, b) * n + max(a, b)]
        # the input loop between the two samples (its own vertices kept), ends exactly at them
        g = dec.curves[int(smp.loop[a])].between(float(smp.s[a]), float(smp.s[b]))
        g[0], g[-1] = P[a], P[b]
        halfedges.append((a, b, find(F(("B", c, i))), g))
    for key in sorted(dec.live_chords):
        c, u = sk.chord[key]
        i = sk.eside[c].index(key)
        vs = sk.poly[c]
        a, b = vs[i], vs[(i + 1) % len(vs)]
        mid = 0.5 * (P[a] + P[b])
        geom = np.array([sk.pos[c], mid, sk.pos[u]])
        halfedges.append((n + c, n + u, find(F(("H", key, b))), geom))
        halfedges.append((n + u, n + c, find(F(("H", key, a))), geom[::-1]))
    for c in sorted(live):
        vs = sk.poly[c]
        for i in sorted(dec.spokes[c]):
            v = vs[i]
            lf, rf = find(F(face_at(c, i, v))), find(F(face_at(c, i - 1, v)))
            if lf == rf:
                raise GeometryError(
                    "a graft ends inside one patch (dangling branch) near "
                    f"({P[v][0]:.6g}, {P[v][1]:.6g}); try another sample_spacing"
                )
            halfedges.append((n + c, v, lf, None))
            halfedges.append((v, n + c, rf, None))

    def geom_of(he):
        a, b, _, g = he
        return g if g is not None else np.array([X(a), X(b)])

    half_degree: Counter[int] = Counter()
    for a, b, _, _ in halfedges:
        half_degree[a] += 1
        half_degree[b] += 1
    for a, b in bnd_dir:  # boundary edges were added once, count their other direction
        half_degree[a] += 1
        half_degree[b] += 1
    degree = {k: v // 2 for k, v in half_degree.items()}
    coarse_nodes = {p for p, d in degree.items() if d != 2}
    coarse_nodes |= {int(v) for v in np.flatnonzero(smp.corner)}

    by_patch: defaultdict[int, dict[int, tuple]] = defaultdict(dict)  # patch -> start -> he
    for he in halfedges:
        d = by_patch[he[2]]
        if he[0] in d:
            x = X(he[0])
            raise GeometryError(
                f"a patch touches itself at ({x[0]:.6g}, {x[1]:.6g}); the skeleton "
                "decomposition failed here - try another sample_spacing"
            )
        d[he[0]] = he
    cycles = {}
    for pid in sorted(by_patch):
        d = by_patch[pid]
        start = min(d)
        cyc = [d[start]]
        while cyc[-1][1] != start:
            cyc.append(d[cyc[-1][1]])
            if len(cyc) > len(d):
                raise GeometryError(
                    "patch outline does not close; internal error of the decomposition"
                )
        if len(cyc) != len(d):
            x = X(start)
            raise GeometryError(
                f"a patch near ({x[0]:.6g}, {x[1]:.6g}) is not a disk (it surrounds "
                "an opening); the skeleton decomposition failed - try another "
                "sample_spacing"
            )
        cycles[pid] = cyc

    # coarse vertex ids: boundary samples in loop order, then skeleton nodes
    order_key = {}
    for li, o in enumerate(smp.order):
        for k, v in enumerate(o):
            order_key[v] = (0, li, k)
    cn = sorted(coarse_nodes, key=lambda p: order_key.get(p, (1, p, 0)))
    vid = {p: i for i, p in enumerate(cn)}
    verts = [X(p) for p in cn]
    loop_of = [int(smp.loop[p]) if p < n else -1 for p in cn]
    corner = [bool(p < n and smp.corner[p]) for p in cn]

    # patch sides
    sides: dict[tuple[int, ...], int] = {}  # canonical node tuple -> side id
    side_geom: list[np.ndarray] = []  # side id -> polyline in canonical direction
    side_ends = []
    side_loop = []
    side_nodes = []
    patches = []  # list of list of (side id, forward?)
    for pid in sorted(cycles):
        cyc = cycles[pid]
        s0 = next((j for j, he in enumerate(cyc) if he[0] in coarse_nodes), None)
        if s0 is None:
            x = X(cyc[0][0])
            raise GeometryError(
                f"a boundary loop near ({x[0]:.6g}, {x[1]:.6g}) has no split point; "
                "internal error of the decomposition"
            )
        cyc = cyc[s0:] + cyc[:s0]
        cur_nodes, cur_geoms, plist = [cyc[0][0]], [], []
        for he in cyc:
            cur_nodes.append(he[1])
            cur_geoms.append(geom_of(he))
            if he[1] in coarse_nodes:
                t = tuple(cur_nodes)
                rt = t[::-1]
                if t in sides:
                    plist.append((sides[t], True))
                elif rt in sides:
                    plist.append((sides[rt], False))
                else:
                    sides[t] = len(side_geom)
                    side_geom.append(_side_polyline(cur_geoms, t, n))
                    side_ends.append((vid[t[0]], vid[t[-1]]))
                    on_b = all(p < n for p in t)
                    side_loop.append(int(smp.loop[t[0]]) if on_b else -1)
                    side_nodes.append(t)
                    plist.append((sides[t], True))
                cur_nodes, cur_geoms = [he[1]], []
        patches.append(plist)

    def corners_of(plist):
        return [side_ends[s][0] if fw else side_ends[s][1] for s, fw in plist]

    nsides = Counter(len(p) for p in patches)
    info["patches"] = len(patches)
    info["patches_by_sides"] = {str(k): int(v) for k, v in sorted(nsides.items())}
    pairs = Counter(tuple(sorted(e)) for e in side_ends)
    vsets = Counter(frozenset(corners_of(p)) for p in patches)
    all_quads = (
        all(len(p) == 4 and len(set(corners_of(p))) == 4 for p in patches)
        and max(pairs.values()) == 1
        and max(vsets.values()) == 1
    )
    info["midpoint_subdivision"] = not all_quads

    edge_curves = {}
    quads = []
    bad_centres = 0
    if all_quads:
        for s, (a, b) in enumerate(side_ends):
            g = side_geom[s]
            edge_curves[(a, b) if a < b else (b, a)] = g if a < b else g[::-1]
        quads = [corners_of(p) for p in patches]
    else:
        mid_of = []
        halves = []
        for s, g in enumerate(side_geom):
            if side_loop[s] >= 0 and len(g) >= 3:
                # split a boundary side at its sample nearest to the middle: stays on the input
                cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(g, axis=0), axis=1))])
                j = int(np.argmin(np.abs(cum[1:-1] - cum[-1] / 2.0))) + 1
                first, m, second = g[: j + 1], g[j].copy(), g[j:]
            elif side_loop[s] >= 0:
                # one sample segment: take the middle along the input loop
                a, b = side_nodes[s][0], side_nodes[s][-1]
                curve = dec.curves[side_loop[s]]
                sa, sb = float(smp.s[a]), float(smp.s[b])
                if sb <= sa:
                    sb += curve.length
                m = curve.at(0.5 * (sa + sb))
                first, second = np.array([g[0], m]), np.array([m, g[-1]])
            else:
                first, m, second = _halves(g)
            mid_of.append(len(verts))
            verts.append(m)
            loop_of.append(side_loop[s])
            corner.append(False)
            halves.append((first, second))
        # small-face membership: which dead skeleton nodes lie fully inside each patch
        inside_nodes = defaultdict(list)
        for c in range(sk.ncl):
            if c in live:
                continue
            vs = sk.poly[c]
            fs = {find(F(face_at(c, i, vs[i]))) for i in range(len(vs))}
            fs |= {find(F(face_at(c, i - 1, vs[i]))) for i in range(len(vs))}
            if len(fs) == 1:
                inside_nodes[fs.pop()].append(c)
        pids = sorted(cycles)
        for pid, plist in zip(pids, patches):
            k = len(plist)
            cs = corners_of(plist)
            ms = [mid_of[s] for s, _ in plist]
            # half polylines oriented along the patch: into corner i, out of corner i
            outs, ins = [], []
            for s, fw in plist:
                first, second = halves[s]
                if fw:
                    outs.append(first)  # corner -> mid
                    ins.append(second)  # mid -> next corner
                else:
                    outs.append(second[::-1])
                    ins.append(first[::-1])
            outline = _join([_join([outs[i], ins[i]]) for i in range(k)])
            poly = Polygon(outline)
            cands = []
            if poly.is_valid and poly.area > 0:
                cands.append(np.array(poly.centroid.coords[0]))
                cands.append(np.array(poly.representative_point().coords[0]))
            cen0 = outline.mean(0)
            nodes = sorted(
                inside_nodes.get(pid, []),
                key=lambda c: (float(np.linalg.norm(sk.pos[c] - cen0)), c),
            )
            cands += [sk.pos[c] for c in nodes[:40]]
            if not cands:
                cands.append(cen0)
            best = None
            for q in cands:
                good = 0
                for i in range(k):
                    j = i - 1
                    quad = _join(
                        [outs[i], np.array([verts[ms[i]], q]), np.array([q, verts[ms[j]]]), ins[j]]
                    )
                    good += _quad_ok(quad[:-1])
                if best is None or good > best[0]:
                    best = (good, q)
                if good == k:
                    break
            if best is None:  # cands is never empty
                raise GeometryError(
                    "a patch has no centre candidate; internal error of the decomposition"
                )
            if best[0] < k:
                bad_centres += 1
            centre = len(verts)
            verts.append(best[1])
            loop_of.append(-1)
            corner.append(False)
            for i in range(k):
                j = (i - 1) % k
                quads.append([cs[i], ms[i], centre, ms[j]])
                for a, b, g in (
                    (cs[i], ms[i], outs[i]),
                    (ms[j], cs[i], ins[j]),
                    (ms[i], centre, np.array([verts[ms[i]], best[1]])),
                ):
                    key = (a, b) if a < b else (b, a)
                    edge_curves[key] = g if a < b else g[::-1]
    V = np.array(verts, float)
    Q = np.array(quads, dtype=np.int64).reshape(-1, 4)
    info["quads"] = len(Q)
    info["patches_without_valid_centre"] = bad_centres

    # validity report: straight-edge signed area and polyline polygons
    def poly_of(q):
        parts = []
        for i in range(4):
            a, b = int(q[i]), int(q[(i + 1) % 4])
            g = edge_curves[(a, b)] if a < b else edge_curves[(b, a)][::-1]
            parts.append(g)
        return _join(parts)[:-1]

    st = 0
    bad = []
    for fi, q in enumerate(Q):
        if _area(V[q]) <= 0:
            st += 1
        if not _quad_ok(poly_of(q)):
            bad.append(fi)
    info["quads_nonpositive_straight"] = st
    info["quads_invalid_polyline"] = len(bad)
    if bad:
        log.warning(
            "skeleton layout: %d quads whose edge polylines do not form a simple CCW polygon: %s",
            len(bad),
            bad[:10],
        )

    valence: Counter[int] = Counter()
    for a, b in edge_curves:
        valence[a] += 1
        valence[b] += 1
    loop_arr = np.array(loop_of, dtype=np.int64)
    singular = np.array(
        sorted(v for v in range(len(V)) if loop_arr[v] == -1 and valence[v] != 4), dtype=np.int64
    )
    info["singular_valences"] = {
        str(k): int(v) for k, v in sorted(Counter(valence[v] for v in singular).items())
    }

    if point_features is not None and len(point_features):
        pf = np.asarray(point_features, float).reshape(-1, 2)
        ok = 0
        for p in pf:
            d = np.linalg.norm(V - p, axis=1)
            if d.min() <= 1e-6 * diag:
                ok += 1
            else:
                log.warning(
                    "point feature (%.6g, %.6g) is not a vertex of the skeleton layout; "
                    "point features are not supported by the skeleton method yet, ignored",
                    p[0],
                    p[1],
                )
        info["point_features_matched"] = ok
        info["point_features_ignored"] = int(len(pf) - ok)

    sampled = tuple(P[np.array(o)] for o in smp.order)
    return CoarseLayout(
        vertices=V,
        quads=Q,
        edge_curves=edge_curves,
        loop_of_vertex=loop_arr,
        corner=np.array(corner, bool),
        singular=singular,
        loops=sampled,
        info=info,
    )
