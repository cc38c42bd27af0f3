"""The dataclasses carried from stage to stage.

Every length is in millimetres in the local frame of the design surface (after the input's unit
conversion; the design's own coordinates are ``local + Surface.origin``) unless a field says
otherwise. Arrays are numpy arrays; shapes are given in the field
documentation as ``(n, 3) float``. The dataclasses are frozen: stages return new objects and never
mutate their input. ``to_dict()`` gives JSON-ready data (arrays summarised or listed) for the
manifest.

Flow::

    Surface --panelize--> PanelLayout --develop--> DevelopedPanels --build--> Model
    Model --cut--> FlatParts --nest--> Nests
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .errors import Issue

PartKind = Literal["sheet-top", "sheet-bottom", "rib", "stiffener", "packing"]
PanelClass = Literal["planar", "single-curved", "conical", "not-developable"]


def _round(values: Any, digits: int = 4) -> Any:
    return np.round(np.asarray(values, dtype=float), digits).tolist()


# --------------------------------------------------------------------------------------------
# Surface
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Surface:
    """The design surface as read, in millimetres.

    vertices : (n, 3) float
        mesh vertices, mm (a tessellation for B-rep input).
    faces : (m, 3) int
        triangles, oriented consistently where the input allows; normals point to the outer side.
    boundary_loops : tuple of (k,) int
        vertex indices of each closed boundary loop (first vertex not repeated). The loop with the
        largest projected area is ``boundary_loops[0]``, the outer boundary; the rest are openings.
    source : Path
        the file read.
    format : str
        ``"obj"``, ``"stl"``, ``"ply"``, ``"off"``, ``"glb"``, ``"step"``, ``"iges"``, ``"brep"``.
    units : str
        the unit the input was declared in (``"m"``, ``"mm"``); coordinates here are mm anyway.
    brep : bytes or None
        for B-rep input, the exact surface as OCCT BREP text (a face or shell, mm); kept for exact
        closeness queries and for grids in the face's own parameters.
    origin : (3,) float
        mm: where the local frame's origin lies in the design's own coordinates. ``vertices``
        and ``brep`` are local (``world = local + origin``): :func:`~fabpanel.load_surface`
        recentres every surface (:mod:`fabpanel.surface.frame`), and the writers of model files
        add the origin back.
    folds : tuple of (k,) int
        vertex chains (in order) of the seams between B-rep faces where the surface kinks by
        more than :data:`fabpanel.surface.folds.FOLD_DEG`: the field layout puts panel sides
        along them. Empty for meshes.
    """

    vertices: np.ndarray
    faces: np.ndarray
    boundary_loops: tuple[np.ndarray, ...]
    source: Path
    format: str
    units: str
    brep: bytes | None = None
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    folds: tuple[np.ndarray, ...] = ()

    @property
    def area(self) -> float:
        """Surface area, mm2."""
        tri = self.vertices[self.faces]
        return float(
            0.5
            * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
        )

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float: min and max corner, mm."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def openings(self) -> int:
        return max(len(self.boundary_loops) - 1, 0)

    def to_dict(self) -> dict:
        return {
            "source": str(self.source),
            "format": self.format,
            "units": self.units,
            "vertices": len(self.vertices),
            "faces": len(self.faces),
            "bounds_mm": _round(self.bounds + self.origin, 3),
            "origin_mm": _round(self.origin, 3),
            "area_m2": round(self.area / 1e6, 6),
            "boundary_loops": len(self.boundary_loops),
            "openings": self.openings,
            "exact_brep": self.brep is not None,
        }


# --------------------------------------------------------------------------------------------
# Panel layout
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PanelLayout:
    """A quad panel layout on the design surface.

    vertices : (n, 3) float
        panel corner points, mm, on the design surface.
    quads : (m, 4) int
        corner indices per panel, counter-clockwise seen from the outer side (so the normal from
        the right-hand rule points outwards). Side ``s`` of a panel runs from corner ``s`` to
        corner ``s + 1``.
    panel_ids : tuple of str
        ``"P001"``... in panel order.
    method : str
        how the layout was made (``"grid"``...).
    metrics : dict
        measured quality (edge lengths, angles...), JSON-ready.
    parameters : (m, 4, 2) float or None
        for layouts made in a surface parameter domain, each corner's (u, v); lets the next stage
        sample panels exactly on a B-rep surface.
    origin : (3,) float
        mm, the surface's :attr:`Surface.origin`: ``vertices`` (and every later stage's points)
        are local, the model files are written at ``local + origin``.
    """

    vertices: np.ndarray
    quads: np.ndarray
    panel_ids: tuple[str, ...]
    method: str
    metrics: dict = field(default_factory=dict)
    parameters: np.ndarray | None = None
    issues: tuple[Issue, ...] = ()
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def edges(self) -> np.ndarray:
        """(e, 2) int: unique undirected panel edges, sorted vertex pairs."""
        sides = np.stack([self.quads, np.roll(self.quads, -1, axis=1)], axis=2).reshape(-1, 2)
        return np.unique(np.sort(sides, axis=1), axis=0)

    @property
    def side_edges(self) -> np.ndarray:
        """(m, 4) int: the :attr:`edges` row of every panel side."""
        sides = np.stack([self.quads, np.roll(self.quads, -1, axis=1)], axis=2).reshape(-1, 2)
        _, inverse = np.unique(np.sort(sides, axis=1), axis=0, return_inverse=True)
        return inverse.reshape(self.quads.shape)

    @property
    def side_neighbours(self) -> np.ndarray:
        """(m, 4) int: the panel across each side, -1 on the boundary."""
        m = len(self.quads)
        sides = np.stack([self.quads, np.roll(self.quads, -1, axis=1)], axis=2).reshape(-1, 2)
        key = np.sort(sides, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inverse = inverse.ravel()
        order = np.argsort(inverse, kind="stable")
        neighbours = np.full(4 * m, -1, dtype=int)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        shared = counts == 2
        first, second = order[starts[shared]], order[starts[shared] + 1]
        neighbours[first] = second // 4
        neighbours[second] = first // 4
        return neighbours.reshape(m, 4)

    def to_dict(self) -> dict:
        neighbours = self.side_neighbours
        return {
            "method": self.method,
            "panels": [
                {
                    "id": pid,
                    "corners_mm": _round(self.vertices[quad], 3),
                    "neighbours": [self.panel_ids[n] if n >= 0 else None for n in neighbours[i]],
                }
                for i, (pid, quad) in enumerate(zip(self.panel_ids, self.quads))
            ],
            "metrics": self.metrics,
        }


# --------------------------------------------------------------------------------------------
# Developed panels
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DevelopedPanels:
    """Each panel's final (developable) surface as a k x k sample grid.

    Grid convention for panel ``p`` with corners ``c0..c3`` of ``PanelLayout.quads[p]``:
    ``samples[p, i, j]`` with ``i`` running from side 3 to side 1 and ``j`` from side 0 to side 2,
    so ``samples[p, 0, 0] = c0``, ``samples[p, -1, 0] = c1``, ``samples[p, -1, -1] = c2``,
    ``samples[p, 0, -1] = c3``. Side 0 is ``samples[p, :, 0]``, side 1 ``samples[p, -1, :]``,
    side 2 ``samples[p, ::-1, -1]``, side 3 ``samples[p, 0, ::-1]``. Neighbouring panels hold
    identical samples (and normals) along their shared side.

    samples : (m, k, k, 3) float
        points of the design face of the build-up (see ``[sandwich] design_face``), mm.
    normals : (m, k, k, 3) float
        unit normals at the samples, pointing to the outer side.
    side_planes : (m, 4, 4) float
        plane ``(nx, ny, nz, d)`` with ``n . x = d`` of each panel side's rib, normal into the
        panel: it holds the side's sample polyline (the sheet edge); the normals along the side
        meet it at one constant angle where the side is a planar curvature line (see
        :func:`fabpanel.develop.sides.side_planes`).
    classes : tuple of PanelClass
        per panel.
    bending_radius : (m,) float
        smallest bending radius per panel, mm (``inf`` for planar panels).
    metrics : dict
        per panel and overall measures (unroll strain, deviation...), JSON-ready.
    deviation : (m, k, k) float or None
        distance of every sample from the design surface, mm (for the deviation map).
    design_samples : (m, k, k, 3) float or None
        the same panels sampled on the design surface before development (``None`` when that
        is ``samples`` itself), for before/after figures.
    """

    layout: PanelLayout
    samples: np.ndarray
    normals: np.ndarray
    side_planes: np.ndarray
    classes: tuple[PanelClass, ...]
    bending_radius: np.ndarray
    method: str
    metrics: dict = field(default_factory=dict)
    issues: tuple[Issue, ...] = ()
    deviation: np.ndarray | None = None
    design_samples: np.ndarray | None = None

    @property
    def panel_ids(self) -> tuple[str, ...]:
        return self.layout.panel_ids

    def side_samples(self, panel: int, side: int) -> np.ndarray:
        """(k, 3) float: samples along one side, from corner ``side`` to corner ``side + 1``."""
        grid = self.samples[panel]
        return [grid[:, 0], grid[-1, :], grid[::-1, -1], grid[0, ::-1]][side]

    def to_dict(self) -> dict:
        return {
            "method": self.method,
            "samples_per_side": int(self.samples.shape[1]),
            "classes": dict(zip(self.panel_ids, self.classes)),
            "metrics": self.metrics,
        }


# --------------------------------------------------------------------------------------------
# Model (OCCT parts)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Hole:
    """A round hole in a part: centre in the part's flat frame (2D, mm) and diameter, mm."""

    centre: tuple[float, float]
    diameter: float
    purpose: Literal["bolt", "access"] = "bolt"


@dataclass(frozen=True)
class Part:
    """One steel part, as an exact solid and as what the cutting stage needs to lay it flat.

    id : str
        ``"P012-TOP"``, ``"P012-BOT"``, ``"P012-RIB-3"`` (side 3), ``"P012-STF-1"`` (corner 1).
    kind : PartKind
    panel_id : str
    material : str
    thickness : float
        plate thickness, mm.
    volume : float
        solid volume, mm3 (from OCCT).
    area : float
        area of one face of the flat plate, mm2 (what is cut from stock).
    mass : float
        kg.
    brep : bytes
        the solid as OCCT BREP text, mm, world frame.
    surface_grid : (a, b, 3) float or None
        sheets only: the surface to unroll (the fibre set by ``[cutting] neutral_fibre``) sampled
        densely, mm, world frame, with the same side convention as ``DevelopedPanels.samples``.
    outline : (n, 2) float or None
        ribs and stiffeners: the flat outline, counter-clockwise, mm, in the part's own plane.
    frame : (4, 4) float or None
        ribs and stiffeners: maps the plane's (x, y, 0) to world coordinates.
    holes : tuple of Hole
        ribs: bolt holes in the flat frame (``outline``'s).
    openings : tuple of (n, 2) float
        sheets: the access slots as closed loops of surface parameters ``(u, v)`` in [0, 1]²,
        which index ``surface_grid`` uniformly; the cutting stage unrolls them with the sheet.
    opening_area : float
        sheets: the openings' area, mm2 (taken off ``area`` already).
    centroid : (3,) float or None
        the solid's centre of volume, mm, world frame (None where the builder did not measure
        it).
    """

    id: str
    kind: PartKind
    panel_id: str
    material: str
    thickness: float
    volume: float
    area: float
    mass: float
    brep: bytes = field(repr=False)
    surface_grid: np.ndarray | None = field(default=None, repr=False)
    outline: np.ndarray | None = field(default=None, repr=False)
    frame: np.ndarray | None = field(default=None, repr=False)
    holes: tuple[Hole, ...] = ()
    openings: tuple[np.ndarray, ...] = field(default=(), repr=False)
    opening_area: float = 0.0
    files: tuple[str, ...] = ()
    centroid: np.ndarray | None = field(default=None, repr=False)

    def bolt_hole_axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The bolt holes of a plate in the world frame: centres at mid-thickness (n, 3), unit
        axes (n, 3) along the frame's z, diameters (n,), mm (empty for a part without a frame)."""
        bolts = [h for h in self.holes if h.purpose == "bolt"]
        if self.frame is None or not bolts:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
        frame = np.asarray(self.frame, dtype=float)
        flat = np.array([(*h.centre, self.thickness / 2.0, 1.0) for h in bolts])
        axis = frame[:3, 2] / np.linalg.norm(frame[:3, 2])
        centres = (flat @ frame.T)[:, :3]
        return centres, np.tile(axis, (len(bolts), 1)), np.array([h.diameter for h in bolts])

    def to_dict(self) -> dict:
        record = {
            "id": self.id,
            "kind": self.kind,
            "panel": self.panel_id,
            "material": self.material,
            "thickness_mm": self.thickness,
            "volume_mm3": round(self.volume, 1),
            "area_mm2": round(self.area, 1),
            "mass_kg": round(self.mass, 4),
            "holes": len(self.holes),
            "openings": len(self.openings),
            "files": list(self.files),
        }
        if self.centroid is not None:
            record["centroid_mm"] = _round(self.centroid, 3)
        centres, axes, diameters = self.bolt_hole_axes()
        if len(diameters):
            record["bolt_holes"] = [
                {"centre_mm": _round(c, 3), "axis": _round(a, 6), "diameter_mm": float(d)}
                for c, a, d in zip(centres, axes, diameters)
            ]
        return record


@dataclass(frozen=True)
class Model:
    """All parts of all panels.

    parts : tuple of Part
        grouped by panel in panel order; within a panel: TOP, BOT, RIB-0..3, STF-0..3.
    metrics : dict
        checks (validity, plate planarity, rib contact, bolt coaxiality, clash, sheet fit
        error, neighbouring edge mismatch) and totals, JSON-ready.
    """

    parts: tuple[Part, ...]
    developed: DevelopedPanels
    metrics: dict = field(default_factory=dict)
    issues: tuple[Issue, ...] = ()

    @property
    def mass(self) -> float:
        return float(sum(part.mass for part in self.parts))

    def parts_of(self, panel_id: str) -> tuple[Part, ...]:
        return tuple(part for part in self.parts if part.panel_id == panel_id)

    def to_dict(self) -> dict:
        return {"parts": [part.to_dict() for part in self.parts], "metrics": self.metrics}


# --------------------------------------------------------------------------------------------
# Flat parts and nests
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FlatPart:
    """A part laid flat for cutting, in its own 2D frame, mm.

    outline : (n, 2) float
        outer contour, counter-clockwise, not closed (first point not repeated).
    holes : tuple of (k, 2) float
        inner contours (clockwise), and round holes as ``Hole`` in ``round_holes`` (cut) and
        ``drill_holes`` (too small for the plasma: drilled, their centres etched).
    etch : tuple of (k, 2) float
        polylines to etch (labels, bend lines), not cut.
    bend_lines : (b, 2, 2) float
        rulings along which the sheet is rolled, for sheets (empty otherwise).
    labels : tuple of (text, x, y, height, angle_deg)
        texts to etch; the DXF writer turns them into single-stroke geometry.
    max_strain : float
        largest relative edge-length change of the flattening (0 for planar parts).
    edge_lengths_flat, edge_lengths_3d : (4,) float
        sheets: length of each side in the flat outline and on the 3D surface, mm.
    forming : str
        sheets: how the shop forms it, as etched (``OUT CONVEX R4000``, ``OUT FLAT``).
    face : str
        ribs and stiffeners: which way the drawn face looks, as etched (``IN``: into the panel).
    mark : str
        the part mark (:mod:`fabpanel.flat.marks`): parts equal within 0.1 mm share it.
    bend_tick : float
        sheets: bend lines are etched as ticks this long at the edges (0: full lines), mm.
    stock_form : str
        ``plate`` (burnt from plate, nested) or ``flat-bar`` (a straight rib sawn from flat
        bar, :mod:`fabpanel.flat.flatbar`).
    bend_radius : float
        single-curved sheets: the smallest bending radius at the unrolling fibre, mm (0: flat,
        double curved or unknown).
    bend_radius_max : float
        the largest bending radius along the bend lines, mm (a cone's wide end; equal to
        ``bend_radius`` on a cylinder, 0 where that is 0).
    spring_stress : float
        a sheet sprung elastically onto its ribs (forming ``... SPRING``): the bending stress
        that stays locked in, E t / (2 R), MPa; 0 when rolled or flat (:mod:`fabpanel.forming`).
    """

    id: str
    kind: PartKind
    panel_id: str
    material: str
    thickness: float
    outline: np.ndarray
    holes: tuple[np.ndarray, ...] = ()
    round_holes: tuple[Hole, ...] = ()
    drill_holes: tuple[Hole, ...] = ()
    etch: tuple[np.ndarray, ...] = ()
    bend_lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    labels: tuple[tuple[str, float, float, float, float], ...] = ()
    max_strain: float = 0.0
    edge_lengths_flat: np.ndarray | None = None
    edge_lengths_3d: np.ndarray | None = None
    forming: str = ""
    face: str = ""
    mark: str = ""
    bend_tick: float = 0.0
    stock_form: Literal["plate", "flat-bar"] = "plate"
    bend_radius: float = 0.0
    spring_stress: float = 0.0
    files: tuple[str, ...] = ()
    bend_radius_max: float = 0.0

    @property
    def area(self) -> float:
        """Net area (outline minus holes), mm2."""
        from .geom.polygon import polygon_area

        net = abs(polygon_area(self.outline)) - sum(abs(polygon_area(h)) for h in self.holes)
        return float(
            net - sum(np.pi * h.diameter**2 / 4 for h in self.round_holes + self.drill_holes)
        )

    @property
    def roll_axis_deg(self) -> float:
        """Direction of the bend lines (the roll's axis) in the flat frame, degrees from +x in
        [0, 180) (their length-weighted mean direction; 0 without bend lines)."""
        if not len(self.bend_lines):
            return 0.0
        d = self.bend_lines[:, 1] - self.bend_lines[:, 0]
        # doubled angles average undirected lines
        doubled = np.arctan2(d[:, 1], d[:, 0]) * 2.0
        weight = np.linalg.norm(d, axis=1)
        mean = np.arctan2((weight * np.sin(doubled)).sum(), (weight * np.cos(doubled)).sum())
        return float(np.degrees(mean / 2.0) % 180.0)

    def to_dict(self) -> dict:
        record = {
            "id": self.id,
            "mark": self.mark,
            "kind": self.kind,
            "panel": self.panel_id,
            "thickness_mm": self.thickness,
            "area_mm2": round(self.area, 1),
            "max_strain": float(self.max_strain),
            "files": list(self.files),
        }
        if self.forming:
            record["forming"] = self.forming
        if self.stock_form != "plate":
            record["stock_form"] = self.stock_form
        if self.spring_stress:
            record["spring_stress_MPa"] = round(self.spring_stress, 1)
        if self.bend_radius > 0:
            record["bend_radius_mm"] = [
                round(self.bend_radius, 1),
                round(max(self.bend_radius_max, self.bend_radius), 1),
            ]
        if len(self.bend_lines):
            angle = np.radians(self.roll_axis_deg)
            along = np.array([np.cos(angle), np.sin(angle)])
            record["roll_axis_deg"] = round(self.roll_axis_deg, 2)
            # the flat sheet's extent along the roll's axis and across it (the rolled width)
            record["roll_extent_mm"] = [
                round(float(np.ptp(self.outline @ along)), 1),
                round(float(np.ptp(self.outline @ np.array([-along[1], along[0]]))), 1),
            ]
        record["size_mm"] = _round(np.ptp(self.outline, axis=0), 1)
        if self.edge_lengths_flat is not None:
            record["edge_lengths_flat_mm"] = _round(self.edge_lengths_flat, 3)
            record["edge_lengths_3d_mm"] = _round(self.edge_lengths_3d, 3)
        return record


@dataclass(frozen=True)
class MarkGroup:
    """One part mark: the ids of its parts (the first is the one drawn) and, per part, the
    (3, 3) transform from the first part's flat frame to its own."""

    mark: str
    part_ids: tuple[str, ...]
    transforms: tuple[np.ndarray, ...]

    @property
    def quantity(self) -> int:
        return len(self.part_ids)

    def to_dict(self) -> dict:
        return {"mark": self.mark, "quantity": self.quantity, "parts": list(self.part_ids)}


@dataclass(frozen=True)
class FlatParts:
    """The flat parts, one per part of the model, and their marks (every part in one)."""

    parts: tuple[FlatPart, ...]
    metrics: dict = field(default_factory=dict)
    issues: tuple[Issue, ...] = ()
    marks: tuple[MarkGroup, ...] = ()

    def to_dict(self) -> dict:
        return {
            "parts": [p.to_dict() for p in self.parts],
            "marks": [m.to_dict() for m in self.marks],
            "metrics": self.metrics,
        }


@dataclass(frozen=True)
class Placement:
    """A part on a plate: ``transform`` (3, 3) maps the part's flat frame to the plate, mm."""

    part_id: str
    transform: np.ndarray

    def to_dict(self) -> dict:
        return {"part": self.part_id, "transform": _round(self.transform, 6)}


@dataclass(frozen=True)
class Plate:
    """One stock plate with its parts. ``size`` is (length, width), mm."""

    index: int
    material: str
    thickness: float
    size: tuple[float, float]
    placements: tuple[Placement, ...]
    utilisation: float
    files: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        return f"plate-{self.index:03d}"

    def to_dict(self) -> dict:
        return {
            "plate": self.name,
            "material": self.material,
            "thickness_mm": self.thickness,
            "size_mm": list(self.size),
            "utilisation": round(self.utilisation, 4),
            "placements": [p.to_dict() for p in self.placements],
            "files": list(self.files),
        }


@dataclass(frozen=True)
class Nests:
    plates: tuple[Plate, ...]
    metrics: dict = field(default_factory=dict)
    issues: tuple[Issue, ...] = ()

    def to_dict(self) -> dict:
        return {"plates": [p.to_dict() for p in self.plates], "metrics": self.metrics}
