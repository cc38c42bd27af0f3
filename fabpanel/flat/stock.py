"""Stock suggestion: the standard plate size that buys the least steel for each material and
thickness.

Candidates are the common stock formats of hot- and cold-rolled sheet and plate in the mill
widths 1000, 1250, 1500, 2000 and 2500 mm (``STANDARD_SIZES``, 2000 x 1000 to 6000 x 2500), and
the job's own stock. Each is first ranked by the plates its parts' bounding boxes need (rectpack, a few
milliseconds); the ``NESTED_CANDIDATES`` best are then nested for real (spyrrow's constructive
pack, as :func:`fabpanel.flat.nest.nest` does with a 0 s budget) and the one with the least steel
bought wins (fewer plates on a tie). Reported per group with bought against net weight and the
scrap; the job adopts it with ``[[cutting.stock]]``.
"""

from __future__ import annotations

from ..data import FlatParts
from ..job import Job, StockSection
from .nest import nest_group, nest_groups, on_stock, packing_grow, usable
from .packing import Item, box_plates

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
#: candidates nested for real after the bounding-box ranking
NESTED_CANDIDATES = 4


def candidate_sizes(job: Job, thickness: float) -> list[StockSection]:
    """The standard sizes and the job's own stock for parts of ``thickness``, each once."""
    sizes = {(length, width): StockSection.of(length, width) for length, width in STANDARD_SIZES}
    for stock in job.cutting.stock_for(thickness):
        sizes.setdefault((stock.length, stock.width), StockSection.of(stock.length, stock.width))
    return list(sizes.values())


def _bought(plates: int, stock: StockSection, kg_per_mm2: float) -> float:
    return plates * stock.length * stock.width * kg_per_mm2


def _box_ranked(items: list[Item], job: Job, kg_per_mm2: float) -> list[tuple[float, StockSection]]:
    """Candidates holding every part, by the steel their bounding-box nest buys."""
    turns = {r % 180 for r in job.cutting.rotations} == {0, 90}
    ranked = []
    for stock in candidate_sizes(job, float(items[0].part.thickness)):
        fitting = on_stock(items, job, stock)
        if len(fitting) < len(items):
            continue
        plates = len(box_plates(fitting, *usable(job, stock), turns))
        ranked.append((_bought(plates, stock, kg_per_mm2), stock))
    return sorted(ranked, key=lambda r: (r[0], r[1].length * r[1].width))


def suggest_stock(flat: FlatParts, job: Job) -> list[dict]:
    """Per (material, thickness): the suggested stock size, its plates, steel bought and net
    (kg), their ratio and the scrap, JSON-ready. Groups no standard size holds are left out."""
    groups, _ = nest_groups(flat, job)
    grow = packing_grow(job)
    out = []
    for (material, thickness), items in sorted(groups.items()):
        kg_per_mm2 = thickness * float(job.material.density)
        net = sum(it.part.area for it in items) * kg_per_mm2
        best = None
        for _, stock in _box_ranked(items, job, kg_per_mm2)[:NESTED_CANDIDATES]:
            plates, _ = nest_group(
                on_stock(items, job, stock),
                job,
                grow,
                0.0,
                job.cutting.seed,
                lambda _: None,
                stock,
            )
            bought = _bought(len(plates), stock, kg_per_mm2)
            if best is None or (bought, len(plates)) < (best[0], best[1]):
                best = (bought, len(plates), stock)
        if best is None or net <= 0:
            continue
        bought, count, stock = best
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
            }
        )
    return out


def stock_toml(suggestion: list[dict]) -> str:
    """The suggestion as ``[[cutting.stock]]`` entries to paste into the job."""
    return "\n".join(
        f'[[cutting.stock]]\nlength = "{s["length_mm"]:g} mm"\nwidth = "{s["width_mm"]:g} mm"\n'
        f'thickness = "{s["thickness_mm"]:g} mm"\n'
        for s in suggestion
    )
