"""Plate files: one plasma DXF and one PNG preview per nested plate.

A plate DXF holds one block per part mark (the mark's first part: etching, inner contours, outer
contour, in cut order) and an INSERT per part placed; the plate outline is on ``PLATE``, a layer
never cut (and not plotted). The PNG is a quick preview drawn with PIL (parts filled, labelled
with their ids, bend lines in green), a few milliseconds a plate.
"""

from __future__ import annotations

import functools
import logging
from pathlib import Path

import matplotlib
import numpy as np
from shapely.geometry import Polygon

from ..data import FlatPart, FlatParts, Nests, Plate
from ..raster import palette_png
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


def write_plate_png(
    plate: Plate, parts: dict[str, FlatPart], path: str | Path, dpi: int = 80
) -> Path:
    """A preview of one plate: plate outline, parts filled (holes open) and labelled, bend
    lines in green, its size and use as the title. Drawn with PIL straight onto the pixels
    (12 inches wide at ``dpi``): the matplotlib figure it replaces took 55 ms a plate, most
    of it setting up axes and laying out text, for the same flat colours and labels."""
    length, width = plate.size
    canvas = _PreviewCanvas(length, width, dpi)
    canvas.draw.rectangle(canvas.box(0.0, 0.0, length, width), outline="black")
    labels = []
    for placement in plate.placements:
        part = parts[placement.part_id]
        t = np.asarray(placement.transform)
        outline = transform_points(t, part.outline)
        holes = [transform_points(t, h) for h in part.holes]
        for round_hole in part.round_holes + part.drill_holes:
            circle = _CIRCLE * round_hole.diameter / 2 + round_hole.centre
            holes.append(transform_points(t, circle))
        canvas.draw.polygon(canvas.pixels(outline), fill=PART_FILL, outline=PART_EDGE)
        for contour in holes:
            canvas.draw.polygon(canvas.pixels(contour), fill="white", outline=PART_EDGE)
        for line in bend_marks(part):
            canvas.draw.line(canvas.pixels(transform_points(t, line)), fill=BEND_COLOUR)
        centre = Polygon(outline).representative_point()
        labels.append((part.id, canvas.pixels(np.array([[centre.x, centre.y]]))[0]))
    # the labels last, over every part's fill
    small = _font(6 * dpi / 72)
    for text, where in labels:
        canvas.draw.text(where, text, fill="black", font=small, anchor="mm")
    title = (
        f"{plate.name}: {plate.material} {plate.thickness:g} x {length:g} x {width:g} mm, "
        f"{len(plate.placements)} parts, {plate.utilisation:.0%} used"
    )
    canvas.draw.text(
        (canvas.image.width / 2, 0.01 * canvas.image.height),
        title,
        fill="black",
        font=_font(9 * dpi / 72),
        anchor="ma",
    )
    Path(path).write_bytes(palette_png(canvas.image, NEST_COLOURS))
    return Path(path)


#: the preview's colours: parts, their edges, bend lines
PART_FILL, PART_EDGE, BEND_COLOUR = "#9ecae1", "#08519c", "#31a354"
#: the drawing's margins, as shares of the image (left, right, bottom, top) and around the
#: plate, mm
PREVIEW_MARGINS, PLATE_MARGIN = (0.01, 0.01, 0.01, 0.07), 20.0


class _PreviewCanvas:
    """A white image 12 inches wide at ``dpi`` whose drawing area shows the plate (and
    ``PLATE_MARGIN`` round it) at one scale, centred; plate millimetres to pixels (y up)."""

    def __init__(self, length: float, width: float, dpi: int) -> None:
        from PIL import Image, ImageDraw

        size = (round(12 * dpi), round((12 * width / length + 0.6) * dpi))
        self.image = Image.new("RGB", size, "white")
        self.draw = ImageDraw.Draw(self.image)
        left, right, bottom, top = PREVIEW_MARGINS
        area_w, area_h = size[0] * (1 - left - right), size[1] * (1 - bottom - top)
        shown_w, shown_h = length + 2 * PLATE_MARGIN, width + 2 * PLATE_MARGIN
        self.scale = min(area_w / shown_w, area_h / shown_h)
        self.x0 = size[0] * left + (area_w - self.scale * shown_w) / 2
        self.y0 = size[1] * (1 - bottom) - (area_h - self.scale * shown_h) / 2

    def pixels(self, points: np.ndarray) -> list[tuple[float, float]]:
        px = self.x0 + (np.asarray(points)[:, 0] + PLATE_MARGIN) * self.scale
        py = self.y0 - (np.asarray(points)[:, 1] + PLATE_MARGIN) * self.scale
        return list(zip(px.tolist(), py.tolist()))

    def box(self, x0: float, y0: float, x1: float, y1: float) -> list[float]:
        (a, b), (c, d) = self.pixels(np.array([[x0, y1], [x1, y0]]))
        return [a, b, c, d]


@functools.lru_cache(maxsize=8)
def _font(size: float):
    """DejaVu Sans (matplotlib's own) at ``size`` pixels, as the report's figures use."""
    from PIL import ImageFont

    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
    return ImageFont.truetype(str(path), max(1, round(size)))


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
