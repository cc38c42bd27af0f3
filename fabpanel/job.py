"""The job: everything a run needs besides the design surface, read from a TOML file.

Lengths carry their unit in the file (``"3 mm"``, ``"1.2 m"``); pressures, stresses, densities and
times too. Validation turns every problem into one :class:`~fabpanel.errors.InputError` line that
names the key and what is allowed. Internally all values are in millimetres, N/mm2 (MPa), kg/mm3
and seconds (see :mod:`fabpanel.units`).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainSerializer,
    ValidationError,
    model_validator,
)

from .errors import InputError
from .units import format_quantity, parse_quantity


def _quantity(dimension: str):
    return [BeforeValidator(lambda value: parse_quantity(value, dimension)),
            PlainSerializer(lambda value: format_quantity(value, dimension), return_type=str)]


Length = Annotated[float, *_quantity("length")]
PositiveLength = Annotated[float, *_quantity("length"), Field(gt=0)]
NonNegativeLength = Annotated[float, *_quantity("length"), Field(ge=0)]
Pressure = Annotated[float, *_quantity("pressure"), Field(ge=0)]
Stress = Annotated[float, *_quantity("stress"), Field(gt=0)]
Density = Annotated[float, *_quantity("density"), Field(gt=0)]
Duration = Annotated[float, *_quantity("time"), Field(ge=0)]

Stage = Literal["panelize", "develop", "build", "cut", "structure"]
#: pipeline stages in order; ``--until`` takes one of these
STAGES: tuple[Stage, ...] = ("panelize", "develop", "build", "cut", "structure")


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


class InputSection(_Section):
    """[input]: the design surface."""

    #: path of the design surface, relative to the job file
    path: str | None = None
    #: length unit of the input coordinates. Meshes do not carry units: required for them.
    #: STEP/IGES/BREP are converted by OCCT from the units in their header; this overrides nothing.
    units: Literal["m", "cm", "mm"] | None = None


class PanelizeSection(_Section):
    """[panelize]: how the surface is covered with quad panels."""

    #: ``auto``: ``grid`` for four-sided surfaces without openings, ``skeleton`` otherwise;
    #: ``layout``: the quad mesh in ``layout`` is used as the panel layout
    method: Literal["auto", "grid", "skeleton", "layout"] = "auto"
    #: target panel edge length (panels are made as close to it as the layout allows)
    panel_size: PositiveLength = "1200 mm"
    #: explicit panel counts along the grid's two directions (override ``panel_size``)
    grid_u: int | None = Field(default=None, ge=1, le=1000)
    grid_v: int | None = Field(default=None, ge=1, le=1000)
    #: boundary vertices turning more than this are corners (degrees)
    corner_angle: float = Field(default=30.0, gt=0, lt=180)
    #: user layout: a quad mesh (OBJ, PLY, 3DM) relative to the job file, in the input's units
    #: (a 3DM file's own unit system wins where it has one)
    layout: str | None = None
    #: skeleton: densify the coarse quads with per-strip counts, or by Catmull-Clark levels
    density: Literal["strips", "catmull-clark"] = "strips"
    #: skeleton: relax the dense layout on the surface (even edges, fair lines)
    relax: bool = True
    #: skeleton: points (x, y, z in the input's units) that must become layout vertices,
    #: e.g. columns
    singular_points: list[tuple[float, float, float]] = Field(default_factory=list)

    @model_validator(mode="after")
    def _layout_has_a_file(self) -> PanelizeSection:
        if self.method == "layout" and not self.layout:
            raise ValueError('method "layout" needs the quad mesh: set layout = "my-layout.obj"')
        return self


class DevelopSection(_Section):
    """[develop]: how panel surfaces are made developable."""

    #: ``global`` (default): one optimisation moves all panels at once to developable panels with
    #: planar rib edges, staying close to the design surface (Gavriil et al. 2019 Gauss-image
    #: planes; see :mod:`fabpanel.develop.optimise`); ``loft``: the thesis's baseline, a ruled
    #: surface per panel between two opposite sides (Appendix D); ``project``: panels sampled on
    #: the design surface itself (exact when it is already developable, e.g. a barrel vault),
    #: developability measured, not enforced.
    method: Literal["global", "loft", "project"] = "global"
    #: samples per panel side (k x k grid per panel; 9 is the thesis's subdivision level 3)
    samples: int = Field(default=9, ge=3, le=65)
    #: largest unroll strain (relative edge-length change) for a panel to count as developable.
    #: 5e-4 is 0.05 %: 0.75 mm on a 1.5 m sheet, within the plasma tolerance.
    strain_tolerance: float = Field(default=5e-4, gt=0, lt=0.5)
    #: global: weight of closeness to the design surface against developability (1). Lower lets
    #: panels move further to become developable; higher keeps the shape
    closeness: float = Field(default=0.05, gt=0, le=100)
    #: global: weight of fairness (second differences along the sample grid lines)
    fairness: float = Field(default=0.1, ge=0, le=100)
    #: global: weight of rib planarity (side samples in one plane per side, the normals along it
    #: at one angle to that plane)
    rib_planarity: float = Field(default=10.0, ge=0, le=100)
    #: global: Levenberg-Marquardt iterations at most
    max_iterations: int = Field(default=60, ge=1, le=10000)
    #: global: stop when an iteration lowers the energy by less than this (relative)
    tolerance: float = Field(default=1e-6, gt=0, lt=1)


class BoltSection(_Section):
    """[sandwich.bolts]: bolted joints between back-to-back ribs."""

    diameter: PositiveLength = "13 mm"
    spacing: PositiveLength = "250 mm"
    edge_distance: PositiveLength = "60 mm"
    #: sheet with openings to reach the bolts
    access_sheet: Literal["bottom", "top", "none"] = "bottom"
    access_diameter: PositiveLength = "40 mm"


class SandwichSection(_Section):
    """[sandwich]: the build-up of each panel."""

    #: ``sandwich``: top and bottom sheet with ribs between; ``cladding``: one sheet, no ribs
    buildup: Literal["sandwich", "cladding"] = "sandwich"
    #: which face of the build-up lies on the design surface
    design_face: Literal["top-outer", "bottom-outer", "middle"] = "top-outer"
    sheet_thickness: PositiveLength = "3 mm"
    #: bottom sheet thickness (default: same as the top sheet)
    bottom_sheet_thickness: PositiveLength | None = None
    #: clear height of the ribs between the two sheets
    rib_height: PositiveLength = "150 mm"
    rib_thickness: PositiveLength = "8 mm"
    #: distance along both edges from a corner to the corner stiffener
    stiffener_offset: PositiveLength = "150 mm"
    stiffener_thickness: PositiveLength | None = None
    bolts: BoltSection = BoltSection()

    @property
    def bottom_thickness(self) -> float:
        return self.bottom_sheet_thickness or self.sheet_thickness

    @property
    def total_depth(self) -> float:
        """Outer face of the top sheet to outer face of the bottom sheet, mm."""
        if self.buildup == "cladding":
            return self.sheet_thickness
        return self.sheet_thickness + self.rib_height + self.bottom_thickness


class MaterialSection(_Section):
    """[material]: steel grade (S235 by default)."""

    name: str = "S235"
    E: Stress = "210 GPa"
    nu: float = Field(default=0.3, gt=0, lt=0.5)
    density: Density = "7850 kg/m3"
    fy: Stress = "235 MPa"


class CuttingSection(_Section):
    """[cutting]: stock plates and the plasma table."""

    plate_length: PositiveLength = "3000 mm"
    plate_width: PositiveLength = "1500 mm"
    #: plasma kerf (the CAM compensates it; used here to check the spacing)
    kerf: NonNegativeLength = "2 mm"
    #: clear distance between parts on a plate (at least the kerf plus a margin)
    part_spacing: NonNegativeLength = "10 mm"
    #: clear border along the plate edges
    plate_margin: NonNegativeLength = "10 mm"
    #: time budget for improving the nest of each material/thickness group. "0 s" (default) keeps
    #: spyrrow's constructive solution, which is reproducible bit for bit; a budget gives denser
    #: nests, but spyrrow stops on the wall clock, so the result can vary with machine load
    nest_time: Duration = "0 s"
    #: allowed part rotations on the plate, degrees
    rotations: list[Literal[0, 90, 180, 270]] = Field(default=[0, 90, 180, 270], min_length=1)
    #: round holes smaller than this many plate thicknesses are drilled, not cut: plasma cuts
    #: clean holes down to about 1-1.5 x the thickness. They go on the DRILL layer with an
    #: etched centre mark, and are not pierced
    min_plasma_hole: float = Field(default=1.0, ge=0.0, le=5.0)
    #: sheets are unrolled at this fibre of the plate
    neutral_fibre: Literal["mid", "outer", "inner"] = "mid"
    seed: int = Field(default=0, ge=0)

    @model_validator(mode="after")
    def _spacing_covers_kerf(self) -> CuttingSection:
        if self.part_spacing < self.kerf:
            raise ValueError(f"part_spacing ({self.part_spacing:g} mm) must be at least the kerf "
                             f"({self.kerf:g} mm)")
        return self


class LoadsSection(_Section):
    """[loads]: actions and checks for the structural summary."""

    snow: Pressure = "0.56 kN/m2"
    wind: Pressure = "0.8 kN/m2"
    #: horizontal wind direction (x, y); both signs are checked (pressure and suction on the
    #: faces the wind meets first, as the thesis)
    wind_direction: tuple[float, float] = (1.0, 0.0)
    #: also the wind blowing against ``wind_direction`` (other faces; one more static case,
    #: about a quarter more CalculiX time)
    wind_opposite: bool = False
    gamma_g: float = Field(default=1.2, gt=0)
    gamma_q: float = Field(default=1.5, gt=0)
    #: knock-down on the linear buckling factor (1/6: a factor of 6 is required)
    buckling_knockdown: float = Field(default=1 / 6, gt=0, le=1)
    #: deflection limit as span / N
    deflection_limit: float = Field(default=300.0, gt=0)


class StructureSection(_Section):
    """[structure]: the shell model and the CalculiX run of the structural check."""

    #: element length along the panel sides (every side gets ceil(median side / size)
    #: elements); default: as fine as ``max_elements`` allows, at most 4 per side
    element_size: PositiveLength | None = None
    #: element budget of the default size. CalculiX's time and memory grow fast: about 6000
    #: S8R with their rib/sheet knots take ~1 min and < 2 GB on 2 cores for the static cases and
    #: 10 buckling modes
    max_elements: int = Field(default=6000, ge=50, le=200000)
    #: ``lowest``: nodes within ``support_band`` of the lowest one (the thesis); ``boundary``:
    #: every boundary rib; ``openings``: the ribs around the openings (support rims)
    supports: Literal["lowest", "boundary", "openings"] = "lowest"
    support_band: NonNegativeLength = "10 mm"
    #: span for the deflection limit (default: twice the largest plan distance to a support)
    span: PositiveLength | None = None
    #: buckling factors requested from CalculiX (the positive ones are kept; >= 5 are reported)
    buckling_modes: int = Field(default=10, ge=5, le=100)
    #: CalculiX threads (default: the --jobs count, else all cores)
    threads: int | None = Field(default=None, ge=1, le=256)
    #: stop a CalculiX run after this long
    timeout: Duration = "30 min"
    #: without CalculiX the export still completes and the summary says "not analysed";
    #: true (or ``--require-fem``) makes that an error
    required: bool = False


class OutputSection(_Section):
    """[output]: where and what to write."""

    #: output folder, relative to the job file (default: ``<input name>-fabpanel`` beside it)
    dir: str | None = None
    step: bool = True
    glb: bool = True
    #: model/design.3dm for Rhino and Grasshopper (panel surfaces, outlines, labels on layers)
    rhino: bool = True
    dxf: bool = True
    report: bool = True


class _JobModel(_Section):
    input: InputSection = InputSection()
    panelize: PanelizeSection = PanelizeSection()
    develop: DevelopSection = DevelopSection()
    sandwich: SandwichSection = SandwichSection()
    material: MaterialSection = MaterialSection()
    cutting: CuttingSection = CuttingSection()
    loads: LoadsSection = LoadsSection()
    structure: StructureSection = StructureSection()
    output: OutputSection = OutputSection()


_SECTION_NAMES = tuple(_JobModel.model_fields)


class Job:
    """A validated, immutable job.

    Build one from sections, as a TOML file would hold them::

        Job(input={"path": "vault.obj", "units": "m"}, sandwich={"rib_height": "200 mm"})

    or with :meth:`from_toml`, :meth:`from_dict` or :meth:`for_input`; change it with
    :meth:`replace` (returns a new job). ``base_dir`` is the folder relative paths start from
    (default: the current folder). Sections are read as attributes: ``job.sandwich.rib_height``
    (internal units: mm, MPa, kg/mm3, s).
    """

    __slots__ = ("base_dir", "settings", "source")

    def __init__(self, settings: _JobModel | None = None, base_dir: str | Path = ".",
                 source: str | Path | None = None, **sections: dict[str, Any]):
        if settings is None:
            where = str(source) if source else "job"
            try:
                settings = _JobModel.model_validate(sections)
            except ValidationError as err:
                raise InputError(f"{where}: {_describe(err)}") from None
        elif sections:
            raise TypeError("give either settings or sections, not both")
        object.__setattr__(self, "settings", settings)
        object.__setattr__(self, "base_dir", Path(base_dir).resolve())
        object.__setattr__(self, "source", Path(source) if source else None)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Job is immutable; use job.replace(section={...})")

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Job) and self.settings == other.settings
                and self.base_dir == other.base_dir)

    def __hash__(self) -> int:
        return hash((self.base_dir, repr(self.settings)))

    def __reduce__(self):
        # immutable with __slots__: pickle through the constructor (worker processes, caches)
        return (Job, (self.settings, self.base_dir, self.source))

    def __repr__(self) -> str:
        return f"Job(source={self.source}, base_dir={self.base_dir}, {self.to_dict()})"

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: dict[str, Any], base_dir: str | Path = ".",
                  source: str | Path | None = None) -> Job:
        if not isinstance(data, dict):
            raise InputError(f"{source or 'job'}: expected sections such as [input], got "
                             f"{type(data).__name__}")
        unknown = [key for key in data if not isinstance(key, str)]
        if unknown:
            raise InputError(f"{source or 'job'}: section names must be text, got {unknown[0]!r}")
        return cls(None, base_dir, source, **data)

    @classmethod
    def from_toml(cls, path: str | Path) -> Job:
        path = Path(path)
        if not path.is_file():
            raise InputError(f"job file {path} does not exist; create one with `fabpanel init`")
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
            raise InputError(f"{path}: not valid TOML ({err}); check the syntax at that line") \
                from None
        return cls.from_dict(data, base_dir=path.parent, source=path)

    @classmethod
    def for_input(cls, input_path: str | Path, units: str | None = None, **sections: dict) -> Job:
        """A default job for one design surface (what ``fabpanel export surface.obj`` runs)."""
        input_path = Path(input_path).resolve()
        data: dict[str, Any] = {k: dict(v) for k, v in sections.items()}
        data.setdefault("input", {})["path"] = str(input_path)
        if units is not None:
            data["input"]["units"] = units
        return cls.from_dict(data, base_dir=input_path.parent)

    def replace(self, **changes: dict[str, Any]) -> Job:
        """A new job with some keys changed: ``job.replace(panelize={"panel_size": "1 m"})``."""
        data = self.to_dict()
        for section, values in changes.items():
            if section not in _SECTION_NAMES:
                raise InputError(f"unknown job section [{section}]; sections are "
                                 f"{', '.join(_SECTION_NAMES)}")
            data[section] = {**data.get(section, {}), **values}
        return Job.from_dict(data, self.base_dir, self.source)

    # -- access -------------------------------------------------------------------------------
    def __getattr__(self, name: str) -> Any:
        if name in _SECTION_NAMES:
            return getattr(self.settings, name)
        raise AttributeError(name)

    @property
    def input_path(self) -> Path | None:
        if self.settings.input.path is None:
            return None
        return (self.base_dir / self.settings.input.path).resolve()

    @property
    def output_dir(self) -> Path:
        if self.settings.output.dir:
            return (self.base_dir / self.settings.output.dir).resolve()
        stem = self.input_path.stem if self.input_path else "fabpanel"
        return (self.base_dir / f"{stem}-fabpanel").resolve()

    def to_dict(self) -> dict[str, Any]:
        """The job as TOML-ready data, quantities written with their internal unit."""
        return self.settings.model_dump(mode="json", exclude_none=True)


def _describe(err: ValidationError) -> str:
    """One line for the first validation error: key, problem, what is allowed."""
    first = err.errors()[0]
    loc = [str(part) for part in first["loc"]]
    key = _key_name(loc)
    kind = first["type"]
    if kind == "extra_forbidden":
        model = _JobModel
        for part in loc[:-1]:
            field = model.model_fields.get(part)
            model = field.annotation if field is not None else model
        allowed = ", ".join(getattr(model, "model_fields", {})) or "none"
        what = "section" if len(loc) == 1 else "key"
        return f"unknown {what} {key}; allowed here: {allowed}"
    if kind == "value_error":
        message = str(first.get("ctx", {}).get("error", first["msg"]))
        return f"{key}: {message}"
    if kind == "literal_error":
        return f"{key}: {first['input']!r} is not allowed; {first['msg'].lower()}"
    if kind in {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}:
        limit = next(iter(first.get("ctx", {}).values()), "")
        sign = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<",
                "less_than_equal": "<="}[kind]
        unit = " mm" if isinstance(first["input"], str) and "m" in first["input"] else ""
        return f"{key}: {first['input']!r} is out of range; it must be {sign} {limit}{unit}"
    return f"{key}: {first['msg']} (got {first.get('input')!r})"


def _key_name(loc: list[str]) -> str:
    if not loc:
        return "job"
    if len(loc) == 1:
        return f"[{loc[0]}]"
    return f"[{'.'.join(loc[:-1])}] {loc[-1]}"


def check_finite(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise InputError(f"{name} must be a finite number, got {value!r}")
    return value
