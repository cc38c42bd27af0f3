"""Build stage: the steel parts of every panel as exact OCCT solids.

Per panel (see :class:`fabpanel.data.DevelopedPanels` for the grid convention):

- **sheets**: a degree-3 B-spline surface interpolates the sample grid moved along the normals to
  the sheet's outer face (top sheet) or upper face (bottom sheet), and is thickened inward by the
  sheet thickness (``BRepOffsetAPI_MakeThickSolid``). Neighbouring panels share their side samples,
  and the interpolation uses iso-parametric parameters, so their sheet edges are the same curve.
- **ribs**: one flat plate per side in ``DevelopedPanels.side_planes``. Its outline is the top
  sheet's inner edge curve and the bottom sheet's upper edge curve along that side, projected into
  the plane; the plate is extruded by the rib thickness into the panel, so its outer face lies in
  the side plane and touches the neighbour's rib back to back (bolted later). Rib ends stop at
  the neighbouring ribs' inner faces, so the ribs of one panel never overlap.

Build-up along the outward normal (offsets in mm, ``t``: top sheet, ``h``: rib height, ``b``:
bottom sheet; ``design_face = "top-outer"``)::

      0        top sheet outer face (design surface)
     -t        top sheet inner face = rib top
     -t-h      bottom sheet upper face = rib bottom
     -t-h-b    bottom sheet lower face

``"bottom-outer"`` adds ``t + h + b`` (the bottom sheet's lower face on the design surface),
``"middle"`` half of it. ``"cladding"`` is the top sheet alone.

Panels are built in worker processes; only numpy arrays and BREP bytes cross the process
boundary. Sandwich panels after the thesis set-up: Schiftner et al., "Statics-sensitive layout of
planar quadrilateral meshes", and the steel sandwich shells of Pottmann et al., "Architectural
Geometry" (2007), chapter on panels and support structures.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

import numpy as np

from ..data import DevelopedPanels, Model, Part
from ..errors import Issue, KernelError
from ..geom.polygon import polygon_area
from ..job import Job
from ..tolerances import TOLERANCES
from . import occ

log = logging.getLogger(__name__)

#: points along each rib edge curve (top and bottom), corner to corner
RIB_CURVE_POINTS = 65
#: dense samples of sheet fibre grids per sample interval of the developed grid
GRID_REFINE = 4


# --------------------------------------------------------------------------------------------
# build-up
# --------------------------------------------------------------------------------------------
def buildup_offsets(job: Job) -> dict[str, float]:
    """Normal offsets (mm, outward positive) of the build-up's faces relative to the design face.

    Keys: ``top_outer``, ``top_inner``, ``bottom_upper``, ``bottom_lower`` (the last two only for
    ``buildup = "sandwich"``).
    """
    sw = job.sandwich
    depth = sw.total_depth
    shift = {"top-outer": 0.0, "bottom-outer": depth, "middle": depth / 2}[sw.design_face]
    offsets = {"top_outer": shift, "top_inner": shift - sw.sheet_thickness}
    if sw.buildup == "sandwich":
        offsets["bottom_upper"] = offsets["top_inner"] - sw.rib_height
        offsets["bottom_lower"] = offsets["bottom_upper"] - sw.bottom_thickness
    return offsets


# --------------------------------------------------------------------------------------------
# public stage
# --------------------------------------------------------------------------------------------
def build(developed: DevelopedPanels, job: Job, jobs: int | None = None,
          progress: Callable[[int], None] | None = None) -> Model:
    """Stage 3: the steel parts of every panel (:class:`~fabpanel.data.Model`).

    developed : the panels' sample grids, normals and rib planes.
    job : uses ``[sandwich]``, ``[material]`` and ``[cutting] neutral_fibre``.
    jobs : worker processes (default ``os.cpu_count()``); 1 builds inline.
    progress : called with 1 after each finished panel.

    Raises :class:`~fabpanel.errors.KernelError` naming the part when OCCT fails; parts that miss
    a tolerance (sheet fit, rib planarity, rib contact) become ``Model.issues``.
    """
    started = time.perf_counter()
    sw = job.sandwich
    settings = {
        "buildup": sw.buildup,
        "offsets": buildup_offsets(job),
        "t_top": float(sw.sheet_thickness),
        "t_bot": float(sw.bottom_thickness),
        "t_rib": float(sw.rib_thickness),
        "fibre": job.cutting.neutral_fibre,
        "refine": GRID_REFINE,
    }
    m = len(developed.panel_ids)
    payloads = [
        {"panel_id": developed.panel_ids[p], "samples": np.asarray(developed.samples[p], float),
         "normals": np.asarray(developed.normals[p], float),
         "planes": np.asarray(developed.side_planes[p], float), **settings}
        for p in range(m)
    ]
    workers = max(1, min(jobs or os.cpu_count() or 1, m))
    results: list[dict[str, Any] | None] = [None] * m
    if workers == 1:
        for p, payload in enumerate(payloads):
            results[p] = build_panel(payload)
            if progress:
                progress(1)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(build_panel, payload): p for p, payload in enumerate(payloads)}
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                if progress:
                    progress(1)

    material, density = job.material.name, float(job.material.density)
    parts: list[Part] = []
    done = [result for result in results if result is not None]  # every panel was waited for
    for result in done:
        for record in result["parts"]:
            parts.append(Part(id=record["id"], kind=record["kind"], panel_id=result["panel_id"],
                              material=material, thickness=record["thickness"],
                              volume=record["volume"], area=record["area"],
                              mass=record["volume"] * density, brep=record["brep"],
                              surface_grid=record.get("surface_grid"),
                              outline=record.get("outline"), frame=record.get("frame")))
    metrics, issues = _model_metrics(developed, parts, done, time.perf_counter() - started)
    log.info("built %d parts of %d panels in %.1f s", len(parts), m, metrics["seconds"])
    return Model(parts=tuple(parts), developed=developed, metrics=metrics, issues=tuple(issues))


# --------------------------------------------------------------------------------------------
# one panel (runs in a worker process: plain data in, plain data out)
# --------------------------------------------------------------------------------------------
def build_panel(payload: dict[str, Any]) -> dict[str, Any]:
    """All parts of one panel from plain data (see :func:`build`); returns part records with
    BREP bytes and arrays, and the panel's measures."""
    pid = payload["panel_id"]
    samples, normals = payload["samples"], payload["normals"]
    offsets, fibre = payload["offsets"], payload["fibre"]
    k = samples.shape[0]
    dense = payload["refine"] * (k - 1) + 1
    parts, measures = [], {}

    top = _sheet(f"{pid}-TOP", "sheet-top", samples, normals, offsets["top_outer"],
                 payload["t_top"], fibre, dense)
    parts.append(top.record)
    measures["fit_error_top_mm"] = top.fit_error
    measures["offset_error_top_mm"] = top.offset_error
    if payload["buildup"] == "sandwich":
        bot = _sheet(f"{pid}-BOT", "sheet-bottom", samples, normals, offsets["bottom_upper"],
                     payload["t_bot"], fibre, dense)
        parts.append(bot.record)
        measures["fit_error_bottom_mm"] = bot.fit_error
        measures["offset_error_bottom_mm"] = bot.offset_error
        planes = payload["planes"]
        planarity, off_plane = [], []
        for side in range(4):
            record, flatness, edge_off = _rib(f"{pid}-RIB-{side}", side, planes, top, bot,
                                              payload["t_top"], payload["t_rib"])
            parts.append(record)
            planarity.append(flatness)
            off_plane.append(edge_off)
        measures["rib_planarity_mm"] = planarity
        measures["rib_edge_off_plane_mm"] = off_plane
    measures["valid"] = all(p["valid"] for p in parts)
    return {"panel_id": pid, "parts": parts, "measures": measures}


class _Sheet:
    """A built sheet: its fitted reference surface (outer/upper face) and its part record."""

    def __init__(self, surface, orient: float, thickness: float, record: dict,
                 fit_error: float, offset_error: float) -> None:
        self.surface, self.orient, self.thickness = surface, orient, thickness
        self.record, self.fit_error, self.offset_error = record, fit_error, offset_error

    def side_curve(self, side: int, depth: float, n: int = RIB_CURVE_POINTS) -> np.ndarray:
        """(n, 3) float: the face ``depth`` mm below the reference face, along side ``side``
        from corner ``side`` to corner ``side + 1``."""
        return side_curve(self.surface, side, n, -self.orient * depth)


def _sheet(name: str, kind: str, samples: np.ndarray, normals: np.ndarray, outer: float,
           thickness: float, fibre: str, dense: int) -> _Sheet:
    """Fit the sheet's outer face through ``samples + outer * normals`` and thicken it inward."""
    grid = samples + outer * normals
    surface, fit = occ.bspline_surface(grid, name)
    orient = _orientation(surface, normals)
    solid = occ.thicken(occ.face_from_surface(surface, name), -orient * thickness, name)
    # the inner face as the offset surface must match the samples moved along the developed
    # normals: a measure of how well the B-spline's normals agree with the developed ones
    inner = occ.offset_surface(surface, -orient * thickness)
    offset_error = occ.fit_error(inner, (samples + (outer - thickness) * normals).reshape(-1, 3))
    fibre_depth = {"outer": 0.0, "mid": thickness / 2, "inner": thickness}[fibre]
    surface_grid = occ.sample_surface(surface, dense, dense, -orient * fibre_depth)
    mid = occ.face_from_surface(occ.offset_surface(surface, -orient * thickness / 2), name)
    record = {"id": name, "kind": kind, "thickness": thickness, "volume": occ.volume(solid),
              "area": occ.face_area(mid), "brep": occ.to_brep(solid),
              "surface_grid": surface_grid, "valid": occ.is_valid(solid)}
    return _Sheet(surface, orient, thickness, record, fit, offset_error)


def _orientation(surface, normals: np.ndarray) -> float:
    """+1 when the surface normal ``dS/du x dS/dv`` points along the developed (outward) normals."""
    k = normals.shape[0]
    probe = occ.sample_surface(surface, 3, 3, 1.0) - occ.sample_surface(surface, 3, 3, 0.0)
    return 1.0 if float(probe[1, 1] @ normals[k // 2, k // 2]) >= 0 else -1.0


def side_curve(surface, side: int, n: int, offset: float = 0.0) -> np.ndarray:
    """(n, 3) float: the boundary iso-curve of side ``side`` of a surface fitted to a panel grid,
    moved ``offset`` mm along the surface normal, from corner ``side`` to corner ``side + 1``."""
    u0, u1, v0, v1 = surface.Bounds()
    t = np.linspace(0.0, 1.0, n)
    uv = {0: (u0 + t * (u1 - u0), np.full(n, v0)),
          1: (np.full(n, u1), v0 + t * (v1 - v0)),
          2: (u1 - t * (u1 - u0), np.full(n, v1)),
          3: (np.full(n, u0), v1 - t * (v1 - v0))}[side]
    return occ.surface_points(surface, uv[0], uv[1], offset)


def _rib(name: str, side: int, planes: np.ndarray, top: _Sheet, bot: _Sheet, t_top: float,
         t_rib: float) -> tuple[dict, float, float]:
    """One rib plate: outline between the sheets, trimmed at the neighbouring ribs, extruded."""
    plane = planes[side] / np.linalg.norm(planes[side][:3])
    plane = np.r_[plane[:3], planes[side][3] / np.linalg.norm(planes[side][:3])]
    upper = top.side_curve(side, t_top)          # top sheet inner face
    lower = bot.side_curve(side, 0.0)            # bottom sheet upper face
    edge_off = float(np.abs(np.r_[upper, lower] @ plane[:3] - plane[3]).max())
    frame = plane_frame(plane, upper[0], upper[-1] - upper[0])
    to_local = np.linalg.inv(frame)
    chains = [(np.c_[curve, np.ones(len(curve))] @ to_local.T)[:, :2] for curve in (upper, lower)]
    # trim at the neighbouring ribs' inner faces (planes shifted inward by the rib thickness);
    # the whole thickness of this plate stays on the inner side, so the end face is square to
    # the plate (as cut) and clears the neighbour even when the planes are not perpendicular
    for other in ((side - 1) % 4, (side + 1) % 4):
        n_o = planes[other][:3] / np.linalg.norm(planes[other][:3])
        d_o = planes[other][3] / np.linalg.norm(planes[other][:3])
        a, b, c = n_o @ frame[:3, 0], n_o @ frame[:3, 1], n_o @ frame[:3, 2]
        e = d_o + t_rib - n_o @ frame[:3, 3] - min(0.0, c * t_rib)
        chains = [clip_polyline(chain, np.array([a, b]), e) for chain in chains]
        if min(len(chain) for chain in chains) < 2:
            raise KernelError(f"outline of {name} vanished when trimmed at rib {other}; "
                              f"the panel is too small for ribs of {t_rib:g} mm")
    top2, bottom2 = (_drop_duplicates(chain, closed=False) for chain in chains)
    outline = _drop_duplicates(np.r_[top2, bottom2[::-1]])
    solid = occ.prism([top2, np.array([top2[-1], bottom2[-1]]), bottom2[::-1],
                       np.array([bottom2[0], top2[0]])], frame, t_rib, name)
    if polygon_area(outline) < 0:
        outline = outline[::-1]
    # both plate faces must be flat: every point of the edges bounding the outer and the inner
    # face (lateral edges through the thickness skipped) against the plane and its offset
    flatness = 0.0
    for points in occ.edge_points(solid, per_edge=8):
        dist = points @ plane[:3] - plane[3]
        if abs(dist[-1] - dist[0]) > t_rib / 2:
            continue
        flatness = max(flatness, float(np.minimum(np.abs(dist), np.abs(dist - t_rib)).max()))
    record = {"id": name, "kind": "rib", "thickness": t_rib, "volume": occ.volume(solid),
              "area": float(abs(polygon_area(outline))), "brep": occ.to_brep(solid),
              "outline": outline, "frame": frame, "valid": occ.is_valid(solid)}
    return record, flatness, edge_off


def plane_frame(plane: np.ndarray, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(4, 4) float: frame on ``plane (4,)`` with z = the plane normal, x = ``direction``
    projected into the plane, origin = ``origin`` projected onto the plane."""
    z = plane[:3] / np.linalg.norm(plane[:3])
    o = origin - (origin @ z - plane[3]) * z
    x = direction - (direction @ z) * z
    norm = np.linalg.norm(x)
    if norm < 1e-9:
        raise KernelError("rib direction is normal to its plane")
    x /= norm
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, o
    return frame


def clip_polyline(points: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """(n', 2) float: the longest run of the open polyline ``points (n, 2)`` with
    ``normal . p >= offset``, ended exactly on the line where it is cut."""
    value = points @ normal - offset
    inside = value >= 0
    if not inside.any():
        return points[:0]
    # longest contiguous run of inside points
    best, start = (0, 0), None
    for i, flag in enumerate(np.r_[inside, False]):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    i0, i1 = best
    run = [points[i0:i1]]
    if i0 > 0:
        p, q, vp, vq = points[i0 - 1], points[i0], value[i0 - 1], value[i0]
        run.insert(0, (p + (q - p) * (vp / (vp - vq)))[None])
    if i1 < len(points):
        p, q, vp, vq = points[i1 - 1], points[i1], value[i1 - 1], value[i1]
        run.append((p + (q - p) * (vp / (vp - vq)))[None])
    return np.concatenate(run)


def _drop_duplicates(points: np.ndarray, closed: bool = True, eps: float = 1e-6) -> np.ndarray:
    """Points without consecutive repeats (within ``eps`` mm)."""
    if closed:
        keep = np.linalg.norm(points - np.roll(points, -1, axis=0), axis=1) > eps
        return points[keep]
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > eps]
    return points[keep]


# --------------------------------------------------------------------------------------------
# metrics
# --------------------------------------------------------------------------------------------
def _model_metrics(developed: DevelopedPanels, parts: list[Part], results: list,
                   seconds: float) -> tuple[dict, list[Issue]]:
    tol = TOLERANCES
    issues: list[Issue] = []
    counts: dict[str, int] = {}
    for part in parts:
        counts[part.kind] = counts.get(part.kind, 0) + 1
    per_panel, fit, planarity = {}, [0.0], [0.0]
    for result in results:
        pid, meas = result["panel_id"], result["measures"]
        per_panel[pid] = _jsonable(meas)
        for key, kind in (("fit_error_top_mm", "TOP"), ("fit_error_bottom_mm", "BOT")):
            if key in meas:
                fit.append(meas[key])
                if meas[key] > tol.sheet_fit:
                    issues.append(Issue("sheet-fit", f"B-spline sheet misses its samples by "
                                        f"{meas[key]:.3f} mm (> {tol.sheet_fit} mm)",
                                        f"{pid}-{kind}"))
        for side, value in enumerate(meas.get("rib_planarity_mm", [])):
            planarity.append(value)
            if value > tol.rib_planarity:
                issues.append(Issue("rib-not-planar", f"rib faces deviate {value:.3f} mm from "
                                    f"flat (> {tol.rib_planarity} mm)", f"{pid}-RIB-{side}"))
        if not meas["valid"]:
            issues.append(Issue("invalid-solid", "a solid of this panel is not valid in OCCT",
                                pid, "error"))
    gap = _rib_contact_gap(developed, parts, issues)
    volume = float(sum(p.volume for p in parts))
    metrics = {
        "parts": len(parts),
        "counts": counts,
        "total_mass_kg": round(float(sum(p.mass for p in parts)), 3),
        "total_volume_mm3": round(volume, 1),
        "max_sheet_fit_error_mm": float(max(fit)),
        "max_rib_planarity_mm": float(max(planarity)),
        "max_rib_contact_gap_mm": gap,
        "all_valid": all(r["measures"]["valid"] for r in results),
        "seconds": round(seconds, 2),
        "panels": per_panel,
    }
    return metrics, issues


def _rib_contact_gap(developed: DevelopedPanels, parts: list[Part],
                     issues: list[Issue]) -> float:
    """Largest distance between a rib's outer face corners and its back-to-back neighbour's
    rib plane, mm (0 when there are no ribs)."""
    ribs = {p.id: p for p in parts if p.kind == "rib"}
    if not ribs:
        return 0.0
    neighbours = developed.layout.side_neighbours
    ids = developed.panel_ids
    worst = 0.0
    for p, pid in enumerate(ids):
        for s in range(4):
            q = neighbours[p, s]
            rib = ribs.get(f"{pid}-RIB-{s}")
            if q < 0 or rib is None:
                continue
            # the neighbour's side facing this panel
            for t in [t for t in range(4) if neighbours[q, t] == p]:
                plane = developed.side_planes[q, t]
                world = np.c_[rib.outline, np.zeros(len(rib.outline)),
                              np.ones(len(rib.outline))] @ rib.frame.T
                gap = float(np.abs(world[:, :3] @ plane[:3] - plane[3]).max()
                            / np.linalg.norm(plane[:3]))
                worst = max(worst, gap)
                if gap > TOLERANCES.rib_contact_gap:
                    issues.append(Issue("rib-gap", f"rib stands {gap:.3f} mm off its "
                                        f"neighbour's rib plane (> "
                                        f"{TOLERANCES.rib_contact_gap} mm)", rib.id))
    return worst


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    return value
