"""Bending instructions for an unrolled sheet: rulings (bend lines), roll direction, radii.

A developable sheet is rolled along its rulings: straight lines on the surface that stay straight
in the flat, along which the sheet does not bend. They are found from the shape operator
expressed in the flat (isometric) coordinates of the unrolled grid,

    S = -R^T D,    R = dr/d(x, y),    D = dn/d(x, y),

whose eigenvector of the smaller curvature is the ruling and whose other eigenvalue is the
bending curvature, signed against the face the flat layout is seen from (the outer face: the
layout keeps the orientation of ``d_i x d_j``). A negative curvature bends the sheet's edges away
from that face, so the face seen in the drawing ends up convex.

Rulings are not grid lines in general (the optimiser moves the grid freely), so the bend lines
are laid at evenly spaced stations across the sheet, each through the middle of the sheet at its
station. The local ruling direction there points it; then the line is turned about that point
until the surface normals sampled along its whole length agree best (a developable surface's
normal is constant along a ruling), which is far more precise over a long line than the local
finite-difference estimate. Lines are clipped to the outline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator
from scipy.optimize import minimize_scalar
from scipy.stats import theilslopes
from shapely.geometry import LineString, Point, Polygon

#: number of bend lines etched on a single-curved sheet
BEND_LINES = 5
#: a sheet counts as flat when its largest bending sagitta over its diagonal is below this, mm
FLAT_SAGITTA = 0.5
#: beyond this ratio of largest to smallest radius only the smallest is etched (``R934+``)
OPEN_RADIUS_RATIO = 10.0
#: a bend line is turned by at most this much (radians) from the local ruling direction when
#: it is fitted along its whole length
REFINE_ANGLE = 0.1
#: share of a bend line at either end where its radius is not read (see ``bending_of``)
EDGE_MARGIN = 0.1
#: a sheet counts as single-curved when its typical smaller curvature is below this share of
#: its typical bending curvature (when its unroll strain is not known)
SINGLE_CURVED_RATIO = 0.1


@dataclass(frozen=True)
class Bending:
    """How an unrolled sheet is formed.

    form : "flat" | "single" | "double" | "unknown"
        flat: no rolling; single: rolled along ``lines``; double: not developable, no bend lines;
        unknown: the sheet is too degenerate to tell (a sliver), no bend lines.
    lines : (c, 2, 2) float
        bend lines (rulings) in the flat frame, mm.
    radii : (c, 2) float
        smallest and largest bending radius along each bend line, mm (equal on a cylinder; a
        cone's radius grows away from its apex).
    convex : bool
        True when the face seen in the flat layout (the outer face) becomes convex.
    """

    form: str
    lines: np.ndarray
    radii: np.ndarray
    convex: bool

    def smallest_radius(self) -> float:
        """The tightest bending radius of a single-curved sheet, mm (0 otherwise)."""
        if self.form != "single" or not len(self.radii):
            return 0.0
        return float(self.radii[:, 0].min())

    def largest_radius(self) -> float:
        """The widest bending radius of a single-curved sheet along its bend lines, mm (0
        otherwise)."""
        if self.form != "single" or not len(self.radii):
            return 0.0
        return float(self.radii[:, 1].max())

    def instruction(self) -> str:
        """The etched forming instruction: ``OUT CONVEX R4000`` (cylinder), ``OUT CONCAVE
        R866-1501`` (a cone's radii along its rulings), ``OUT CONVEX R934+`` (from R934 opening
        out to nearly flat), ``OUT FLAT``, ``OUT DOUBLE CURVED``."""
        if self.form == "flat":
            return "OUT FLAT"
        if self.form == "double":
            return "OUT DOUBLE CURVED"
        if self.form == "unknown":
            return "OUT"
        if not len(self.radii):
            return f"OUT {'CONVEX' if self.convex else 'CONCAVE'}"
        low, high = round(self.radii[:, 0].min()), round(self.radii[:, 1].max())
        if high - low <= max(0.01 * low, 1):
            radius = f"R{low}"
        elif high <= OPEN_RADIUS_RATIO * low:
            radius = f"R{low}-{high}"
        else:  # opens out to nearly flat: the tightest radius
            radius = f"R{low}+"
        return f"OUT {'CONVEX' if self.convex else 'CONCAVE'} {radius}"


def _solve2(jacobian: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """(m, 3, 2): ``columns (m, 3, 2)`` times the inverse of ``jacobian (m, 2, 2)``."""
    return columns @ np.linalg.inv(jacobian)


def curvature_field(grid: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Principal directions and curvatures of a sampled surface in flat coordinates.

    grid : (a, b, 3) float, the surface samples, mm; uv : (a, b, 2) float, their flat positions.
    Returns ``ruling (a, b, 2)`` unit flat direction of the smaller |curvature|,
    ``bending (a, b)`` the other principal curvature (1/mm, signed: negative bends away from the
    ``d_i x d_j`` side), ``residual (a, b)`` the smaller curvature (1/mm, zero when developable).
    """
    r_i, r_j = np.gradient(grid, axis=(0, 1), edge_order=2)
    normal = np.cross(r_i, r_j)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    n_i, n_j = np.gradient(normal, axis=(0, 1), edge_order=2)
    u_i, u_j = np.gradient(uv, axis=(0, 1), edge_order=2)
    jacobian = np.stack([u_i, u_j], axis=-1).reshape(-1, 2, 2)
    position = _solve2(jacobian, np.stack([r_i, r_j], axis=-1).reshape(-1, 3, 2))
    turning = _solve2(jacobian, np.stack([n_i, n_j], axis=-1).reshape(-1, 3, 2))
    shape = -np.swapaxes(position, 1, 2) @ turning
    shape = (shape + np.swapaxes(shape, 1, 2)) / 2
    values, vectors = np.linalg.eigh(shape)
    small = np.argmin(np.abs(values), axis=1)
    rows = np.arange(len(values))
    ruling = vectors[rows, :, small]
    bending = values[rows, 1 - small]
    residual = values[rows, small]
    a, b = grid.shape[:2]
    return ruling.reshape(a, b, 2), bending.reshape(a, b), residual.reshape(a, b)


def _doubled(direction: np.ndarray) -> np.ndarray:
    """Directions as (cos 2t, sin 2t): a line's direction without its sign, for averaging."""
    angle = np.arctan2(direction[..., 1], direction[..., 0])
    return np.stack([np.cos(2 * angle), np.sin(2 * angle)], axis=-1)


def _undoubled(doubled: np.ndarray) -> np.ndarray:
    angle = np.arctan2(doubled[..., 1], doubled[..., 0]) / 2
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _chord(seed: np.ndarray, angle: float, polygon: Polygon, reach: float) -> np.ndarray | None:
    """(2, 2) float: the piece of the line through ``seed`` at ``angle`` inside the polygon."""
    direction = np.array([np.cos(angle), np.sin(angle)])
    cut = LineString([seed - reach * direction, seed + reach * direction]).intersection(polygon)
    pieces = [g for g in getattr(cut, "geoms", [cut]) if g.length > 0]
    if not pieces:
        return None
    piece = min(pieces, key=lambda g: g.distance(Point(seed)))
    return np.asarray(piece.coords)[[0, -1]]


def _normal_spread(
    seed: np.ndarray, angle: float, polygon: Polygon, reach: float, normals: LinearNDInterpolator
) -> float:
    """How much the surface normal varies along the chord through ``seed`` at ``angle``."""
    ends = _chord(seed, angle, polygon, reach)
    if ends is None:
        return np.inf
    along = np.linspace(0.02, 0.98, 25)[:, None]
    sampled = normals(ends[0] + along * (ends[1] - ends[0]))
    sampled = sampled[np.all(np.isfinite(sampled), axis=1)]
    if len(sampled) < 2:
        return np.inf
    return float(((sampled - sampled.mean(axis=0)) ** 2).sum(axis=1).mean())


def _radius_range(along: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(2,) float: the smallest and largest radius along a bend line from its samples
    ``radius`` at positions ``along``: a straight line through them by Theil and Sen (a
    cone's radius grows linearly along its ruling; a cylinder's is constant) read at the
    line's ends (0 and 1), so that a few samples spoiled near a corner (a third of them may
    be) do not set the instruction."""
    slope, intercept, _, _ = theilslopes(radius, along, method="joint")
    ends = intercept + slope * np.array([0.0, 1.0])
    if ends.min() <= 0:  # the fit does not hold: the middle radius both ways
        ends = np.full(2, np.median(radius))
    return np.sort(ends)


def bending_of(
    grid: np.ndarray,
    uv: np.ndarray,
    outline: np.ndarray,
    count: int = BEND_LINES,
    developable: bool | None = None,
) -> Bending:
    """Classify a sheet and lay its bend lines (see the module docstring).

    developable : whether the sheet unrolled within the job's strain tolerance, when known.
        That decides single against double curvature: it is the shop's criterion (what rolls
        onto its ribs within tolerance is rolled), and the ratio of the principal curvatures
        (used when it is not known) calls a gently curved sheet double-curved where its
        residual curvature is a few millimetres of sagitta (a 1.6 m sheet rolled at R 15 m
        with 1/75 m left over: 4 mm, unrolling at 1e-4 strain)."""
    ruling, bending, residual = curvature_field(grid, uv)
    diagonal = float(np.linalg.norm(np.ptp(uv.reshape(-1, 2), axis=0)))
    big = np.abs(bending)
    if big.max() * diagonal**2 / 8 < FLAT_SAGITTA:
        return Bending("flat", np.zeros((0, 2, 2)), np.zeros((0, 2)), False)
    if developable is None:
        double = bool(np.median(np.abs(residual)) > SINGLE_CURVED_RATIO * np.median(big))
    else:
        double = not developable
    if double:
        return Bending(
            "double", np.zeros((0, 2, 2)), np.zeros((0, 2)), bool(np.median(bending) < 0)
        )
    points = uv.reshape(-1, 2)
    doubled = _doubled(ruling.reshape(-1, 2))
    # where the sheet hardly bends its ruling direction is noise: weight by curvature
    weights = big.reshape(-1)
    field = LinearNDInterpolator(points, np.column_stack([doubled * weights[:, None], weights]))
    nearest = NearestNDInterpolator(points, np.column_stack([doubled * weights[:, None], weights]))
    curvature = LinearNDInterpolator(points, bending.reshape(-1))
    normal = np.cross(*np.gradient(grid, axis=(0, 1), edge_order=2))
    normals = LinearNDInterpolator(
        points, (normal / np.linalg.norm(normal, axis=-1, keepdims=True)).reshape(-1, 3)
    )
    mean_ruling = _undoubled((doubled * weights[:, None]).sum(axis=0))
    across = np.array([-mean_ruling[1], mean_ruling[0]])
    polygon = Polygon(outline)
    station = outline @ across
    lines, radii = [], []
    reach = 2.0 * diagonal
    for s in np.linspace(station.min(), station.max(), count + 2)[1:-1]:
        base = s * across
        cross = LineString([base - reach * mean_ruling, base + reach * mean_ruling]).intersection(
            polygon
        )
        pieces = [g for g in getattr(cross, "geoms", [cross]) if g.length > 0]
        if not pieces:
            continue
        seed = np.asarray(
            max(pieces, key=lambda g: g.length).interpolate(0.5, normalized=True).coords[0]
        )
        value = field(seed[None])[0]
        if not np.all(np.isfinite(value)):
            value = nearest(seed[None])[0]
        direction = _undoubled(value[:2])
        # the local estimate points the line; the whole line then sets it: along a ruling the
        # normal does not change, so turn the line about its seed until the normals sampled
        # along it agree best
        angle = float(np.arctan2(direction[1], direction[0]))
        found = minimize_scalar(
            lambda a, s=seed: _normal_spread(s, a, polygon, reach, normals),
            bounds=(angle - REFINE_ANGLE, angle + REFINE_ANGLE),
            method="bounded",
            options={"xatol": 1e-6},
        )
        ends = _chord(seed, float(found.x), polygon, reach)
        if ends is None:
            continue
        # the radius is read inside the sheet: at the outline the field's one-sided
        # differences, and at a corner near 180 degrees its singular flat map, give spikes
        # (R 1 m read on a sheet rolled at R 15 m)
        along = np.linspace(EDGE_MARGIN, 1.0 - EDGE_MARGIN, 11)[:, None]
        samples = curvature(ends[0] + along * (ends[1] - ends[0]))
        kept = np.isfinite(samples)
        if kept.sum() < 3 or np.abs(samples[kept]).min() < 1e-12:
            continue
        lines.append(ends)
        radii.append(_radius_range(along[kept, 0], 1.0 / np.abs(samples[kept])))
    convex = bool(np.median(bending[np.abs(bending) > 0.5 * big.max()]) < 0)
    return Bending(
        "single", np.array(lines).reshape(-1, 2, 2), np.array(radii).reshape(-1, 2), convex
    )


__all__ = ["Bending", "bending_of", "curvature_field"]
