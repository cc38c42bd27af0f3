"""What the shop documents are made from: the run's manifest, read into typed records.

The schedules, the key plan and the IFC model are built from the manifest (and, for the IFC's
solids, the model) alone, so ``fabpanel docs OUTPUT_DIR`` makes the same documents from an
output folder as the run made. Every length is in millimetres in the design's own frame (the
manifest's), masses in kg.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..job import Job


@dataclass(frozen=True)
class PanelDoc:
    """One panel: id, corners (4, 3) mm in the layout's order, neighbour id per side (or None)."""

    id: str
    corners: np.ndarray
    neighbours: tuple[str | None, ...]
    panel_class: str


@dataclass(frozen=True)
class PartDoc:
    """One part as the documents need it.

    centroid : (3,) mm or None.  bolt_centres, bolt_axes : (n, 3) (mid-thickness of the plate,
    unit axis), bolt_diameters : (n,) hole diameters, mm.  bend_radius : (smallest, largest) at
    the unrolling fibre, mm ((0, 0): not rolled).  roll_axis_deg : the bend lines' direction in
    the flat part's frame.  roll_extent : the flat sheet's extent along
    that axis and across it.  size : flat extent along the flat frame's x and y.  edge_lengths_3d :
    sheets' four sides on the surface (empty otherwise).
    """

    id: str
    kind: str
    panel: str
    material: str
    thickness: float
    volume: float
    mass: float
    centroid: np.ndarray | None
    mark: str
    forming: str
    net_area: float
    cut_length: float
    size: tuple[float, float]
    bend_radius: tuple[float, float]
    roll_axis_deg: float
    roll_extent: tuple[float, float]
    spring_stress: float
    edge_lengths_3d: np.ndarray
    bolt_centres: np.ndarray
    bolt_axes: np.ndarray
    bolt_diameters: np.ndarray

    @property
    def coating_area(self) -> float:
        """Surface to coat, mm2: both faces of the net flat area and the cut edges (the sheet's
        two faces differ from the flat by t / 2R each way, which cancels)."""
        return 2.0 * self.net_area + self.cut_length * self.thickness


@dataclass(frozen=True)
class DocSource:
    """The run as the documents read it: the job, panels in layout order, parts in model order,
    the joints' bolt count and the design's origin (added to the model's local solids)."""

    job: Job
    name: str
    panels: tuple[PanelDoc, ...]
    parts: tuple[PartDoc, ...]
    bolts_total: int
    origin: np.ndarray
    fabpanel_version: str
    #: error-level issues by panel id (an issue on a part counts for its panel): the panel is
    #: on hold until they are resolved
    errors: dict[str, tuple[str, ...]] = field(default_factory=dict)

    @classmethod
    def from_manifest(cls, manifest: dict, name: str | None = None) -> DocSource:
        """Read a manifest (as ``build_manifest`` makes it, or as read from manifest.json);
        ``name`` defaults to the input file's name without its suffix."""
        job = Job.from_dict(manifest["job"])
        classes = {p["id"]: p.get("class") or "" for p in manifest["panels"]}
        panels = tuple(
            PanelDoc(
                id=p["id"],
                corners=np.asarray(p["corners_mm"], dtype=float),
                neighbours=tuple(p["neighbours"]),
                panel_class=classes[p["id"]],
            )
            for p in manifest["panels"]
        )
        parts = tuple(_part(record) for record in manifest["parts"])
        build = manifest.get("metrics", {}).get("build", {})
        return cls(
            job=job,
            name=name or _run_name(manifest, "fabpanel"),
            panels=panels,
            parts=parts,
            bolts_total=int(build.get("bolts_total", 0)),
            origin=np.asarray(manifest.get("origin_mm", (0.0, 0.0, 0.0)), dtype=float),
            fabpanel_version=str(manifest.get("fabpanel", "")),
            errors=_errors_by_panel(manifest.get("issues", []), {p.id for p in panels}),
        )

    @classmethod
    def from_folder(cls, folder: str | Path) -> DocSource:
        """Read ``folder/manifest.json`` of a finished run (exit 2 when it is missing or not one)."""
        path = Path(folder) / "manifest.json"
        if not path.is_file():
            raise InputError(
                f"{folder}: no manifest.json; give the output folder of a fabpanel run"
            )
        try:
            manifest = json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise InputError(f"{path}: not valid JSON ({err}); run the job again") from err
        if "parts" not in manifest or "job" not in manifest:
            raise InputError(f"{path}: not a fabpanel manifest (no parts or job)")
        if not manifest["parts"]:
            raise InputError(
                f"{path}: the run built no parts; documents need a run through the build stage"
            )
        return cls.from_manifest(manifest, name=_run_name(manifest, Path(folder).name))

    def parts_of(self, panel: str) -> list[PartDoc]:
        return [p for p in self.parts if p.panel == panel]


def _errors_by_panel(issues: list[dict], panel_ids: set[str]) -> dict[str, tuple[str, ...]]:
    found: dict[str, list[str]] = {}
    for issue in issues:
        if issue.get("severity") != "error":
            continue
        panel = str(issue.get("item", "")).split("-", 1)[0]
        if panel in panel_ids:
            found.setdefault(panel, []).append(f"{issue['code']}: {issue['message']}")
    return {k: tuple(v) for k, v in found.items()}


def _run_name(manifest: dict, fallback: str) -> str:
    """The input file's name without its suffix, or ``fallback`` for a job without one."""
    source = manifest.get("job", {}).get("input", {}).get("path")
    return Path(source).stem if source else fallback


def _part(record: dict) -> PartDoc:
    flat = record.get("flat") or {}
    holes = record.get("bolt_holes", [])
    centroid = record.get("centroid_mm")
    return PartDoc(
        id=record["id"],
        kind=record["kind"],
        panel=record["panel"],
        material=record["material"],
        thickness=float(record["thickness_mm"]),
        volume=float(record["volume_mm3"]),
        mass=float(record["mass_kg"]),
        centroid=np.asarray(centroid, dtype=float) if centroid is not None else None,
        mark=flat.get("mark", "") or record["id"],
        forming=flat.get("forming", ""),
        net_area=float(flat.get("area_mm2", record["area_mm2"])),
        cut_length=float(flat.get("cut_length_mm", 0.0)),
        size=tuple(flat.get("size_mm", (0.0, 0.0))),  # type: ignore[arg-type]
        bend_radius=tuple(flat.get("bend_radius_mm", (0.0, 0.0))),  # type: ignore[arg-type]
        roll_axis_deg=float(flat.get("roll_axis_deg", 0.0)),
        roll_extent=tuple(flat.get("roll_extent_mm", (0.0, 0.0))),  # type: ignore[arg-type]
        spring_stress=float(flat.get("spring_stress_MPa", 0.0)),
        edge_lengths_3d=np.asarray(flat.get("edge_lengths_3d_mm", ()), dtype=float),
        bolt_centres=np.array([h["centre_mm"] for h in holes], dtype=float).reshape(-1, 3),
        bolt_axes=np.array([h["axis"] for h in holes], dtype=float).reshape(-1, 3),
        bolt_diameters=np.array([h["diameter_mm"] for h in holes], dtype=float),
    )
