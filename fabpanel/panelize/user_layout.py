"""The user layout: a quad mesh drawn by hand (or by another tool), mapped onto the surface.

The thesis drew its panel topology in Grasshopper and mapped it onto the design surface
(section 7.1.1, Figure 5); this method takes such a drawing as it is. Steps:

1. read the quads, keeping them as quads: OBJ (parsed here, since trimesh splits quads into
   triangles on load), PLY (ASCII or binary, parsed here for the same reason) and 3DM (the first
   mesh object, through ``rhino3dm``). Every face must have four corners;
2. scale to millimetres, weld coincident vertices (exporters write a shared vertex once per face
   in some settings), drop vertices no quad uses;
3. move every vertex to its closest point on the design surface;
4. orient each quad outwards: its right-hand normal (of the diagonals) must agree with the
   surface normal at the quad's centre, otherwise its corners are reordered ``[0, 3, 2, 1]``;
   neighbouring quads must then cross their shared side in opposite directions, or the drawing
   folds over itself on the surface.

How far the drawing was from the surface is reported (``mapping_distance_mm``); beyond 5 % of
the median panel edge the drawing is probably meant for another surface (or another unit), and
an Issue says so.
"""

from __future__ import annotations

import logging
import re
import struct
from pathlib import Path

import numpy as np

from ..data import PanelLayout, Surface
from ..errors import InputError, Issue
from ..job import Job
from ..surface import SurfaceQuery
from ..units import length_scale
from .quality import layout_metrics

log = logging.getLogger(__name__)

#: file types :func:`read_quad_mesh` reads
LAYOUT_FORMATS = (".obj", ".ply", ".3dm")

#: largest mapping distance, as a fraction of the median panel edge, before a warning: a drawing
#: made on the design surface lies on it up to its modeller's tolerance, far below 5 %
MAPPING_WARNING = 0.05

#: coincident vertices are welded on a grid of this fraction of the bounding-box diagonal
#: (exporters repeat a shared vertex with identical digits; the grid absorbs only rounding)
WELD_RELATIVE = 1e-9

_FIX_QUADS = (
    "every face of a panel layout must be a quad; redraw or rebuild that face with "
    "four corners (e.g. join the triangle with its neighbour) and export again"
)


# --------------------------------------------------------------------------------------------
# the method
# --------------------------------------------------------------------------------------------
def user_layout(
    path: str | Path, units: str | None, surface: Surface, query: SurfaceQuery, job: Job
) -> PanelLayout:
    """The quad mesh in ``path`` as the panel layout of ``surface`` (see the module docstring).

    path : OBJ, PLY or 3DM file of quads.
    units : length unit of the file's coordinates (``"m"``, ``"cm"``, ``"mm"``), normally the
        job's ``[input] units``; a 3DM file's own unit system takes precedence.
    Returns a :class:`PanelLayout` with ``method="layout"`` and panel ids ``P001``... in the
    file's face order. Raises :class:`InputError` for files that are not quad meshes, for faces
    with a repeated corner, for edges shared by more than two quads and for drawings that fold
    over themselves on the surface.
    """
    path = Path(path)
    name = path.name
    drawn, quads = read_quad_mesh(path, units)
    drawn, quads = _weld(drawn - surface.origin, quads)  # drawn in the design's frame
    repeated = np.flatnonzero(np.array([len(set(q)) < 4 for q in quads.tolist()], dtype=bool))
    if len(repeated):
        raise InputError(
            f"{name}: face {int(repeated[0])} has two corners at the same point (a "
            f"collapsed side); {_FIX_QUADS}"
        )
    _check_manifold(name, quads)
    vertices, _, distances = query.closest(drawn)
    quads, flipped = _orient_outwards(vertices, quads, query)
    _check_consistent(name, quads)
    ids = tuple(f"P{i + 1:03d}" for i in range(len(quads)))
    layout = PanelLayout(vertices=vertices, quads=quads, panel_ids=ids, method="layout")
    loops = [surface.vertices[loop] for loop in surface.boundary_loops]
    metrics, issues = layout_metrics(layout, query, job.panelize.panel_size, job.cutting, loops)
    edges = layout.edges
    median_edge = float(
        np.median(np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1))
    )
    largest = float(distances.max())
    metrics = {
        **metrics,
        "source": name,
        "flipped_quads": int(flipped.sum()),
        "mapping_distance_mm": {
            "max": round(largest, 3),
            "median": round(float(np.median(distances)), 3),
            "worst_vertex": int(np.argmax(distances)),
        },
    }
    if largest > MAPPING_WARNING * median_edge:
        issues = (
            *issues,
            Issue(
                "layout-off-surface",
                f"{name}: the drawn layout lies up to {largest:.0f} mm from the design surface "
                f"(vertex {int(np.argmax(distances))}), more than {100 * MAPPING_WARNING:g} % of the "
                f"median panel edge ({median_edge:.0f} mm); check that it was drawn on this surface "
                f"and in the job's units",
                "",
                "warning",
            ),
        )
    log.info(
        "user layout %s: %d panels, largest mapping distance %.3f mm, %d quads flipped",
        name,
        len(quads),
        largest,
        int(flipped.sum()),
    )
    return PanelLayout(
        vertices=vertices,
        quads=quads,
        panel_ids=ids,
        method="layout",
        metrics=metrics,
        issues=issues,
        origin=surface.origin,
    )


def _weld(vertices: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices and drop unused ones; kept vertices keep their file order."""
    used = np.unique(quads)
    if len(used) == 0:
        return vertices[:0], quads
    points = vertices[used]
    low = points.min(axis=0)
    step = max(
        float(np.linalg.norm(points.max(axis=0) - low)) * WELD_RELATIVE, np.finfo(float).tiny
    )
    keys = np.round((points - low) / step).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    # number the merged vertices in the order of their first occurrence in the file
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    renumber = np.full(len(vertices), -1, dtype=np.int64)
    renumber[used] = rank[inverse.ravel()]
    return points[first[order]], renumber[quads]


def _sides(quads: np.ndarray) -> np.ndarray:
    """(4 m, 2) int: directed sides, ``4 p + s`` runs from corner ``s`` to ``s + 1`` of quad p."""
    return np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)


def _check_manifold(name: str, quads: np.ndarray) -> None:
    key = np.sort(_sides(quads), axis=1)
    edges, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if counts.max() > 2:
        bad = int(np.argmax(counts))
        faces = sorted({int(i) // 4 for i in np.flatnonzero(inverse.ravel() == bad)})
        raise InputError(
            f"{name}: the edge between vertices {edges[bad, 0]} and {edges[bad, 1]} "
            f"is shared by {counts[bad]} faces ({', '.join(map(str, faces))}); a "
            f"panel side can join at most two panels, remove the extra faces"
        )


def _orient_outwards(
    vertices: np.ndarray, quads: np.ndarray, query: SurfaceQuery
) -> tuple[np.ndarray, np.ndarray]:
    """Quads with corners reordered ``[0, 3, 2, 1]`` where they face inwards, and which were."""
    corners = vertices[quads]
    normals = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    _, surface_normals, _ = query.closest(corners.mean(axis=1))
    flipped = np.einsum("ij,ij->i", normals, surface_normals) < 0
    quads = quads.copy()
    quads[flipped] = quads[flipped][:, [0, 3, 2, 1]]
    return quads, flipped


def _check_consistent(name: str, quads: np.ndarray) -> None:
    """Raise when two outward quads run a shared side in the same direction (a fold)."""
    sides = _sides(quads)
    key = np.sort(sides, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    shared = np.flatnonzero(counts[inverse] == 2)
    order = shared[np.argsort(inverse[shared], kind="stable")]
    first, second = order[0::2], order[1::2]
    same = np.flatnonzero(sides[first, 0] == sides[second, 0])
    if len(same):
        a, b = int(first[same[0]]) // 4, int(second[same[0]]) // 4
        raise InputError(
            f"{name}: faces {a} and {b} fold over each other on the surface (both "
            f"face outwards but run their shared side the same way); the drawing "
            f"overlaps itself there, redraw it"
        )


# --------------------------------------------------------------------------------------------
# reading quad meshes
# --------------------------------------------------------------------------------------------
def read_quad_mesh(path: str | Path, units: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(n, 3) float`` in millimetres and quads ``(m, 4) int`` of a quad mesh file.

    OBJ and PLY need ``units``; 3DM files carry their own (``units`` is used only when the file's
    unit system is unset). Raises :class:`InputError` for unknown or unreadable files and for
    any face that is not a quad (naming the face, counted from 0 in file order).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in LAYOUT_FORMATS:
        raise InputError(
            f"{path.name}: a panel layout must be an OBJ, PLY or 3DM quad mesh, not "
            f"{suffix or '(no extension)'!r}; export the layout as OBJ"
        )
    if not path.is_file():
        raise InputError(f"{path.name}: layout file not found ({path}); check [panelize] layout")
    if suffix == ".3dm":
        vertices, faces, file_units = _read_3dm(path)
        scale = file_units if file_units is not None else _scale(path.name, units)
    else:
        scale = _scale(path.name, units)
        vertices, faces = _read_obj(path) if suffix == ".obj" else _read_ply(path)
    if not faces:
        raise InputError(f"{path.name}: no faces found; export the layout as a quad mesh")
    for index, face in enumerate(faces):
        if len(face) != 4:
            raise InputError(f"{path.name}: face {index} has {len(face)} corners; {_FIX_QUADS}")
    quads = np.array(faces, dtype=np.int64).reshape(-1, 4)
    if quads.min() < 0 or quads.max() >= len(vertices):
        bad = int(np.flatnonzero((quads < 0).any(axis=1) | (quads >= len(vertices)).any(axis=1))[0])
        raise InputError(
            f"{path.name}: face {bad} refers to a vertex that does not exist (the "
            f"file has {len(vertices)}); export the layout again"
        )
    vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
    if not np.isfinite(vertices).all():
        raise InputError(
            f"{path.name}: a vertex has a NaN or infinite coordinate; export the layout again"
        )
    return vertices * scale, quads


def _scale(name: str, units: str | None) -> float:
    if units is None:
        raise InputError(
            f"{name}: the layout mesh carries no units; set [input] units (m, cm or mm) in the job"
        )
    return length_scale(units)


def _read_obj(path: Path) -> tuple[np.ndarray, list[list[int]]]:
    """OBJ ``v`` and ``f`` records, faces as 0-based index lists (negative indices resolved)."""
    text = path.read_text(errors="replace").replace("\\\n", " ")
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        tokens = line.split("#", 1)[0].split()
        if not tokens:
            continue
        if tokens[0] == "v":
            try:
                vertices.append([float(t) for t in tokens[1:4]])
            except ValueError as err:
                raise InputError(
                    f"{path.name}: line {number}: cannot read the vertex "
                    f"{line.strip()!r}; export the layout again"
                ) from err
            if len(vertices[-1]) != 3:
                raise InputError(f"{path.name}: line {number}: a vertex needs x, y and z")
        elif tokens[0] == "f":
            face = []
            for token in tokens[1:]:
                try:
                    index = int(token.split("/", 1)[0])
                except ValueError as err:
                    raise InputError(
                        f"{path.name}: line {number}: cannot read the face "
                        f"{line.strip()!r}; export the layout again"
                    ) from err
                if index == 0 or index > len(vertices) or index < -len(vertices):
                    raise InputError(
                        f"{path.name}: line {number}: face {len(faces)} refers to "
                        f"vertex {index}, but {len(vertices)} vertices come before "
                        f"it; export the layout again"
                    )
                face.append(index - 1 if index > 0 else len(vertices) + index)
            faces.append(face)
    return np.array(vertices, dtype=float).reshape(-1, 3), faces


_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


def _read_ply(path: Path) -> tuple[np.ndarray, list[list[int]]]:
    """PLY (ASCII or binary) ``vertex`` x, y, z and ``face`` index lists, other elements skipped."""
    data = path.read_bytes()
    end = re.search(rb"end_header\r?\n", data)
    if not data.startswith(b"ply") or end is None:
        raise InputError(
            f"{path.name}: not a PLY file (no 'ply' ... 'end_header' header); export "
            f"the layout again"
        )
    elements: list[tuple[str, int, list[tuple]]] = []
    fmt = "ascii"
    try:
        for line in data[: end.start()].decode("ascii", errors="replace").splitlines():
            words = line.split()
            if not words or words[0] in ("ply", "comment", "obj_info"):
                continue
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property" and words[1] == "list":
                elements[-1][2].append((words[4], _PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
            elif words[0] == "property":
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]]))
    except (IndexError, KeyError, ValueError) as err:
        raise InputError(
            f"{path.name}: malformed PLY header ({err}); export the layout again"
        ) from err
    body = data[end.end() :]
    try:
        if fmt == "ascii":
            rows = _ply_ascii(body, elements)
        elif fmt in ("binary_little_endian", "binary_big_endian"):
            rows = _ply_binary(body, elements, "<" if fmt == "binary_little_endian" else ">")
        else:
            raise InputError(f"{path.name}: unknown PLY format {fmt!r}")
    except (IndexError, ValueError, struct.error) as err:
        if isinstance(err, InputError):
            raise
        raise InputError(
            f"{path.name}: PLY data shorter or other than its header says; export the layout again"
        ) from err
    vertex = rows.get("vertex", {})
    if not all(k in vertex for k in "xyz"):
        raise InputError(f"{path.name}: no vertex x, y, z in the PLY file; export the layout again")
    vertices = np.stack([np.asarray(vertex[k], dtype=float) for k in "xyz"], axis=1)
    face = rows.get("face", {})
    faces = face.get("vertex_indices", face.get("vertex_index", []))
    return vertices, [list(map(int, f)) for f in faces]


def _ply_ascii(body: bytes, elements: list) -> dict:
    tokens = body.split()
    position = 0
    rows: dict[str, dict[str, list]] = {}
    for name, count, properties in elements:
        columns: dict[str, list] = {p[0]: [] for p in properties}
        for _ in range(count):
            for prop in properties:
                if len(prop) == 3:
                    n = int(tokens[position])
                    columns[prop[0]].append(
                        [float(t) for t in tokens[position + 1 : position + 1 + n]]
                    )
                    position += 1 + n
                else:
                    columns[prop[0]].append(float(tokens[position]))
                    position += 1
        rows[name] = columns
    return rows


def _ply_binary(body: bytes, elements: list, order: str) -> dict:
    position = 0
    rows: dict[str, dict[str, list]] = {}
    for name, count, properties in elements:
        if all(len(p) == 2 for p in properties):
            dtype = np.dtype([(p[0], order + p[1]) for p in properties])
            table = np.frombuffer(body, dtype=dtype, count=count, offset=position)
            position += count * dtype.itemsize
            rows[name] = {p[0]: table[p[0]].tolist() for p in properties}
            continue
        columns: dict[str, list] = {p[0]: [] for p in properties}
        for _ in range(count):  # rows of varying length: one at a time
            for prop in properties:
                if len(prop) == 3:
                    size = np.dtype(prop[1]).itemsize
                    n = int(np.frombuffer(body, order + prop[1], 1, position)[0])
                    position += size
                    item = np.dtype(order + prop[2])
                    columns[prop[0]].append(np.frombuffer(body, item, n, position).tolist())
                    position += n * item.itemsize
                else:
                    item = np.dtype(order + prop[1])
                    columns[prop[0]].append(np.frombuffer(body, item, 1, position)[0].item())
                    position += item.itemsize
        rows[name] = columns
    return rows


#: Rhino unit systems fabpanel reads, to millimetres
_RHINO_UNITS = {
    "Millimeters": 1.0,
    "Centimeters": 10.0,
    "Decimeters": 100.0,
    "Meters": 1000.0,
    "Inches": 25.4,
    "Feet": 304.8,
}


def _read_3dm(path: Path) -> tuple[np.ndarray, list[list[int]], float | None]:
    """The first mesh object of a Rhino file: vertices, faces and the file's unit scale to mm.

    Rhino stores a triangle as a quad whose last two corners are equal; such a face is returned
    with three corners (and refused by the caller).
    """
    try:
        import rhino3dm
    except ImportError as err:
        raise InputError(
            f"{path.name}: reading 3DM needs the rhino3dm package (pip install "
            f"rhino3dm), or export the layout as OBJ"
        ) from err
    model = rhino3dm.File3dm.Read(str(path))
    if model is None:
        raise InputError(
            f"{path.name}: cannot read as a Rhino 3DM file; save it again or export "
            f"the layout as OBJ"
        )
    # rhino3dm's stubs omit the runtime __iter__/__len__/__getitem__ of its tables and lists
    for obj in model.Objects:  # type: ignore[attr-defined]
        mesh = obj.Geometry
        if isinstance(mesh, rhino3dm.Mesh):
            break
    else:
        raise InputError(
            f"{path.name}: holds no mesh object; convert the layout to a quad mesh "
            f"in Rhino (Mesh from SubD or QuadRemesh) and save again"
        )
    n_vertices = len(mesh.Vertices)  # type: ignore[arg-type]
    points = [mesh.Vertices[i] for i in range(n_vertices)]  # type: ignore[index]
    vertices = np.array([[p.X, p.Y, p.Z] for p in points], dtype=float)
    faces = []
    for i in range(mesh.Faces.Count):
        a, b, c, d = mesh.Faces[i]  # type: ignore[index]
        faces.append([a, b, c] if c == d else [a, b, c, d])
    unit = model.Settings.ModelUnitSystem.name
    scale = _RHINO_UNITS.get(unit)
    if scale is None and unit not in ("None", "Unset"):
        raise InputError(
            f"{path.name}: Rhino unit system {unit} is not supported; use "
            f"millimeters, centimeters or meters"
        )
    return vertices, faces, scale
