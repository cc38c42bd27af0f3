"""The design boundary as closed 3D polylines: closest points on it, and the stretch of it
between two boundary vertices of a layout.

A panel side on the design boundary must follow the boundary, rounded corners included, not
the chord between its two corners; the develop stage takes its samples from
:meth:`DesignBoundary.between`.
"""

from __future__ import annotations

import numpy as np

from ..data import PanelLayout, Surface
from ..geom.quads import side_index
from .folds import fold_ends

#: (point, segment) pairs evaluated at once
_CHUNK_PAIRS = 2_000_000
#: a boundary vertex turning more than this (degrees) is a corner: the smooth curve kinks there
CORNER_TURN = 30.0
#: points per boundary segment in the smooth curve
_SMOOTH_DENSITY = 8


def smooth_loop(points: np.ndarray, breaks: np.ndarray | None = None) -> np.ndarray:
    """The closed boundary polyline as the smooth curve it samples: cubic splines through its
    vertices (chord-length parameters), one per stretch between corners, periodic without them.
    ``breaks``: indices of further vertices where the curve kinks (the ends of the surface's
    fold lines).

    A mesh's boundary is a polyline whose chords cut inside a rounded outline by the sagitta
    (5 mm for 0.3 m segments on a 2 m radius); the spline through the same vertices, which lie
    on the design outline, is within a fraction of a millimetre of it. Where a fold meets the
    boundary the outline kinks in 3D without turning much in plan: one spline across a 6°
    fold, through the two ends of a straight 4.7 m edge (all its tessellation has), sagged
    81 mm below it.
    """
    from scipy.interpolate import CubicSpline

    n = len(points)
    if n < 4:
        return points
    incoming = points - np.roll(points, 1, axis=0)
    outgoing = np.roll(points, -1, axis=0) - points
    cos = np.einsum("ij,ij->i", incoming, outgoing) / np.maximum(
        np.linalg.norm(incoming, axis=1) * np.linalg.norm(outgoing, axis=1), 1e-300
    )
    turning = np.degrees(np.arccos(np.clip(cos, -1, 1))) > CORNER_TURN
    if breaks is not None:
        turning[np.asarray(breaks, dtype=np.int64)] = True
    corners = np.flatnonzero(turning)
    if not len(corners):
        closed = np.vstack([points, points[:1]])
        return _spline_points(CubicSpline, closed, "periodic")[:-1]
    pieces = []
    for start, end in zip(corners, [*corners[1:], corners[0] + n]):
        run = points[np.arange(start, end + 1) % n]
        pieces.append(_spline_points(CubicSpline, run, "not-a-knot" if len(run) > 3 else None)[:-1])
    return np.concatenate(pieces)


def _spline_points(spline, run: np.ndarray, condition: str | None) -> np.ndarray:
    """Dense points of a cubic spline through ``run`` (``None``: the straight polyline)."""
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(run, axis=0), axis=1))])
    keep = np.concatenate([[True], np.diff(chord) > 0])
    run, chord = run[keep], chord[keep]
    fine = np.interp(
        np.linspace(0, len(run) - 1, (len(run) - 1) * _SMOOTH_DENSITY + 1),
        np.arange(len(run)),
        chord,
    )
    if condition is None or len(run) < 4:
        return np.column_stack([np.interp(fine, chord, run[:, i]) for i in range(3)])
    return spline(chord, run, axis=0, bc_type=condition)(fine)


class DesignBoundary:
    """The boundary loops of a surface, parametrised by arc length."""

    def __init__(self, surface: Surface | None = None, loops: list[np.ndarray] | None = None):
        """The surface's boundary loops as smooth curves, or the given closed polylines (any
        dimension, taken as they are)."""
        if surface is not None:
            ends = fold_ends(surface.folds)
            loops = [
                smooth_loop(surface.vertices[loop], np.flatnonzero(np.isin(loop, ends)))
                for loop in surface.boundary_loops
            ]
        loops = loops or []
        self.dim = loops[0].shape[1] if loops else 3
        self.loops = loops
        self.starts = np.concatenate(loops) if loops else np.zeros((0, self.dim))
        self.ends = (
            np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
            if loops
            else np.zeros((0, self.dim))
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
        points = np.asarray(points, dtype=float).reshape(-1, self.dim)
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
        _, _, loop, s = self.locate(np.stack([start, end]))
        if loop[0] != loop[1]:
            return None
        total = self.loop_length[loop[0]]
        forward = (s[1] - s[0]) % total
        step = forward if forward <= total - forward else forward - total
        targets = s[0] + np.linspace(0.0, step, count)
        points = self.at(loop[0], targets % total)
        points[0], points[-1] = start, end
        return points

    def on_stretches(self, pairs: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(n,) bool: which of ``points (n, 3)`` (on the boundary) lie on the boundary between
        the two points of any of ``pairs (p, 2, 3)``, the shorter way round their loop."""
        inside = np.zeros(len(points), dtype=bool)
        if not len(pairs) or not len(points):
            return inside
        _, _, loop, s = self.locate(points)
        _, _, ends_loop, ends_s = self.locate(pairs.reshape(-1, 3))
        for (la, lb), (sa, sb) in zip(ends_loop.reshape(-1, 2), ends_s.reshape(-1, 2)):
            if la != lb:
                continue
            total = self.loop_length[la]
            forward = (sb - sa) % total
            start, length = (sa, forward) if forward <= total - forward else (sb, total - forward)
            inside |= (loop == la) & ((s - start) % total <= length)
        return inside

    def at(self, loop: int, s: np.ndarray) -> np.ndarray:
        """Points of one loop at arc lengths ``s`` (in [0, loop length))."""
        first, last = self.first_segment[loop], self.first_segment[loop + 1]
        seg_s = self.segment_start_s[first:last]
        index = np.clip(np.searchsorted(seg_s, s, side="right") - 1, 0, last - first - 1)
        starts, ends = self.starts[first:last][index], self.ends[first:last][index]
        length = np.linalg.norm(ends - starts, axis=1)
        t = np.where(length > 0, (s - seg_s[index]) / np.where(length > 0, length, 1.0), 0.0)
        return starts + np.clip(t, 0.0, 1.0)[:, None] * (ends - starts)


#: points per sample interval when a side's samples are interpolated (the sheets are smooth
#: B-spline surfaces through the samples, not polylines)
_DENSITY = 8


def boundary_sides_as_curves(
    layout: PanelLayout, samples: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(b, (k - 1) * 8 + 1, 3): the sample rows of every panel side on the layout's boundary,
    interpolated by a cubic spline (chord-length parameters), as the sheets' edges run; and
    (b, 2) int, the panel and side of each."""
    from scipy.interpolate import CubicSpline

    k = samples.shape[1]
    neighbours = layout.side_neighbours
    curves, sides = [], []
    for panel, side in zip(*np.nonzero(neighbours < 0)):
        rows, cols = side_index(k, int(side))
        points = samples[panel][rows, cols]
        chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        if chord[-1] <= 0:
            continue
        fine = np.linspace(0.0, chord[-1], (k - 1) * _DENSITY + 1)
        curves.append(CubicSpline(chord, points, axis=0)(fine))
        sides.append((panel, side))
    return (
        np.asarray(curves).reshape(-1, (k - 1) * _DENSITY + 1, 3),
        np.asarray(sides, dtype=np.int64).reshape(-1, 2),
    )


def boundary_deviation(
    layout: PanelLayout,
    samples: np.ndarray,
    surface: Surface,
    chords: np.ndarray | None = None,
) -> dict:
    """How far the panels' boundary sides lie from the design boundary, mm, both ways.

    ``design_to_panels``: largest distance from a design boundary vertex to the nearest
    boundary side (interpolated through its samples); ``panels_to_design``: largest distance
    from a point of those sides to the design boundary. Empty for closed surfaces.
    ``chords`` (m, 4) bool marks the sides that cut the chord across the design boundary on
    purpose (a planar rib cannot follow it there): ``followed`` then gives both figures without
    them and the stretches of the design boundary they cut across.
    """
    from ..geom.polygon import point_segment_distances

    curves, sides = boundary_sides_as_curves(layout, samples)
    if not surface.boundary_loops or not len(curves):
        return {}
    design = DesignBoundary(surface)
    n = curves.shape[1] - 1
    starts, ends = curves[:, :-1].reshape(-1, 3), curves[:, 1:].reshape(-1, 3)
    to_panels = point_segment_distances(design.starts, starts, ends)
    _, to_design, _, _ = design.locate(curves.reshape(-1, 3))
    result: dict = {
        "design_to_panels": round(float(to_panels.max()), 3),
        "panels_to_design": round(float(to_design.max()), 3),
    }
    if chords is not None and chords.any():
        chorded = chords[sides[:, 0], sides[:, 1]]
        ends = curves[chorded][:, [0, -1]]
        followed_design = ~design.on_stretches(ends, design.starts)
        followed_panels = np.repeat(~chorded, n + 1)
        result["followed"] = {
            "design_to_panels": round(float(to_panels[followed_design].max(initial=0.0)), 3),
            "panels_to_design": round(float(to_design[followed_panels].max(initial=0.0)), 3),
        }
    return result
