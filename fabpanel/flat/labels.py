"""Etched part labels: where the text goes on a flat part, and what it covers.

A label is a stack of text lines, ``(text, x, y, cap height, angle_deg)`` each. It is placed
in the part's free area (the outline less every hole, opening and drill hole, grown by
``LABEL_CLEARANCE``), as large as ``LABEL_HEIGHT`` allows, at the pole of inaccessibility where
the whole stack fits there; otherwise at the roomiest place where it does, shrinking it as far
as needed. A cut edge never crosses the etched strokes.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import polylabel

from ..data import FlatPart
from .strokefont import text_width

#: label cap height limits, mm (15-30 mm reads well on a shop floor)
LABEL_HEIGHT = (4.0, 30.0)
#: etched text keeps this clear of every hole and opening, mm (a cut edge would cross it)
LABEL_CLEARANCE = 3.0
#: line pitch of a stack, in cap heights
LINE_PITCH = 1.6
#: candidate centres tried per cap height when the stack does not fit at the pole
SEARCH_POINTS = 400
#: cap heights tried, from the largest that may fit down to the smallest readable
SEARCH_HEIGHTS = 8
#: halvings of the step between the last height that did not fit and the first that did
BISECTIONS = 5

Label = tuple[str, float, float, float, float]


def hole_areas(part: FlatPart, clearance: float) -> shapely.Geometry:
    """Every hole, opening and drill hole of a part, grown by ``clearance`` mm."""
    shapes = [Polygon(h).buffer(clearance) for h in part.holes]
    shapes += [
        Point(h.centre).buffer(h.diameter / 2 + clearance, quad_segs=8)
        for h in (*part.round_holes, *part.drill_holes)
    ]
    return shapely.union_all(shapes) if shapes else Polygon()


def label_boxes(labels) -> shapely.Geometry:
    """The area the etched labels cover, with a clear border of half a cap height."""
    return shapely.union_all(_line_boxes(labels))


def _line_boxes(labels) -> list[Polygon]:
    """One rectangle per text line: its strokes and a border of half a cap height."""
    boxes = []
    for text, x, y, height, angle in labels:
        half = np.array([text_width(text, height) / 2 + height / 2, 1.3 * height])
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
        turn = np.radians(angle)
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        boxes.append(Polygon(corners @ rotation.T + [x, y]))
    return boxes


def lines_around_labels(lines: np.ndarray, labels) -> np.ndarray:
    """(c', 2, 2) float: bend lines with the stretches under a label left out, so the etched
    text stays legible; pieces shorter than 5 mm are dropped."""
    if not len(lines) or not labels:
        return lines
    covered = label_boxes(labels)
    pieces = []
    for line in lines:
        rest = LineString(line).difference(covered)
        for piece in getattr(rest, "geoms", [rest]):
            if piece.length >= 5.0:
                pieces.append(np.asarray(piece.coords)[[0, -1]])
    return np.array(pieces).reshape(-1, 2, 2)


def place_labels(
    outline: np.ndarray,
    lines: list[str],
    angle: float | None = None,
    obstacles: shapely.Geometry | None = None,
) -> tuple[Label, ...]:
    """Stack text lines inside a polygon, clear of its obstacles.

    outline : (n, 2) float, mm. ``angle`` (degrees) defaults to the outline's principal axis.
    obstacles : what the text must keep clear of (holes, openings), already grown by the
        clearance wanted; the free area is the outline less these.
    Returns ``(text, x, y, height, angle_deg)`` per line, centred, cap height in ``LABEL_HEIGHT``.
    The stack sits at the pole of inaccessibility of the free area if it fits there whole;
    otherwise at the roomiest place it fits, as large as it can be; if it fits nowhere, at the
    pole at the smallest height (a part too small for legible text).
    """
    free = _free_area(outline, obstacles)
    if free.is_empty:
        return ()
    if angle is None:
        angle = _principal_angle(outline)
    pole = polylabel(free, tolerance=1.0)
    height = _height_at(free, pole, lines, angle)
    labels = _stack(lines, np.array(pole.coords[0]), height, angle)
    if _fits(free, labels):
        return labels
    return _searched(free, lines, angle) or _stack(
        lines, np.array(pole.coords[0]), LABEL_HEIGHT[0], angle
    )


def _free_area(outline: np.ndarray, obstacles: shapely.Geometry | None) -> Polygon:
    """The largest piece of the outline less the obstacles (the whole outline if none is
    left)."""
    polygon = Polygon(outline).buffer(0)
    if obstacles is not None and not polygon.is_empty:
        free = polygon.difference(obstacles)
        polygon = free if not free.is_empty else polygon
    if polygon.geom_type == "MultiPolygon":
        polygon = max(polygon.geoms, key=lambda g: g.area)
    return polygon


def _principal_angle(outline: np.ndarray) -> float:
    """Degrees in [-90, 90): the direction of the outline's longest extent."""
    centred = outline - outline.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    angle = float(np.degrees(np.arctan2(vt[0, 1], vt[0, 0])))
    return (angle + 90.0) % 180.0 - 90.0


def _height_at(free: Polygon, pole: Point, lines: list[str], angle: float) -> float:
    """The cap height a stack centred on ``pole`` may have: bounded by the depth there (to the
    outline; the holes bound the chord, and the stack is checked against them afterwards) and
    by the free chord along the text."""
    depth = max(free.exterior.distance(pole), 1e-6)
    direction = _direction(angle)
    span = 4.0 * np.sqrt(free.area) + 4 * depth
    centre = np.array(pole.coords[0])
    chord = LineString([centre - span * direction, centre + span * direction]).intersection(free)
    pieces = getattr(chord, "geoms", [chord])
    available = min((g.length for g in pieces if g.distance(pole) < 1e-6), default=2 * depth)
    longest = max(len(t) for t in lines)
    height = min(
        LABEL_HEIGHT[1],
        1.4 * depth / (LINE_PITCH * len(lines)),
        0.8 * available / max(text_width("X" * longest, 1.0), 1e-9),
    )
    return max(height, LABEL_HEIGHT[0])


def _direction(angle: float) -> np.ndarray:
    return np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])


def _stack(lines: list[str], centre: np.ndarray, height: float, angle: float) -> tuple[Label, ...]:
    """The lines stacked across the text direction, centred on ``centre``, first line on top."""
    direction = _direction(angle)
    normal = np.array([-direction[1], direction[0]])
    offsets = (np.arange(len(lines))[::-1] - (len(lines) - 1) / 2) * LINE_PITCH * height
    return tuple(
        (text, *(centre + off * normal).tolist(), float(height), float(angle))
        for text, off in zip(lines, offsets, strict=True)
    )


def _fits(free: Polygon, labels: tuple[Label, ...]) -> bool:
    return all(free.contains(box) for box in _line_boxes(labels))


def _searched(free: Polygon, lines: list[str], angle: float) -> tuple[Label, ...] | None:
    """The largest stack that fits whole somewhere in the free area (cap heights stepped down
    through ``LABEL_HEIGHT``, then bisected between the last that did not fit and the first that did),
    at the candidate centre deepest inside it; None when even the smallest height fits
    nowhere."""
    shapely.prepare(free)
    centres = _candidate_centres(free)
    if not len(centres):
        return None
    heights = np.geomspace(LABEL_HEIGHT[1], LABEL_HEIGHT[0], SEARCH_HEIGHTS)
    for step, height in enumerate(heights):
        fits = _fitting_centres(free, centres, lines, angle, height)
        if fits.any():
            break
    else:
        return None
    if step > 0:
        too_tall = heights[step - 1]
        for _ in range(BISECTIONS):
            middle = (too_tall + height) / 2
            better = _fitting_centres(free, centres, lines, angle, middle)
            if better.any():
                height, fits = middle, better
            else:
                too_tall = middle
    depth = shapely.distance(free.boundary, shapely.points(centres[fits]))
    return _stack(lines, centres[fits][np.argmax(depth)], float(height), angle)


def _fitting_centres(
    free: Polygon, centres: np.ndarray, lines: list[str], angle: float, height: float
) -> np.ndarray:
    """(c,) bool: whether the stack at this cap height, centred on each candidate, lies whole
    in the (prepared) free area."""
    fits = np.ones(len(centres), dtype=bool)
    for box in _line_boxes(_stack(lines, np.zeros(2), float(height), angle)):
        corners = np.asarray(box.exterior.coords)
        fits &= shapely.contains(free, shapely.polygons(corners[None] + centres[:, None]))
    return fits


def _candidate_centres(free: Polygon) -> np.ndarray:
    """(c, 2) float: a regular grid of points inside the free area, about ``SEARCH_POINTS``."""
    x0, y0, x1, y1 = free.bounds
    step = max(np.sqrt(free.area / SEARCH_POINTS), 0.5)
    x, y = np.meshgrid(np.arange(x0, x1 + step, step), np.arange(y0, y1 + step, step))
    points = np.column_stack([x.ravel(), y.ravel()])
    return points[shapely.contains_xy(free, points[:, 0], points[:, 1])]
