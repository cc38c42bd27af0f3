"""Plate files: one plasma DXF and one PNG preview per nested plate.

DXF entity order is the cut order: all etching first (marking before the parts are cut loose), then
per part its inner contours before its outer contour. The PNG is a quick matplotlib preview (parts
filled, labelled with their ids, bend lines in green), about 0.2 s per plate.
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import PathPatch
from matplotlib.path import Path as MplPath
from shapely.geometry import Polygon

from ..data import FlatPart, FlatParts, Nests, Plate
from .dxf import add_part, etch_polylines, new_document, save
from .nest import transform_points

log = logging.getLogger(__name__)


def write_plate_dxf(plate: Plate, parts: dict[str, FlatPart], path: str | Path) -> Path:
    """One plate as DXF: ``PLATE`` outline, ``ETCH`` first, then holes and outer contours."""
    doc = new_document()
    msp = doc.modelspace()
    length, width = plate.size
    msp.add_lwpolyline(
        [(0, 0), (length, 0), (length, width), (0, width)],
        close=True,
        dxfattribs={"layer": "PLATE"},
    )
    for placement in plate.placements:
        part = parts[placement.part_id]
        for line in etch_polylines(part):
            msp.add_lwpolyline(
                transform_points(placement.transform, line).tolist(), dxfattribs={"layer": "ETCH"}
            )
    for placement in plate.placements:
        add_part(msp, parts[placement.part_id], np.asarray(placement.transform), etch=False)
    return save(doc, path)


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
    for placement in plate.placements:
        part = parts[placement.part_id]
        t = np.asarray(placement.transform)
        outline = transform_points(t, part.outline)
        contours = [outline] + [transform_points(t, h) for h in part.holes]
        for hole in part.round_holes + part.drill_holes:
            angle = np.linspace(0, 2 * np.pi, 24, endpoint=False)
            circle = np.stack([np.cos(angle), np.sin(angle)], 1) * hole.diameter / 2
            contours.append(transform_points(t, circle + hole.centre)[::-1])
        ax.add_patch(PathPatch(_contour_path(contours), fc="#9ecae1", ec="#08519c", lw=0.6))
        if len(part.bend_lines):
            ax.add_collection(
                LineCollection(
                    [transform_points(t, line) for line in part.bend_lines],
                    colors="#31a354",
                    linewidths=0.5,
                )
            )
        centre = Polygon(outline).representative_point()
        ax.text(centre.x, centre.y, part.id, ha="center", va="center", fontsize=6)
    ax.set_xlim(-20, length + 20)
    ax.set_ylim(-20, width + 20)
    ax.set_aspect("equal")
    ax.set_title(
        f"{plate.name}: {plate.material} {plate.thickness:g} mm, "
        f"{len(plate.placements)} parts, {plate.utilisation:.0%} used",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)


def write_nests(nests: Nests, flat: FlatParts, folder: str | Path) -> dict[str, list[str]]:
    """Write ``plate-NNN.dxf`` and ``plate-NNN.png`` per plate; returns name -> [dxf, png]."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    parts = {p.id: p for p in flat.parts}
    files = {}
    for plate in nests.plates:
        dxf_name, png_name = f"{plate.name}.dxf", f"{plate.name}.png"
        write_plate_dxf(plate, parts, folder / dxf_name)
        write_plate_png(plate, parts, folder / png_name)
        files[plate.name] = [dxf_name, png_name]
    log.info("wrote %d plate files to %s", len(files), folder)
    return files
