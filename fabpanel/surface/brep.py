"""Read exact surfaces (STEP, IGES, OCCT BREP) into a :class:`Surface`, through OCCT.

The exact shape is kept as OCCT BREP text in ``Surface.brep`` (without triangulation, so the
bytes hold the geometry only); the ``vertices``/``faces`` of the Surface are a tessellation of it
for everything that works on meshes (boundary loops, areas, previews, orientation references).

Units: STEP and IGES files declare their length unit and OCCT converts on reading into the
session unit ``xstep.cascade.unit``, which fabpanel sets to ``MM`` before every read (pinned in the
tests by reading a STEP written in metres). BREP files carry no unit; by OCCT convention, and in
fabpanel, they are millimetres. A ``units`` argument is therefore ignored for B-reps (logged).

Tessellation (``BRepMesh_IncrementalMesh``): linear deflection ``TESS_RELATIVE`` x the bounding
box diagonal, clipped to ``[TESS_MIN, TESS_MAX]`` mm, and angular deflection ``TESS_ANGLE`` rad.
For a 2 m part this is 0.1 mm, for a 20 m shell 1 mm: chord errors far below plate tolerances,
at roughly 10^4 triangles whatever the size, which keeps the mesh stages fast. Exact queries go
to the B-rep itself (:mod:`.query`), never to this mesh.
"""

from __future__ import annotations

import io
import logging
from pathlib import Path

import numpy as np

from ..data import Surface
from ..errors import InputError, KernelError
from ..units import UNITS, plausible_length_unit
from .boundary import boundary_loops, orient_consistently
from .checks import CREASE_ANGLE, check_surface
from .folds import fold_lines
from .mesh import outer_orientation

log = logging.getLogger(__name__)

#: file extension -> Surface.format
BREP_FORMATS = {".step": "step", ".stp": "step", ".iges": "iges", ".igs": "iges", ".brep": "brep"}

#: linear deflection as a fraction of the bounding-box diagonal, and its limits in mm
TESS_RELATIVE = 5e-5
TESS_MIN = 0.01
TESS_MAX = 1.0
#: angular deflection, rad (about 5.7 degrees between neighbouring triangle normals)
TESS_ANGLE = 0.1
#: welding tolerance of the tessellation as a fraction of the bounding-box diagonal (see
#: ``weld_tessellation``)
WELD_RELATIVE = 1e-6
#: m: a B-rep larger than this, in the unit its file declares, is a unit mistake (ten times
#: the largest shell, ``units.PLAUSIBLE_EXTENT_M``), refused before it is meshed
MAX_EXTENT_M = 3000.0


# --------------------------------------------------------------------------------------------
# BREP text <-> shape
# --------------------------------------------------------------------------------------------
def shape_to_brep(shape) -> bytes:
    """OCCT BREP text of ``shape`` (a ``TopoDS_Shape``), geometry only (no triangulation)."""
    from OCP.BRepTools import BRepTools
    from OCP.TopTools import TopTools_FormatVersion

    stream = io.BytesIO()
    BRepTools.Write_s(
        shape, stream, False, False, TopTools_FormatVersion.TopTools_FormatVersion_CURRENT
    )
    if not stream.getvalue():
        raise KernelError("BREP writing gave no data")
    return stream.getvalue()


def brep_to_shape(data: bytes, name: str = "shape"):
    """``TopoDS_Shape`` from OCCT BREP text (as written by :func:`shape_to_brep`).

    Raises :class:`KernelError` naming ``name`` when the text does not hold a shape.
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Shape

    shape = TopoDS_Shape()
    try:
        BRepTools.Read_s(shape, io.BytesIO(data), BRep_Builder())
    except Exception as err:  # OCCT raises Standard_Failure subclasses through pybind11
        raise KernelError(f"cannot read the BREP data of {name} ({err})") from err
    if shape.IsNull():
        raise KernelError(f"the BREP data of {name} holds no shape")
    return shape


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------
def read_brep(path: Path, units: str | None = None, crease_angle: float = CREASE_ANGLE) -> Surface:
    """Read a STEP, IGES or BREP file into a :class:`Surface` in millimetres.

    units : ignored (B-rep files carry their units); logged when it was given.
    crease_angle : degrees; a sharper fold of the welded tessellation, within a face or between
        two faces, is refused (see :func:`~.checks.check_surface`).
    Raises :class:`InputError` when the file cannot be read, holds no face, or fails a check of
    :func:`~.checks.check_surface`.
    """
    fmt = BREP_FORMATS[path.suffix.lower()]
    if units is not None:
        log.info(
            "%s: --units %s ignored, %s files carry their own units", path.name, units, fmt.upper()
        )
    if fmt == "step":
        shape, declared = _read_step(path)
    elif fmt == "iges":
        shape, declared = _read_iges(path)
    else:
        shape, declared = _read_native(path), "mm"
    faces = shape_faces(shape)
    if not faces:
        raise InputError(
            f"{path.name}: contains no surface (no faces); export the design "
            f"surface as a surface or a mesh"
        )
    _refuse_absurd_extent(shape, path, declared)
    try:
        vertices, triangles, face_ids = tessellate(shape)
    except KernelError as err:
        raise InputError(
            f"{path.name}: {err}; repair the surface in the modeller (or export a mesh)"
        ) from err
    triangles, _ = orient_consistently(triangles)
    triangles = outer_orientation(vertices, triangles)
    check_surface(
        vertices, triangles, name=path.name, units=declared, crease_angle=crease_angle, brep=True
    )
    loops = boundary_loops(triangles, vertices, where=path.name)
    folds = fold_lines(vertices, triangles, face_ids)
    log.info(
        "read %s: %d faces, tessellated to %d vertices, %d triangles, %d boundary loops, "
        "%d fold lines",
        path.name,
        len(faces),
        len(vertices),
        len(triangles),
        len(loops),
        len(folds),
    )
    return Surface(
        vertices=vertices,
        faces=triangles,
        boundary_loops=loops,
        source=path,
        format=fmt,
        units=declared,
        brep=shape_to_brep(shape),
        folds=folds,
    )


def _set_session_unit_mm() -> None:
    from OCP.IGESControl import IGESControl_Controller
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_Controller

    # the static parameters exist only once the controllers are initialised
    STEPControl_Controller.Init_s()
    IGESControl_Controller.Init_s()
    if not Interface_Static.SetCVal_s("xstep.cascade.unit", "MM"):
        raise KernelError("cannot set OCCT's xstep.cascade.unit to MM")


def _refuse_absurd_extent(shape, path: Path, declared: str) -> None:
    """Refuse a B-rep larger than ``MAX_EXTENT_M`` in the unit its file declares, before it is
    meshed: a roof drawn in mm and exported as metres is 14 km across, and meshing it to
    the surface tolerance (1 mm at most) took 24 GB before the kernel killed the run, with no
    word. B-rep files carry their units, so the fix is in the export."""
    size = bbox_size(shape)
    if size.max() <= MAX_EXTENT_M * 1000:
        return
    scale = UNITS["length"].get(declared, 1.0)  # mm per declared unit
    wanted = plausible_length_unit(float(size.max() / scale), declared)
    fix = (
        f"if its coordinates are in {wanted}, export it again with {wanted} as its unit "
        f"({size.max() / scale * UNITS['length'][wanted] / 1000:.3g} m across then)"
        if wanted
        else "export it again in the unit it was drawn in"
    )
    raise InputError(
        f"{path.name}: the surface is {' x '.join(f'{v / 1000:,.0f}' for v in size)} m in the "
        f"unit the file declares ({declared}), larger than any shell (refused above "
        f"{MAX_EXTENT_M:,.0f} m); {fix} "
        f"(B-rep files carry their own units: [input] units does not apply to them)"
    )


def _read_step(path: Path):
    from OCP.collections import Sequence_TCollection_AsciiString as AsciiSequence
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPControl import STEPControl_Reader

    _set_session_unit_mm()
    reader = STEPControl_Reader()
    try:
        status = reader.ReadFile(str(path))
    except Exception as err:
        raise InputError(
            f"{path.name}: cannot read as STEP ({err}); export the surface again "
            f"as STEP AP203/AP214/AP242"
        ) from err
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise InputError(
            f"{path.name}: not a readable STEP file ({status.name}); export the "
            f"surface again as STEP AP203/AP214/AP242"
        )
    declared = "mm"
    try:
        lengths = AsciiSequence()
        reader.FileUnits(lengths, AsciiSequence(), AsciiSequence())
        if lengths.Length():
            declared = _unit_name(lengths.Value(1).ToCString())
    except Exception as err:  # the unit name is informative only; coordinates are mm anyway
        log.debug("%s: cannot read the declared STEP unit (%s)", path.name, err, exc_info=True)
    return _transfer(reader, path, "STEP"), declared


def _read_iges(path: Path):
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.IGESControl import IGESControl_Reader

    _set_session_unit_mm()
    reader = IGESControl_Reader()
    try:
        status = reader.ReadFile(str(path))
    except Exception as err:
        raise InputError(
            f"{path.name}: cannot read as IGES ({err}); export the surface again "
            f"as IGES 5.3 or STEP"
        ) from err
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise InputError(
            f"{path.name}: not a readable IGES file ({status.name}); export the "
            f"surface again as IGES 5.3 or STEP"
        )
    return _transfer(reader, path, "IGES"), "mm"


def _transfer(reader, path: Path, kind: str):
    try:
        roots = reader.NbRootsForTransfer()
        if roots == 0:
            raise InputError(
                f"{path.name}: no {kind} entities found (is this really {kind}?); "
                f"export the design surface as a surface or a mesh"
            )
        reader.TransferRoots()
        shape = reader.OneShape()
    except InputError:
        raise
    except Exception as err:
        raise InputError(
            f"{path.name}: OCCT cannot convert the {kind} entities ({err}); export "
            f"the surface again or as a mesh"
        ) from err
    if shape.IsNull():
        raise InputError(
            f"{path.name}: contains no surface (no faces); export the design "
            f"surface as a surface or a mesh"
        )
    return shape


def _read_native(path: Path):
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Shape

    shape = TopoDS_Shape()
    try:
        BRepTools.Read_s(shape, str(path), BRep_Builder())
    except Exception as err:
        raise InputError(
            f"{path.name}: cannot read as OCCT BREP ({err}); write it with "
            f"BRepTools::Write or export STEP"
        ) from err
    if shape.IsNull():
        raise InputError(
            f"{path.name}: not an OCCT BREP file (no shape read); write it with "
            f"BRepTools::Write or export STEP"
        )
    return shape


def _unit_name(text: str) -> str:
    """'MILLIMETRE' / 'METRE' / 'INCH'... -> 'mm' / 'm' / lower-case name."""
    key = text.strip().upper()
    return {
        "MILLIMETRE": "mm",
        "MILLIMETER": "mm",
        "MM": "mm",
        "METRE": "m",
        "METER": "m",
        "M": "m",
        "CENTIMETRE": "cm",
        "CENTIMETER": "cm",
        "CM": "cm",
    }.get(key, key.lower())


# --------------------------------------------------------------------------------------------
# topology and tessellation
# --------------------------------------------------------------------------------------------
def shape_faces(shape) -> list:
    """The distinct faces of ``shape`` (``TopoDS_Face`` list, in exploration order)."""
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    faces = ShapeMap()
    TopExp.MapShapes_s(shape, TopAbs_FACE, faces)
    return [TopoDS.Face(faces.FindKey(i)) for i in range(1, faces.Extent() + 1)]


def bbox_size(shape) -> np.ndarray:
    """(3,) float: the sides of the shape's bounding box along x, y and z, mm (zeros for an
    empty shape)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    if box.IsVoid():
        return np.zeros(3)
    low, high = box.CornerMin(), box.CornerMax()
    return np.array([high.X() - low.X(), high.Y() - low.Y(), high.Z() - low.Z()])


def bbox_diagonal(shape) -> float:
    """Diagonal of the shape's bounding box, mm."""
    return float(np.linalg.norm(bbox_size(shape)))


def linear_deflection(shape) -> float:
    """Linear deflection used to tessellate ``shape``, mm (see the module docstring)."""
    return float(np.clip(TESS_RELATIVE * bbox_diagonal(shape), TESS_MIN, TESS_MAX))


def tessellate(
    shape, deflection: float | None = None, angle: float = TESS_ANGLE
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangulate every face of ``shape`` and weld the faces along their seams.

    ``deflection``: linear, mm (default :func:`linear_deflection`); ``angle``: angular, rad.
    Returns ``vertices (n, 3) float`` mm, ``triangles (m, 3) int`` wound like the faces'
    orientation in the shape (OCCT ``REVERSED`` faces flipped) and ``face_ids (m,) int``: the
    index in :func:`shape_faces` of the face each triangle comes from.
    Raises :class:`KernelError` when OCCT cannot triangulate a face.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    deflection = linear_deflection(shape) if deflection is None else deflection
    mesher = BRepMesh_IncrementalMesh(shape, deflection, False, angle, True)
    if not mesher.IsDone():
        raise KernelError("OCCT could not tessellate the surface")
    points, triangles, face_ids, offset = [], [], [], 0
    for index, face in enumerate(shape_faces(shape)):
        location = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, location)
        if poly is None or poly.NbTriangles() == 0:
            raise KernelError(f"OCCT could not tessellate face {index}")
        transform = location.Transformation()
        # OCCT exposes nodes one by one; this runs once per load, not per query
        nodes = np.array(
            [poly.Node(i).Transformed(transform).Coord() for i in range(1, poly.NbNodes() + 1)],
            dtype=float,
        )
        tris = (
            np.array(
                [poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)], dtype=np.int64
            )
            - 1
        )
        if face.Orientation() == TopAbs_REVERSED:
            tris = tris[:, ::-1]
        points.append(nodes)
        triangles.append(tris + offset)
        face_ids.append(np.full(len(tris), index, dtype=np.int64))
        offset += len(nodes)
    vertices, tri, ids = weld_tessellation(
        np.vstack(points), np.vstack(triangles), np.concatenate(face_ids)
    )
    return vertices, tri, ids


def weld_tessellation(
    vertices: np.ndarray,
    triangles: np.ndarray,
    face_ids: np.ndarray,
    relative: float = WELD_RELATIVE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge tessellation nodes closer than ``relative`` x bbox diagonal, id-stable.

    BRepMesh discretises each edge once and reuses those points in both adjacent faces, so seam
    nodes coincide up to the rounding of the faces' locations; ``1e-6`` of the diagonal (0.02 mm
    on a 20 m shell) is far below any feature a steel shell has and far above that rounding,
    so welding by distance joins exactly the seams and nothing else. Pairs are found with a
    k-d tree and joined transitively (connected components), which, unlike rounding to a grid,
    cannot split two close nodes across a cell border.
    Triangles that collapse (degenerate edges at poles and apexes) are dropped.
    """
    from scipy import sparse
    from scipy.sparse import csgraph
    from scipy.spatial import cKDTree

    n = len(vertices)
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    pairs = cKDTree(vertices).query_pairs(max(relative * diagonal, 1e-12), output_type="ndarray")
    graph = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = csgraph.connected_components(graph, directed=False)
    # representative of each group = its first node; number groups by first occurrence
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    triangles = rank[inverse.ravel()][triangles]
    keep = (
        (triangles[:, 0] != triangles[:, 1])
        & (triangles[:, 1] != triangles[:, 2])
        & (triangles[:, 2] != triangles[:, 0])
    )
    return vertices[first[order]], triangles[keep], face_ids[keep]
