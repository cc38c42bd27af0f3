"""Ribs sawn from flat bar instead of burnt from plate.

A rib whose outline is a straight strip of constant height (two long straight parallel edges,
straight ends, square or mitred: the saw cuts both) no wider than a rolled flat bar is cheaper
sawn from bar than burnt from plate: no nest, no burnt long edges, bar bought by the metre.
Hot-rolled flat bars for general purposes (EN 10058) come in widths up to 150 mm. With
``[cutting] flat_bar = true`` such ribs are flagged (``FlatPart.stock_form = "flat-bar"``), left
out of the plate nests and cut from bars of ``bar_length`` (first fit decreasing, one saw kerf
per cut); their holes are still drilled from the part's DXF. Snipes are coped after sawing. A rib
with a curved edge, or an edge that is not straight within ``STRAIGHT_TOLERANCE``, stays a
plate part.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from shapely.geometry import Polygon

from ..data import FlatPart

#: widest hot-rolled flat bar for general purposes (EN 10058), mm
MAX_BAR_WIDTH = 150.0
#: a flat-bar rib's edges are straight and its height constant within this, mm
STRAIGHT_TOLERANCE = 0.2


def bar_size(part: FlatPart) -> tuple[float, float] | None:
    """(width, length) in mm of the flat bar piece ``part`` is sawn from, or None when it is not
    a straight strip of constant height at most :data:`MAX_BAR_WIDTH` wide (see the module
    docstring): its outline fills its smallest enclosing rectangle but for the ends (square or
    mitred saw cuts, snipes coped after sawing), and between the ends every outline point lies
    on one of the two long sides within :data:`STRAIGHT_TOLERANCE`. The length is the piece's
    extent along the bar."""
    if part.kind != "rib" or part.holes:
        return None
    outline = np.asarray(part.outline, float)
    box = np.asarray(Polygon(outline).minimum_rotated_rectangle.exterior.coords)[:-1]
    sides = np.roll(box, -1, axis=0) - box
    lengths = np.linalg.norm(sides, axis=1)
    long = int(np.argmax(lengths))
    axis = sides[long] / lengths[long]
    normal = np.array([-axis[1], axis[0]])
    along, across = (outline - box[long]) @ axis, (outline - box[long]) @ normal
    across -= across.min()
    width, length = float(across.max()), float(np.ptp(along))
    if width > MAX_BAR_WIDTH + STRAIGHT_TOLERANCE or length < 2 * width:
        return None
    # between the ends (a bar width from each), the outline runs along the two long sides only
    middle = (along > along.min() + width) & (along < along.max() - width)
    off = np.minimum(np.abs(across[middle]), np.abs(across[middle] - width))
    if not middle.any() or off.max() > STRAIGHT_TOLERANCE:
        return None
    # and both long sides are there (a wedge or a triangle has points on one side only)
    if not (
        across[middle].min() < STRAIGHT_TOLERANCE
        and across[middle].max() > width - STRAIGHT_TOLERANCE
    ):
        return None
    return width, length


def bars_needed(lengths: list[float], bar_length: float, kerf: float) -> int:
    """Bars of ``bar_length`` mm the pieces need, first fit decreasing with one ``kerf`` per
    cut (a 1D bin packing: within 11/9 of the optimum plus one bar)."""
    free: list[float] = []
    for piece in sorted(lengths, reverse=True):
        need = piece + kerf
        for i, room in enumerate(free):
            if need <= room + 1e-9:
                free[i] = room - need
                break
        else:
            free.append(bar_length - need)
    return len(free)


def bar_metrics(
    parts: list[FlatPart], bar_length: float, kerf: float, density: float
) -> list[dict]:
    """Per (material, thickness, width) of the flat-bar parts: pieces, bars, metres, bought and
    net kg (net: the pieces' flat areas), JSON-ready."""
    groups: dict[tuple[str, float, float], list[tuple[FlatPart, float]]] = defaultdict(list)
    for part in parts:
        size = bar_size(part)
        if size is not None:
            groups[(part.material, float(part.thickness), round(size[0], 1))].append(
                (part, size[1])
            )
    out = []
    for (material, thickness, width), pieces in sorted(groups.items()):
        lengths = [length for _, length in pieces]
        bars = bars_needed(lengths, bar_length, kerf)
        out.append(
            {
                "material": material,
                "thickness_mm": thickness,
                "width_mm": width,
                "pieces": len(pieces),
                "bars": bars,
                "bar_length_mm": bar_length,
                "cut_metres": round(sum(lengths) / 1000, 3),
                "bought_kg": round(bars * bar_length * width * thickness * density, 2),
                "net_kg": round(sum(p.area for p, _ in pieces) * thickness * density, 2),
            }
        )
    return out
