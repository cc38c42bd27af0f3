"""Panel sides of k x k sample grids and the planes of their ribs."""

from __future__ import annotations

import numpy as np

from ..errors import Issue
from ..geom.fitting import bestfit_planes
from ..tolerances import TOLERANCES

#: neighbouring sheets whose normals differ by more than this (degrees) along their common
#: side are folded onto each other: the input refuses creases far gentler than this, so it is
#: never the design's own
FOLDED_KINK = 90.0


def panel_sides(grids: np.ndarray) -> np.ndarray:
    """The four sides of every panel grid, each from corner ``s`` to corner ``s + 1``.

    grids : (m, k, k, c) float (points or normals, see :class:`fabpanel.data.DevelopedPanels`)
    Returns (m, 4, k, c).
    """
    return np.stack(
        [grids[:, :, 0], grids[:, -1, :], grids[:, ::-1, -1], grids[:, 0, ::-1]], axis=1
    )


#: a side that lies this close (mm) to the plane through its own direction and its mean normal
#: gets that plane: its rib stands square to the sheet. Otherwise the side is curved enough to
#: fix its own plane (the sheet edge must lie on the rib), and the rib takes that plane
SQUARE_RIB_FIT = 0.05


def largest_rib_lean() -> float:
    """Degrees: the most a boundary rib may lean from square to its sheet and still be built.
    Leaning ``a``, it meets the bottom sheet ``depth x tan(a)`` along the sheet from the top
    sheet's edge, and the build slides a sheet edge at most ``trim_slide x depth`` to reach its
    rib (45 degrees at the default 1.0); nor may it lie within ``rib_tangent_deg`` of the sheet."""
    slide = float(np.degrees(np.arctan(TOLERANCES.trim_slide)))
    return min(90.0 - TOLERANCES.rib_tangent_deg, slide)


def side_planes(
    samples: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rib plane of every panel side, with how well the side and its normals lie in it.

    The plane holds the sheet edge: the best-fitting plane of the side's samples, or, where the
    side is nearly straight and leaves that plane undetermined, the plane through the side's
    direction and its mean normal (``SQUARE_RIB_FIT``). That square plane is also taken where
    the best-fitting one leans more than ``TOLERANCES.square_rib_lean_deg`` from square to the
    sheet and the side lies within ``TOLERANCES.rib_edge`` of the square one.
    Returns ``planes (m, 4, 4)`` as (nx, ny, nz, d) with the normal pointing into the panel;
    ``edge_residuals (m, 4)``: the largest distance of a side sample from its plane, mm; and
    ``normal_angles (m, 4)``: the largest angle between a normal along the side (corners
    excluded: the ribs are trimmed against each other there) and the plane, degrees: the rib
    stands that much off square to the sheet; ``bevel_twist (m, 4)``: how much that angle varies
    along the side, degrees. The twist is zero exactly where the side is a planar curvature line
    (Joachimsthal): the arcs and generators of a cylinder (angle 0 too), the parallels of a
    cone (angle constant, not 0).
    """
    m, k = samples.shape[:2]
    side_points = panel_sides(samples)  # (m, 4, k, 3)
    side_normals = panel_sides(normals)
    flat_points = side_points.reshape(m * 4, k, 3)
    plane_normals, offsets, edge_fit = bestfit_planes(flat_points)
    # square alternative: through the principal direction of the samples and the mean normal
    centroid = flat_points.mean(axis=1)
    direction = np.linalg.svd(flat_points - centroid[:, None], full_matrices=False)[2][:, 0]
    square = np.cross(direction, side_normals.reshape(m * 4, k, 3).sum(axis=1))
    square /= np.maximum(np.linalg.norm(square, axis=1, keepdims=True), 1e-300)
    square_offsets = np.einsum("bi,bi->b", square, centroid)
    square_fit = np.abs(np.einsum("bki,bi->bk", flat_points, square) - square_offsets[:, None]).max(
        axis=1
    )
    fit_normals = np.einsum(
        "bki,bi->bk", side_normals[:, :, 1:-1].reshape(m * 4, k - 2, 3), plane_normals
    )
    fit_lean = np.degrees(np.arcsin(np.clip(np.abs(fit_normals).max(axis=1), 0.0, 1.0)))
    use_square = (square_fit <= np.maximum(SQUARE_RIB_FIT, edge_fit)) | (
        (fit_lean > TOLERANCES.square_rib_lean_deg) & (square_fit <= TOLERANCES.rib_edge)
    )
    plane_normals = np.where(use_square[:, None], square, plane_normals).reshape(m, 4, 3)
    offsets = np.where(use_square, square_offsets, offsets).reshape(m, 4)
    # orient each plane normal towards the panel's centre sample
    centre = samples[:, k // 2, k // 2]  # (m, 3)
    inward = np.einsum("msi,mi->ms", plane_normals, centre) - offsets < 0
    plane_normals[inward] *= -1
    offsets[inward] *= -1
    planes = np.concatenate([plane_normals, offsets[..., None]], axis=2)
    edge = np.abs(np.einsum("mski,msi->msk", side_points, plane_normals) - offsets[..., None])
    sine = np.einsum("mski,msi->msk", side_normals[:, :, 1:-1], plane_normals)
    angles = np.degrees(np.arcsin(np.clip(sine, -1.0, 1.0)))
    return planes, edge.max(axis=2), np.abs(angles).max(axis=2), np.ptp(angles, axis=2)


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


def side_gaps_and_kinks(
    layout, samples: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Largest gap (mm) and kink angle (degrees) between every panel side and its neighbour's
    copy of it; (m, 4) each, 0 on the boundary."""
    own, theirs = across_sides(layout, samples)
    gaps = np.nan_to_num(np.linalg.norm(own - theirs, axis=-1).max(axis=-1))
    own_n, theirs_n = across_sides(layout, normals)
    cosine = np.clip((own_n * theirs_n).sum(-1), -1.0, 1.0)
    kinks = np.nan_to_num(np.degrees(np.arccos(cosine)).max(axis=-1))
    return gaps, kinks


def folded_sides(layout, kinks: np.ndarray) -> tuple[Issue, ...]:
    """An error for each panel folded onto a neighbour (``kinks`` (m, 4), degrees, from
    :func:`side_gaps_and_kinks`, above ``FOLDED_KINK``), naming both panels and the angle.
    No sheet or rib can be made there; the layout's panels round it are too large for the
    surface's curvature or too skewed to bend to a developable shape."""
    neighbours = layout.side_neighbours
    issues = []
    for panel in np.flatnonzero((kinks > FOLDED_KINK).any(axis=1)):
        side = int(np.argmax(kinks[panel]))
        other = layout.panel_ids[neighbours[panel, side]]
        pid = layout.panel_ids[panel]
        issues.append(
            Issue(
                "panel-folded",
                f"panel {pid} is folded onto {other}: their sheets meet at "
                f"{kinks[panel, side]:.0f}° across side {side}, so neither can be built; the "
                f"panels there are too large or too skewed for the surface's curvature: lower "
                f'panel_size, or draw the layout there (method = "layout")',
                pid,
                "error",
            )
        )
    return tuple(issues)
