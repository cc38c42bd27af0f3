"""Stock suggestion: the standard plate size that buys the least steel for each material and
thickness.

Candidates are the common stock formats of hot- and cold-rolled sheet and plate in the mill
widths 1000, 1250, 1500, 2000 and 2500 mm (``STANDARD_SIZES``, 2000 x 1000 to 6000 x 2500), sheet
cut to length from coil (2000-6000 mm in 250 mm steps, widths up to 2000 mm, up to 20 mm thick),
and the job's own stock. Each is first ranked by the plates its parts' bounding boxes need (rectpack, a few
milliseconds; on every k-th part of a group of more than ``BOX_SAMPLE_PARTS``, since rectpack's
time grows with the square of the parts); the ``NESTED_CANDIDATES`` best are then nested for real (spyrrow's constructive
pack, as :func:`fabpanel.flat.nest.nest` does with a 0 s budget) and the one with the least steel
bought wins (fewer plates on a tie). A group of more than ``SAMPLE_PARTS`` parts is ranked on
the real nests of a sample (every k-th part; each candidate's plates counted with the last one
by how full it is, and scaled by the group's net area over the sample's), and only the best
of them and the job's own stock are then nested in full: on a 252-panel roof the 2016 ribs
took 10 s a nest, six times. Reported per group with bought against net weight and the
scrap; the job adopts it with ``[[cutting.stock]]``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from contextlib import ExitStack

import numpy as np

from ..data import FlatParts, Nests
from ..job import Job, StockSection
from ..parallel import worker_pool
from .nest import nest_group, nest_groups, on_stock, packing_grow, usable
from .packing import Item, box_fits, box_plates

#: common stock formats (length, width) of sheet and plate, mm
STANDARD_SIZES = (
    (2000.0, 1000.0),
    (2500.0, 1250.0),
    (3000.0, 1250.0),
    (3000.0, 1500.0),
    (4000.0, 1500.0),
    (6000.0, 1500.0),
    (4000.0, 2000.0),
    (5000.0, 2000.0),
    (6000.0, 2000.0),
    (5000.0, 2500.0),
    (6000.0, 2500.0),
)
STANDARD_WIDTHS = tuple(sorted({w for _, w in STANDARD_SIZES}))
#: sheet cut to length from coil: any length in this range (in COIL_STEP steps), in the
#: standard widths up to COIL_MAX_WIDTH, for thicknesses up to COIL_MAX_THICKNESS (hot-rolled
#: wide strip; thicker plate comes as plate only)
COIL_LENGTHS = (2000.0, 6000.0)
COIL_STEP = 250.0
COIL_MAX_WIDTH = 2000.0
COIL_MAX_THICKNESS = 20.0
#: plate formats and coil lengths nested for real after the bounding-box ranking
NESTED_CANDIDATES = 4
NESTED_COIL = 2
#: a group of more parts is ranked on the real nests of a sample of this many (every k-th
#: part), and only the best candidate and the job's own stock are then nested in full
SAMPLE_PARTS = 300
#: a group of more parts is ranked by the bounding boxes of a sample of this many
BOX_SAMPLE_PARTS = 1000


def candidate_sizes(job: Job, thickness: float) -> list[StockSection]:
    """The standard sizes, the lengths cut from coil and the job's own stock for parts of
    ``thickness``, each once."""
    sizes = {(length, width): StockSection.of(length, width) for length, width in STANDARD_SIZES}
    if thickness <= COIL_MAX_THICKNESS:
        lengths = np.arange(COIL_LENGTHS[0], COIL_LENGTHS[1] + 1e-9, COIL_STEP)
        for width in (w for w in STANDARD_WIDTHS if w <= COIL_MAX_WIDTH):
            for length in lengths:
                sizes.setdefault((float(length), width), StockSection.of(length, width))
    for stock in job.cutting.stock_for(thickness):
        sizes.setdefault((stock.length, stock.width), StockSection.of(stock.length, stock.width))
    return list(sizes.values())


def from_coil(length: float, width: float) -> bool:
    """Whether a suggested size is cut to length from coil (not a standard plate format)."""
    return (length, width) not in STANDARD_SIZES


def _bought(plates: float, stock: StockSection, kg_per_mm2: float) -> float:
    return plates * stock.length * stock.width * kg_per_mm2


def _bought_by(candidate: tuple[tuple[str, float], StockSection], counts: dict, job: Job) -> float:
    """The steel a (group, stock) candidate buys by its plate count in ``counts``."""
    (_, thickness), stock = candidate
    return _bought(counts[_size_key(candidate)], stock, thickness * float(job.material.density))


def _box_counts(
    items: list[Item], job: Job, stocks: list[StockSection], scale: float = 1.0
) -> list[float | None]:
    """Plates of each of ``stocks`` the items' bounding boxes need; None where a part fits
    none (a worker process's task: rectpack on 1000 parts takes a tenth of a second a size,
    and there are about 80 sizes). With a ``scale`` (``items`` a sample of a group), the
    plates the whole group would need by the sample's, counted as :func:`_scaled_plates`."""
    turns = {r % 180 for r in job.cutting.rotations} == {0, 90}
    counts: list[float | None] = []
    for stock in stocks:
        fitting = on_stock(items, job, stock)
        if len(fitting) != len(items):
            counts.append(None)
            continue
        plates = box_plates(fitting, *usable(job, stock), turns)
        filled = [sum(item.area for item in plate.items) for plate in plates]
        counts.append(_scaled_plates(filled, scale))
    return counts


def _scaled_plates(filled: list[float], scale: float) -> float:
    """The plates a group needs by the nest of a sample of it whose plates hold ``filled``
    (mm2 of parts each): the sample's plates, the last one counted by how full it is against
    the others, times ``scale`` (the group's net area over the sample's); the plain count when
    ``scale`` is 1 (no sample)."""
    if scale == 1.0:
        return float(len(filled))
    last = filled[-1] / float(np.mean(filled[:-1])) if len(filled) > 1 else 1.0
    return (len(filled) - 1 + last) * scale


def _box_ranked(
    items: list[Item], job: Job, kg_per_mm2: float, mapped: Callable = map, split: int = 1
) -> list[tuple[float, StockSection]]:
    """Candidates holding every part, by the steel their bounding-box nest buys; the sizes
    counted in ``split`` interleaved shares through ``mapped``.

    rectpack's best-fit bins try every box on every open plate, so its time grows with the
    square of the parts (4758 ribs: 2.5 s a size, 200 s for the sizes of one group): a group
    of more than ``BOX_SAMPLE_PARTS`` parts is counted on every k-th part, scaled to the
    group. The sizes that hold no part of the group are found on every part."""
    sizes = _holding_every_part(items, job, candidate_sizes(job, float(items[0].part.thickness)))
    sample, scale = _sample(items, BOX_SAMPLE_PARTS)
    shares = [sizes[i::split] for i in range(min(split, len(sizes)))]
    counts = mapped(
        _box_counts,
        [sample] * len(shares),
        [job] * len(shares),
        shares,
        [scale] * len(shares),
    )
    ranked = [
        (_bought(count, stock, kg_per_mm2), stock)
        for share, found in zip(shares, counts)
        for stock, count in zip(share, found)
        if count is not None
    ]
    return sorted(ranked, key=lambda r: (r[0], r[1].length * r[1].width))


def _holding_every_part(
    items: list[Item], job: Job, sizes: list[StockSection]
) -> list[StockSection]:
    """The sizes whose usable area holds every item in one of its rotations (as
    :func:`fabpanel.flat.nest.on_stock`, all items at once)."""
    extent = np.array([np.ptp(it.shape, axis=0) for it in items])
    straight = np.array([any(r % 180 == 0 for r in it.rotations) for it in items])
    turned = np.array([any(r % 180 != 0 for r in it.rotations) for it in items])
    holding = []
    for stock in sizes:
        length, height = usable(job, stock)
        fits = straight & box_fits(extent[:, 0], extent[:, 1], length, height)
        fits |= turned & box_fits(extent[:, 1], extent[:, 0], length, height)
        if fits.all():
            holding.append(stock)
    return holding


def _candidates(
    items: list[Item], job: Job, thickness: float, mapped: Callable = map, split: int = 1
) -> list[StockSection]:
    """The sizes nested for real: the best plate formats and coil lengths by their boxes, and
    what the job nests on now (so the suggestion is never worse than it): the box count is only
    a rough guide to the real nest."""
    kg_per_mm2 = thickness * float(job.material.density)
    ranked = [stock for _, stock in _box_ranked(items, job, kg_per_mm2, mapped, split)]
    current = {(s.length, s.width) for s in job.cutting.stock_for(thickness)}
    plates = [s for s in ranked if not from_coil(s.length, s.width)]
    coil = [s for s in ranked if from_coil(s.length, s.width)]
    nested = plates[:NESTED_CANDIDATES] + coil[:NESTED_COIL]
    return nested + [s for s in ranked if (s.length, s.width) in current and s not in nested]


def _plates_on(items: list[Item], job: Job, stock: StockSection, scale: float = 1.0) -> float:
    """Plates of ``stock`` the items' real nest needs (a worker process's task); with a
    ``scale`` (the whole group's net area over that of ``items``, a sample of it), the plates
    the whole group would need by the sample's (:func:`_scaled_plates`)."""
    fitting = on_stock(items, job, stock)
    plates, _ = nest_group(
        fitting, job, packing_grow(job), 0.0, job.cutting.seed, lambda _: None, stock
    )
    return _scaled_plates([sum(item.area for item, _ in plate) for plate in plates], scale)


def _sample(items: list[Item], size: int) -> tuple[list[Item], float]:
    """Every k-th item of a group larger than ``size`` (the whole group otherwise), and the
    group's net area over the sample's."""
    if len(items) <= size:
        return items, 1.0
    sample = items[:: math.ceil(len(items) / size)]
    return sample, sum(it.area for it in items) / sum(it.area for it in sample)


def _nested_already(nests: Nests | None, job: Job) -> dict[tuple, int]:
    """Plates of the job's own nest per (material, thickness, length, width), where that nest
    is the one a candidate would get: one stock size without a count limit and no time budget
    (spyrrow's constructive pack is then the same computation, bit for bit)."""
    if nests is None or job.cutting.nest_time > 0:
        return {}
    known = {}
    for group in nests.metrics.get("groups", []):
        stocks = job.cutting.stock_for(group["thickness_mm"])
        if len(stocks) == 1 and stocks[0].count is None:
            size = (stocks[0].length, stocks[0].width)
            known[(group["material"], group["thickness_mm"], *size)] = group["plates"]
    return known


def _size_key(candidate: tuple[tuple[str, float], StockSection]) -> tuple:
    """(material, thickness, length, width) of a (group, stock) candidate."""
    (material, thickness), stock = candidate
    return (material, thickness, stock.length, stock.width)


def suggest_stock(
    flat: FlatParts, job: Job, jobs: int | None = None, nests: Nests | None = None
) -> list[dict]:
    """Per (material, thickness): the suggested stock size, its plates, steel bought and net
    (kg), their ratio, the scrap and whether it is cut from coil, JSON-ready. Groups no
    candidate holds are left out. The candidates' nests run in ``jobs`` worker processes
    (default: all cores; 1 inline); the job's own ``nests``, when given, stand in for the
    candidate they equal."""
    groups, _ = nest_groups(flat, job)
    known = _nested_already(nests, job)
    samples = {key: _sample(items, SAMPLE_PARTS) for key, items in groups.items()}
    workers = jobs or os.cpu_count() or 1
    with ExitStack() as stack:
        mapped: Callable = map
        if workers > 1:  # this process has run spyrrow
            mapped = stack.enter_context(worker_pool(workers, fresh=True)).map
        candidates = [
            (key, stock)
            for key, items in sorted(groups.items())
            for stock in _candidates(items, job, key[1], mapped, workers)
        ]
        tasks = [c for c in candidates if _size_key(c) not in known]
        # first every candidate on its group's sample (the whole group where small)
        counts = {_size_key(c): known[_size_key(c)] for c in candidates if c not in tasks}
        counts |= zip(
            [_size_key(c) for c in tasks],
            mapped(
                _plates_on,
                [samples[key][0] for key, _ in tasks],
                [job] * len(tasks),
                [stock for _, stock in tasks],
                [samples[key][1] for key, _ in tasks],
            ),
        )
        # then, where a sample ranked them, the best and the job's own stock in full
        kept = [c for c in candidates if samples[c[0]][1] == 1.0]
        for key in sorted(k for k, (_, scale) in samples.items() if scale != 1.0):
            mine = [c for c in candidates if c[0] == key]
            if not mine:  # no size holds every part: the group is left out
                continue
            kept.append(min(mine, key=lambda c: (_bought_by(c, counts, job), counts[_size_key(c)])))
            current = {(s.length, s.width) for s in job.cutting.stock_for(key[1])}
            kept += [c for c in mine if (c[1].length, c[1].width) in current and c not in kept]
        again = [c for c in kept if samples[c[0]][1] != 1.0 and _size_key(c) not in known]
        counts |= zip(
            [_size_key(c) for c in again],
            mapped(_plates_on, [groups[key] for key, _ in again], [job] * len(again),
                   [stock for _, stock in again]),
        )  # fmt: skip
    best: dict[tuple[str, float], tuple[float, int, StockSection]] = {}
    for key, stock in kept:
        count = int(counts[_size_key((key, stock))])
        bought = _bought(count, stock, key[1] * float(job.material.density))
        if key not in best or (bought, count) < best[key][:2]:
            best[key] = (bought, count, stock)
    out = []
    for (material, thickness), (bought, count, stock) in sorted(best.items()):
        net = sum(it.part.area for it in groups[(material, thickness)])
        net *= thickness * float(job.material.density)
        if net <= 0:
            continue
        out.append(
            {
                "material": material,
                "thickness_mm": thickness,
                "length_mm": stock.length,
                "width_mm": stock.width,
                "plates": count,
                "bought_kg": round(bought, 1),
                "net_kg": round(net, 1),
                "bought_to_net": round(bought / net, 3),
                "scrap_kg": round(bought - net, 1),
                "from_coil": from_coil(stock.length, stock.width),
                # the parts the candidates were ranked on (every k-th of a large group); the
                # plates above are always the whole group's real nest
                "ranked_on_parts": len(samples[(material, thickness)][0]),
            }
        )
    return out


def stock_toml(suggestion: list[dict]) -> str:
    """The suggestion as ``[[cutting.stock]]`` entries to paste into the job."""
    return "\n".join(
        f'[[cutting.stock]]\nlength = "{s["length_mm"]:g} mm"\nwidth = "{s["width_mm"]:g} mm"\n'
        f'thickness = "{s["thickness_mm"]:g} mm"\n'
        + ("# cut to length from coil\n" if s.get("from_coil") else "")
        for s in suggestion
    )
