"""The one spyrrow adapter: nest flat parts on stock plates for the plasma table.

spyrrow (sparrow: J. Gardeyn, T. Wauters, "An open-source heuristic for 2D irregular strip packing",
2024) solves strip packing: a strip of fixed height, minimise its length. Plates are made from it:

1. Parts are grouped by (material, thickness); each group is nested on its own plates.
2. Each outline is validated, grown by half the part spacing plus a small safety gap (shapely
   mitre buffer) and simplified (Douglas-Peucker, the grow covers the simplification tolerance) to
   keep spyrrow fast. The cut outline stays the original.
3. A first assignment packs the grown shapes' bounding boxes onto plates (rectpack: MaxRects,
   best-fit bins). It is always feasible, and it is the naive nest the benchmark compares with.
4. Plate by plate, spyrrow packs the plate's parts as the irregular shapes they are, in a strip
   as high as the usable plate width (plate width minus the margin on both sides, plus the grow
   on both sides: a part may touch the usable area's edge with its true outline); it is kept when
   it fits one usable plate length, else the box layout stays. Then the smallest parts still
   waiting on later plates are moved onto this one while everything still packs (a binary search
   over how many), and the strip past the plate's large parts (packed the shorter way: spyrrow,
   their boxes in rows from the plate's start, or MaxRects) is packed on its own with small
   parts (:func:`fabpanel.flat.packing.tail_fill`: the demo's 8 mm ribs and stiffeners went
   from 18 to 17 plates of 4000 x 1500). Plates whose parts have all moved disappear, so the
   nest never needs more plates than the boxes, and no part ever crosses a plate end.

A part whose grown shape fits no plate in any allowed rotation becomes a ``part-too-large`` issue.
Time budget: ``[cutting] nest_time`` per group, spread over the plates it is expected to need in
whole seconds (spyrrow's unit; at least 1 s a plate, so a short budget serves the first plates);
each plate spends its share on one more attempt to add a part with spyrrow's improvement
phase. 0 s means constructive packs only, which are reproducible bit for bit (spyrrow's own seed
is ``seed`` plus the plate's index).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections import Counter, defaultdict
from collections.abc import Callable

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from ..data import FlatPart, FlatParts, Nests, Placement, Plate
from ..errors import Issue
from ..geom.polygon import polyline_length
from ..job import Job, StockSection
from .flatbar import bar_metrics
from .marks import TOLERANCE as MARK_TOLERANCE
from .packing import (
    SAFETY_GAP,
    Item,
    Packing,
    box_plates,
    fill_plate,
    fitting_rotations,
    narrowest_frame,
    pack_on_plate,
    packing_shape,
    round_seconds,
    tail_fill,
    transform_points,
    validate_outline,
)

log = logging.getLogger(__name__)

#: geometric tolerance of the nest checks, mm
CHECK_TOLERANCE = 0.01

#: expected share of a plate the grown shapes cover (splits the time budget over the plates)
FILL_DENSITY = 0.85

Progress = Callable[[float, str], None]


def nest_group(
    items: list[Item],
    job: Job,
    grow: float,
    budget_s: float,
    seed: int,
    on_round: Callable[[int], None],
    stock: StockSection | None = None,
) -> tuple[list[list[tuple[Item, np.ndarray]]], int]:
    """Plates of one group: per plate a list of (item, transform part frame -> plate); and how
    many plates the bounding boxes alone needed.

    The bounding-box assignment (:func:`box_plates`) gives each plate its first parts. Plate by
    plate, spyrrow packs them as irregular shapes (the box layout stays when spyrrow's
    constructive pack does not fit them in one plate), then the smallest parts still waiting on
    later plates are added while everything still packs onto this one (:func:`fill_plate`). Plates
    whose parts have all moved disappear, so there are never more plates than boxes need.
    """
    cutting = job.cutting
    length, height = usable(job, stock)
    offset = np.eye(3)
    offset[:2, 2] = cutting.plate_margin - grow
    # a part that fits one way only cannot be turned by rectpack: its turned box does not fit
    turns = {r % 180 for r in cutting.rotations} == {0, 90}
    boxes = box_plates(items, length, height, turns)
    estimate = sum(it.area for it in items) / (FILL_DENSITY * length * height)
    # the budget in whole seconds per plate (spyrrow's unit), at least 1 s while any is left
    share = max(math.ceil(budget_s / max(math.ceil(estimate), 1)), 1)
    deadline = time.perf_counter() + budget_s
    placed: set[int] = set()
    plates: list[list[tuple[Item, np.ndarray]]] = []
    for index, assigned in enumerate(boxes):
        keep = [k for k, it in enumerate(assigned.items) if id(it) not in placed]
        if not keep:
            continue
        members = [assigned.items[k] for k in keep]
        plate = pack_on_plate(members, length, height, 0, seed + index) or Packing(
            members, [assigned.transforms[k] for k in keep]
        )
        waiting = sorted(
            (it for later in boxes[index + 1 :] for it in later.items if id(it) not in placed),
            key=lambda it: it.area,
        )
        if len(plate.items) == len(members) and waiting:
            left = round_seconds(deadline - time.perf_counter())
            plate = fill_plate(plate, waiting, length, height, min(share, left), seed + index)
            inside = {id(it) for it in plate.items}
            rest = [it for it in waiting if id(it) not in inside]
            plate = tail_fill(plate, rest, length, height, seed + index, turns)
        placed |= {id(it) for it in plate.items}
        plates.append([(it, offset @ t) for it, t in zip(plate.items, plate.transforms)])
        on_round(len(items) - len(placed))
    log.debug(
        "nest: %d parts on %d plates (bounding boxes: %d)", len(items), len(plates), len(boxes)
    )
    return plates, len(boxes)


_Layout = list[tuple[StockSection, list[tuple[Item, np.ndarray]]]]


def _plate_kg(stock: StockSection, thickness: float, job: Job) -> float:
    return stock.length * stock.width * thickness * float(job.material.density)


def _nest_on_stock(
    items: list[Item],
    job: Job,
    stocks: list[StockSection],
    budget_s: float,
    on_round: Callable[[int], None],
) -> tuple[_Layout, int, list[Item]]:
    """Plates of one group from several stock sizes: ``(stock, placements)`` per plate, the
    bounding-box plate count of the chosen nests, and the items no stock plate was left for.

    Greedy by cost: every stock size with plates left nests the waiting parts
    (:func:`nest_group`, its first ``count`` plates taken, its last plate moved to a cheaper
    size that holds its parts where there is one); the nest whose plates cost least per mm2 of
    part placed is kept, and the rest goes round again.
    """
    thickness = float(items[0].part.thickness) if items else 0.0
    grow, seed = packing_grow(job), job.cutting.seed
    left: list[int | None] = [s.count for s in stocks]
    waiting, layout, boxes = list(items), [], 0
    while waiting:
        best = None
        for index, stock in enumerate(stocks):
            fitting = on_stock(waiting, job, stock)
            if left[index] == 0 or not fitting:
                continue
            plates, box_count = nest_group(
                fitting, job, grow, budget_s, seed, lambda _: None, stock
            )
            plates = plates[: left[index]] if left[index] is not None else plates
            trial_left = list(left)
            trial_left[index] = None if (n := left[index]) is None else n - len(plates)
            trial = _cheaper_last_plates(
                [(stock, members) for members in plates], job, stocks, trial_left, thickness
            )
            placed = sum(it.part.area for _, members in trial for it, _ in members)
            cost = sum(s.cost(_plate_kg(s, thickness, job)) for s, _ in trial)
            if placed > 0 and (best is None or cost / placed < best[0] - 1e-12):
                best = (cost / placed, trial, trial_left, box_count)
        if best is None:
            break
        _, trial, left, box_count = best
        boxes += box_count
        done = {it.part.id for _, members in trial for it, _ in members}
        waiting = [it for it in waiting if it.part.id not in done]
        layout += trial
        on_round(len(waiting))
    return layout, boxes, waiting


def _cheaper_last_plates(
    layout: _Layout,
    job: Job,
    stocks: list[StockSection],
    left: list[int | None],
    thickness: float,
) -> _Layout:
    """The last plate of each stock size moved onto the cheapest size (with plates left) that
    holds its parts, when that costs less; ``left`` is updated."""
    last = {id(stock): n for n, (stock, _) in enumerate(layout)}
    grow = packing_grow(job)
    out = list(layout)
    for n in sorted(last.values()):
        stock, members = out[n]
        cost = stock.cost(_plate_kg(stock, thickness, job))
        cheaper = sorted(
            (
                (s.cost(_plate_kg(s, thickness, job)), i, s)
                for i, s in enumerate(stocks)
                if left[i] != 0 and s is not stock
            ),
            key=lambda c: c[0],
        )
        for other_cost, i, other in cheaper:
            if other_cost >= cost:
                break
            fitting = on_stock([it for it, _ in members], job, other)
            if len(fitting) < len(members):
                continue
            packed = pack_on_plate(fitting, *usable(job, other), 0, job.cutting.seed + n)
            if packed is None:
                continue
            offset = np.eye(3)
            offset[:2, 2] = job.cutting.plate_margin - grow
            out[n] = (other, [(it, offset @ t) for it, t in zip(packed.items, packed.transforms)])
            remaining = left[i]
            left[i] = None if remaining is None else remaining - 1
            given = stocks.index(stock) if stock in stocks else -1
            back = left[given] if given >= 0 else None
            if back is not None:
                left[given] = back + 1  # the plate it leaves is the shop's again
            break
    return out


def cut_length(part: FlatPart) -> float:
    """Total cut length of a part, mm: outline, polygon holes, round holes."""
    return (
        polyline_length(part.outline, closed=True)
        + sum(polyline_length(h, closed=True) for h in part.holes)
        + sum(math.pi * h.diameter for h in part.round_holes)
    )


def pierces(part: FlatPart) -> int:
    """Pierces of a part: one per closed contour."""
    return 1 + len(part.holes) + len(part.round_holes)


def packing_grow(job: Job) -> float:
    """How far packing shapes are grown beyond the outlines, mm."""
    return job.cutting.part_spacing / 2 + SAFETY_GAP


def usable(job: Job, stock: StockSection | None = None) -> tuple[float, float]:
    """(length, height) of the area the grown shapes are packed into on one plate of ``stock``
    (default: the job's plate), mm."""
    cutting, grow = job.cutting, packing_grow(job)
    length, width = (
        (cutting.plate_length, cutting.plate_width)
        if stock is None
        else (stock.length, stock.width)
    )
    return (
        length - 2 * cutting.plate_margin + 2 * grow,
        width - 2 * cutting.plate_margin + 2 * grow,
    )


def on_stock(items: list[Item], job: Job, stock: StockSection) -> list[Item]:
    """The items that fit a plate of ``stock``, each with the rotations it fits in there."""
    length, height = usable(job, stock)
    fitting = []
    for item in items:
        rotations = fitting_rotations(item.shape, list(item.rotations), length, height)
        if rotations:
            fitting.append(dataclasses.replace(item, rotations=rotations))
    return fitting


def nest_groups(
    flat: FlatParts, job: Job
) -> tuple[dict[tuple[str, float], list[Item]], list[Issue]]:
    """Parts ready for packing, by (material, thickness); issues for parts left out."""
    cutting = job.cutting
    issues: list[Issue] = []
    groups: dict[tuple[str, float], list[Item]] = defaultdict(list)
    frames = _mark_frames(flat)
    shapes: dict[str, np.ndarray] = {}
    for part in flat.parts:
        if part.stock_form == "flat-bar":
            continue  # sawn from bar (fabpanel.flat.flatbar), not nested
        try:
            outline = validate_outline(part.outline, part.id)
        except ValueError as err:
            issues.append(Issue("invalid-outline", str(err), part.id, "error"))
            continue
        key, to_shape, grow = part.id, np.eye(3), packing_grow(job)
        if part.id in frames:  # one shape for the whole mark, in its first part's frame
            first, to_shape = frames[part.id]
            key = part.mark
            outline = validate_outline(first.outline, first.id)
            grow += MARK_TOLERANCE  # its parts differ from the first by up to this
        if key not in shapes:
            shapes[key] = packing_shape(outline, grow)
        shape = shapes[key]
        stocks = cutting.stock_for(float(part.thickness))
        rotations = tuple(int(r) for r in cutting.rotations)
        fits = _on_some_stock(shape, rotations, job, stocks)
        if not fits and {r % 180 for r in rotations} == {0, 90}:
            # a part too wide along its first side may fit turned to its narrowest, where the
            # job lets parts lie along and across the plate (the rolling direction does not
            # matter to it); every part of its mark the same way: the turn follows from the
            # shared shape
            turned, turn = narrowest_frame(shape)
            fits = _on_some_stock(turned, rotations, job, stocks)
            if fits:
                shape, to_shape = turned, turn @ to_shape
        if not fits:
            size = outline.max(axis=0) - outline.min(axis=0)
            narrow = np.ptp(narrowest_frame(outline)[0], axis=0)
            sizes = " or ".join(f"{s.length:.0f} x {s.width:.0f}" for s in stocks) or "no stock"
            issues.append(
                Issue(
                    "part-too-large",
                    f"{part.id} ({size[0]:.0f} x {size[1]:.0f} mm, {narrow[0]:.0f} x "
                    f"{narrow[1]:.0f} mm at its narrowest, plus {cutting.part_spacing:g} mm "
                    f"spacing) fits no {sizes} mm plate with {cutting.plate_margin:g} mm margin "
                    f"in rotations {list(cutting.rotations)}; it is left out of the nests: a "
                    "wider stock plate or a smaller [panelize] panel_size",
                    part.id,
                    "error",
                )
            )
            continue
        groups[(part.material, float(part.thickness))].append(
            Item(part, shape, rotations, key, to_shape)
        )
    return groups, issues


def _on_some_stock(
    shape: np.ndarray, rotations: tuple[int, ...], job: Job, stocks: list[StockSection]
) -> bool:
    """Whether the shape fits the usable area of one of ``stocks`` in one of ``rotations``."""
    return any(fitting_rotations(shape, list(rotations), *usable(job, stock)) for stock in stocks)


def _mark_frames(flat: FlatParts) -> dict[str, tuple[FlatPart, np.ndarray]]:
    """Per part of a mark of two or more: the mark's first part and the (3, 3) map from the
    part's own flat frame to that first part's frame."""
    by_id = {p.id: p for p in flat.parts}
    frames = {}
    for group in flat.marks:
        if group.quantity < 2 or group.part_ids[0] not in by_id:
            continue
        first = by_id[group.part_ids[0]]
        for part_id, transform in zip(group.part_ids, group.transforms):
            frames[part_id] = (first, np.linalg.inv(transform))
    return frames


def bounding_box_plates(flat: FlatParts, job: Job) -> dict[tuple[str, float], int]:
    """Plates per (material, thickness) when only the parts' bounding boxes are packed (the
    naive nest, and the first assignment :func:`nest` improves on)."""
    turns = {r % 180 for r in job.cutting.rotations} == {0, 90}
    groups, _ = nest_groups(flat, job)
    plates = {}
    for key, items in sorted(groups.items()):
        stock = job.cutting.stock_for(key[1])[0]
        fitting = on_stock(items, job, stock)
        plates[key] = len(box_plates(fitting, *usable(job, stock), turns)) if fitting else 0
    return plates


def _reporter(
    progress: Progress | None, done: int, count: int, total: int, group: str
) -> Callable[[int], None]:
    """Progress callback of one group: called with the number of its parts still waiting."""

    def on_round(left: int) -> None:
        if progress is not None:
            progress(
                (done + count - left) / max(total, 1),
                f"nesting {group}: {count - left}/{count} parts placed",
            )

    return on_round


def nest(flat: FlatParts, job: Job, progress: Progress | None = None) -> Nests:
    """Nest all flat parts on stock plates (``[cutting]`` plate, or ``[[cutting.stock]]``).

    Returns :class:`Nests`: plates numbered from 1 across all (material, thickness) groups, each
    placement's transform (3, 3) maps the part's flat frame to plate coordinates (origin at the
    plate corner, x along the plate length, mm). Issues: ``part-too-large`` (left out),
    ``invalid-outline`` (left out), ``stock-exhausted`` (no plate left for a part).
    """
    cutting = job.cutting
    started = time.perf_counter()
    groups, issues = nest_groups(flat, job)

    total = sum(len(g) for g in groups.values())
    placed_parts = 0
    plates: list[Plate] = []
    lower_bound = boxes = 0
    group_metrics = []
    for (material, thickness), items in sorted(groups.items()):
        group_start = time.perf_counter()
        on_round = _reporter(
            progress, placed_parts, len(items), total, f"{material} {thickness:g} mm"
        )
        stocks = cutting.stock_for(thickness)
        layout, box_count, stranded = _nest_on_stock(
            items, job, stocks, cutting.nest_time, on_round
        )
        issues += [
            Issue(
                "stock-exhausted",
                f"no [[cutting.stock]] plate left for {it.part.id}: it is left out of the nests; "
                "raise a stock count or add a size",
                it.part.id,
                "error",
            )
            for it in stranded
        ]
        boxes += box_count
        placed_parts += len(items)
        stranded_ids = {it.part.id for it in stranded}
        area = sum(it.part.area for it in items if it.part.id not in stranded_ids)
        largest = max(s.length * s.width for s in stocks)
        bound = math.ceil(area / largest - 1e-9)
        lower_bound += bound
        kg_per_mm2 = thickness * float(job.material.density)
        bought = 0.0
        for stock, members in layout:
            used = sum(it.part.area for it, _ in members)
            plates.append(
                Plate(
                    index=len(plates) + 1,
                    material=material,
                    thickness=thickness,
                    size=(stock.length, stock.width),
                    placements=tuple(Placement(it.part.id, t @ it.to_shape) for it, t in members),
                    utilisation=used / (stock.length * stock.width),
                )
            )
            bought += stock.length * stock.width * kg_per_mm2
        sizes = Counter(f"{s.length:g} x {s.width:g}" for s, _ in layout)
        filled = [p.utilisation for p in plates[len(plates) - len(layout) :]]
        group_metrics.append(
            {
                "material": material,
                "thickness_mm": thickness,
                "parts": len(items),
                "plates": len(layout),
                "plates_by_size": dict(sizes),
                # the last plate of a group takes what is left; the others should be full
                "utilisation_min_but_last": round(min(sorted(filled)[1:], default=1.0), 4),
                "bought_kg": round(bought, 2),
                "net_kg": round(area * kg_per_mm2, 2),
                "plates_lower_bound": bound,
                "bounding_box_plates": box_count,
                "time_s": round(time.perf_counter() - group_start, 3),
            }
        )
        log.info(
            "nested %d parts of %s %g mm on %d plates (lower bound %d)",
            len(items),
            material,
            thickness,
            len(layout),
            bound,
        )

    by_id = {p.id: p for p in flat.parts}
    placed = [by_id[pl.part_id] for plate in plates for pl in plate.placements]
    plate_area = sum(p.size[0] * p.size[1] for p in plates)
    sawn = [p for p in flat.parts if p.stock_form == "flat-bar"]
    bars = bar_metrics(sawn, cutting.bar_length, cutting.saw_kerf, float(job.material.density))
    metrics = {
        "plates": len(plates),
        "plates_lower_bound": lower_bound,
        "bounding_box_plates": boxes,
        "utilisation_by_plate": {p.name: round(p.utilisation, 4) for p in plates},
        "utilisation": sum(p.area for p in placed) / plate_area if plates else 0.0,
        "parts_placed": len(placed),
        "parts_left_out": len(flat.parts) - len(placed) - len(sawn),
        "parts_sawn_from_bar": len(sawn),
        "cut_length_mm": float(sum(cut_length(p) for p in placed)),
        "pierces": int(sum(pierces(p) for p in placed)),
        "time_s": round(time.perf_counter() - started, 3),
        # steel bought (whole plates and bars) against steel in the parts (net flat areas)
        "bought_kg": round(sum(g["bought_kg"] for g in group_metrics + bars), 2),
        "net_kg": round(sum(g["net_kg"] for g in group_metrics + bars), 2),
        "groups": group_metrics,
        "flat_bars": bars,
    }
    metrics["bought_to_net"] = (
        round(metrics["bought_kg"] / metrics["net_kg"], 3) if metrics["net_kg"] else None
    )
    return Nests(plates=tuple(plates), metrics=metrics, issues=tuple(issues))


def placed_polygon(part: FlatPart, transform: np.ndarray) -> Polygon:
    """The part's outline (with polygon holes) on the plate, as a shapely polygon."""
    return Polygon(
        transform_points(transform, part.outline),
        [transform_points(transform, h) for h in part.holes],
    )


def validate_nests(
    nests: Nests, flat: FlatParts, job: Job, tolerance: float = CHECK_TOLERANCE
) -> list[str]:
    """Problems of a nest, as sentences (empty when it is sound).

    Checks: every part placed exactly once (parts with a ``part-too-large`` or
    ``invalid-outline`` issue: never); transforms are rigid motions without mirroring; every part
    inside its plate's usable area (plate minus margin); parts on one plate at least the part
    spacing apart; each plate holds only its material and thickness.
    """
    cutting = job.cutting
    by_id = {p.id: p for p in flat.parts}
    excluded = {i.item for i in nests.issues if i.code in ("part-too-large", "invalid-outline")}
    errors: list[str] = []
    counts = Counter(pl.part_id for plate in nests.plates for pl in plate.placements)
    for part_id in by_id:
        expected = 0 if part_id in excluded else 1
        if counts[part_id] != expected:
            errors.append(f"{part_id} is placed {counts[part_id]} times, expected {expected}")
    errors += [f"{pid} is placed but is not a flat part" for pid in counts if pid not in by_id]
    m = cutting.plate_margin
    for plate in nests.plates:
        length, width = plate.size
        usable = box(m, m, length - m, width - m).buffer(tolerance, join_style="mitre")
        polygons, names = [], []
        for pl in plate.placements:
            part = by_id.get(pl.part_id)
            if part is None:
                continue
            t = np.asarray(pl.transform, dtype=float)
            r = t[:2, :2]
            if not (
                np.allclose(r.T @ r, np.eye(2), atol=1e-9)
                and np.linalg.det(r) > 0
                and np.allclose(t[2], [0, 0, 1])
            ):
                errors.append(f"{plate.name}: {part.id} transform is not a rigid motion")
            if (part.material, float(part.thickness)) != (plate.material, float(plate.thickness)):
                errors.append(
                    f"{plate.name}: {part.id} is {part.material} {part.thickness:g} mm "
                    f"on a {plate.material} {plate.thickness:g} mm plate"
                )
            polygon = placed_polygon(part, t)
            if not usable.contains(polygon):
                errors.append(f"{plate.name}: {part.id} leaves the usable area")
            polygons.append(polygon)
            names.append(part.id)
        if len(polygons) < 2:
            continue
        tree = shapely.STRtree(polygons)
        limit = max(cutting.part_spacing - tolerance, 0.0)
        left, right = (
            tree.query(polygons, predicate="dwithin", distance=limit)
            if limit > 0
            else tree.query(polygons, predicate="intersects")
        )
        for i, j in zip(left, right):
            if i >= j:
                continue
            gap = polygons[i].distance(polygons[j])
            if polygons[i].intersection(polygons[j]).area > 0 or gap < limit:
                errors.append(
                    f"{plate.name}: {names[i]} and {names[j]} are {gap:.3f} mm apart "
                    f"(spacing {cutting.part_spacing:g} mm)"
                )
    return errors
