"""Arc fitting: a dense polyline as a few lines and circular arcs (DXF bulges).

Plasma controllers move along lines and arcs (G01/G02/G03); a contour of hundreds of tiny chords
cuts slower and rougher than the same contour as arcs, and CAM programs expect arcs in the
DXF. :func:`fit_arcs` walks the polyline greedily: from each vertex it takes the longest run of
vertices that one line or one arc holds within the tolerance (galloping, then bisection on the
run's end; each trial is one vectorised check), preferring a line where both fit.

An arc must hold every vertex of its run within the tolerance, turn one way only, and pass
within the tolerance plus the chord's own sagitta of every chord midpoint, so a sharp corner is
never rounded off.
"""

from __future__ import annotations

import numpy as np

#: largest distance of a polyline vertex from its fitted line or arc, mm
ARC_TOLERANCE = 0.02
#: an arc covers at least this many polyline segments (three points define any circle)
MIN_ARC_SEGMENTS = 3
#: largest turn between consecutive segments inside an arc, radians: a coarser polygon (a 16-gon
#: turns 22.5 degrees a vertex) keeps its corners even when they lie on a circle
MAX_ARC_TURN = np.radians(10.0)
#: largest sweep of one arc, radians (bulge at most tan(pi / 4) = 1: a half circle)
MAX_SWEEP = np.pi * 0.999


def _line_fits(points: np.ndarray, tolerance: float) -> bool:
    chord = points[-1] - points[0]
    length = np.hypot(*chord)
    if length < 1e-12:
        return False
    rel = points - points[0]
    return bool(np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]).max() / length <= tolerance)


def _arc_bulge(points: np.ndarray, tolerance: float) -> float | None:
    """The bulge of the arc through a run of points, or None when no arc holds them."""
    if len(points) < MIN_ARC_SEGMENTS + 1:
        return None
    a, m, b = points[0], points[len(points) // 2], points[-1]
    ab, am = b - a, m - a
    cross = ab[0] * am[1] - ab[1] * am[0]
    if abs(cross) < 1e-12:
        return None
    # circumcentre of a, m, b relative to a
    sq_ab, sq_am = ab @ ab, am @ am
    centre = a + np.array([am[1] * sq_ab - ab[1] * sq_am, ab[0] * sq_am - am[0] * sq_ab]) / (
        2 * cross
    )
    radius = np.hypot(*(a - centre))
    rel = points - centre
    if np.abs(np.hypot(rel[:, 0], rel[:, 1]) - radius).max() > tolerance:
        return None
    turns = np.arctan2(
        rel[:-1, 0] * rel[1:, 1] - rel[:-1, 1] * rel[1:, 0],
        np.einsum("ij,ij->i", rel[:-1], rel[1:]),
    )
    chords = np.diff(points, axis=0)
    bends = np.arctan2(
        chords[:-1, 0] * chords[1:, 1] - chords[:-1, 1] * chords[1:, 0],
        np.einsum("ij,ij->i", chords[:-1], chords[1:]),
    )
    if len(bends) and np.abs(bends).max() > MAX_ARC_TURN:
        return None
    if not (np.all(turns > 0) or np.all(turns < 0)):
        return None
    sweep = float(turns.sum())
    if abs(sweep) > MAX_SWEEP:
        return None
    middles = (points[:-1] + points[1:]) / 2 - centre
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    sagitta = chords**2 / (8 * radius)
    if np.any(np.abs(np.hypot(middles[:, 0], middles[:, 1]) - radius) > tolerance + sagitta):
        return None
    return float(np.tan(sweep / 4))


def _piece(points: np.ndarray, tolerance: float) -> float | None:
    """Bulge of one line (0.0) or arc holding the run, None when neither does."""
    if _line_fits(points, tolerance):
        return 0.0
    return _arc_bulge(points, tolerance)


def _longest_run(points: np.ndarray, start: int, tolerance: float) -> tuple[int, float]:
    """(end index, bulge) of the longest run from ``start`` one line or arc holds."""
    last = len(points) - 1
    good, bulge = start + 1, 0.0  # one segment always fits as a line
    bad = None
    step = 1
    while good < last and bad is None:
        trial = min(start + step + 1, last)
        step *= 2
        fitted = _piece(points[start : trial + 1], tolerance)
        if fitted is not None:
            good, bulge = trial, fitted
        elif trial - start >= MIN_ARC_SEGMENTS:
            bad = trial  # shorter runs may fail only for want of an arc
        if trial == last:
            break
    if bad is not None:
        while bad - good > 1:
            trial = (good + bad) // 2
            fitted = _piece(points[start : trial + 1], tolerance)
            if fitted is None:
                bad = trial
            else:
                good, bulge = trial, fitted
    return good, bulge


def fit_arcs(
    points: np.ndarray, closed: bool = True, tolerance: float = ARC_TOLERANCE
) -> tuple[np.ndarray, np.ndarray]:
    """Lines and arcs through a polyline.

    points : (n, 2) float, mm (a closed contour without its first point repeated).
    Returns ``vertices (m, 2)`` (a subset of the points) and ``bulges (m,)``: segment ``i`` runs
    from vertex ``i`` to vertex ``i + 1`` (for a closed contour the last one back to vertex 0)
    with DXF bulge ``tan(sweep / 4)`` (positive counter-clockwise, 0 for a line).
    """
    points = np.asarray(points, dtype=float)
    if not closed:
        vertices, bulges, _ = _fit_from(points, closed=False, tolerance=tolerance)
        return vertices, bulges
    # start at the sharpest corner; on a smooth contour that may lie inside an arc, so fit again
    # from the end of the first piece (where the greedy walk found a real break) and keep the
    # fit with fewer pieces
    before, after = points - np.roll(points, 1, axis=0), np.roll(points, -1, axis=0) - points
    turning = np.abs(
        np.arctan2(
            before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0],
            np.einsum("ij,ij->i", before, after),
        )
    )
    first = int(np.argmax(turning))
    best = _fit_from(np.roll(points, -first, axis=0), True, tolerance)
    second = (first + int(best[2][1])) % len(points) if len(best[2]) > 1 else first
    again = _fit_from(np.roll(points, -second, axis=0), True, tolerance)
    vertices, bulges, _ = min(best, again, key=lambda fit: len(fit[0]))
    return vertices, bulges


def _fit_from(
    points: np.ndarray, closed: bool, tolerance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Greedy fit from ``points[0]``; also returns the indices of the vertices kept."""
    if closed:
        points = np.concatenate([points, points[:1]])
    vertices, bulges, kept = [], [], []
    start = 0
    while start < len(points) - 1:
        end, bulge = _longest_run(points, start, tolerance)
        vertices.append(points[start])
        bulges.append(bulge)
        kept.append(start)
        start = end
    if not closed:
        vertices.append(points[-1])
        bulges.append(0.0)
        kept.append(len(points) - 1)
    return np.array(vertices), np.array(bulges), np.array(kept)


def bulge_polyline(
    vertices: np.ndarray, bulges: np.ndarray, closed: bool = True, chord_tolerance: float = 0.005
) -> np.ndarray:
    """(k, 2) float: lines and arcs back to a dense polyline (arcs within ``chord_tolerance``)."""
    count = len(vertices)
    out = []
    for i in range(count if closed else count - 1):
        a, b, bulge = vertices[i], vertices[(i + 1) % count], bulges[i]
        out.append(a[None])
        if bulge == 0.0:
            continue
        sweep = 4 * np.arctan(bulge)
        chord = b - a
        length = np.hypot(*chord)
        radius = length / (2 * abs(np.sin(sweep / 2)))
        # centre: from the chord's middle, along its left normal for a counter-clockwise arc
        normal = np.array([-chord[1], chord[0]]) / length
        centre = (a + b) / 2 + normal * radius * np.cos(sweep / 2) * np.sign(sweep)
        steps = max(
            int(np.ceil(abs(sweep) / (2 * np.arccos(max(1 - chord_tolerance / radius, -1.0))))), 1
        )
        start = np.arctan2(*(a - centre)[::-1])
        angles = start + sweep * np.arange(1, steps) / steps
        out.append(centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1))
    if not closed:
        out.append(vertices[-1][None])
    return np.concatenate(out)


__all__ = ["ARC_TOLERANCE", "bulge_polyline", "fit_arcs"]
