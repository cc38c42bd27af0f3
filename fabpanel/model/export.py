"""Model files: the STEP assembly (named, coloured parts grouped per panel), one STEP per panel,
and a tessellated GLB preview; and re-reading a STEP file by part name for verification.

Each part is a solid labelled with its part id and coloured by kind, a child of one assembly node
per panel labelled with the panel id. The STEP files (AP214, mm) carry what STEP allows beyond
that: the material (name and density, as OCCT's XCAF material writes it) and per part a property
set with kind, panel, material, thickness, volume, area and mass (``GENERAL_PROPERTY`` with
descriptive and real representation items, OCCT's metadata mode). The XCAF document is built by
build123d's ``_create_xde`` (names, colours, assembly structure; pinned with build123d < 0.14)
and written by ``STEPCAFControl_Writer`` here, with the material and metadata modes on.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path

import build123d as bd
import numpy as np

from ..data import Model, Part
from ..errors import KernelError
from . import occ
from .step_chunks import compact_file

log = logging.getLogger(__name__)

#: preview colours per part kind (RGB 0..1): sheets steel grey, ribs orange, stiffeners red,
#: packing plates blue
KIND_COLOURS: dict[str, tuple[float, float, float]] = {
    "sheet-top": (0.72, 0.74, 0.78),
    "sheet-bottom": (0.55, 0.58, 0.62),
    "rib": (0.90, 0.55, 0.15),
    "stiffener": (0.80, 0.20, 0.15),
    "packing": (0.30, 0.45, 0.80),
}


def _solid(part: Part) -> bd.Solid:
    solid = bd.Solid(occ.from_brep(part.brep, part.id))
    solid.label = part.id
    solid.color = bd.Color(*KIND_COLOURS.get(part.kind, (0.5, 0.5, 0.5)))
    return solid


def _panel_compound(model: Model, panel_id: str) -> bd.Compound:
    children = [_solid(part) for part in model.parts_of(panel_id)]
    return bd.Compound(children=children, label=panel_id)


def _placed(compound: bd.Compound, model: Model) -> bd.Compound:
    """``compound`` placed in the design's own frame: the parts are built in the local frame
    (:mod:`fabpanel.surface.frame`); the files carry the origin as the top node's location."""
    origin = model.developed.layout.origin
    if np.any(origin):
        compound.location = bd.Location(tuple(float(v) for v in origin))
    return compound


def write_step_assembly(
    model: Model, path: str | Path, density: float | None = None, workers: int = 1
) -> Path:
    """One STEP file (AP214, mm) with every part a named, coloured solid, grouped per panel,
    with material and part properties (see the module docstring). ``density``: kg/mm3 for the
    material record (default: from the parts' mass and volume). Written in chunks of panels by
    ``workers`` worker processes and merged (:mod:`fabpanel.model.step_chunks`)."""
    from ..parallel import worker_pool
    from .step_chunks import chunk_groups, merged_step, write_chunk

    path = Path(path)
    ids = [pid for pid in model.developed.panel_ids if model.parts_of(pid)]
    groups = chunk_groups(ids)
    x, y, z = (float(v) for v in model.developed.layout.origin)
    origin = (x, y, z)
    requests = [
        (k, len(groups), [(pid, list(model.parts_of(pid))) for pid in group], origin, density)
        for k, group in enumerate(groups)
    ]
    if workers <= 1 or len(requests) == 1:
        return merged_step((write_chunk(*r) for r in requests), path)
    with worker_pool(workers, fresh=True) as pool:
        return merged_step(pool.map(_chunk, requests), path)


def _chunk(request: tuple) -> tuple[bytes, bytes]:
    from .step_chunks import write_chunk

    return write_chunk(*request)


def write_step_document(
    groups: list[tuple[str, list[Part]]],
    label: str,
    origin: tuple[float, float, float],
    path: Path,
    density: float | None = None,
) -> None:
    """One STEP file of the panels ``groups`` ((panel id, its parts) each) under one node
    ``label`` placed at ``origin`` (the design frame's), under a root ``fabpanel``."""
    panels = [
        bd.Compound(children=[_solid(part) for part in parts], label=pid) for pid, parts in groups
    ]
    node = bd.Compound(children=panels, label=label)
    if any(origin):
        node.location = bd.Location(origin)
    parts = [part for _, group in groups for part in group]
    _write_step(bd.Compound(children=[node], label="fabpanel"), parts, path, density)


def _write_step(
    assembly: bd.Compound,
    parts: tuple[Part, ...] | list[Part],
    path: Path,
    density: float | None = None,
) -> None:
    from build123d.exporters3d import _create_xde
    from OCP.collections import Sequence_TDF_Label
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.Message import Message, Message_Gravity
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.TCollection import TCollection_ExtendedString, TCollection_HAsciiString
    from OCP.TDataStd import TDataStd_Name, TDataStd_NamedData
    from OCP.XCAFDoc import XCAFDoc_DocumentTool
    from OCP.XSControl import XSControl_WorkSession

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    doc = _create_xde(assembly, bd.Unit.MM, auto_naming=False)
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    materials = XCAFDoc_DocumentTool.MaterialTool_s(doc.Main())
    labels = Sequence_TDF_Label()
    shapes.GetShapes(labels)
    by_id = {part.id: part for part in parts}
    material_labels = {}
    for index in range(1, labels.Length() + 1):
        label = labels.Value(index)
        name = TDataStd_Name()
        if not label.FindAttribute(TDataStd_Name.GetID_s(), name):
            continue
        part = by_id.get(name.Get().ToExtString())
        if part is None:
            continue
        if part.material not in material_labels:
            rho = density if density is not None else part.mass / max(part.volume, 1e-300)
            material_labels[part.material] = materials.AddMaterial(
                TCollection_HAsciiString(part.material),
                TCollection_HAsciiString("steel"),
                rho * 1e9,
                TCollection_HAsciiString("density"),
                TCollection_HAsciiString("kg/m3"),
            )
        materials.SetMaterial(label, material_labels[part.material])
        data = TDataStd_NamedData.Set_s(label)
        for key, value in (
            ("kind", part.kind),
            ("panel", part.panel_id),
            ("material", part.material),
        ):
            data.SetString(TCollection_ExtendedString(key), TCollection_ExtendedString(value))
        for key, number in (
            ("thickness_mm", part.thickness),
            ("volume_mm3", part.volume),
            ("area_mm2", part.area),
            ("mass_kg", part.mass),
        ):
            data.SetReal(TCollection_ExtendedString(key), float(number))
    # no p-curves: a reader projects the 3D edges onto their faces (OCCT's does, tested), and
    # the 2D curves of every edge on both its faces were a third of the file
    writer = STEPCAFControl_Writer(XSControl_WorkSession(), False)
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 0)  # after the writer's defaults
    for mode in (
        writer.SetColorMode,
        writer.SetNameMode,
        writer.SetLayerMode,
        writer.SetMaterialMode,
        writer.SetMetadataMode,
    ):
        mode(True)
    if not writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs):
        raise KernelError(f"STEP transfer for {path.name} failed")
    if writer.Write(str(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise KernelError(f"STEP export to {path} failed")


def write_panel_steps(model: Model, folder: str | Path) -> dict[str, str]:
    """One STEP per panel, ``<folder>/<panel>.step``; returns {panel id: file name}."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = {}
    for pid in model.developed.panel_ids:
        if not model.parts_of(pid):
            continue
        name = f"{pid}.step"
        _write_step(_placed(_panel_compound(model, pid), model), model.parts_of(pid), folder / name)
        compact_file(folder / name)
        written[pid] = name
    return written


#: a part's tessellation deflection, as a share of its bounding-box diagonal, and its limits in
#: mm: 2.4 mm on a 1.2 m sheet or rib, invisible in a preview of a building, 0.4 mm on a
#: 200 mm stiffener. The angular deflection sets the holes' and openings' vertex count, most
#: of the preview's: 0.6 rad draws a circle with 11 chords (a 14 mm bolt hole within 0.3 mm,
#: a 40 mm opening within 0.9 mm) and halves the demo's vertices against 0.3 rad
GLB_RELATIVE = 0.002
GLB_DEFLECTION = (0.2, 5.0)
GLB_ANGLE = 0.6


def write_glb(
    model: Model,
    path: str | Path,
    workers: int = 1,
    geometry: Mapping[str, object] | None = None,
) -> Path:
    """A binary glTF preview: one named mesh per part (its part id), a node per panel holding
    its parts, coloured by kind; in metres with Y up, as glTF defines (the parts are mm, Z up).
    ``geometry``: the parts' exchange geometry, when the write stage made it for the IFC and
    the 3DM (:func:`fabpanel.docs.ifc.solid_geometries`): a flat plate is then its profile
    extruded, as there. The other parts (the sheets) are tessellated with a deflection tied
    to their size (``GLB_RELATIVE``), in ``workers`` worker processes.
    Indices in 16 bits where they fit (:mod:`.glb`)."""
    import trimesh

    from .glb import narrow_indices

    path = Path(path)
    origin = np.asarray(model.developed.layout.origin, dtype=float)
    # mm, Z up -> m, Y up: (x, y, z) -> (x, z, -y)
    to_gltf = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]) / 1000.0
    meshes = _exchange_meshes(model.parts, geometry or {})
    missing = [p for p in model.parts if p.id not in meshes]
    meshes.update(zip((p.id for p in missing), _part_meshes(missing, workers)))
    scene = trimesh.Scene()
    by_panel: dict[str, list[Part]] = {}
    for part in model.parts:
        by_panel.setdefault(part.panel_id, []).append(part)
    for panel_id in model.developed.panel_ids:
        if panel_id not in by_panel:
            continue
        scene.graph.update(frame_to=panel_id, frame_from=scene.graph.base_frame)
        for part in by_panel[panel_id]:
            vertices, triangles = meshes[part.id]
            colour = (*KIND_COLOURS.get(part.kind, (0.5, 0.5, 0.5)), 1.0)
            mesh = trimesh.Trimesh(
                (vertices + origin) @ to_gltf.T,
                triangles,
                process=False,
                visual=trimesh.visual.TextureVisuals(
                    material=trimesh.visual.material.PBRMaterial(
                        name=part.kind, baseColorFactor=colour, metallicFactor=0.6
                    )
                ),
            )
            scene.add_geometry(
                mesh, node_name=part.id, geom_name=part.id, parent_node_name=panel_id
            )
    data = scene.export(file_type="glb")
    if not data:
        raise KernelError(f"glTF export to {path} failed")
    path.write_bytes(narrow_indices(data))
    return path


def _exchange_meshes(
    parts: tuple[Part, ...], geometry: Mapping[str, object]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Part id -> (vertices mm, triangles) of every flat plate ``geometry`` holds as a
    profile. A sheet's exchange mesh is left out: meshed to a quarter of its thickness for its
    volume, it is finer than a preview needs (the demo's GLB 6.6 MB against 8.3 MB)."""
    from .profiles import PrismProfile, prism_mesh

    meshes = {}
    for part in parts:
        found = geometry.get(part.id)
        if isinstance(found, PrismProfile):
            meshes[part.id] = prism_mesh(found)
    return meshes


def _part_meshes(parts: list[Part], workers: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every part's preview tessellation (vertices mm, triangles), in worker processes."""
    rule = (GLB_RELATIVE, *GLB_DEFLECTION, GLB_ANGLE)
    return tessellate_breps([(p.id, p.brep) for p in parts], rule, workers)


def tessellate_breps(
    breps: list[tuple[str, bytes]],
    rule: tuple[float, float, float, float],
    workers: int = 1,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Tessellate named BREP solids: (vertices mm, triangles) each, in ``workers`` worker
    processes. ``rule`` is (deflection relative to the part's bounding-box diagonal, smallest
    and largest deflection mm, angular deflection rad)."""
    from functools import partial

    from ..parallel import map_chunks

    return map_chunks(partial(_tessellated, rule=rule), breps, workers)


def _tessellated(
    breps: list[tuple[str, bytes]], rule: tuple[float, float, float, float]
) -> list[tuple[np.ndarray, np.ndarray]]:
    from ..surface.brep import bbox_diagonal, tessellate

    relative, low, high, angle = rule
    meshes = []
    for name, brep in breps:
        shape = occ.from_brep(brep, name)
        deflection = float(np.clip(relative * bbox_diagonal(shape), low, high))
        vertices, triangles, _ = tessellate(shape, deflection, angle)
        meshes.append((vertices, triangles))
    return meshes


def read_step_parts(path: str | Path) -> dict[str, object]:
    """{label: OCCT shape} of every labelled solid in a STEP file (assembly nodes are walked).

    The shapes are in the parts' own (local) frame: the location of the file's top node, which
    places the assembly in the design's frame (``PanelLayout.origin``), is not applied.
    """
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
