"""Panel sides of k x k sample grids and the planes of their ribs."""

from __future__ import annotations

import numpy as np

from ..geom.fitting import bestfit_planes


def panel_sides(grids: np.ndarray) -> np.ndarray:
    """The four sides of every panel grid, each from corner ``s`` to corner ``s + 1``.

    grids : (m, k, k, c) float (points or normals, see :class:`fabpanel.data.DevelopedPanels`)
    Returns (m, 4, k, c).
    """
    return np.stack([grids[:, :, 0], grids[:, -1, :], grids[:, ::-1, -1], grids[:, 0, ::-1]],
                    axis=1)


def side_planes(samples: np.ndarray, normals: np.ndarray, depth: float) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
    """Rib plane of every panel side: the plane through the side's samples and their normals.

    The plane is fitted to the side polyline and to the same polyline moved by ``depth`` (mm,
    the build-up depth) along its normals, so it holds the rib's top and bottom edge at once.
    Returns ``planes (m, 4, 4)`` as (nx, ny, nz, d) with the normal pointing into the panel, and
    ``residuals (m, 4)``: the largest distance of those points to the plane, mm (zero for a
    planar curvature-line side such as the arcs and generators of a cylinder).
    """
    m, k = samples.shape[:2]
    side_points = panel_sides(samples)                      # (m, 4, k, 3)
    side_normals = panel_sides(normals)
    cloud = np.concatenate([side_points, side_points - depth * side_normals], axis=2)
    plane_normals, offsets, residuals = bestfit_planes(cloud.reshape(m * 4, 2 * k, 3))
    plane_normals = plane_normals.reshape(m, 4, 3)
    offsets = offsets.reshape(m, 4)
    # orient each plane normal towards the panel's centre sample
    centre = samples[:, k // 2, k // 2]                     # (m, 3)
    inward = np.einsum("msi,mi->ms", plane_normals, centre) - offsets < 0
    plane_normals[inward] *= -1
    offsets[inward] *= -1
    planes = np.concatenate([plane_normals, offsets[..., None]], axis=2)
    return planes, residuals.reshape(m, 4)


def neighbour_sides(layout) -> tuple[np.ndarray, np.ndarray]:
    """The panel across every side and that panel's side index: ``(neighbour (m, 4),
    side (m, 4))``, both -1 on the boundary. The neighbour runs the shared side backwards."""
    quads = layout.quads
    neighbour = layout.side_neighbours
    other_side = np.full(neighbour.shape, -1, dtype=np.int64)
    shared = neighbour >= 0
    start = quads
    end = np.roll(quads, -1, axis=1)
    for t in range(4):
        q = np.where(shared, neighbour, 0)
        match = shared & (quads[q, t] == end) & (quads[q, (t + 1) % 4] == start)
        other_side[match] = t
    return neighbour, other_side


def across_sides(layout, grids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each panel side's samples and the neighbour's samples of the same side, aligned.

    grids : (m, k, k, c). Returns ``own (m, 4, k, c)`` and ``theirs (m, 4, k, c)`` (NaN on the
    boundary), point for point along the side.
    """
    neighbour, other_side = neighbour_sides(layout)
    own = panel_sides(grids)
    theirs = np.full_like(own, np.nan)
    shared = neighbour >= 0
    theirs[shared] = own[neighbour[shared], other_side[shared]][:, ::-1]
    return own, theirs


def side_gaps_and_kinks(layout, samples: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
    """Largest gap (mm) and kink angle (degrees) between every panel side and its neighbour's
    copy of it; (m, 4) each, 0 on the boundary."""
    own, theirs = across_sides(layout, samples)
    gaps = np.nan_to_num(np.linalg.norm(own - theirs, axis=-1).max(axis=-1))
    own_n, theirs_n = across_sides(layout, normals)
    cosine = np.clip((own_n * theirs_n).sum(-1), -1.0, 1.0)
    kinks = np.nan_to_num(np.degrees(np.arccos(cosine)).max(axis=-1))
    return gaps, kinks
