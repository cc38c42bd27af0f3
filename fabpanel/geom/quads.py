"""Quad-grid kernels: bilinear patches, grid-line curvature, discrete Gaussian curvature."""

from __future__ import annotations

import numpy as np


def bilinear_grid(corners: np.ndarray, k: int) -> np.ndarray:
    """Bilinear k x k grids spanned by quad corners.

    corners : (m, 4, c) float, corners ``c0..c3`` counter-clockwise.
    Returns (m, k, k, c) with ``[:, 0, 0] = c0``, ``[:, -1, 0] = c1``, ``[:, -1, -1] = c2``,
    ``[:, 0, -1] = c3`` (the :class:`fabpanel.data.DevelopedPanels` convention). Points along a
    side depend only on that side's two corners, so neighbouring panels get identical side
    samples.
    """
    s = np.linspace(0.0, 1.0, k)
    a = s[:, None, None]  # along side 0 (c0 -> c1)
    b = s[None, :, None]  # along side 3 reversed (c0 -> c3)
    c0, c1, c2, c3 = (corners[:, i, None, None, :] for i in range(4))
    return (1 - a) * (1 - b) * c0 + a * (1 - b) * c1 + a * b * c2 + (1 - a) * b * c3


def side_index(k: int, side: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i, j) into a k x k panel grid (:func:`bilinear_grid`'s convention) of side
    ``side``, from corner ``side`` to corner ``side + 1``."""
    r, last = np.arange(k), np.full(k, k - 1)
    first = np.zeros(k, dtype=int)
    return [(r, first), (last, r), (r[::-1], last), (first, r[::-1])][side]


def circumradii(points: np.ndarray) -> np.ndarray:
    """Radius of the circle through each consecutive point triple along axis -2.

    points : (..., n, 3) float. Returns (..., n - 2) float (``inf`` for collinear triples).
    """
    a, b, c = points[..., :-2, :], points[..., 1:-1, :], points[..., 2:, :]
    ab = np.linalg.norm(b - a, axis=-1)
    bc = np.linalg.norm(c - b, axis=-1)
    ca = np.linalg.norm(a - c, axis=-1)
    twice_area = np.linalg.norm(np.cross(b - a, c - a), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = ab * bc * ca / (2.0 * twice_area)
    return np.where(twice_area > 1e-12 * np.maximum(ab * bc, 1e-300), radius, np.inf)


def grid_triangles(a: int, b: int) -> np.ndarray:
    """(2 (a-1)(b-1), 3) int: triangles of an a x b grid with vertex index ``i * b + j``,
    oriented so that their right-hand normal is ``d_i x d_j``."""
    i, j = np.meshgrid(np.arange(a - 1), np.arange(b - 1), indexing="ij")
    v00 = (i * b + j).ravel()
    v10, v01, v11 = v00 + b, v00 + 1, v00 + b + 1
    return np.concatenate([np.stack([v00, v10, v11], 1), np.stack([v00, v11, v01], 1)])


def angle_defects(grid: np.ndarray) -> np.ndarray:
    """Angle defect (2 pi minus the sum of corner angles) at the interior vertices of grids.

    grid : (m, a, b, 3) float. Returns (m, a - 2, b - 2): the integral of Gaussian curvature over
    each interior vertex's area (zero for a developable grid with planar faces, up to sampling).
    """
    m, a, b, _ = grid.shape
    tris = grid_triangles(a, b)
    pts = grid.reshape(m, a * b, 3)
    sums = np.zeros((m, a * b))
    for corner in range(3):
        p = pts[:, tris[:, corner]]
        q = pts[:, tris[:, (corner + 1) % 3]] - p
        r = pts[:, tris[:, (corner + 2) % 3]] - p
        cos = np.einsum("mti,mti->mt", q, r) / (
            np.linalg.norm(q, axis=-1) * np.linalg.norm(r, axis=-1)
        )
        angles = np.arccos(np.clip(cos, -1.0, 1.0))
        # numpy's stubs for ufunc.at omit the documented tuple-with-slices index
        np.add.at(sums, (slice(None), tris[:, corner]), angles)  # type: ignore[arg-type]
    defects = 2 * np.pi - sums.reshape(m, a, b)
    return defects[:, 1:-1, 1:-1]


def coons_patch(
    side0: np.ndarray, side1: np.ndarray, side2: np.ndarray, side3: np.ndarray
) -> np.ndarray:
    """Bilinearly blended Coons patches (Coons 1967) through four boundary polylines.

    side0 : (..., a, 3) from c0 to c1; side1 : (..., b, 3) from c1 to c2;
    side2 : (..., a, 3) from c2 to c3; side3 : (..., b, 3) from c3 to c0 (counter-clockwise,
    as :meth:`fabpanel.data.DevelopedPanels.side_samples`). Corners must agree.
    Returns (..., a, b, 3) with ``[..., i, j]`` following the DevelopedPanels grid convention;
    the patch's boundary rows are exactly the given sides.
    """
    a, b = side0.shape[-2], side1.shape[-2]
    bottom = side0  # j = 0, i from c0 to c1
    top = side2[..., ::-1, :]  # j = b-1, i from c3 to c2
    left = side3[..., ::-1, :]  # i = 0, j from c0 to c3
    right = side1  # i = a-1, j from c1 to c2
    s = np.linspace(0.0, 1.0, a)[:, None, None]
    t = np.linspace(0.0, 1.0, b)[None, :, None]
    ruled_s = (1 - t) * bottom[..., :, None, :] + t * top[..., :, None, :]
    ruled_t = (1 - s) * left[..., None, :, :] + s * right[..., None, :, :]
    c0, c1 = bottom[..., :1, None, :], bottom[..., -1:, None, :]
    c3, c2 = top[..., :1, None, :], top[..., -1:, None, :]
    corners = (1 - s) * (1 - t) * c0 + s * (1 - t) * c1 + (1 - s) * t * c3 + s * t * c2
    patch = ruled_s + ruled_t - corners
    # keep the boundary rows bit-identical to the given sides
    patch[..., :, 0, :], patch[..., :, -1, :] = bottom, top
    patch[..., 0, :, :], patch[..., -1, :, :] = left, right
    return patch


def resample_polylines(polylines: np.ndarray, count: int) -> np.ndarray:
    """Resample polylines evenly by arc length, ends kept.

    polylines : (e, n, 3) float. Returns (e, count, 3).
    """
    steps = np.linalg.norm(np.diff(polylines, axis=1), axis=2)
    cumulative = np.concatenate([np.zeros((len(polylines), 1)), np.cumsum(steps, axis=1)], axis=1)
    targets = np.linspace(0.0, 1.0, count)[None, :] * cumulative[:, -1:]
    # index of the segment holding each target, then linear interpolation inside it
    seg = np.clip(
        np.array([np.searchsorted(c, t, side="right") - 1 for c, t in zip(cumulative, targets)]),
        0,
        polylines.shape[1] - 2,
    )
    rows = np.arange(len(polylines))[:, None]
    start, length = cumulative[rows, seg], steps[rows, seg]
    frac = np.where(length > 0, (targets - start) / np.where(length > 0, length, 1.0), 0.0)
    points = polylines[rows, seg] + frac[..., None] * (
        polylines[rows, seg + 1] - polylines[rows, seg]
    )
    points[:, 0], points[:, -1] = polylines[:, 0], polylines[:, -1]
    return points


def _midpoints_along(grid: np.ndarray, axis: int) -> np.ndarray:
    """Midpoints between consecutive samples along ``axis`` by the four-point interpolatory rule
    (Dubuc 1986; exact for cubics), with the three-point quadratic rule at the two ends."""
    g = np.moveaxis(grid, axis, 0)
    n = g.shape[0]
    if n < 3:
        return np.moveaxis(0.5 * (g[:-1] + g[1:]), 0, axis)
    mids = np.empty((n - 1, *g.shape[1:]))
    mids[0] = (3 * g[0] + 6 * g[1] - g[2]) / 8
    mids[-1] = (3 * g[-1] + 6 * g[-2] - g[-3]) / 8
    if n > 3:
        mids[1:-1] = (-g[:-3] + 9 * g[1:-2] + 9 * g[2:-1] - g[3:]) / 16
    return np.moveaxis(mids, 0, axis)


def cell_centres(grids: np.ndarray) -> np.ndarray:
    """Centres of the cells of smooth sample grids, (m, a, b, 3) -> (m, a-1, b-1, 3).

    Interpolated by the four-point rule in both directions: the point of a smooth surface through
    the samples, not the chord midpoint (which lies ``h**2 / (8 R)`` inside a curved surface).
    """
    return _midpoints_along(_midpoints_along(grids, 1), 2)
