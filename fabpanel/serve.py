"""The designer's loop: a Grasshopper Hops endpoint (``fabpanel serve``, ghhops-server).

Grasshopper's Hops component calls these over HTTP with Rhino geometry as JSON; each takes the
design surface as a mesh (in the Rhino document's ``Units``: m, cm or mm) and returns Rhino
geometry and numbers, so a designer iterates on the shape without leaving the canvas:

``/inspect``   area (m²), boundary loops, openings, and what was read, as text
``/panelize``  the panel layout for a ``Panel size`` (in ``Units``) and ``Method`` (auto, grid,
               field, skeleton): each panel's outline as a closed polyline, its id, the layout
               gates' verdict
``/develop``   the panels made developable (``Method``: global, loft, project): each panel's
               developed surface as a quad mesh, its class, the largest unroll strain and
               deviation, the verdict
``/export``    the whole pipeline into ``Folder`` up to ``Until`` (build, cut, structure): the
               report's verdicts, the folder, the number of error-level issues

Coordinates come back in the document's units. Every call runs in the server's process, one at
a time (the stages use worker processes of their own); an input the pipeline refuses comes back
as the Hops component's error, one line.
"""

from __future__ import annotations

import tempfile
import threading
from pathlib import Path

import numpy as np

#: one solve at a time: the stages are heavy and use every core already
_LOCK = threading.Lock()
#: millimetres per document unit
UNIT_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0}


def mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """A ``rhino3dm.Mesh``'s vertices (n, 3) and triangles (m, 3) (quads split)."""
    vertices = np.array([[v.X, v.Y, v.Z] for v in mesh.Vertices.ToPoint3dArray()], dtype=float)
    triangles = []
    for i in range(mesh.Faces.Count):
        a, b, c, d = mesh.Faces[i]
        triangles.append((a, b, c))
        if d != c:
            triangles.append((a, c, d))
    return vertices, np.array(triangles, dtype=int).reshape(-1, 3)


def _job(mesh, units: str, folder: Path, **sections):
    """The mesh written as OBJ into ``folder`` and a default job for it."""
    from .errors import InputError
    from .job import Job

    if units not in UNIT_MM:
        raise InputError(f"Units {units!r}: give m, cm or mm (the Rhino document's units)")
    vertices, triangles = mesh_arrays(mesh)
    if not len(triangles):
        raise InputError("the Surface mesh has no faces; pass a mesh of the design surface")
    path = folder / "surface.obj"
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles.tolist()]
    path.write_text("\n".join(lines) + "\n")
    return Job.for_input(path, units=units, **sections)


def _polyline(points_mm: np.ndarray, origin: np.ndarray, units: str):
    import rhino3dm

    scale = 1.0 / UNIT_MM[units]
    closed = np.vstack([points_mm, points_mm[:1]]) + origin
    points = [rhino3dm.Point3d(*map(float, p * scale)) for p in closed]
    return rhino3dm.PolylineCurve(points)  # type: ignore[call-arg]  # stubs lack the overload


def _grid_mesh(grid_mm: np.ndarray, origin: np.ndarray, units: str):
    import rhino3dm

    scale = 1.0 / UNIT_MM[units]
    a, b = grid_mm.shape[:2]
    mesh = rhino3dm.Mesh()
    for x, y, z in ((grid_mm.reshape(-1, 3) + origin) * scale).tolist():
        mesh.Vertices.Add(x, y, z)
    for i in range(a - 1):
        for j in range(b - 1):
            mesh.Faces.AddFace(i * b + j, (i + 1) * b + j, (i + 1) * b + j + 1, i * b + j + 1)
    mesh.Normals.ComputeNormals()
    return mesh


def inspect_surface(mesh, units: str) -> tuple[float, int, int, list[str]]:
    """/inspect: (area m², boundary loops, openings, what was read as lines)."""
    from .surface import describe_surface, load_surface

    with _LOCK, tempfile.TemporaryDirectory(prefix="fabpanel-hops-") as tmp:
        job = _job(mesh, units, Path(tmp))
        surface = load_surface(job.input_path, units)
        info = describe_surface(surface)
        lines = [f"{k}: {v}" for k, v in info.items() if k != "source"]
        return surface.area / 1e6, len(surface.boundary_loops), surface.openings, lines


def panelize_surface(mesh, units: str, size: float, method: str):
    """/panelize: (outlines, ids, verdict)."""
    from .panelize import panelize
    from .surface import load_surface

    with _LOCK, tempfile.TemporaryDirectory(prefix="fabpanel-hops-") as tmp:
        job = _job(mesh, units, Path(tmp), panelize={"panel_size": f"{size} {units}",
                                                      "method": method})  # fmt: skip
        surface = load_surface(job.input_path, units)
        layout = panelize(surface, job)
        outlines = [_polyline(layout.vertices[quad], layout.origin, units) for quad in layout.quads]
        return outlines, list(layout.panel_ids), _layout_verdict(layout)


def _layout_verdict(layout) -> str:
    gates = layout.metrics.get("gates", {})
    failed = [i.code for i in layout.issues if i.code.startswith("layout-")]
    return (
        f"{len(layout.quads)} panels ({layout.method}); edges in band "
        f"{gates.get('edges_in_band', 0):.0%}, corners in 60-120° "
        f"{gates.get('corners_in_60_120', 0):.0%}; "
        + (f"fails: {', '.join(sorted(set(failed)))}" if failed else "every layout gate passed")
    )


def develop_surface(mesh, units: str, size: float, method: str):
    """/develop: (panel meshes, classes, largest unroll strain, largest deviation in the
    document's units, verdict)."""
    from .develop import develop
    from .panelize import panelize
    from .surface import load_surface

    with _LOCK, tempfile.TemporaryDirectory(prefix="fabpanel-hops-") as tmp:
        job = _job(mesh, units, Path(tmp), panelize={"panel_size": f"{size} {units}"},
                   develop={"method": method})  # fmt: skip
        surface = load_surface(job.input_path, units)
        developed = develop(panelize(surface, job), surface, job)
        origin = developed.layout.origin
        meshes = [_grid_mesh(grid, origin, units) for grid in developed.samples]
        metrics = developed.metrics
        strain = float(metrics["unroll_strain"]["max"])
        deviation = float(metrics["deviation_mm"]["max"]) / UNIT_MM[units]
        bad = sum(c == "not-developable" for c in developed.classes)
        verdict = (
            f"{len(developed.classes) - bad} of {len(developed.classes)} panels developable; "
            f"largest unroll strain {strain:.2e}; deviation max "
            f"{metrics['deviation_mm']['max']:.1f} mm"
        )
        return meshes, list(developed.classes), strain, deviation, verdict


def export_surface(mesh, units: str, size: float, folder: str, until: str):
    """/export: (verdict lines, output folder, error-level issues)."""
    from .pipeline import run
    from .report.content import verdicts

    with _LOCK:
        out = Path(folder).expanduser().resolve()
        keep = out.parent / f".{out.name}-input"
        keep.mkdir(parents=True, exist_ok=True)
        job = _job(mesh, units, keep, panelize={"panel_size": f"{size} {units}"},
                   output={"dir": str(out)})  # fmt: skip
        result = run(job, out_dir=out, until=until, force=True)  # type: ignore[arg-type]
        lines = [f"{v.name}: {v.state.upper()}; " + "; ".join(v.lines) for v in
                 verdicts(result).items]  # fmt: skip
        errors = sum(i.severity == "error" for i in result.issues)
        return lines, str(result.out_dir), errors


def hops_app():
    """The Hops application with the four components (module docstring)."""
    import ghhops_server as hs

    hops = hs.Hops()
    surface = hs.HopsMesh("Surface", "S", "the design surface as a mesh")
    units = hs.HopsString("Units", "U", "the document's units: m, cm or mm")
    size = hs.HopsNumber("Panel size", "P", "target panel side, in Units")

    hops.component(
        "/inspect", name="fabpanel inspect", nickname="Inspect",
        description="What fabpanel reads from the design surface", category="fabpanel",
        inputs=[surface, units],
        outputs=[hs.HopsNumber("Area", "A", "m²"), hs.HopsInteger("Loops", "L"),
                 hs.HopsInteger("Openings", "O"),
                 hs.HopsString("Report", "R", access=hs.HopsParamAccess.LIST)],
    )(inspect_surface)  # fmt: skip
    hops.component(
        "/panelize", name="fabpanel panelize", nickname="Panelize",
        description="The panel layout", category="fabpanel",
        inputs=[surface, units, size, hs.HopsString("Method", "M", "auto, grid, field, skeleton")],
        outputs=[hs.HopsCurve("Panels", "P", access=hs.HopsParamAccess.LIST),
                 hs.HopsString("Ids", "I", access=hs.HopsParamAccess.LIST),
                 hs.HopsString("Verdict", "V")],
    )(panelize_surface)  # fmt: skip
    hops.component(
        "/develop", name="fabpanel develop", nickname="Develop",
        description="Developable panels", category="fabpanel",
        inputs=[surface, units, size, hs.HopsString("Method", "M", "global, loft, project")],
        outputs=[hs.HopsMesh("Panels", "P", access=hs.HopsParamAccess.LIST),
                 hs.HopsString("Classes", "C", access=hs.HopsParamAccess.LIST),
                 hs.HopsNumber("Strain", "E", "largest unroll strain"),
                 hs.HopsNumber("Deviation", "D", "largest deviation, in Units"),
                 hs.HopsString("Verdict", "V")],
    )(develop_surface)  # fmt: skip
    hops.component(
        "/export", name="fabpanel export", nickname="Export",
        description="Panels, solids, cutting files, structure", category="fabpanel",
        inputs=[surface, units, size, hs.HopsString("Folder", "F", "output folder"),
                hs.HopsString("Until", "T", "build, cut or structure")],
        outputs=[hs.HopsString("Verdicts", "V", access=hs.HopsParamAccess.LIST),
                 hs.HopsString("Folder", "F"), hs.HopsInteger("Errors", "E")],
    )(export_surface)  # fmt: skip
    return hops


def server(host: str = "localhost", port: int = 5000):
    """A threading HTTP server answering Hops on ``host:port`` (``serve_forever`` runs it,
    ``shutdown`` stops it)."""
    from http.server import ThreadingHTTPServer

    from ghhops_server.middlewares.hopsdefault import _HopsHTTPHandler

    _HopsHTTPHandler.hops = hops_app()
    return ThreadingHTTPServer((host, port), _HopsHTTPHandler)
