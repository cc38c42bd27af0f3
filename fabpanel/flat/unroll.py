"""Cut stage, first half: lay every part flat (unroll sheets, take rib outlines as they are).

Sheets are unrolled with :func:`fabpanel.geom.flatten.flatten_grid`; the flat outline is the
boundary of the flat grid in side order 0, 1, 2, 3 (counter-clockwise, seen from the outer side).
Single-curved sheets get their rulings as bend lines and a forming instruction (which way the
outer face rolls, the radii: :mod:`fabpanel.flat.bending`); every part gets its id and its panel
id as etched labels, sheets also the forming instruction (``OUT CONVEX R4000``), ribs and
stiffeners the way their etched face looks (``IN``: into the panel).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections import Counter
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from functools import partial

import numpy as np
import shapely
from scipy.spatial import QhullError
from shapely.geometry import Polygon

from ..data import FlatPart, FlatParts, Hole, MarkGroup, Model, Part
from ..errors import GeometryError, Issue
from ..forming import formed
from ..geom.flatten import flatten_grid
from ..geom.polygon import polygon_area
from ..job import Job
from ..parallel import worker_pool
from .bending import Bending, bending_of
from .flatbar import bar_size
from .holing import is_drilled
from .labels import LABEL_CLEARANCE, hole_areas, lines_around_labels, place_labels

log = logging.getLogger(__name__)

#: what a sheet's label says of the face up on the table: the one the drawing shows, towards the
#: ribs, hidden in the finished shell (the only face etched)
HIDDEN_FACE_UP = "RIB FACE UP"
#: length of a bend tick at a sheet's edge, mm (``[cutting] bend_marks = "ticks"``)
BEND_TICK = 50.0


def grid_sides(grid: np.ndarray) -> list[np.ndarray]:
    """The four side polylines of an (a, b, d) grid, side ``s`` from corner ``s`` to ``s + 1``."""
    return [grid[:, 0], grid[-1, :], grid[::-1, -1], grid[0, ::-1]]


def polyline_lengths(polylines: list[np.ndarray]) -> np.ndarray:
    """(p,) float: length of each polyline, mm."""
    return np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in polylines])


def grid_outline(uv: np.ndarray) -> np.ndarray:
    """(2 (a + b) - 4, 2) float: the flat grid's boundary, sides 0..3, corners not repeated."""
    return np.concatenate([side[:-1] for side in grid_sides(uv)])


def grid_point(grid: np.ndarray, u: float, v: float) -> np.ndarray:
    """The point at fractions ``(u, v)`` of a grid's index ranges (bilinear between samples):
    sheet holes are stored in the surface parameters, which index ``surface_grid`` uniformly."""
    a, b = grid.shape[:2]
    x, y = u * (a - 1), v * (b - 1)
    i, j = min(int(x), a - 2), min(int(y), b - 2)
    s, t = x - i, y - j
    return (
        (1 - s) * (1 - t) * grid[i, j]
        + s * (1 - t) * grid[i + 1, j]
        + s * t * grid[i + 1, j + 1]
        + (1 - s) * t * grid[i, j + 1]
    )


def _clockwise(contour: np.ndarray) -> np.ndarray:
    """An inner contour runs clockwise."""
    return contour[::-1].copy() if polygon_area(contour) > 0 else contour


def unroll_sheet(part: Part, tolerance: float | None = None) -> FlatPart:
    """Unroll one sheet's ``surface_grid`` into a :class:`FlatPart`. ``tolerance``: the job's
    strain tolerance; a sheet unrolled within it is rolled (single-curved), one beyond it is
    double-curved (without it the curvatures decide, :func:`~.bending.bending_of`)."""
    if part.surface_grid is None:
        raise GeometryError(f"sheet {part.id} has no surface_grid to unroll")
    grid = np.asarray(part.surface_grid, dtype=float)
    seen_from_outside, strain = flatten_grid(grid)
    # the drawing shows the face towards the ribs, hidden in the finished shell and the only face
    # etched: the flattening looks from outside, which is the bottom sheet's upper face and the
    # top sheet's exterior, so a top sheet is drawn mirrored (as seen from below)
    mirror = np.array([-1.0, 1.0]) if part.kind == "sheet-top" else np.ones(2)
    uv = seen_from_outside * mirror
    outline = grid_outline(uv)
    if polygon_area(outline) < 0:
        outline = outline[::-1].copy()
    lengths_flat = polyline_lengths(grid_sides(uv))
    lengths_3d = polyline_lengths(grid_sides(grid))
    try:
        # classified as seen from outside, so "OUT CONVEX" names the outer face either way
        developable = None if tolerance is None else bool(strain <= tolerance)
        seen = bending_of(
            grid, seen_from_outside, grid_outline(seen_from_outside), developable=developable
        )
        bending = dataclasses.replace(seen, lines=seen.lines * mirror)
    except (QhullError, ValueError, np.linalg.LinAlgError, shapely.errors.GEOSException) as err:
        # a degenerate (sliver) sheet, or a flat outline that crosses itself (``cut`` reports
        # it as ``invalid-outline``): no bend lines rather than no cutting files
        log.warning("%s: no bend lines (%s)", part.id, err)
        bending = Bending("unknown", np.zeros((0, 2, 2)), np.zeros((0, 2)), False)
    holes = tuple(
        dataclasses.replace(h, centre=tuple(grid_point(uv, *h.centre))) for h in part.holes
    )
    contours = tuple(
        _clockwise(np.array([grid_point(uv, *p) for p in loop])) for loop in part.openings
    )
    return FlatPart(
        id=part.id,
        kind=part.kind,
        panel_id=part.panel_id,
        material=part.material,
        thickness=part.thickness,
        outline=outline,
        holes=contours,
        round_holes=holes,
        bend_lines=bending.lines,  # cut round the labels once they are placed (labelled)
        max_strain=strain,
        forming=bending.instruction(),
        bend_radius=bending.smallest_radius(),
        bend_radius_max=bending.largest_radius(),
        face=HIDDEN_FACE_UP,
        edge_lengths_flat=lengths_flat,
        edge_lengths_3d=lengths_3d,
    )


def flat_plate(part: Part, face: str = "") -> FlatPart:
    """A rib or stiffener: its outline as given (made counter-clockwise), no strain.

    ``face`` is etched as a third label line: ``IN`` when the face the drawing shows (the
    frame's +z side) looks into the part's panel, ``OUT`` when it looks away.
    """
    if part.outline is None:
        raise GeometryError(f"part {part.id} ({part.kind}) has no flat outline")
    outline = np.asarray(part.outline, dtype=float)
    if len(outline) > 1 and np.allclose(outline[0], outline[-1]):
        outline = outline[:-1]
    if polygon_area(outline) < 0:
        outline = outline[::-1].copy()
    return FlatPart(
        id=part.id,
        kind=part.kind,
        panel_id=part.panel_id,
        material=part.material,
        thickness=part.thickness,
        outline=outline,
        round_holes=tuple(part.holes),
        max_strain=0.0,
        face=face,
    )


def labelled(part: FlatPart, quantity: int) -> FlatPart:
    """The part with its etched labels: its mark; its id, or the quantity cut to the mark
    (``24 OFF``); the forming instruction and ``RIB FACE UP`` (sheets) or the way the drawn
    face looks (plates).
    Bend lines stop short of the labels."""
    second = part.id if quantity == 1 else f"{quantity} OFF"
    more = [part.forming, part.face] if part.kind.startswith("sheet") else [part.face]
    lines = [part.mark or part.id, second] + [line for line in more if line]
    obstacles = hole_areas(part, LABEL_CLEARANCE)
    if part.kind.startswith("sheet"):
        labels = place_labels(part.outline, lines, angle=0.0, obstacles=obstacles)
    else:
        labels = place_labels(part.outline, lines, obstacles=obstacles)
    return dataclasses.replace(
        part, labels=labels, bend_lines=lines_around_labels(part.bend_lines, labels)
    )


def _lay_flat(part: Part, face: str = "", tolerance: float | None = None) -> FlatPart:
    if part.kind.startswith("sheet"):
        return unroll_sheet(part, tolerance)
    return flat_plate(part, face)


def plate_faces(parts: Sequence[Part]) -> list[str]:
    """Per part, which way a plate's drawn face looks: ``IN`` (into its panel: for a rib the
    other face is the joint face against the neighbour's rib), ``OUT``, or "" for sheets and
    plates whose panel has no sheet to tell its centre."""
    centres: dict[str, np.ndarray] = {}
    for part in parts:
        if part.surface_grid is not None:
            centres.setdefault(
                part.panel_id, np.asarray(part.surface_grid).reshape(-1, 3).mean(axis=0)
            )
    faces = []
    for part in parts:
        if part.kind.startswith("sheet") or part.frame is None or part.panel_id not in centres:
            faces.append("")
            continue
        frame = np.asarray(part.frame, dtype=float)
        faces.append("IN" if frame[:3, 2] @ (centres[part.panel_id] - frame[:3, 3]) > 0 else "OUT")
    return faces


def _edge_length_error(part: FlatPart) -> float:
    """Largest difference between an unrolled sheet's flat and 3D edge lengths, mm."""
    if part.edge_lengths_flat is None or part.edge_lengths_3d is None:
        raise ValueError(f"{part.id}: no edge lengths; not an unrolled sheet")
    return float(np.abs(part.edge_lengths_flat - part.edge_lengths_3d).max())


def cut(model: Model, job: Job, jobs: int | None = None) -> FlatParts:
    """Lay every part of the model flat (sheets unrolled in ``jobs`` worker processes).

    Sheets (``sheet-top``/``sheet-bottom``) are unrolled from their ``surface_grid``; ribs and
    stiffeners keep their outline. Round holes the plasma cannot hold become drill holes
    (:mod:`fabpanel.flat.holing`). Issues: ``unroll-strain`` when a sheet's strain exceeds
    ``[develop] strain_tolerance``, ``invalid-outline`` for self-intersecting outlines.
    """
    tolerance = job.develop.strain_tolerance
    parts, issues = [], []
    # the solids stay behind: workers need the sample grids and outlines only
    light = [dataclasses.replace(part, brep=b"") for part in model.parts]
    workers = jobs or os.cpu_count() or 1
    with ExitStack() as stack:
        mapped: Callable = map
        if workers > 1 and len(light) > 8:
            pool = stack.enter_context(worker_pool(workers))
            mapped = partial(pool.map, chunksize=max(1, len(light) // (4 * workers)))
        flats = list(mapped(_lay_flat, light, plate_faces(light), [tolerance] * len(light)))
        flats, marks = _finished(flats, job, mapped)
    for part, flat in zip(model.parts, flats):
        if flat.max_strain > tolerance:
            issues.append(
                Issue(
                    "unroll-strain",
                    f"{part.id} unrolls with strain "
                    f"{flat.max_strain:.2e} > {tolerance:.1e}: the cut sheet will not "
                    "fit the surface without stretching",
                    part.id,
                )
            )
        if not shapely.is_valid(Polygon(flat.outline)):
            issues.append(
                Issue(
                    "invalid-outline",
                    f"{part.id}: flat outline intersects itself",
                    part.id,
                    "error",
                )
            )
        parts.append(flat)
    sheets = [p for p in parts if p.edge_lengths_flat is not None]
    quantities = Counter(p.mark for p in parts)
    kind_of = {p.id: p.kind for p in parts}
    edge_error = max((_edge_length_error(p) for p in sheets), default=0.0)
    metrics = {
        "parts": len(parts),
        "count_by_kind": dict(Counter(p.kind for p in parts)),
        "max_strain": max((p.max_strain for p in parts), default=0.0),
        "strain_by_part": {p.id: float(p.max_strain) for p in sheets},
        "max_edge_length_error_mm": edge_error,
        "bend_lines": int(sum(len(p.bend_lines) for p in parts)),
        "drill_holes": int(sum(len(p.drill_holes) for p in parts)),
        "area_mm2": float(sum(p.area for p in parts)),
        "marks": len(marks),
        "marks_by_kind": dict(Counter(kind_of[group.part_ids[0]] for group in marks)),
        "largest_quantity": max(quantities.values(), default=0),
    }
    log.info(
        "cut: %d flat parts, max strain %.2e, edge length error %.3f mm",
        len(parts),
        metrics["max_strain"],
        edge_error,
    )
    return FlatParts(parts=tuple(parts), metrics=metrics, issues=tuple(issues), marks=marks)


def _finished(
    flats: list[FlatPart], job: Job, mapped: Callable = map
) -> tuple[list[FlatPart], tuple[MarkGroup, ...]]:
    """The laid-flat parts as cut: holes the plasma cannot hold drilled, forming instructions,
    flat bar where asked, marks and labels (the labels through ``mapped``: placing them is a
    search round each part's holes, 8 ms a part)."""
    cutting = job.cutting

    def drilled(hole: Hole, thickness: float) -> bool:
        return is_drilled(
            hole,
            thickness,
            min_plasma_hole=cutting.min_plasma_hole,
            quality=cutting.plasma_quality,
            tolerance=cutting.hole_tolerance,
            fit=job.sandwich.bolts.fit,
        )

    flats = [
        formed(
            dataclasses.replace(
                flat,
                round_holes=tuple(h for h in flat.round_holes if not drilled(h, flat.thickness)),
                drill_holes=tuple(h for h in flat.round_holes if drilled(h, flat.thickness)),
            ),
            job,
        )
        for flat in flats
    ]
    if cutting.flat_bar:
        flats = [
            dataclasses.replace(flat, stock_form="flat-bar") if bar_size(flat) else flat
            for flat in flats
        ]
    return _marked(flats, BEND_TICK if cutting.bend_marks == "ticks" else 0.0, mapped)


def _marked(
    flats: list[FlatPart], bend_tick: float = 0.0, mapped: Callable = map
) -> tuple[list[FlatPart], tuple[MarkGroup, ...]]:
    """The parts with their marks and labels (placed through ``mapped``), and the marks
    (:mod:`.marks`); bend lines to be etched as ``bend_tick`` mm ticks (0: full lines)."""
    from .marks import mark_groups

    groups = mark_groups(flats)
    mark_of = {pid: group for group in groups for pid in group.part_ids}
    marked = mapped(
        labelled,
        [
            dataclasses.replace(flat, mark=mark_of[flat.id].mark, bend_tick=bend_tick)
            for flat in flats
        ],
        [mark_of[flat.id].quantity for flat in flats],
    )
    return list(marked), groups


__all__ = [
    "cut",
    "flat_plate",
    "grid_outline",
    "grid_sides",
    "unroll_sheet",
]
