"""The assembly as an IFC4 model (``model/assembly.ifc``), written with ifcopenshell.

Structure: IfcProject > IfcSite > IfcBuilding > IfcBuildingStorey, which contains one
IfcElementAssembly per panel (Name the panel id) and the joints' IfcMechanicalFastener bolts;
each assembly aggregates its IfcPlate parts. A flat plate (rib, stiffener, packing) carries its
solid exactly, as its profile extruded by its thickness (IfcExtrudedAreaSolid of an
IfcArbitraryProfileDefWithVoids, holes included; :mod:`fabpanel.model.profiles`); a rolled
sheet as a closed IfcTriangulatedFaceSet (OCCT's tessellation, deflection ``IFC_RULE``). Its
material (IfcMaterial, category steel), Tag = part mark, ObjectType = part kind, the quantity
set Qto_PlateBaseQuantities (thickness as Width, net volume, net weight) and the property set
FABPANEL_Part (mark, kind, thickness, mass, forming). A bolt is a cylinder of its nominal
diameter and length on the joint's axis, with NominalDiameter and NominalLength. Lengths are
millimetres in the design's own frame (the manifest's), areas m2, volumes m3, masses kg.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .bolts import Bolts, bolt_set
from .source import DocSource

#: tessellation of the solids: deflection 0.1 % of a part's bounding-box diagonal, between 0.1
#: and 2 mm, angular 0.6 rad, and for a sheet at most :data:`SHEET_DEFLECTION` of its
#: thickness. The openings' circles set most of a sheet's vertex count: 0.6 rad draws one with
#: 11 chords (a 40 mm opening within 0.9 mm) and has a third fewer vertices than 0.3 rad on
#: the demo's sheets, their meshed volumes unchanged to 1e-5
IFC_RULE = (0.001, 0.1, 2.0, 0.6)
#: a sheet's largest deflection as a share of its thickness. A sheet's two faces are meshed
#: apart (a fitted sheet face has few knot spans, so OCCT's mesh follows the deflection alone),
#: so their chord errors cancel only in part. On the test vault's 3 mm sheets the meshed volume
#: was 0.9 % off at 2 mm, 0.36 % at t / 3, 0.22 % at t / 4 and 0.07 % at t / 6 (the test allows
#: 0.5 %); t / 4 costs the demo's IFC 3.3 MB (t / 6: 7 MB)
SHEET_DEFLECTION = 1.0 / 4.0
#: coordinates are written to 0.01 mm
IFC_DECIMALS = 2
#: IfcPlate predefined type by part kind (IFC4 IfcPlateTypeEnum)
PLATE_TYPE = {"sheet-top": "SHEET", "sheet-bottom": "SHEET"}


def write_ifc(
    source: DocSource,
    meshes: Mapping[str, object],
    bolts: Bolts,
    path: str | Path,
) -> Path:
    """Write ``path``: every part of ``source`` with its geometry from ``meshes`` (a
    ``PrismProfile`` or (vertices, triangles), local frame, mm; :func:`solid_geometry`), and
    the joint ``bolts`` (module docstring)."""
    import ifcopenshell
    import ifcopenshell.api.context
    import ifcopenshell.api.material
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.unit

    api = ifcopenshell.api
    model = api.project.create_file(version="IFC4")
    project = api.root.create_entity(model, ifc_class="IfcProject", name=_project(source))
    # the units in this order (the API's assign_unit keeps them in a set, whose order changes
    # from process to process)
    project.UnitsInContext = model.createIfcUnitAssignment(
        [
            api.unit.add_si_unit(model, unit_type="LENGTHUNIT", prefix="MILLI"),
            api.unit.add_si_unit(model, unit_type="AREAUNIT"),
            api.unit.add_si_unit(model, unit_type="VOLUMEUNIT"),
            api.unit.add_si_unit(model, unit_type="MASSUNIT", prefix="KILO"),
        ]
    )
    context = api.context.add_context(model, context_type="Model")
    body = api.context.add_context(
        model,
        context_type="Model",
        context_identifier="Body",
        target_view="MODEL_VIEW",
        parent=context,
    )
    site = api.root.create_entity(model, ifc_class="IfcSite", name="Site")
    building = api.root.create_entity(model, ifc_class="IfcBuilding", name=_project(source))
    storey = api.root.create_entity(model, ifc_class="IfcBuildingStorey", name="Shell")
    # relationships made directly: the API's assign_* re-place the children's placements
    # through sets, in an order that changes from process to process
    _aggregate(model, project, [site])
    _aggregate(model, site, [building])
    _aggregate(model, building, [storey])
    origin_placement = _placement(model, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    materials = {
        name: api.material.add_material(model, name=name, category="steel")
        for name in sorted({p.material for p in source.parts})
    }
    assemblies = []
    for panel in source.panels:
        parts = source.parts_of(panel.id)
        if not parts:
            continue
        assembly = api.root.create_entity(
            model, ifc_class="IfcElementAssembly", predefined_type="USERDEFINED", name=panel.id
        )
        assembly.ObjectType = "sandwich panel"
        assembly.ObjectPlacement = model.createIfcLocalPlacement(None, origin_placement)
        plates = [
            _plate(model, body, part, meshes[part.id], source.origin, origin_placement)
            for part in parts
        ]
        _aggregate(model, assembly, plates)
        for name, material in materials.items():
            chosen = [p for p, part in zip(plates, parts) if part.material == name]
            if chosen:
                model.createIfcRelAssociatesMaterial(_guid(), None, None, None, chosen, material)
        assemblies.append(assembly)
    fasteners = _fasteners(model, body, source, bolts, origin_placement)
    model.createIfcRelContainedInSpatialStructure(
        _guid(), None, None, None, assemblies + fasteners, storey
    )
    _make_deterministic(model, _project(source), path)
    path = Path(path)
    model.write(str(path))
    return path


def _make_deterministic(model, project: str, path: str | Path) -> None:
    """The same run gives the same file: GlobalIds from the entities' order, class and name
    (ifcopenshell draws random ones), the header stamped with the day, not the second."""
    import uuid
    from datetime import date

    import ifcopenshell.guid

    namespace = uuid.uuid5(uuid.NAMESPACE_URL, f"fabpanel:{project}")
    for index, entity in enumerate(model.by_type("IfcRoot")):
        key = f"{index}:{entity.is_a()}:{entity.Name}"
        entity.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(namespace, key).hex)
    # tessellated plates and swept bolts: the reference view's geometry
    model.header.file_description.description = ("ViewDefinition [ReferenceView_V1.2]",)
    header = model.header.file_name
    header.name = Path(path).name
    header.time_stamp = f"{date.today().isoformat()}T00:00:00"
    header.author = ("fabpanel",)
    header.organization = ("",)
    header.authorization = "fabpanel"


def _guid() -> str:
    """A placeholder GlobalId (replaced by a deterministic one before writing)."""
    import ifcopenshell.guid

    return ifcopenshell.guid.new()


def _aggregate(model, whole, parts: list) -> None:
    model.createIfcRelAggregates(_guid(), None, None, None, whole, parts)


def _project(source: DocSource) -> str:
    return source.job.docs.project or source.name


def _placement(model, location: np.ndarray, axis: np.ndarray, ref: np.ndarray | None = None):
    ref = ref if ref is not None else _perpendicular(axis)
    return model.createIfcAxis2Placement3D(
        model.createIfcCartesianPoint([float(v) for v in location]),
        model.createIfcDirection([float(v) for v in axis]),
        model.createIfcDirection([float(v) for v in ref]),
    )


def _perpendicular(axis: np.ndarray) -> np.ndarray:
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    ref = helper - axis * (helper @ axis)
    return ref / np.linalg.norm(ref)


def solid_geometries(
    parts: list[tuple[str, bytes, float, str]], workers: int = 1
) -> dict[str, object]:
    """Every part's exchange geometry (:func:`solid_geometry`) by part id, in ``workers``
    worker processes; ``parts`` are (id, BREP, thickness mm, kind). The IFC and the 3DM
    carry the same: a flat plate's profile, a sheet's tessellation."""
    from ..parallel import map_chunks

    items = [(pid, brep, t, not kind.startswith("sheet")) for pid, brep, t, kind in parts]
    return dict(zip((item[0] for item in items), map_chunks(solid_geometry, items, workers)))


def solid_geometry(items: list[tuple[str, bytes, float, bool]]) -> list:
    """Each part's IFC geometry (run in worker processes): a ``PrismProfile`` for a flat plate
    (items marked flat: not the sheets, whose large B-spline faces are slow to measure), else
    its tessellation (vertices, triangles) by ``IFC_RULE``."""
    from ..model.export import tessellate_breps
    from ..model.profiles import prism_profile

    found: list = []
    relative, low, high, angle = IFC_RULE
    for name, brep, thickness, flat in items:
        profile = prism_profile(brep, thickness) if flat else None
        if profile is not None:
            found.append(profile)
            continue
        largest = max(low, min(high, SHEET_DEFLECTION * thickness))
        found.append(tessellate_breps([(name, brep)], (relative, low, largest, angle))[0])
    return found


def _prism_solid(model, profile, origin: np.ndarray):
    """An IfcExtrudedAreaSolid of a flat plate's profile (design frame: + ``origin``)."""

    def curve(loop: np.ndarray):
        closed = np.vstack([loop, loop[:1]])
        points = model.createIfcCartesianPointList2D(np.round(closed, IFC_DECIMALS).tolist())
        return model.createIfcIndexedPolyCurve(points, None, False)

    if profile.inner:
        area = model.createIfcArbitraryProfileDefWithVoids(
            "AREA", None, curve(profile.outer), [curve(loop) for loop in profile.inner]
        )
    else:
        area = model.createIfcArbitraryClosedProfileDef("AREA", None, curve(profile.outer))
    return model.createIfcExtrudedAreaSolid(
        area,
        _placement(model, profile.origin + origin, profile.z_axis, profile.x_axis),
        model.createIfcDirection([0.0, 0.0, 1.0]),
        float(profile.depth),
    )


def _plate(model, body, part, mesh, origin: np.ndarray, placement):
    import ifcopenshell.api.root

    api = ifcopenshell.api
    plate = api.root.create_entity(
        model,
        ifc_class="IfcPlate",
        predefined_type=PLATE_TYPE.get(part.kind, "USERDEFINED"),
        name=part.id,
    )
    plate.Tag = part.mark
    plate.ObjectType = part.kind
    plate.ObjectPlacement = model.createIfcLocalPlacement(None, placement)
    if isinstance(mesh, tuple):
        vertices, triangles = mesh
        points = model.createIfcCartesianPointList3D(
            np.round(np.asarray(vertices, dtype=float) + origin, IFC_DECIMALS).tolist()
        )
        faces = model.createIfcTriangulatedFaceSet(
            points, None, True, (np.asarray(triangles, dtype=int) + 1).tolist(), None
        )
        shape = model.createIfcShapeRepresentation(body, "Body", "Tessellation", [faces])
    else:
        solid = _prism_solid(model, mesh, origin)
        shape = model.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid])
    plate.Representation = model.createIfcProductDefinitionShape(None, None, [shape])
    _property_set(
        model,
        plate,
        "Qto_PlateBaseQuantities",
        {
            "Width": float(part.thickness),
            "NetArea": part.net_area / 1e6,
            "NetVolume": part.volume / 1e9,
            "NetWeight": part.mass,
        },
    )
    _property_set(
        model,
        plate,
        "FABPANEL_Part",
        {
            "Mark": part.mark,
            "Kind": part.kind,
            "Panel": part.panel,
            "Thickness_mm": float(part.thickness),
            "Mass_kg": float(part.mass),
            "Forming": part.forming,
        },
    )
    return plate


#: the quantity entity of each Qto_PlateBaseQuantities quantity (IFC4's template)
QUANTITY_ENTITY = {
    "Width": "IfcQuantityLength",
    "NetArea": "IfcQuantityArea",
    "NetVolume": "IfcQuantityVolume",
    "NetWeight": "IfcQuantityWeight",
}


def _property_set(model, product, name: str, values: dict) -> None:
    """A property set (or, for a ``Qto_`` name, a quantity set) on ``product``: the entities
    ifcopenshell's ``pset.add_pset``/``edit_pset`` (``add_qto``/``edit_qto``) make, made
    directly (the API looks up the schema's templates for every property of every part, a
    quarter of the IFC's time). Text is an IfcLabel, a number an IfcReal; ``None`` is left
    out, as the API does."""
    given = {key: value for key, value in values.items() if value is not None}
    if name.startswith("Qto_"):
        quantities = [
            model.create_entity(QUANTITY_ENTITY[key], key, None, None, float(value), None)
            for key, value in given.items()
        ]
        definition = model.createIfcElementQuantity(
            _guid(), None, name, None, "BaseQuantities", quantities
        )
    else:
        properties = [
            model.createIfcPropertySingleValue(key, None, _single_value(model, value), None)
            for key, value in given.items()
        ]
        definition = model.createIfcPropertySet(_guid(), None, name, None, properties)
    model.createIfcRelDefinesByProperties(_guid(), None, None, None, [product], definition)


def _single_value(model, value):
    """A property's nominal value: IfcLabel for text, IfcBoolean, IfcInteger, IfcReal."""
    if isinstance(value, str):
        return model.create_entity("IfcLabel", value)
    if isinstance(value, (bool, np.bool_)):
        return model.create_entity("IfcBoolean", bool(value))
    if isinstance(value, (int, np.integer)):
        return model.create_entity("IfcInteger", int(value))
    return model.create_entity("IfcReal", float(value))


def _fasteners(model, body, source: DocSource, bolts: Bolts, placement) -> list:
    import ifcopenshell.api.root

    api = ifcopenshell.api
    made = []
    # one bolt set per hole size (each is worked out from the job's build-up)
    sets = {float(hole): bolt_set(source, float(hole)) for hole in np.unique(bolts.diameters)}
    for index, (centre, axis, hole, ribs) in enumerate(
        zip(bolts.centres, bolts.axes, bolts.diameters, bolts.ribs), start=1
    ):
        found = sets[float(hole)]
        if found is None:
            continue
        bolt = api.root.create_entity(
            model, ifc_class="IfcMechanicalFastener", predefined_type="BOLT", name=f"B{index:05d}"
        )
        bolt.ObjectType = found.screw
        bolt.NominalDiameter = float(found.bolt.d)
        bolt.NominalLength = float(found.length)
        bolt.ObjectPlacement = model.createIfcLocalPlacement(None, placement)
        # the bolts' centres are in the design's frame already (the manifest's)
        start = np.asarray(centre) - axis * found.length / 2.0
        solid = model.createIfcExtrudedAreaSolid(
            model.createIfcCircleProfileDef("AREA", None, None, float(found.bolt.d) / 2.0),
            _placement(model, start, np.asarray(axis)),
            model.createIfcDirection([0.0, 0.0, 1.0]),
            float(found.length),
        )
        shape = model.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid])
        bolt.Representation = model.createIfcProductDefinitionShape(None, None, [shape])
        _property_set(
            model,
            bolt,
            "FABPANEL_Bolt",
            {
                "Grade": found.grade,
                "Grip_mm": float(found.grip),
                "Hole_mm": float(hole),
                "Connects": " ".join(ribs),
            },
        )
        made.append(bolt)
    return made
