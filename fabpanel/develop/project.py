"""The ``project`` method: sample each panel on the design surface, then measure it.

Panels laid out in a B-rep face's parameters are sampled in those parameters (exact points and
normals). Other layouts are sampled bilinearly between the panel corners and projected onto the
surface. Either way a sample on a shared side depends only on that side, so neighbouring panels
hold identical side samples and normals.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..data import DevelopedPanels, PanelLayout, Surface
from ..errors import Issue
from ..geom.quads import bilinear_grid, coons_patch, resample_polylines, side_index
from ..job import Job
from ..surface import SurfaceQuery
from ..surface.design_boundary import boundary_deviation
from ..tolerances import TOLERANCES
from .measure import classify_and_measure
from .sides import largest_rib_lean, side_planes

log = logging.getLogger(__name__)


def develop(
    layout: PanelLayout, surface: Surface, job: Job, query: SurfaceQuery | None = None
) -> DevelopedPanels:
    """Give every panel of ``layout`` its sample grid on the design surface, and measure it."""
    query = query or SurfaceQuery(surface)
    design = sample_panels(layout, query, job.develop.samples)
    return developed_panels(
        layout, design.samples, design.normals, query, job, "project", design.chords
    )


@dataclass(frozen=True)
class PanelSamples:
    """Every panel sampled on the design surface, and where its boundary sides cut across.

    samples, normals : (m, k, k, 3) float, mm and unit outward; neighbouring panels hold
    identical samples and normals along their shared side.
    chords : the boundary sides that cut the chord across the design boundary instead of
    following it (:func:`_flat_rib_chords`), keyed by their ``PanelLayout.edges`` row.
    """

    samples: np.ndarray
    normals: np.ndarray
    chords: dict[int, BoundaryChord]


def sample_panels(layout: PanelLayout, query: SurfaceQuery, k: int) -> PanelSamples:
    """k x k samples and outward normals of every panel on the design surface."""
    m = len(layout.quads)
    chords: dict[int, BoundaryChord] = {}
    if layout.parameters is not None:
        uv = bilinear_grid(layout.parameters, k).reshape(-1, 2)
        points, normals = query.evaluate_uv(uv[:, 0], uv[:, 1])
        samples, normals = points.reshape(m, k, k, 3), normals.reshape(m, k, k, 3)
    else:
        samples, normals, chords = _surface_patches(layout, query, k)
    samples, normals = _pin_corners(layout, samples, normals)
    return PanelSamples(*_share_sides(layout, samples, normals), chords)


def developed_panels(
    layout: PanelLayout,
    samples: np.ndarray,
    normals: np.ndarray,
    query: SurfaceQuery,
    job: Job,
    method: str,
    chords: dict[int, BoundaryChord],
    extra_metrics: dict | None = None,
    extra_issues: tuple = (),
    design_samples: np.ndarray | None = None,
) -> DevelopedPanels:
    """Rib planes, classes and measures of final panel grids, as :class:`DevelopedPanels`.

    ``chords``: the boundary sides that cut across the design boundary (:class:`PanelSamples`);
    ``design_samples``: the panels on the design surface before development, if they moved."""
    planes, edge_residuals, normal_angles, twist = side_planes(samples, normals)
    classes, radius, metrics, issues, deviation = classify_and_measure(
        layout.panel_ids,
        samples,
        normals,
        edge_residuals,
        normal_angles,
        twist,
        layout.side_neighbours < 0,
        query,
        job,
    )
    metrics["method"] = method
    metrics["boundary_deviation_mm"] = boundary_deviation(
        layout, samples, query.surface, _chord_sides(layout, chords)
    )
    metrics["boundary_chords"] = {
        "sides": len(chords),
        "offset_mm_max": round(max((c.offset for c in chords.values()), default=0.0), 1),
    }
    metrics.update(extra_metrics or {})
    issues = tuple(issues) + _chord_issues(layout, chords)
    log.info("develop (%s): %s", method, {c: classes.count(c) for c in set(classes)})
    return DevelopedPanels(
        layout=layout,
        samples=samples,
        normals=normals,
        side_planes=planes,
        classes=classes,
        bending_radius=radius,
        method=method,
        metrics=metrics,
        issues=tuple(extra_issues) + issues,
        deviation=deviation,
        design_samples=design_samples,
    )


def _chord_sides(layout: PanelLayout, chords: dict[int, BoundaryChord]) -> np.ndarray:
    """(m, 4) bool: the panel sides that cut the chord across the design boundary."""
    return np.isin(layout.side_edges, list(chords))


def _chord_issues(layout: PanelLayout, chords: dict[int, BoundaryChord]) -> tuple[Issue, ...]:
    """A warning for every panel side that cuts the chord across the design boundary."""
    if not chords:
        return ()
    edges = layout.side_edges
    found = []
    for panel, side in zip(*np.nonzero(np.isin(edges, list(chords)))):
        chord, pid = chords[int(edges[panel, side])], layout.panel_ids[panel]
        found.append(
            Issue(
                "boundary-chord",
                f"panel {pid}: side {side} cuts straight across the design boundary, up to "
                f"{chord.offset:.0f} mm from it: the boundary curves in the sheet's own plane "
                f"there (radius about {chord.radius / 1000:.2f} m), and a planar rib following "
                f"it would lean {chord.lean:.0f} degrees from square (at most "
                f"{largest_rib_lean():.0f} can be built); the chord's bow goes with its "
                f"length squared: panel sides half as long here (about "
                f"{chord.length / 2:.0f} mm) would cut about {chord.offset / 4:.0f} mm deep",
                pid,
                "warning",
            )
        )
    return tuple(found)


def surface_sides(
    starts: np.ndarray, ends: np.ndarray, query: SurfaceQuery, count: int, levels: int = 6
) -> np.ndarray:
    """Polylines on the surface between point pairs, evenly spaced by arc length.

    Repeated midpoint subdivision with projection onto the surface (``levels`` times, so
    2**levels segments), then resampling to ``count`` points. The result depends only on the two
    end points, so two panels sharing a side get the same curve. Over an opening the curve runs
    on the surface's tangent-plane continuation (a side cutting the chord across its rim).
    starts, ends : (e, 3). Returns (e, count, 3).
    """
    lines = np.stack([starts, ends], axis=1)
    for _ in range(levels):
        mids = 0.5 * (lines[:, :-1] + lines[:, 1:])
        projected, _, _ = query.closest_continued(mids.reshape(-1, 3))
        refined = np.empty((len(lines), 2 * lines.shape[1] - 1, 3))
        refined[:, 0::2], refined[:, 1::2] = lines, projected.reshape(mids.shape)
        lines = refined
    return resample_polylines(lines, count)


def _surface_patches(
    layout: PanelLayout, query: SurfaceQuery, k: int
) -> tuple[np.ndarray, np.ndarray, dict[int, BoundaryChord]]:
    """k x k samples per panel: sides traced on the surface, interiors by Coons, projected;
    and the boundary sides that cut their chord (:func:`_follow_design_boundary`)."""
    m = len(layout.quads)
    edges = layout.edges  # (e, 2) sorted vertex pairs
    curves = surface_sides(layout.vertices[edges[:, 0]], layout.vertices[edges[:, 1]], query, k)
    chords = _follow_design_boundary(layout, query, edges, curves)
    # each side from its panel's corner s to s + 1; the edge curves run low -> high vertex
    forward = layout.quads < np.roll(layout.quads, -1, axis=1)
    along = curves[layout.side_edges]  # (m, 4, k, 3)
    sides = np.where(forward[..., None, None], along, along[:, :, ::-1])
    patches = coons_patch(sides[:, 0], sides[:, 1], sides[:, 2], sides[:, 3])
    points, normals, _ = query.closest_continued(patches.reshape(-1, 3))
    points = points.reshape(m, k, k, 3)
    # boundary samples stay exactly on the traced sides (projection could move them by rounding)
    grid = patches
    points[:, :, 0], points[:, :, -1] = grid[:, :, 0], grid[:, :, -1]
    points[:, 0, :], points[:, -1, :] = grid[:, 0, :], grid[:, -1, :]
    return points, normals.reshape(m, k, k, 3), chords


#: a layout vertex this close to the design boundary lies on it (mm)
ON_BOUNDARY = 0.5
#: a boundary stretch longer than this multiple of the side's chord is not the side's (the two
#: corners lie on the boundary, but the panel side cuts across, e.g. over a notch)
STRETCH_LIMIT = 1.5


@dataclass(frozen=True)
class BoundaryChord:
    """A boundary side that cuts the chord across a design edge curving in the sheet's plane.

    edge : index into ``PanelLayout.edges``; length : mm, the chord's; offset : mm, how far the
    design edge bows away from the upright plane through the chord; radius : mm, the edge's
    radius of curvature in the sheet (from chord and bow); lean : degrees, how far from square
    to the sheet a rib plane following the design edge would lean."""

    edge: int
    length: float
    offset: float
    radius: float
    lean: float


def _boundary_stretches(
    layout: PanelLayout, query: SurfaceQuery, edges: np.ndarray, k: int
) -> dict[int, np.ndarray]:
    """The design boundary (k points) between the corners of every boundary side whose two
    corners lie on it, keyed by the side's index into ``edges``; not where the boundary runs
    much longer than the side (the side cuts across a notch)."""
    from ..surface.design_boundary import DesignBoundary

    if not query.surface.boundary_loops:
        return {}
    neighbours = layout.side_neighbours
    starts, ends = layout.quads, np.roll(layout.quads, -1, axis=1)
    outer = np.unique(
        np.sort(np.stack([starts[neighbours < 0], ends[neighbours < 0]], 1), 1), axis=0
    )
    if not len(outer):
        return {}
    boundary = DesignBoundary(query.surface)
    _, distance, _, _ = boundary.locate(layout.vertices)
    index = {(int(a), int(b)): i for i, (a, b) in enumerate(edges)}
    stretches = {}
    for a, b in outer:
        if distance[a] > ON_BOUNDARY or distance[b] > ON_BOUNDARY:
            continue
        stretch = boundary.between(layout.vertices[a], layout.vertices[b], k)
        if stretch is None:
            continue
        chord = float(np.linalg.norm(layout.vertices[b] - layout.vertices[a]))
        length = float(np.linalg.norm(np.diff(stretch, axis=0), axis=1).sum())
        if length <= STRETCH_LIMIT * max(chord, 1e-9):
            stretches[index[(int(a), int(b))]] = stretch
    return stretches


def _flat_rib_chords(
    stretches: dict[int, np.ndarray], query: SurfaceQuery
) -> dict[int, BoundaryChord]:
    """The stretches a planar rib cannot follow: they bow out of the upright plane through
    their chord by more than the rib-edge tolerance, and the plane that holds them leans more
    than :func:`largest_rib_lean` from square to the sheet somewhere along them (a round
    opening or a tight rounding in a flattish sheet, whose plane is the sheet's own, or an
    edge arch the shell stands tangent to)."""
    from ..geom.fitting import bestfit_planes

    limit = largest_rib_lean()
    chords = {}
    for e, stretch in stretches.items():
        _, normals, _ = query.closest(stretch)
        chord = stretch[-1] - stretch[0]
        length = float(np.linalg.norm(chord))
        upright = np.cross(chord, normals.mean(axis=0))
        if length < 1e-9 or np.linalg.norm(upright) < 1e-12:
            continue
        upright /= np.linalg.norm(upright)
        offset = float(np.abs((stretch - stretch[0]) @ upright).max())
        if offset <= TOLERANCES.rib_edge:
            continue
        plane, _, _ = bestfit_planes(stretch[None])
        lean = float(np.degrees(np.arcsin(min(1.0, np.abs(normals @ plane[0]).max()))))
        if lean > limit:
            radius = (length**2 / 4 + offset**2) / (2 * offset)
            chords[e] = BoundaryChord(e, length, offset, radius, lean)
    return chords


def _follow_design_boundary(
    layout: PanelLayout, query: SurfaceQuery, edges: np.ndarray, curves: np.ndarray
) -> dict[int, BoundaryChord]:
    """Replace (in place) the traced curve of each boundary side whose two corners lie on the
    design boundary by the design boundary between them: the panel then follows the design's
    outline, rounded corners included, instead of cutting the chord across. Not where a planar
    rib along it would lie nearly flat in the sheet: that side keeps its traced chord, which
    runs over the opening on the surface's tangent-plane continuation. Returns those sides."""
    stretches = _boundary_stretches(layout, query, edges, curves.shape[1])
    chords = _flat_rib_chords(stretches, query)
    for e, stretch in stretches.items():
        if e not in chords:
            curves[e] = stretch
    return chords


def _pin_corners(
    layout: PanelLayout, samples: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Make the grid corners the layout's corner points exactly (no copy drift at shared corners)."""
    samples = samples.copy()
    corners = layout.vertices[layout.quads]
    samples[:, 0, 0], samples[:, -1, 0] = corners[:, 0], corners[:, 1]
    samples[:, -1, -1], samples[:, 0, -1] = corners[:, 2], corners[:, 3]
    return samples, normals


def _share_sides(
    layout: PanelLayout, samples: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Copy each shared side's samples from the lower-numbered panel to the other one.

    Both panels computed the side from the same two corners, so the copy changes nothing but
    rounding; it makes "identical side samples" exact, which the B-spline sheets rely on.
    """
    samples, normals = samples.copy(), normals.copy()
    k = samples.shape[1]
    neighbours = layout.side_neighbours
    for panel, side in zip(*np.nonzero(neighbours > panel_index(neighbours))):
        other = neighbours[panel, side]
        a, b = layout.quads[panel, side], layout.quads[panel, (side + 1) % 4]
        other_side = int(
            np.flatnonzero((layout.quads[other] == b) & (np.roll(layout.quads[other], -1) == a))[0]
        )
        src, dst = side_index(k, side), side_index(k, other_side)
        # the neighbour runs the shared side the other way round
        samples[other][dst[0], dst[1]] = samples[panel][src[0], src[1]][::-1]
        normals[other][dst[0], dst[1]] = normals[panel][src[0], src[1]][::-1]
    return samples, normals


def panel_index(neighbours: np.ndarray) -> np.ndarray:
    """(m, 4) int: each row's own panel index, to compare with ``side_neighbours``."""
    return np.repeat(np.arange(len(neighbours))[:, None], neighbours.shape[1], axis=1)
