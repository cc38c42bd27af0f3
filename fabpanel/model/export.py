"""Model files: the STEP assembly (named, coloured parts grouped per panel), one STEP per panel,
and a tessellated GLB preview; and re-reading a STEP file by part name for verification.

Written through build123d's exporters (XCAF underneath): each part is a solid labelled with its
part id and coloured by kind, children of one assembly node per panel labelled with the panel id.
"""

from __future__ import annotations

import logging
from pathlib import Path

import build123d as bd

from ..data import Model, Part
from ..errors import KernelError
from . import occ

log = logging.getLogger(__name__)

#: preview colours per part kind (RGB 0..1): sheets steel grey, ribs orange, stiffeners red
KIND_COLOURS: dict[str, tuple[float, float, float]] = {
    "sheet-top": (0.72, 0.74, 0.78),
    "sheet-bottom": (0.55, 0.58, 0.62),
    "rib": (0.90, 0.55, 0.15),
    "stiffener": (0.80, 0.20, 0.15),
}


def _solid(part: Part) -> bd.Solid:
    solid = bd.Solid(occ.from_brep(part.brep, part.id))
    solid.label = part.id
    solid.color = bd.Color(*KIND_COLOURS.get(part.kind, (0.5, 0.5, 0.5)))
    return solid


def _panel_compound(model: Model, panel_id: str) -> bd.Compound:
    children = [_solid(part) for part in model.parts_of(panel_id)]
    return bd.Compound(children=children, label=panel_id)


def write_step_assembly(model: Model, path: str | Path) -> Path:
    """One STEP file (AP214, mm) with every part a named, coloured solid, grouped per panel."""
    path = Path(path)
    panels = [_panel_compound(model, pid) for pid in model.developed.panel_ids
              if model.parts_of(pid)]
    assembly = bd.Compound(children=panels, label="fabpanel")
    if not bd.export_step(assembly, str(path)):
        raise KernelError(f"STEP export of the assembly to {path} failed")
    return path


def write_panel_steps(model: Model, folder: str | Path) -> dict[str, str]:
    """One STEP per panel, ``<folder>/<panel>.step``; returns {panel id: file name}."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = {}
    for pid in model.developed.panel_ids:
        if not model.parts_of(pid):
            continue
        name = f"{pid}.step"
        if not bd.export_step(_panel_compound(model, pid), str(folder / name)):
            raise KernelError(f"STEP export of panel {pid} failed")
        written[pid] = name
    return written


def write_glb(model: Model, path: str | Path, linear_deflection: float = 0.5,
              angular_deflection: float = 0.2) -> Path:
    """A tessellated binary glTF preview of all parts (coloured by kind), mm.

    linear_deflection : mm, chord error of the tessellation (0.5 mm is invisible in a preview
    of a building and keeps the file small).
    """
    path = Path(path)
    panels = [_panel_compound(model, pid) for pid in model.developed.panel_ids
              if model.parts_of(pid)]
    assembly = bd.Compound(children=panels, label="fabpanel")
    if not bd.export_gltf(assembly, str(path), binary=True, linear_deflection=linear_deflection,
                          angular_deflection=angular_deflection):
        raise KernelError(f"glTF export to {path} failed")
    return path


def read_step_parts(path: str | Path) -> dict[str, object]:
    """{label: OCCT shape} of every labelled solid in a STEP file (assembly nodes are walked)."""
    path = Path(path)
    if not path.is_file():
        raise KernelError(f"STEP file {path} does not exist")
    root = bd.import_step(str(path))
    found: dict[str, object] = {}

    def walk(node) -> None:
        children = list(getattr(node, "children", ()) or ())
        if not children:
            if node.label and isinstance(node, bd.Solid | bd.Compound | bd.Shell):
                solids = node.solids()
                if len(solids) == 1:
                    found[node.label] = solids[0].wrapped
                elif solids:
                    found[node.label] = node.wrapped
            return
        for child in children:
            walk(child)

    walk(root)
    return found
