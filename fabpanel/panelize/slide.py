"""Boundary nodes that slide along the flat boundary while the interior is smoothed.

gmsh places the boundary nodes of a quasi-structured mesh before it knows where the interior
strips will run, so along a curved outline a boundary quad often leans: 140-160° at one
boundary corner and 40-45° at the next. Smoothing the interior alone cannot fix that, the
boundary node is in the wrong place. Here every boundary node that is not a corner of the
outline gets one unknown, its arc length along its loop, and the smoothing energy
(:mod:`.untangle`) moves it along the loop with the interior. The energy's barrier keeps nodes
from passing each other, and its size term keeps them from bunching; corners of the outline
stay where they are, and a node never leaves the stretch between its two corners.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: arc-length gap between two loops on the shared axis (never evaluated, it only keeps the
#: loops apart so that no segment joins two of them)
_GAP = 1.0


@dataclass(frozen=True)
class BoundaryTrack:
    """Closed flat loops laid end to end on one arc-length axis.

    points : (k, 2) float, every loop closed (first point repeated) and rotated to start at a
        corner where it has one; params : (k,) float, arc length of each point on the axis.
    spans : (loops, 2) float, each loop's first and last parameter; periodic : (loops,) bool,
        loops without a corner, whose nodes may wrap round; corners : the parameters of the
        corners of each loop (the loop's start and end included where it has corners);
        real : (k - 1,) bool, the segments that belong to a loop (not the joins between loops).
    """

    points: np.ndarray
    params: np.ndarray
    real: np.ndarray
    spans: np.ndarray
    periodic: np.ndarray
    corners: tuple[np.ndarray, ...]

    @classmethod
    def from_loops(cls, loops: list[np.ndarray], corner_flags: list[np.ndarray]) -> BoundaryTrack:
        """The track of flat loops (each (k, 2), open) with their corner flags (each (k,))."""
        points, params, real, spans, periodic, corners = [], [], [], [], [], []
        start = 0.0
        for loop, flags in zip(loops, corner_flags):
            first = int(np.flatnonzero(flags)[0]) if flags.any() else 0
            loop = np.roll(loop, -first, axis=0)
            flags = np.roll(flags, -first)
            closed = np.vstack([loop, loop[:1]])
            arc = start + np.concatenate(
                [[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
            )
            points.append(closed)
            params.append(arc)
            real.append(np.append(np.ones(len(loop), dtype=bool), False))
            spans.append((arc[0], arc[-1]))
            periodic.append(not flags.any())
            corners.append(np.append(arc[:-1][flags], arc[-1]) if flags.any() else arc[[0, -1]])
            start = arc[-1] + _GAP
        return cls(
            points=np.vstack(points),
            params=np.concatenate(params),
            real=np.concatenate(real)[:-1],
            spans=np.asarray(spans),
            periodic=np.asarray(periodic),
            corners=tuple(corners),
        )

    def locate(self, nodes: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
        """Each node's parameter (its foot on the nearest segment) and whether it sits on a
        corner (within ``tolerance``), where it must stay."""
        a, b = self.points[:-1], self.points[1:]
        segment = b - a
        length2 = np.maximum((segment**2).sum(axis=1), 1e-300)
        t = np.empty(len(nodes))
        for i, node in enumerate(nodes):
            u = np.clip(((node - a) * segment).sum(axis=1) / length2, 0.0, 1.0)
            distance = np.linalg.norm(a + u[:, None] * segment - node, axis=1)
            distance[~self.real] = np.inf
            best = int(np.argmin(distance))
            t[i] = self.params[best] + u[best] * np.sqrt(length2[best])
        on_corner = np.zeros(len(nodes), dtype=bool)
        for loop, params in enumerate(self.corners):
            if self.periodic[loop]:
                continue
            near = np.abs(t[:, None] - params[None, :]).min(axis=1) <= tolerance
            on_corner |= near & (t >= self.spans[loop, 0]) & (t <= self.spans[loop, 1])
        return t, on_corner

    def bounds(self, t: np.ndarray) -> list[tuple[float | None, float | None]]:
        """For each parameter, the stretch it may move in: between its two corners, or free
        on a loop without corners (where :meth:`at` wraps it round)."""
        out: list[tuple[float | None, float | None]] = []
        for value, loop in zip(t, self.loop_of(t)):
            if self.periodic[loop]:
                out.append((None, None))
                continue
            params = self.corners[loop]
            k = int(np.clip(np.searchsorted(params, value) - 1, 0, len(params) - 2))
            margin = 1e-6 * (params[k + 1] - params[k])
            out.append((float(params[k] + margin), float(params[k + 1] - margin)))
        return out

    def loop_of(self, t: np.ndarray) -> np.ndarray:
        """The loop of each parameter. A foot at a loop's very end can come out a rounding
        error past it, into the gap before the next loop (or past the last): it belongs to the
        loop that ends there."""
        ends = self.spans[:, 1] + 0.5 * _GAP
        return np.minimum(np.searchsorted(ends, t), len(self.spans) - 1)

    def wrap(self, t: np.ndarray, loops: np.ndarray) -> np.ndarray:
        """Parameters brought back into their loops' spans (loops without corners wrap)."""
        start, end = self.spans[loops, 0], self.spans[loops, 1]
        wrapped = start + np.mod(t - start, end - start)
        return np.where(self.periodic[loops], wrapped, np.clip(t, start, end))

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and unit tangents (direction of growing parameter) at parameters ``t``."""
        index = np.clip(np.searchsorted(self.params, t, side="right") - 1, 0, len(self.params) - 2)
        a, b = self.points[index], self.points[index + 1]
        length = np.maximum(self.params[index + 1] - self.params[index], 1e-300)
        u = ((t - self.params[index]) / length)[:, None]
        return a + u * (b - a), (b - a) / length[:, None]


@dataclass(frozen=True)
class SlidingNodes:
    """The nodes that slide, their loops on the track and their starting parameters; and the
    boundary edges whose lengths are held near a reference (``edges`` (k, 2) node ids,
    ``lengths`` (k,)), since the smoothing energy alone lets boundary nodes drift into short
    and long sides where that squares the panels a little more."""

    ids: np.ndarray
    loops: np.ndarray
    t: np.ndarray
    track: BoundaryTrack
    edges: np.ndarray
    lengths: np.ndarray

    @classmethod
    def on_track(
        cls,
        track: BoundaryTrack,
        nodes: np.ndarray,
        candidates: np.ndarray,
        tolerance: float,
        edges: np.ndarray | None = None,
        lengths: np.ndarray | None = None,
    ) -> SlidingNodes:
        """The candidate nodes (ids) that are not on a corner, located on the track; with the
        boundary ``edges`` to hold at ``lengths`` (none by default)."""
        t, on_corner = track.locate(nodes[candidates], tolerance)
        ids, t = candidates[~on_corner], t[~on_corner]
        return cls(
            ids=ids,
            loops=track.loop_of(t),
            t=t,
            track=track,
            edges=np.zeros((0, 2), dtype=np.int64) if edges is None else edges,
            lengths=np.zeros(0) if lengths is None else lengths,
        )

    def positions(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and tangents of the sliding nodes at parameters ``t``."""
        return self.track.at(self.track.wrap(t, self.loops))

    def edge_energy(self, p: np.ndarray, weight: float) -> tuple[float, np.ndarray]:
        """``weight x sum (length / reference - 1)²`` over the held edges, and its gradient
        with respect to every node position (n, 2)."""
        grad = np.zeros_like(p)
        if not len(self.edges):
            return 0.0, grad
        d = p[self.edges[:, 1]] - p[self.edges[:, 0]]
        length = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
        excess = length / self.lengths - 1.0
        pull = (2.0 * weight * excess / self.lengths / length)[:, None] * d
        for c in range(2):
            grad[:, c] += np.bincount(self.edges[:, 1], weights=pull[:, c], minlength=len(p))
            grad[:, c] -= np.bincount(self.edges[:, 0], weights=pull[:, c], minlength=len(p))
        return float(weight * (excess**2).sum()), grad
