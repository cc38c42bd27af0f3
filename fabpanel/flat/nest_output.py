"""Plate files: one plasma DXF and one PNG preview per nested plate.

A plate DXF holds one block per part mark (the mark's first part: etching, inner contours, outer
contour, in cut order) and an INSERT per part placed; the plate outline is on ``PLATE``, a layer
never cut (and not plotted). The PNG is a quick matplotlib preview (parts
filled, labelled with their ids, bend lines in green), about 0.06 s per plate.
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.path import Path as MplPath
from shapely.geometry import Polygon

from ..data import FlatPart, FlatParts, Nests, Plate
from ..raster import figure_png
from .dxf import add_part, bend_marks, new_document, save
from .packing import transform_points

log = logging.getLogger(__name__)

#: a nest preview's palette: a few flat fills, outlines and black text
NEST_COLOURS = 32


def write_plate_dxf(
    plate: Plate,
    parts: dict[str, FlatPart],
    path: str | Path,
    marks: dict[str, tuple[str, np.ndarray]] | None = None,
) -> Path:
    """One plate as DXF: the ``PLATE`` outline (a layer never cut or plotted), then one INSERT
    per part of a block per part mark (its etching, inner contours, outer contour: the mark's
    first part, as in ``cut/parts``).

    marks : part id -> (its mark's first part id, (3, 3) map from that part's flat frame to
        this part's); without it, every part is its own block.
    """
    doc = new_document()
    doc.layers.get("PLATE").dxf.plot = 0
    msp = doc.modelspace()
    length, width = plate.size
    msp.add_lwpolyline(
        [(0, 0), (length, 0), (length, width), (0, width)],
        close=True,
        dxfattribs={"layer": "PLATE"},
    )
    for placement in plate.placements:
        first_id, to_part = (marks or {}).get(placement.part_id, (placement.part_id, np.eye(3)))
        first = parts[first_id]
        name = first.mark or first.id
        if name not in doc.blocks:
            add_part(doc.blocks.new(name=name), first)
        insert = np.asarray(placement.transform, dtype=float) @ to_part
        angle = float(np.degrees(np.arctan2(insert[1, 0], insert[0, 0])))
        msp.add_blockref(
            name, (float(insert[0, 2]), float(insert[1, 2])), dxfattribs={"rotation": angle}
        )
    return save(doc, path, ((0.0, 0.0), (length, width)))


def mark_frames(flat: FlatParts) -> dict[str, tuple[str, np.ndarray]]:
    """Part id -> (its mark's first part id, the map from that part's flat frame to its own)."""
    frames = {}
    for group in flat.marks:
        for part_id, transform in zip(group.part_ids, group.transforms):
            frames[part_id] = (group.part_ids[0], np.asarray(transform, dtype=float))
    return frames


def _contour_path(contours: list[np.ndarray]) -> MplPath:
    vertices, codes = [], []
    for c in contours:
        vertices += [*c.tolist(), c[0].tolist()]
        codes += [MplPath.MOVETO] + [MplPath.LINETO] * (len(c) - 1) + [MplPath.CLOSEPOLY]
    return MplPath(vertices, codes)


def write_plate_png(
    plate: Plate, parts: dict[str, FlatPart], path: str | Path, dpi: int = 80
) -> Path:
    """A preview of one plate: plate outline, parts filled (holes open) and labelled."""
    length, width = plate.size
    fig, ax = plt.subplots(figsize=(12, 12 * width / length + 0.6))
    ax.add_patch(plt.Rectangle((0, 0), length, width, fill=False, lw=1.0, ec="black"))
    shapes, bends = [], []
    for placement in plate.placements:
        part = parts[placement.part_id]
        t = np.asarray(placement.transform)
        outline = transform_points(t, part.outline)
        contours = [outline] + [transform_points(t, h) for h in part.holes]
        for hole in part.round_holes + part.drill_holes:
            contours.append(transform_points(t, _CIRCLE * hole.diameter / 2 + hole.centre)[::-1])
        shapes.append(_contour_path(contours))
        bends += [transform_points(t, line) for line in bend_marks(part)]
        centre = Polygon(outline).representative_point()
        ax.text(centre.x, centre.y, part.id, ha="center", va="center", fontsize=6)
    # one collection each, not an artist per part, and no autoscaling (the plate sets the
    # limits): a patch per part spent most of a plate's time updating the data limits
    ax.add_collection(
        PathCollection(shapes, facecolors="#9ecae1", edgecolors="#08519c", linewidths=0.6),
        autolim=False,
    )
    if bends:
        ax.add_collection(LineCollection(bends, colors="#31a354", linewidths=0.5), autolim=False)
    ax.set_xlim(-20, length + 20)
    ax.set_ylim(-20, width + 20)
    ax.set_aspect("equal")
    # no axes: the title gives the plate's size, and the ticks' artists were half the drawing
    ax.set_axis_off()
    # the figure's text, not the axes' title: placing a title measures the (hidden) axes
    fig.text(
        0.5,
        0.99,
        f"{plate.name}: {plate.material} {plate.thickness:g} x {length:g} x {width:g} mm, "
        f"{len(plate.placements)} parts, {plate.utilisation:.0%} used",
        fontsize=9,
        ha="center",
        va="top",
    )
    # fixed margins: tight_layout measured every label again, a third of the plate's time
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=0.93)
    Path(path).write_bytes(figure_png(fig, dpi=dpi, colours=NEST_COLOURS))
    plt.close(fig)
    return Path(path)


#: a round hole's preview polygon, unit radius, 24 corners
_CIRCLE = np.column_stack(
    [np.cos(_TURN := np.linspace(0, 2 * np.pi, 24, endpoint=False)), np.sin(_TURN)]
)


def write_nests(nests: Nests, flat: FlatParts, folder: str | Path) -> dict[str, list[str]]:
    """Write ``plate-NNN.dxf`` and ``plate-NNN.png`` per plate; returns name -> [dxf, png]."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    parts = {p.id: p for p in flat.parts}
    marks = mark_frames(flat)
    files = {}
    for plate in nests.plates:
        dxf_name, png_name = f"{plate.name}.dxf", f"{plate.name}.png"
        write_plate_dxf(plate, parts, folder / dxf_name, marks)
        write_plate_png(plate, parts, folder / png_name)
        files[plate.name] = [dxf_name, png_name]
    log.info("wrote %d plate files to %s", len(files), folder)
    return files
