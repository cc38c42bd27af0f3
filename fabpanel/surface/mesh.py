"""Read triangle and quad meshes (OBJ, STL, PLY, OFF, GLB/GLTF) into a :class:`Surface`.

Reading goes through trimesh (``process=False``, so trimesh neither merges nor reorders anything
on its own); fabpanel then checks, welds, scales and orients the mesh itself:

1. the file must give finite coordinates and triangles whose indices exist (OBJ and OFF files are
   also checked against their own text, since a reader may drop or wrap a bad index silently);
2. vertices at the same position are merged, keeping the first occurrence's order (id-stable);
   triangles that collapse to an edge after merging are dropped, unused vertices removed;
3. coordinates are scaled to millimetres with the declared unit (meshes carry none);
4. triangles are flipped to a consistent winding (:func:`~.boundary.orient_consistently`) and
   each connected part is turned to face outwards (:func:`outer_orientation`);
5. what the later stages cannot handle is refused, saying where: unwelded seams, separate
   pieces, creases sharper than ``[input] crease_angle``, self-intersections (:mod:`.checks`).

Outer-side rule (fabpanel's convention for shells, documented in ``outer_orientation``): a closed
part encloses positive volume; an open part faces up, i.e. its area-weighted mean normal has a
positive z component (a roof or a vault is seen from above), unless that mean normal is within
about 5.7 degrees of horizontal (``|n_z| < 0.1``, a wall or a closed-looking tube), where the file's
own winding is kept.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np

from ..data import Surface
from ..errors import InputError
from ..units import length_scale
from .boundary import boundary_loops, edge_use, orient_consistently
from .checks import CREASE_ANGLE, check_surface

log = logging.getLogger(__name__)

#: file extension -> (Surface.format, trimesh file_type)
MESH_FORMATS = {
    ".obj": ("obj", "obj"),
    ".stl": ("stl", "stl"),
    ".ply": ("ply", "ply"),
    ".off": ("off", "off"),
    ".glb": ("glb", "glb"),
    ".gltf": ("glb", "gltf"),
}

#: below this |z| of the unit mean normal an open part counts as "nearly horizontal-facing" and
#: keeps its winding (0.1 = sin 5.7 degrees)
HORIZONTAL_NORMAL_Z = 0.1

#: vertices closer than this fraction of the bounding-box diagonal are welded. Exporters write
#: a shared vertex with identical digits, so exact duplicates are what this catches; the grid
#: only absorbs last-digit noise of float32 formats (STL, GLB).
WELD_RELATIVE = 1e-9


def read_mesh(path: Path, units: str | None, crease_angle: float = CREASE_ANGLE) -> Surface:
    """Read a mesh file into a :class:`Surface` in millimetres.

    path : the file; its extension picks the reader (see ``MESH_FORMATS``).
    units : the length unit of the coordinates (``"m"``, ``"mm"``, ``"cm"``). Required: mesh
        files carry no units.
    crease_angle : degrees; a sharper fold between neighbouring triangles is refused (see
        :func:`~.checks.check_surface`, which also refuses unwelded seams, separate pieces and
        self-intersections).
    """
    name = path.name
    if units is None:
        raise InputError(
            f"{name}: mesh files carry no units; pass --units m|mm or set [input] units in the job"
        )
    scale = length_scale(units)
    fmt, file_type = MESH_FORMATS[path.suffix.lower()]
    # text formats are checked first: a reader may wrap or drop a bad index, or fail with an
    # unhelpful message
    if fmt == "obj":
        _check_obj_text(path)
    elif fmt == "off":
        _check_off_text(path)
    vertices, faces = _load_arrays(path, file_type)
    _check_arrays(name, vertices, faces)
    vertices, faces = weld_vertices(vertices, faces)
    if len(faces) == 0:
        raise InputError(
            f"{name}: all faces are degenerate (zero-length edges); export the design surface again"
        )
    vertices = vertices * scale
    faces, _ = orient_consistently(faces)
    faces = outer_orientation(vertices, faces)
    check_surface(vertices, faces, name=name, units=units, crease_angle=crease_angle)
    loops = boundary_loops(faces, vertices, where=name)
    log.info(
        "read %s: %d vertices, %d triangles, %d boundary loops (units %s)",
        name,
        len(vertices),
        len(faces),
        len(loops),
        units,
    )
    return Surface(
        vertices=vertices, faces=faces, boundary_loops=loops, source=path, format=fmt, units=units
    )


def _load_arrays(path: Path, file_type: str) -> tuple[np.ndarray, np.ndarray]:
    """Raw (vertices (n, 3) float, faces (m, 3) int) as trimesh reads them, quads triangulated."""
    import trimesh

    try:
        mesh = trimesh.load_mesh(str(path), file_type=file_type, process=False)
    except Exception as err:  # trimesh raises anything from IndexError to struct.error
        raise InputError(
            f"{path.name}: cannot read as {file_type.upper()} mesh ({_short(err)}); "
            f"check that the file is a valid {file_type.upper()} export"
        ) from err
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float).reshape(-1, 3)
    faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    return vertices, faces


def _short(err: BaseException) -> str:
    text = " ".join(str(err).split()) or type(err).__name__
    return text if len(text) <= 120 else text[:117] + "..."


def _check_arrays(name: str, vertices: np.ndarray, faces: np.ndarray) -> None:
    if len(faces) == 0:
        raise InputError(
            f"{name}: no faces found (not a mesh, or only points/lines); export the "
            f"design surface as a triangle or quad mesh"
        )
    if not np.isfinite(vertices).all():
        bad = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise InputError(
            f"{name}: vertex {bad} has a NaN or infinite coordinate; fix or remove "
            f"it in the modeller and export again"
        )
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(
            f"{name}: a face refers to a vertex that does not exist (index out of "
            f"range 0..{len(vertices) - 1}); export the mesh again"
        )


_OBJ_VERTEX = re.compile(rb"^v\s", re.MULTILINE)
_OBJ_FACE = re.compile(rb"^f\s+(.*)$", re.MULTILINE)
_OBJ_INDEX = re.compile(rb"(-?\d+)(?:/-?\d*)*")


def _check_obj_text(path: Path) -> None:
    """Check OBJ face indices against the vertex count (readers may wrap negative indices)."""
    data = path.read_bytes()
    count = len(_OBJ_VERTEX.findall(data))
    tokens = b" ".join(_OBJ_FACE.findall(data))
    indices = np.array(_OBJ_INDEX.findall(tokens), dtype=np.int64)
    # OBJ is 1-based; negative indices count back from the last vertex read so far, so -count is
    # the most negative any of them can legally be
    if len(indices) and (indices.max() > count or indices.min() < -count or np.any(indices == 0)):
        bad = int(indices[(indices > count) | (indices < -count) | (indices == 0)][0])
        raise InputError(
            f"{path.name}: a face refers to vertex {bad} but the file has {count} "
            f"vertices (OBJ indices run 1..{count}); export the mesh again"
        )


def _check_off_text(path: Path) -> None:
    """Check OFF face indices against the declared vertex count."""
    lines = [line.split("#")[0].split() for line in path.read_text(errors="replace").splitlines()]
    lines = [line for line in lines if line]
    if not lines:
        return
    header = lines[0]
    start = 1
    if header[0].upper().endswith("OFF"):
        counts = header[1:] if len(header) > 1 else lines[1]
        start = 1 if len(header) > 1 else 2
    else:
        counts = header
    try:
        nv, nf = int(counts[0]), int(counts[1])
        rows = lines[start + nv : start + nv + nf]
        indices = np.array(
            [int(i) for row in rows for i in row[1 : 1 + int(row[0])]], dtype=np.int64
        )
    except (ValueError, IndexError) as err:
        raise InputError(
            f"{path.name}: malformed OFF header or face list; export the mesh again"
        ) from err
    if len(indices) and (indices.min() < 0 or indices.max() >= nv):
        bad = int(indices[(indices < 0) | (indices >= nv)][0])
        raise InputError(
            f"{path.name}: a face refers to vertex {bad} but the file has {nv} "
            f"vertices (OFF indices run 0..{nv - 1}); export the mesh again"
        )


def weld_vertices(
    vertices: np.ndarray, faces: np.ndarray, relative: float = WELD_RELATIVE
) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices, id-stable, and drop collapsed and unused elements.

    vertices : (n, 3) float; faces : (m, 3) int.
    relative : positions are compared on a grid of ``relative * bbox diagonal``.
    Returns ``vertices (n', 3)`` in order of first use and ``faces (m', 3)``; a triangle with two
    equal corners after merging is dropped, as it has no area and breaks edge counting.
    """
    faces = np.asarray(faces, dtype=np.int64)
    # only vertices used by a face take part (stray points would distort bounds and the grid)
    used, faces = np.unique(faces, return_inverse=True)
    faces = faces.reshape(-1, 3)
    vertices = np.asarray(vertices, dtype=float)[used]
    if len(vertices) == 0:
        return vertices.reshape(0, 3), faces
    low = vertices.min(axis=0)
    diagonal = float(np.linalg.norm(vertices.max(axis=0) - low))
    step = max(diagonal * relative, np.finfo(float).tiny)
    # offsets from the minimum corner keep the integer keys below 1 / relative
    keys = np.round((vertices - low) / step).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    faces = inverse[faces]
    collapsed = (
        (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    )
    if collapsed.any():
        log.info("dropped %d triangles that collapse after merging vertices", int(collapsed.sum()))
        faces = faces[~collapsed]
    # renumber the used merged vertices in order of their first original occurrence
    used = np.unique(faces)
    order = used[np.argsort(first[used], kind="stable")]
    renumber = np.full(len(first), -1, dtype=np.int64)
    renumber[order] = np.arange(len(order))
    return vertices[first[order]], renumber[faces]


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 3) float: un-normalised triangle normals, length = twice the area (mm2)."""
    tri = vertices[faces]
    return np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


def outer_orientation(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Flip each connected part of a consistently wound mesh so its normals point outwards.

    vertices : (n, 3) float, mm; faces : (m, 3) int, consistently wound per part.
    Rule: a closed part (no boundary edge) is turned to enclose positive volume; an open part is
    turned so its area-weighted mean normal points up (+z), since a shell's outer side is the
    side a roof or vault is seen from above; when that mean normal is within
    ``HORIZONTAL_NORMAL_Z`` of horizontal (a wall, a tube) the file's winding is kept. Parts are
    judged one by one so that separately modelled patches all face out.
    Returns ``faces (m, 3) int`` (new array).
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    faces = np.asarray(faces, dtype=np.int64).copy()
    m = len(faces)
    _, counts, inverse = edge_use(faces)
    # faces are connected when they share a vertex: enough to find the parts
    rows = np.repeat(np.arange(m), 3)
    graph = sparse.coo_matrix(
        (np.ones(3 * m), (rows, faces.ravel())), shape=(m, len(vertices))
    ).tocsr()
    _, labels = csgraph.connected_components(graph @ graph.T, directed=False)
    normals = face_normals(vertices, faces)
    open_face = np.bincount(np.arange(3 * m) // 3, weights=(counts[inverse] == 1), minlength=m)
    n_parts = labels.max() + 1
    has_boundary = np.bincount(labels, weights=open_face, minlength=n_parts) > 0
    # signed volume of each part: sum over triangles of v0 . (v1 x v2) / 6
    tri = vertices[faces]
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0
    part_volume = np.bincount(labels, weights=volume, minlength=n_parts)
    mean = np.stack(
        [np.bincount(labels, weights=normals[:, c], minlength=n_parts) for c in range(3)], axis=1
    )
    length = np.linalg.norm(mean, axis=1)
    nz = np.divide(mean[:, 2], length, out=np.zeros(n_parts), where=length > 0)
    flip_part = np.where(has_boundary, nz < -HORIZONTAL_NORMAL_Z, part_volume < 0)
    kept = has_boundary & (np.abs(nz) < HORIZONTAL_NORMAL_Z)
    if kept.any():
        log.info(
            "%d open part(s) face nearly horizontally; their winding is kept as read",
            int(kept.sum()),
        )
    flip = flip_part[labels]
    faces[flip] = faces[flip][:, ::-1]
    return faces
