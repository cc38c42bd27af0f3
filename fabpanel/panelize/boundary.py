"""The design boundary as closed 3D polylines: closest points on it, and the stretch of it
between two boundary vertices of a layout.

A panel side on the design boundary must follow the boundary, rounded corners included, not
the chord between its two corners; the develop stage takes its samples from
:meth:`DesignBoundary.between`.
"""

from __future__ import annotations

import numpy as np

from ..data import Surface

#: (point, segment) pairs evaluated at once
_CHUNK_PAIRS = 2_000_000


class DesignBoundary:
    """The boundary loops of a surface, parametrised by arc length."""

    def __init__(self, surface: Surface):
        loops = [surface.vertices[loop] for loop in surface.boundary_loops]
        self.loops = loops
        self.starts = np.concatenate(loops) if loops else np.zeros((0, 3))
        self.ends = (
            np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
            if loops
            else np.zeros((0, 3))
        )
        self.loop_of_segment = (
            np.concatenate([np.full(len(loop), i) for i, loop in enumerate(loops)]).astype(int)
            if loops
            else np.zeros(0, dtype=int)
        )
        lengths = np.linalg.norm(self.ends - self.starts, axis=1)
        self.segment_start_s = np.zeros(len(lengths))
        self.loop_length = np.zeros(len(loops))
        offset = 0
        for i, loop in enumerate(loops):
            part = lengths[offset : offset + len(loop)]
            self.segment_start_s[offset : offset + len(loop)] = np.cumsum(part) - part
            self.loop_length[i] = part.sum()
            offset += len(loop)
        self.first_segment = np.cumsum([0, *[len(loop) for loop in loops]])

    def locate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Closest boundary point of each point: ``(feet, distances, loop, s)`` with ``s`` the
        arc length along its loop from the loop's first vertex."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        direction = self.ends - self.starts
        length2 = np.maximum(np.einsum("sd,sd->s", direction, direction), 1e-300)
        feet = np.zeros_like(points)
        distance = np.full(len(points), np.inf)
        segment = np.zeros(len(points), dtype=int)
        fraction = np.zeros(len(points))
        chunk = max(1, _CHUNK_PAIRS // max(len(self.starts), 1))
        for first in range(0, len(points), chunk):
            block = points[first : first + chunk]
            rel = block[:, None, :] - self.starts[None]
            t = np.clip(np.einsum("nsd,sd->ns", rel, direction) / length2, 0.0, 1.0)
            foot = self.starts[None] + t[..., None] * direction[None]
            gap = np.linalg.norm(block[:, None, :] - foot, axis=2)
            best = np.argmin(gap, axis=1)
            rows = np.arange(len(block))
            feet[first : first + chunk] = foot[rows, best]
            distance[first : first + chunk] = gap[rows, best]
            segment[first : first + chunk] = best
            fraction[first : first + chunk] = t[rows, best]
        seg_length = np.sqrt(length2[segment])
        s = self.segment_start_s[segment] + fraction * seg_length
        return feet, distance, self.loop_of_segment[segment], s

    def closest(self, points: np.ndarray) -> np.ndarray:
        """(p, 3): the closest point on the design boundary of each point."""
        return self.locate(points)[0]

    def between(self, start: np.ndarray, end: np.ndarray, count: int) -> np.ndarray | None:
        """``count`` points evenly spaced along the design boundary from ``start`` to ``end``
        (the shorter way round their loop), or None when the two points do not lie on one loop.
        """
        _, distance, loop, s = self.locate(np.stack([start, end]))
        if loop[0] != loop[1]:
            return None
        total = self.loop_length[loop[0]]
        forward = (s[1] - s[0]) % total
        step = forward if forward <= total - forward else forward - total
        targets = s[0] + np.linspace(0.0, step, count)
        points = self._at(loop[0], targets % total)
        points[0], points[-1] = start, end
        return points

    def _at(self, loop: int, s: np.ndarray) -> np.ndarray:
        """Points of one loop at arc lengths ``s`` (in [0, loop length))."""
        first, last = self.first_segment[loop], self.first_segment[loop + 1]
        seg_s = self.segment_start_s[first:last]
        index = np.clip(np.searchsorted(seg_s, s, side="right") - 1, 0, last - first - 1)
        starts, ends = self.starts[first:last][index], self.ends[first:last][index]
        length = np.linalg.norm(ends - starts, axis=1)
        t = np.where(length > 0, (s - seg_s[index]) / np.where(length > 0, length, 1.0), 0.0)
        return starts + np.clip(t, 0.0, 1.0)[:, None] * (ends - starts)
