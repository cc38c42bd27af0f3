"""Input hygiene, boundary sampling and the boundary-conforming Delaunay of the skeleton method.

Helpers of :mod:`fabpanel.panelize.skeleton` (see shared/notes/quadmesh.md §6, steps 1–3).
Every boundary sample carries an integer id, its loop and its arc-length parameter on the input
loop, so that later steps never match points by coordinates.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import Delaunay
from shapely.geometry import LinearRing, Polygon
from shapely.validation import explain_validity

from ..errors import GeometryError

#: relative tolerance (times the bbox diagonal) under which two consecutive input points are one
DUPLICATE_TOL = 1e-12
#: boundary recovery gives up after this many rounds of segment splitting
MAX_RECOVERY_ROUNDS = 40


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _where(msg: str) -> str:
    m = re.search(r"\[([-+0-9.eE]+) ([-+0-9.eE]+)\]", msg)
    if not m:
        return ""
    return f" near ({float(m.group(1)):.6g}, {float(m.group(2)):.6g})"


def validate_loops(loops) -> list[np.ndarray]:
    """Checked copies of the loops: outer counter-clockwise, openings clockwise.

    Raises :class:`GeometryError` naming the loop for non-finite, degenerate, self-intersecting,
    outside or touching loops.
    """
    if loops is None or len(loops) == 0:
        raise GeometryError(
            "no boundary loop given: pass at least the outer boundary as (n, 2) points"
        )
    out = []
    for i, lp in enumerate(loops):
        name = "boundary loop 0" if i == 0 else f"opening {i}"
        p = np.asarray(lp, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2:
            raise GeometryError(f"{name} has shape {p.shape}, expected (n, 2) points in the plane")
        if not np.all(np.isfinite(p)):
            raise GeometryError(f"{name} has non-finite coordinates; remove NaN/inf points")
        if len(p) > 1 and np.allclose(p[0], p[-1]):
            p = p[:-1]
        diag = float(np.linalg.norm(p.max(0) - p.min(0))) if len(p) else 0.0
        if len(p) >= 2:
            keep = np.linalg.norm(p - np.roll(p, 1, axis=0), axis=1) > DUPLICATE_TOL * max(
                diag, 1e-300
            )
            p = p[keep]
        if len(p) < 3:
            raise GeometryError(f"{name} has fewer than 3 distinct points; give a closed polyline")
        ring = LinearRing(p)
        poly = Polygon(p)
        if not ring.is_simple or not poly.is_valid:
            raise GeometryError(
                f"{name} intersects itself{_where(explain_validity(poly))}; "
                "fix the polyline so that it does not cross itself"
            )
        area = _signed_area(p)
        if abs(area) <= 1e-12 * diag * diag:
            raise GeometryError(
                f"{name} has zero area near ({p[0, 0]:.6g}, {p[0, 1]:.6g}); "
                "remove the degenerate loop"
            )
        if (i == 0) != (area > 0):
            p = p[::-1].copy()
        out.append(p)
    outer = Polygon(out[0])
    holes = [Polygon(h) for h in out[1:]]
    for i, hp in enumerate(holes, start=1):
        if not outer.contains(hp):
            c = hp.representative_point()
            if outer.intersects(hp):
                raise GeometryError(
                    f"opening {i} touches or crosses the outer boundary near "
                    f"({c.x:.6g}, {c.y:.6g}); move it inside"
                )
            raise GeometryError(
                f"opening {i} lies outside the outer boundary near "
                f"({c.x:.6g}, {c.y:.6g}); move it inside or drop it"
            )
        if outer.exterior.distance(hp.exterior) <= 0.0:
            raise GeometryError(f"opening {i} touches the outer boundary; leave a gap")
    for i in range(len(holes)):
        for j in range(i + 1, len(holes)):
            if holes[i].distance(holes[j]) <= 0.0:
                c = holes[i].representative_point()
                raise GeometryError(
                    f"opening {i + 1} touches or overlaps opening {j + 1} near "
                    f"({c.x:.6g}, {c.y:.6g}); merge them or leave a gap"
                )
    return out


def turning_angles(p: np.ndarray) -> np.ndarray:
    """(n,) signed turning angle in degrees at every vertex (positive = left turn)."""
    d_in = p - np.roll(p, 1, axis=0)
    d_out = np.roll(p, -1, axis=0) - p
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    dot = np.einsum("ij,ij->i", d_in, d_out)
    return np.degrees(np.arctan2(cross, dot))


@dataclass
class Sampling:
    """Boundary samples with ids: ``points[i]`` lies on loop ``loop[i]`` at arc length ``s[i]``."""

    points: np.ndarray  # (N, 2)
    loop: np.ndarray  # (N,) int
    s: np.ndarray  # (N,) float, arc length on the (oriented) input loop
    corner: np.ndarray  # (N,) bool
    convex: np.ndarray  # (N,) bool, meaningful for corners
    order: list[list[int]]  # sample ids of every loop in loop order
    lengths: list[float]  # perimeter of every input loop


class _LoopCurve:
    def __init__(self, p: np.ndarray):
        self.p = p
        seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
        self.cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(self.cum[-1])

    def between(self, s0: float, s1: float) -> np.ndarray:
        """(k, 2) the loop from arc length s0 forward to s1, with the loop's own vertices in
        between (so that a chord never cuts a corner of the input)."""
        if s1 <= s0:
            s1 += self.length
        n = len(self.p)
        # loop vertices strictly inside (s0, s1), over up to two turns of the loop
        cum = np.concatenate([self.cum[:-1], self.cum[:-1] + self.length])
        inside = np.flatnonzero((cum > s0 + 1e-9 * self.length) & (cum < s1 - 1e-9 * self.length))
        return np.vstack([self.at(s0)[None], self.p[inside % n], self.at(s1)[None]])

    def at(self, s: float) -> np.ndarray:
        s = s % self.length
        i = int(np.searchsorted(self.cum, s, side="right") - 1)
        i = min(max(i, 0), len(self.p) - 1)
        t = (s - self.cum[i]) / max(self.cum[i + 1] - self.cum[i], 1e-300)
        a, b = self.p[i], self.p[(i + 1) % len(self.p)]
        return a + t * (b - a)


def sample_loops(
    loops: list[np.ndarray], corner_angle: float, spacing: float
) -> tuple[Sampling, list[_LoopCurve]]:
    """Resample every loop at about ``spacing``, keeping corners, at least 12 samples a loop."""
    pts: list[np.ndarray] = []
    lp: list[int] = []
    ss: list[float] = []
    cor: list[bool] = []
    cvx: list[bool] = []
    order: list[list[int]] = []
    lengths: list[float] = []
    curves: list[_LoopCurve] = []
    for li, p in enumerate(loops):
        curve = _LoopCurve(p)
        curves.append(curve)
        lengths.append(curve.length)
        turn = turning_angles(p)
        cidx = np.flatnonzero(np.abs(turn) > corner_angle)
        h = min(spacing, curve.length / 12.0)
        anchors: list[int] = [int(i) for i in cidx] if len(cidx) else [0]
        ids: list[int] = []
        for k, a in enumerate(anchors):
            b = anchors[(k + 1) % len(anchors)]
            s0 = curve.cum[a]
            s1 = curve.cum[b] if (b > a) else curve.cum[b] + curve.length
            n = max(1, int(np.ceil((s1 - s0) / h - 1e-9)))
            for j in range(n):
                s = s0 + (s1 - s0) * j / n
                ids.append(len(pts))
                pts.append(curve.at(s) if j else p[a])
                lp.append(li)
                ss.append(s % curve.length)
                is_c = j == 0 and len(cidx) > 0
                cor.append(is_c)
                cvx.append(bool(is_c and turn[a] > 0))
        order.append(ids)
    smp = Sampling(
        np.array(pts, float),
        np.array(lp, int),
        np.array(ss, float),
        np.array(cor, bool),
        np.array(cvx, bool),
        order,
        lengths,
    )
    return smp, curves


def conforming_delaunay(smp: Sampling, curves: list, domain: Polygon):
    """Delaunay of the boundary samples, boundary segments recovered by splitting.

    Returns ``(smp, tris)``: the (possibly refined) sampling and the (T, 3) counter-clockwise
    triangles inside the domain (centroid test).
    """
    pts = [p for p in smp.points]
    lp, ss, cor, cvx = list(smp.loop), list(smp.s), list(smp.corner), list(smp.convex)
    order = [list(o) for o in smp.order]
    for _ in range(MAX_RECOVERY_ROUNDS):
        P = np.array(pts)
        tri = Delaunay(P)
        simp = tri.simplices
        n = len(P)
        e = np.concatenate([simp[:, [0, 1]], simp[:, [1, 2]], simp[:, [2, 0]]])
        e.sort(axis=1)
        have = set((e[:, 0] * n + e[:, 1]).tolist())
        missing = False
        for li, o in enumerate(order):
            new = []
            L = smp.lengths[li]
            for k, a in enumerate(o):
                b = o[(k + 1) % len(o)]
                new.append(a)
                if min(a, b) * n + max(a, b) not in have:
                    missing = True
                    sa, sb = ss[a], ss[b]
                    if sb <= sa:
                        sb += L
                    sm = 0.5 * (sa + sb) % L
                    new.append(len(pts))
                    pts.append(curves[li].at(sm))
                    lp.append(li)
                    ss.append(sm)
                    cor.append(False)
                    cvx.append(False)
            order[li] = new
        if not missing:
            break
    else:
        raise GeometryError(
            "boundary recovery did not converge; the boundary has features much "
            "smaller than the sample spacing - pass a smaller sample_spacing"
        )
    P = np.array(pts)
    smp = Sampling(
        P,
        np.array(lp, int),
        np.array(ss, float),
        np.array(cor, bool),
        np.array(cvx, bool),
        order,
        smp.lengths,
    )
    simp = np.array(tri.simplices, dtype=np.int64)
    a, b, c = P[simp[:, 0]], P[simp[:, 1]], P[simp[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    simp[cross < 0] = simp[cross < 0][:, [0, 2, 1]]
    diag = float(np.linalg.norm(P.max(0) - P.min(0)))
    cen = (a + b + c) / 3.0
    inside = shapely.contains_xy(domain, cen[:, 0], cen[:, 1])
    keep = inside & (np.abs(cross) > 1e-14 * diag * diag)
    return smp, simp[keep]
