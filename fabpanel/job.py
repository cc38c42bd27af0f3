"""The job: everything a run needs besides the design surface, read from a TOML file.

Lengths carry their unit in the file (``"3 mm"``, ``"1.2 m"``); pressures, stresses, densities and
times too. Validation turns every problem into one :class:`~fabpanel.errors.InputError` line that
names the key, quotes the value as written and says what is allowed. Internally all values are in
millimetres, N/mm2 (MPa), kg/mm3 and seconds (see :mod:`fabpanel.units`).

Besides types and ranges, the job is refused when it cannot be built: numbers that are not finite
(nan, inf, ``"1e308 m"``), a wind direction without a horizontal component, and a sandwich whose
plates, ribs and bolts do not fit together or onto the stock plate. The bolt rules are the minima
of EN 1993-1-8:2005 Table 3.3 (the job's bolt ``diameter`` is the hole diameter d0: ``"13 mm"``
for M12); the others are fabpanel's own, each explained where it is defined.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, get_args

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ModelWrapValidatorHandler,
    PlainSerializer,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from .errors import InputError
from .fasteners import (
    MIN_ENGAGEMENT,
    TOOL_RIB_GAP,
    AccessDesign,
    access_design,
    bolt_for_hole,
    default_tool,
)
from .units import as_written, format_like, format_number, format_quantity, parse_quantity
from .welds import MIN_SHEET_BEARING, default_setback, default_throat


def _quantity(dimension: str) -> list[Any]:
    return [
        BeforeValidator(lambda value: parse_quantity(value, dimension)),
        PlainSerializer(lambda value: format_quantity(value, dimension), return_type=str),
    ]


def _default(text: str, dimension: str = "length") -> float:
    """A default written as in a job file, kept in internal units: ``"1200 mm"`` is 1200.0."""
    return parse_quantity(text, dimension)


Length = Annotated[float, *_quantity("length")]
PositiveLength = Annotated[float, *_quantity("length"), Field(gt=0)]
NonNegativeLength = Annotated[float, *_quantity("length"), Field(ge=0)]
Pressure = Annotated[float, *_quantity("pressure"), Field(ge=0)]
Stress = Annotated[float, *_quantity("stress"), Field(gt=0)]
Density = Annotated[float, *_quantity("density"), Field(gt=0)]
Duration = Annotated[float, *_quantity("time"), Field(ge=0)]
Velocity = Annotated[float, *_quantity("velocity"), Field(gt=0)]

Stage = Literal["panelize", "develop", "build", "cut", "structure"]
#: pipeline stages in order; ``--until`` takes one of these
STAGES: tuple[Stage, ...] = ("panelize", "develop", "build", "cut", "structure")


#: EN 1993-1-8:2005 Table 3.3: end and edge distances e1, e2 >= 1.2 d0 (d0: the hole diameter,
#: the job's bolt ``diameter``)
MIN_EDGE_DISTANCE = 1.2
#: EN 1993-1-8 Table 3.3: bolt spacing p1 >= 2.2 d0 along the force, p2 >= 2.4 d0 across it. The
#: bolts of a rib joint stand in one row and carry shear along the rib (the shell's membrane
#: shear) and across it in the rib's plane (its transverse shear): their spacing is p1 and p2 at
#: once, so the larger minimum
MIN_BOLT_SPACING = 2.4
#: largest erection gap closed by packing plates at the bolts, mm (fabpanel's rule)
MAX_ERECTION_GAP = 10.0
#: holes larger than this many rib thicknesses are refused (fabpanel's rule): the rib's bearing
#: resistance (EN 1993-1-8 Table 3.4, at most 2.5 fu d t; S235 fu = 360 MPa) is then under half
#: the shear resistance of the bolt (grade 8.8, one shear plane, 0.6 fub As with As ~ 0.78 pi
#: d^2 / 4): the bolt is oversized for the plates it clamps, or a unit slipped
MAX_HOLE_PER_RIB_THICKNESS = 6.0
#: sheets, ribs and stiffeners at most this fraction of the rib height (fabpanel's rule): the
#: ribs are the core of the sandwich and hold the bolts between the sheets; a plate as thick as
#: half the core is no sandwich panel (typically a unit slip: "500 mm" for "5 mm")
MAX_PLATE_PER_RIB_HEIGHT = 0.5
#: corners opening up to this angle get a stiffener (degrees, as
#: ``fabpanel.model.panel.MAX_STIFFENED_ANGLE``): a stiffener's chord is at most
#: 2 sin(75 deg) x stiffener_offset long
STIFFENED_ANGLE = 150.0
#: a wind direction shorter than this (in x and y) has no direction
MIN_WIND_DIRECTION = 1e-9

_MISSING = object()


class _RuleError(ValueError):
    """A rule across keys is broken. ``key`` (dotted, relative to the section that checks it) is
    named first; the message quotes the values as written and says how to fix them."""

    def __init__(self, key: str, message: str):
        super().__init__(message)
        self.key = key


class _Written:
    """The values of a section as the user wrote them, for messages: ``w("rib_height")`` is
    ``'"5 m"'``; a key left out shows its default, ``150 mm (the default)``. ``table`` is the
    section's TOML table (``"sandwich"``; ``""`` for the whole job)."""

    def __init__(self, data: Any, model: BaseModel, table: str):
        self.data, self.table = data, table
        self.dumped = model.model_dump(mode="json")

    def raw(self, key: str) -> Any:
        raw: Any = self.data
        for part in key.split("."):
            raw = raw.get(part, _MISSING) if isinstance(raw, dict) else _MISSING
        return raw

    def given(self, key: str) -> bool:
        return self.raw(key) is not _MISSING

    def __call__(self, key: str) -> str:
        raw = self.raw(key)
        if raw is not _MISSING:
            return as_written(raw)
        value: Any = self.dumped
        for part in key.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        shown = value if isinstance(value, str) else as_written(value)
        return f"{shown} (the default)" if isinstance(self.data, dict) else shown

    def label(self, key: str) -> str:
        """The key as a user finds it in the file: ``[sandwich.bolts] diameter``."""
        return _key_name([*filter(None, self.table.split(".")), *key.split(".")])

    def like(self, key: str, value: float) -> str:
        """A length in mm, in the unit the user wrote ``key`` in (``"0.15 m"``), else in mm."""
        raw = self.raw(key)
        written = format_like(value, raw) if raw is not _MISSING else None
        return written or f"{format_number(value)} mm"

    def conflict(self, key: str, other: str, rule: str, fix: str) -> _RuleError:
        """The error of a rule between two keys; it names ``key`` first unless only ``other``
        was written (then the user's value is the one to look at)."""
        if self.given(other) and not self.given(key):
            key, other = other, key
        return _RuleError(
            key, f"{self(key)} against {self.label(other)} {self(other)}: {rule}; {fix}"
        )


def _numeric(annotation: Any) -> bool:
    """Whether a field holds numbers: ``float``, ``int | None``, ``tuple[float, float]``..."""
    if annotation in (float, int):
        return True
    return any(_numeric(arg) for arg in get_args(annotation))


class _Section(BaseModel):
    # defaults are given in internal units (``_default("1200 mm")``), so they are not read
    # again as job text (a bare number is refused there); every float must be finite, in
    # tuples and lists too
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    #: the section's TOML table, for messages
    _table: ClassVar[str] = ""

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        # defaults are not validated: a quantity default written as text would stay text
        for name, field in cls.model_fields.items():
            if isinstance(field.default, str) and any(
                isinstance(meta, BeforeValidator) for meta in field.metadata
            ):
                raise TypeError(
                    f"{cls.__name__}.{name}: write the default as "
                    f"_default({field.default!r}, ...), in internal units"
                )

    @field_validator("*", mode="before")
    @classmethod
    def _no_yes_no_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        # pydantic reads TOML true/false as 1/0 where a number is expected (quantities are
        # refused by parse_quantity, with their unit in the message)
        field = cls.model_fields.get(info.field_name or "")
        if (
            field is None
            or not _numeric(field.annotation)
            or any(isinstance(meta, BeforeValidator) for meta in field.metadata)
        ):
            return value
        if isinstance(value, bool) or (
            isinstance(value, (list, tuple)) and any(isinstance(item, bool) for item in value)
        ):
            raise ValueError(
                f"{as_written(value)} holds a yes/no value (true/false); write a number here"
            )
        return value

    @model_validator(mode="wrap")
    @classmethod
    def _rules(cls, data: Any, handler: ModelWrapValidatorHandler[Any]) -> Any:
        section = handler(data)
        section._check(_Written(data, section, cls._table))
        return section

    def _check(self, w: _Written) -> None:
        """Rules across the section's keys: raise :class:`_RuleError` (none by default)."""


class InputSection(_Section):
    """[input]: the design surface."""

    _table = "input"

    #: path of the design surface, relative to the job file
    path: str | None = None
    #: length unit of the input coordinates. Meshes do not carry units: required for them.
    #: STEP/IGES/BREP are converted by OCCT from the units in their header; this overrides nothing.
    units: Literal["m", "cm", "mm"] | None = None
    #: neighbouring triangles of the (welded) surface mesh whose normals differ by more than
    #: this are a crease and the input is refused (degrees). 45 is twice the sharpest fold of the
    #: examples (20 degrees, on pavilion.obj) and stops a right-angled fold; the same value as
    #: fabpanel.surface.checks.CREASE_ANGLE
    crease_angle: float = Field(default=45.0, gt=0, le=180)


class PanelizeSection(_Section):
    """[panelize]: how the surface is covered with quad panels."""

    _table = "panelize"

    #: ``auto``: ``grid`` for four-sided surfaces without openings; otherwise both ``skeleton``
    #: and ``field`` are made and the better by the layout gates is kept (the reason is in the
    #: manifest); ``field``: gmsh's quasi-structured quads on a conformal flattening;
    #: ``layout``: the quad mesh in ``layout`` is used as the panel layout
    method: Literal["auto", "grid", "skeleton", "field", "layout"] = "auto"
    #: target panel edge length (panels are made as close to it as the layout allows)
    panel_size: PositiveLength = _default("1200 mm")
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
    #: refuse a job whose surface area asks for more panels than this (area / panel_size²),
    #: before any layout work: usually a unit mistake (a mesh in mm declared in m)
    max_panels: int = Field(default=5000, ge=1, le=1_000_000)
    #: a panel narrower than this (its narrower mid-line) is an error-level issue: its ribs and
    #: stiffeners would meet. Default: 0.3 x panel_size
    min_panel_width: PositiveLength | None = None
    #: field method: ``boundary`` lets gmsh align the panels with the boundary; ``curvature``
    #: aligns them with the principal curvature directions where the surface is clearly
    #: anisotropic, blended into the boundary-aligned field elsewhere
    align: Literal["boundary", "curvature"] = "boundary"

    def _check(self, w: _Written) -> None:
        if self.method == "layout" and not self.layout:
            raise _RuleError(
                "layout", 'method "layout" needs the quad mesh: set layout = "my-layout.obj"'
            )

    @property
    def sizes_panels(self) -> bool:
        """Whether ``panel_size`` sets the panel sides in at least one direction."""
        return self.method != "layout" and (self.grid_u is None or self.grid_v is None)


class DevelopSection(_Section):
    """[develop]: how panel surfaces are made developable."""

    _table = "develop"

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
    #: a panel lying farther than this from the design surface anywhere is a warning naming
    #: it, with the panel size that would keep it within (a developable panel leaves a doubly
    #: curved design by about its size squared times the curvature). What the design allows is
    #: the designer's call: set it to the cladding's or the architect's tolerance
    deviation_tolerance: PositiveLength = _default("20 mm")
    #: global: weight of closeness to the design surface against developability (1). Lower lets
    #: panels move further to become developable; higher keeps the shape
    closeness: float = Field(default=0.05, gt=0, le=100)
    #: global: weight of fairness (second differences along the sample grid lines, against the
    #: design's). The sheets are bicubics through the samples: below about 1 the grid lines bend
    #: unevenly from sample to sample on doubly curved shapes, and the bicubic between them is
    #: far less developable than the samples (a 12 m dome meshed at 0.2 m, 1.2 m panels: 164 of
    #: 166 panels over the strain tolerance at 0.1, none at 1 with a mesh's reference smoothed,
    #: see :func:`fabpanel.develop.sample_grid.design_second_differences`); well above 1 the
    #: design's double curvature wins back
    fairness: float = Field(default=1.0, ge=0, le=100)
    #: global: weight of rib planarity (side samples in one plane per side, the normals along it
    #: at one angle to that plane)
    rib_planarity: float = Field(default=10.0, ge=0, le=100)
    #: global: weight that holds the layout's inner vertices (the panel corners) where the
    #: layout put them along the surface. The other terms only see the samples' distance from
    #: the surface, so without it corners slide along it at no cost, by up to 379 mm on a
    #: doubly curved 9 x 6 m shell at 1.2 m, and the panels are no longer those the layout
    #: gates measured and sized to the plate (0: free, as before)
    layout_hold: float = Field(default=1.0, ge=0, le=100)
    #: global: Levenberg-Marquardt iterations at most
    max_iterations: int = Field(default=60, ge=1, le=10000)
    #: global: stop when an iteration lowers the energy by less than this (relative)
    tolerance: float = Field(default=1e-6, gt=0, lt=1)
    #: global: ... or when two undamped iterations in a row move no sample further than this
    #: and lower the energy by less than 1 %: the optimum's long tail trades hundredths of a
    #: millimetre of deviation for strain far below ``strain_tolerance``, which no shop can see
    step_tolerance: PositiveLength = _default("0.01 mm")


class BoltSection(_Section):
    """[sandwich.bolts]: bolted joints between back-to-back ribs."""

    _table = "sandwich.bolts"

    #: bolt hole diameter d0 ("13 mm" takes an M12 bolt); the sandwich needs a rib_height of
    #: at least 2.4 d0 and a rib_thickness of at least d0 / 6
    diameter: PositiveLength = _default("13 mm")
    #: largest distance between the bolts of a rib, at least 2.4 d0 (EN 1993-1-8 Table 3.3).
    #: The bolts are spread evenly, so the real pitch can be down to about half of it
    spacing: PositiveLength = _default("250 mm")
    #: from the corner to the first bolt, at least 1.2 d0 (EN 1993-1-8 Table 3.3)
    edge_distance: PositiveLength = _default("60 mm")
    #: sheet with the access slots the tool reaches the bolts through (``none``: the bolts are
    #: reached otherwise, and not checked)
    access_sheet: Literal["bottom", "top", "none"] = "bottom"
    #: the fitter's tool: a ring spanner, or a socket on a ratchet
    tool: Literal["ring-spanner", "socket"] = "ring-spanner"
    #: ring or ratchet head diameter (default from the bolt's across-flats size s: 1.7 s + 1 mm
    #: for a ring, s + 22 mm for a ratchet)
    tool_head_diameter: PositiveLength | None = None
    #: ring or ratchet head thickness (default 0.55 s for a ring, 0.8 s for a ratchet)
    tool_head_thickness: PositiveLength | None = None
    #: handle width in the swing plane (default 1.1 s)
    tool_handle_width: PositiveLength | None = None
    #: degrees the handle turns between two grips (30: a 12-point ring)
    tool_swing: float = Field(default=30.0, ge=5.0, le=180.0)
    #: socket: from the nut's seat to the ratchet head (default 2 s, at least 30 mm)
    socket_length: PositiveLength | None = None
    #: ``normal``: non-preloaded bolts in normal round holes (EN 1090-2 Table 11 clearance);
    #: ``fitted``: fitted bolts, whose holes are always drilled (or reamed), never burnt
    fit: Literal["normal", "fitted"] = "normal"
    #: property class of the bolts (EN ISO 898-1; EN 1993-1-8 Table 3.1): their shear and
    #: tension resistance in the structural check and their stiffness in its model
    grade: Literal["4.6", "5.6", "8.8", "10.9"] = "8.8"


class WeldSection(_Section):
    """[sandwich.welds]: the sheet-to-rib welds and the fit-up details they need."""

    _table = "sandwich.welds"

    #: throat a of the fillet welds joining the sheets to the ribs (default: the largest
    #: equal-leg fillet the thinner sheet's edge holds, t / sqrt 2, at most 3 mm)
    throat: PositiveLength | None = None
    #: how far sheet edges stand back from the rib's contact face at the joints, so the weld
    #: stays off the face the neighbour's rib seats against (default: the weld leg a sqrt 2
    #: plus 1 mm for fit-up, rounded up to 0.5 mm); boundary edges stay flush
    setback: NonNegativeLength | None = None
    #: leg of the 45-degree snipes cut off stiffener corners and the ends of the ribs that butt
    #: against their neighbours, where three welds would meet ("0 mm": none)
    snipe: NonNegativeLength = _default("15 mm")
    #: clear gap between the ribs of neighbouring panels for erection tolerance, closed at each
    #: bolt by a square packing plate of this thickness ("0 mm": the ribs touch)
    erection_gap: NonNegativeLength = _default("0 mm")

    def sizes(self, thinnest_sheet: float, rib: float) -> tuple[float, float]:
        """(throat, setback) in mm: as written, or their defaults (:mod:`fabpanel.welds`)."""
        throat = self.throat or default_throat(thinnest_sheet, rib)
        setback = self.setback if self.setback is not None else default_setback(throat)
        return float(throat), float(setback)


class SandwichSection(_Section):
    """[sandwich]: the build-up of each panel."""

    _table = "sandwich"

    #: ``sandwich``: top and bottom sheet with ribs between; ``cladding``: one sheet, no ribs
    buildup: Literal["sandwich", "cladding"] = "sandwich"
    #: which face of the build-up lies on the design surface
    design_face: Literal["top-outer", "bottom-outer", "middle"] = "top-outer"
    #: sandwich: the sheets, ribs and stiffeners each at most half the rib height
    sheet_thickness: PositiveLength = _default("3 mm")
    #: bottom sheet thickness (default: same as the top sheet)
    bottom_sheet_thickness: PositiveLength | None = None
    #: clear height of the ribs between the two sheets; at most the plate's usable width
    rib_height: PositiveLength = _default("150 mm")
    rib_thickness: PositiveLength = _default("8 mm")
    #: distance along both edges from a corner to the corner stiffener: more than twice the
    #: rib thickness, less than the panel size
    stiffener_offset: PositiveLength = _default("150 mm")
    stiffener_thickness: PositiveLength | None = None
    bolts: BoltSection = BoltSection()
    welds: WeldSection = WeldSection()

    @property
    def bottom_thickness(self) -> float:
        return self.bottom_sheet_thickness or self.sheet_thickness

    @property
    def total_depth(self) -> float:
        """Outer face of the top sheet to outer face of the bottom sheet, mm."""
        if self.buildup == "cladding":
            return self.sheet_thickness
        return self.sheet_thickness + self.rib_height + self.bottom_thickness

    def access_design(self) -> AccessDesign | None:
        """The bolts' tool, its position and the access slot (:mod:`fabpanel.fasteners`), or
        None without bolts to reach (cladding, no access sheet, no standard bolt)."""
        bolts = self.bolts
        bolt = bolt_for_hole(bolts.diameter)
        if self.buildup != "sandwich" or bolts.access_sheet == "none" or bolt is None:
            return None
        tool = default_tool(
            bolts.tool,
            bolt,
            bolts.tool_head_diameter,
            bolts.tool_head_thickness,
            bolts.tool_handle_width,
            bolts.tool_swing,
            bolts.socket_length,
        )
        sheet = self.sheet_thickness if bolts.access_sheet == "top" else self.bottom_thickness
        return access_design(bolt, tool, self.rib_thickness, self.rib_height / 2 + sheet)

    def _check(self, w: _Written) -> None:
        if self.buildup != "sandwich":
            return  # cladding: one sheet, no ribs, no bolts
        h, t_rib, bolts = self.rib_height, self.rib_thickness, self.bolts
        d0 = bolts.diameter
        plates = [
            ("sheet_thickness", self.sheet_thickness, "sheets"),
            ("bottom_sheet_thickness", self.bottom_sheet_thickness, "sheets"),
            ("rib_thickness", t_rib, "ribs"),
            ("stiffener_thickness", self.stiffener_thickness, "stiffeners"),
        ]
        for key, t, what in plates:
            if t is not None and t > MAX_PLATE_PER_RIB_HEIGHT * h:
                raise w.conflict(
                    key,
                    "rib_height",
                    (
                        f"{what} are at most half the rib height (the ribs are the sandwich's core "
                        "and hold the bolts between the sheets)"
                    ),
                    (
                        f"use {what} of at most {w.like('rib_height', MAX_PLATE_PER_RIB_HEIGHT * h)}"
                        f" or a rib_height of at least {w.like(key, t / MAX_PLATE_PER_RIB_HEIGHT)}"
                    ),
                )
        if h < 2 * MIN_EDGE_DISTANCE * d0:
            raise w.conflict(
                "bolts.diameter",
                "rib_height",
                (
                    "a bolt hole sits at mid-height of the rib and needs 1.2 x its diameter to both "
                    "sheets (EN 1993-1-8 Table 3.3, e2 >= 1.2 d0): a rib height of at least 2.4 d0"
                ),
                (
                    f"use holes of at most {w.like('bolts.diameter', h / 2 / MIN_EDGE_DISTANCE)} "
                    f"or a rib_height of at least {w.like('rib_height', 2 * MIN_EDGE_DISTANCE * d0)}"
                ),
            )
        if d0 > MAX_HOLE_PER_RIB_THICKNESS * t_rib:
            raise w.conflict(
                "bolts.diameter",
                "rib_thickness",
                (
                    f"a hole larger than {MAX_HOLE_PER_RIB_THICKNESS:g} x the rib thickness is "
                    "refused: the rib's bearing resistance is then under half the bolt's shear "
                    "resistance, the bolt is oversized for the plates it clamps"
                ),
                (
                    f"use holes of at most "
                    f"{w.like('bolts.diameter', MAX_HOLE_PER_RIB_THICKNESS * t_rib)} or ribs of "
                    f"at least {w.like('rib_thickness', d0 / MAX_HOLE_PER_RIB_THICKNESS)}"
                ),
            )
        for key, factor, rule in (
            ("bolts.edge_distance", MIN_EDGE_DISTANCE, "e1, e2 >= 1.2 d0"),
            (
                "bolts.spacing",
                MIN_BOLT_SPACING,
                ("p1 >= 2.2 d0 along the rib, p2 >= 2.4 d0 across it; a rib joint has both"),
            ),
        ):
            value = getattr(bolts, key.split(".")[1])
            if value < factor * d0:
                raise w.conflict(
                    key,
                    "bolts.diameter",
                    (
                        f"EN 1993-1-8 Table 3.3 asks for at least {factor:g} x the hole diameter "
                        f"({rule})"
                    ),
                    (
                        f"use at least {w.like(key, factor * d0)} or holes of at most "
                        f"{w.like('bolts.diameter', value / factor)}"
                    ),
                )
        bolt = bolt_for_hole(d0)
        if bolt is None:
            raise _RuleError(
                "bolts.diameter",
                f"{w('bolts.diameter')} takes no standard bolt (an M8 needs a 9 mm hole); use "
                "a hole of at least 9 mm",
            )
        if bolts.access_sheet != "none":
            design = self.access_design()
            if design is not None and design.engagement < MIN_ENGAGEMENT:
                raise w.conflict(
                    "bolts.tool_head_thickness",
                    "bolts.diameter",
                    (
                        f"the tool covers {design.engagement:.0%} of the {bolt.name} hex (at "
                        f"least {MIN_ENGAGEMENT:.0%}): it stands {TOOL_RIB_GAP:g} mm off the rib"
                    ),
                    "use a thicker tool head or a larger bolt",
                )
        if self.stiffener_offset <= 2 * t_rib:
            raise w.conflict(
                "stiffener_offset",
                "rib_thickness",
                (
                    "a corner stiffener runs between the two ribs' inner faces, which leave it "
                    "nothing at a right-angled corner unless the offset is more than twice the rib "
                    "thickness"
                ),
                (
                    f"use a stiffener_offset of more than {w.like('stiffener_offset', 2 * t_rib)} "
                    "(typically about the rib height)"
                ),
            )
        self._check_welds(w)

    def _check_welds(self, w: _Written) -> None:
        welds, t_rib = self.welds, self.rib_thickness
        thinnest = min(self.sheet_thickness, self.bottom_thickness)
        throat, setback = welds.sizes(thinnest, t_rib)
        leg = throat * math.sqrt(2.0)
        if leg > thinnest + 1e-9:
            raise w.conflict(
                "welds.throat",
                "sheet_thickness",
                (
                    f"an equal-leg fillet of throat a has a leg a sqrt 2 on the sheet's edge, which "
                    f"is only {format_number(thinnest)} mm thick"
                ),
                f"use a throat of at most {math.floor(thinnest / math.sqrt(2.0) * 100) / 100:g} mm",
            )
        if setback > t_rib - MIN_SHEET_BEARING:
            # the default set-back follows the throat: blame the throat when it was not given
            key = "welds.setback" if welds.setback is not None else "welds.throat"
            raise w.conflict(
                key,
                "rib_thickness",
                (
                    f"a sheet set back {format_number(setback)} mm behind the rib's contact face "
                    f"keeps less than {MIN_SHEET_BEARING:g} mm of the rib under it"
                    + ("" if welds.setback is not None else " (the default set-back: leg + 1 mm)")
                ),
                (
                    f"use a set-back of at most {format_number(t_rib - MIN_SHEET_BEARING)} mm, a "
                    f"smaller weld throat or ribs of at least "
                    f"{format_number(setback + MIN_SHEET_BEARING)} mm"
                ),
            )
        if 0 < welds.snipe <= leg or welds.snipe > self.rib_height / 3:
            raise w.conflict(
                "welds.snipe",
                "rib_height",
                (
                    f"a snipe clears the welds it meets (legs of {format_number(leg)} mm) and "
                    "takes at most a third of the rib height"
                ),
                (
                    f"use a snipe between {format_number(leg)} and "
                    f"{format_number(self.rib_height / 3)} mm, or 0 mm for none"
                ),
            )
        if welds.erection_gap > MAX_ERECTION_GAP:
            raise _RuleError(
                "welds.erection_gap",
                f"{w('welds.erection_gap')} is more than {MAX_ERECTION_GAP:g} mm: a wider gap needs "
                "a splice, not packing plates; use a smaller gap",
            )


class MaterialSection(_Section):
    """[material]: steel grade (S235 by default)."""

    _table = "material"

    name: str = "S235"
    E: Stress = _default("210 GPa", "stress")
    nu: float = Field(default=0.3, gt=0, lt=0.5)
    density: Density = _default("7850 kg/m3", "density")
    fy: Stress = _default("235 MPa", "stress")
    #: ultimate tensile strength (EN 10025-2, t <= 40 mm: S235 360, S275 430, S355 490 MPa
    #: (510 in EN 1993-1-1 Table 3.1)): the bolts' bearing resistance and stiffness
    fu: Stress = _default("360 MPa", "stress")


class StockSection(_Section):
    """One ``[[cutting.stock]]`` entry: a stock plate size the shop can buy or has."""

    _table = "cutting.stock"

    length: PositiveLength
    width: PositiveLength
    #: plates of this size available (default: as many as needed)
    count: int | None = Field(default=None, ge=0)
    #: only for parts of this thickness (default: every thickness)
    thickness: PositiveLength | None = None
    #: cost of one plate, or per kg (any currency; default: the plate's weight is its cost, so
    #: the nest minimises the steel bought)
    price_per_plate: float | None = Field(default=None, gt=0)
    price_per_kg: float | None = Field(default=None, gt=0)

    def _check(self, w: _Written) -> None:
        if self.price_per_plate is not None and self.price_per_kg is not None:
            raise _RuleError(
                "price_per_plate",
                f"{w.label('price_per_plate')} and {w.label('price_per_kg')} are both given; "
                "give one price per stock plate",
            )

    @classmethod
    def of(cls, length: float, width: float) -> StockSection:
        """A stock size from lengths already in mm (not job text), unlimited and unpriced."""
        return cls.model_construct(length=float(length), width=float(width))

    def cost(self, kg: float) -> float:
        """What one plate weighing ``kg`` costs (its weight when no price is given)."""
        if self.price_per_plate is not None:
            return self.price_per_plate
        return kg * (self.price_per_kg or 1.0)

    @property
    def priced(self) -> bool:
        return self.price_per_plate is not None or self.price_per_kg is not None


class CuttingSection(_Section):
    """[cutting]: stock plates and the plasma table."""

    _table = "cutting"

    plate_length: PositiveLength = _default("3000 mm")
    plate_width: PositiveLength = _default("1500 mm")
    #: plasma kerf (the CAM compensates it; used here to check the spacing)
    kerf: NonNegativeLength = _default("2 mm")
    #: clear distance between parts on a plate (at least the kerf plus a margin)
    part_spacing: NonNegativeLength = _default("10 mm")
    #: clear border along the plate edges
    plate_margin: NonNegativeLength = _default("10 mm")
    #: time budget for improving the nest of each material/thickness group. "0 s" (default) keeps
    #: spyrrow's constructive solution, which is reproducible bit for bit; a budget gives denser
    #: nests, but spyrrow stops on the wall clock, so the result can vary with machine load
    nest_time: Duration = _default("0 s", "time")
    #: allowed part rotations on the plate, degrees
    rotations: list[Literal[0, 90, 180, 270]] = Field(default=[0, 90, 180, 270], min_length=1)
    #: round holes smaller than this many plate thicknesses are drilled, not cut: plasma cuts
    #: clean holes down to about 1-1.5 x the thickness. They go on the DRILL layer with an
    #: etched centre mark, and are not pierced
    min_plasma_hole: float = Field(default=1.0, ge=0.0, le=5.0)
    #: ISO 9013 perpendicularity range the plasma holds (1 best .. 5): a cut face leans by up to
    #: u = 0.05 + 0.003 t (range 1) .. 1.2 + 0.035 t mm (range 5) over the plate thickness t.
    #: Conventional plasma holds about range 4, fine-beam plasma range 2-3
    plasma_quality: int = Field(default=4, ge=1, le=5)
    #: how far a bolt hole's diameter may deviate from the nominal; a bolt hole is plasma-cut
    #: only when the plasma's u stays within it, else drilled (normal holes; fitted bolts are
    #: always drilled)
    hole_tolerance: PositiveLength = _default("0.5 mm")
    #: sheets are unrolled at this fibre of the plate
    neutral_fibre: Literal["mid", "outer", "inner"] = "mid"
    #: ``auto``: a single-curved sheet is sprung onto its ribs when the bending stress it
    #: keeps, E t / (2 R), is at most half of f_y, else rolled; ``roll``: every curved sheet is
    #: rolled (:mod:`fabpanel.forming`)
    forming: Literal["auto", "roll"] = "auto"
    #: bend lines etched as short ticks at the sheet's edges (the roller lines them up), or as
    #: full lines across the sheet
    bend_marks: Literal["ticks", "lines"] = "ticks"
    #: straight ribs of constant height at most 150 mm (EN 10058 flat bar) are sawn from flat
    #: bar, not burnt from plate and nested (:mod:`fabpanel.flat.flatbar`)
    flat_bar: bool = False
    #: length of the flat bars bought
    bar_length: PositiveLength = _default("6000 mm")
    #: saw kerf per cut on the flat bars
    saw_kerf: NonNegativeLength = _default("3 mm")
    seed: int = Field(default=0, ge=0)
    #: stock plate sizes to nest on (``[[cutting.stock]]``); a thickness no entry names (and every
    #: thickness without entries) is nested on plate_length x plate_width, as many as needed.
    #: plate_length and plate_width stay the plate the panels are sized to
    stock: list[StockSection] = Field(default_factory=list)
    #: report the standard stock size that buys the least steel per material and thickness
    suggest_stock: bool = True

    def stock_for(self, thickness: float) -> list[StockSection]:
        """The stock plates parts of ``thickness`` mm may be nested on."""
        listed = [
            s for s in self.stock if s.thickness is None or abs(s.thickness - thickness) < 1e-6
        ]
        return listed or [StockSection.of(self.plate_length, self.plate_width)]

    @property
    def usable(self) -> tuple[float, float]:
        """(long, short) sides of the plate inside its margins, mm."""
        sides = sorted((self.plate_length, self.plate_width), reverse=True)
        return sides[0] - 2 * self.plate_margin, sides[1] - 2 * self.plate_margin

    @property
    def side_keys(self) -> tuple[str, str]:
        """The keys of the plate's (long, short) sides."""
        if self.plate_width <= self.plate_length:
            return "plate_length", "plate_width"
        return "plate_width", "plate_length"

    def _check(self, w: _Written) -> None:
        if len({s.priced for s in self.stock}) > 1:
            raise _RuleError(
                "stock",
                "some [[cutting.stock]] entries have a price and some not; price all of them "
                "(price_per_plate or price_per_kg) or none (the nest then minimises weight)",
            )
        small = [s for s in self.stock if min(s.length, s.width) <= 2 * self.plate_margin]
        if small:
            raise _RuleError(
                "stock",
                f"a {small[0].length:g} x {small[0].width:g} mm stock plate is all margin "
                f"(plate_margin {w('plate_margin')} along both edges); remove it or lower the "
                "margin",
            )
        if self.part_spacing < self.kerf:
            raise w.conflict(
                "part_spacing",
                "kerf",
                "the part spacing must be at least the kerf",
                f"use a part_spacing of at least {w.like('part_spacing', self.kerf)}",
            )
        if self.usable[1] <= 0:
            raise w.conflict(
                "plate_margin",
                self.side_keys[1],
                ("the margins along both edges leave nothing of the plate"),
                (
                    "use a plate_margin of less than "
                    f"{w.like('plate_margin', min(self.plate_length, self.plate_width) / 2)}"
                ),
            )


class LoadsSection(_Section):
    """[loads]: actions, combinations and limits of the structural check.

    ``code = "en1991"`` (default): snow by EN 1991-1-3 (``snow_ground`` s_k, ``snow_exposure``
    C_e, ``snow_thermal`` C_t, mu_1 by the local pitch, half-span cases), wind by EN 1991-1-4
    (``wind_speed`` v_b,0, ``terrain``, the height of the shell above ground, c_pe by the
    local pitch, ``internal_pressure`` under the shell, ``wind_directions``), combined by
    EN 1990 (6.10) with ``gamma_g_sup``/``gamma_g_inf``, ``gamma_q`` and the psi_0 factors.
    ``code = "thesis"``: the thesis's §7.3 (``snow`` on the plan, ``wind`` projected along
    ``wind_direction``), combined as ``gamma_g G + gamma_q Q``. The national annex's values go
    in the same keys.
    """

    _table = "loads"

    code: Literal["en1991", "thesis"] = "en1991"
    # ---- EN 1991-1-3 (snow) -----------------------------------------------------------------
    #: characteristic ground snow load s_k (national map; 0.7 kN/m2: the Netherlands)
    snow_ground: Pressure = _default("0.7 kN/m2", "pressure")
    #: C_e (Table 5.1: windswept 0.8, normal 1.0, sheltered 1.2) and C_t
    snow_exposure: float = Field(default=1.0, gt=0)
    snow_thermal: float = Field(default=1.0, gt=0)
    #: snow guards or parapets keep the snow from sliding: mu_1 >= 0.8 at every pitch
    snow_fenced: bool = False
    # ---- EN 1991-1-4 (wind) -----------------------------------------------------------------
    #: fundamental value of the basic wind velocity v_b,0 (national map)
    wind_speed: Velocity = _default("25 m/s", "velocity")
    #: terrain category (Table 4.1): 0, I, II, III or IV
    terrain: Literal["0", "I", "II", "III", "IV"] = "II"
    #: height of the shell's lowest point above the ground; the reference height is the top
    base_height: NonNegativeLength = _default("0 m")
    #: directional and season factors c_dir, c_season (4.1)
    wind_factor: float = Field(default=1.0, gt=0)
    #: wind directions, degrees from +x towards +y; default: along and across the plan's
    #: principal axes, both ways
    wind_directions: tuple[float, ...] | None = None
    #: internal pressure coefficients under the shell (the more onerous of +0.2 and -0.3,
    #: §7.2.9(6) Note 2)
    internal_pressure: tuple[float, float] = (0.2, -0.3)
    # ---- EN 1990 ----------------------------------------------------------------------------
    gamma_g_sup: float = Field(default=1.35, gt=0)
    gamma_g_inf: float = Field(default=1.0, ge=0)
    psi0_snow: float = Field(default=0.5, ge=0, le=1)
    psi0_wind: float = Field(default=0.6, ge=0, le=1)
    # ---- thesis §7.3 --------------------------------------------------------------------------
    snow: Pressure = _default("0.56 kN/m2", "pressure")
    wind: Pressure = _default("0.8 kN/m2", "pressure")
    #: horizontal wind direction (x, y), any length but not (0, 0); both signs are checked
    #: (pressure and suction on the faces the wind meets first, as the thesis)
    wind_direction: tuple[float, float] = (1.0, 0.0)
    #: also the wind blowing against ``wind_direction`` (other faces; one more static case,
    #: about a quarter more CalculiX time)
    wind_opposite: bool = False
    gamma_g: float = Field(default=1.2, gt=0)
    # ---- both ---------------------------------------------------------------------------------
    gamma_q: float = Field(default=1.5, gt=0)
    #: knock-down on the linear buckling factor (1/6: a factor of 6 is required)
    buckling_knockdown: float = Field(default=1 / 6, gt=0, le=1)
    #: deflection limit as span / N
    deflection_limit: float = Field(default=300.0, gt=0)

    def _check(self, w: _Written) -> None:
        if math.hypot(*self.wind_direction) < MIN_WIND_DIRECTION:
            raise _RuleError(
                "wind_direction",
                (
                    f"{w('wind_direction')} has no horizontal direction; give the wind's direction "
                    "in plan as [x, y], e.g. [1.0, 0.0] for wind along +x"
                ),
            )


class StructureSection(_Section):
    """[structure]: the shell model and the CalculiX run of the structural check."""

    _table = "structure"

    #: element length along the panel sides (every side gets ceil(median side / size)
    #: elements); default: as fine as ``max_elements`` allows, at most 4 per side
    element_size: PositiveLength | None = None
    #: element budget of the default size. CalculiX's time and memory grow fast: about 6000
    #: S8R with their rib/sheet knots take ~1 min and < 2 GB on 2 cores for the static cases and
    #: 10 buckling modes
    max_elements: int = Field(default=6000, ge=50, le=200000)
    #: which boundary ribs stand on foundations: ``lowest``, the anchor nodes within
    #: ``support_band`` of the lowest one (the thesis's lowest points, now at the anchorages),
    #: the band raised until they surround the shell's centre in plan
    #: (:func:`fabpanel.structure.supports.surrounding_band`);
    #: ``boundary``: every boundary rib; ``openings``: the ribs round the openings (rims);
    #: ``points``: the boundary ribs' anchor nodes within ``support_radius`` of each of
    #: ``support_points`` (columns, base plates), one support each; ``ranges``: the boundary
    #: ribs from one point to the other of each pair in ``support_ranges``, along the
    #: boundary loop nearest both, the shorter way round
    supports: Literal["lowest", "boundary", "openings", "points", "ranges"] = "lowest"
    support_band: NonNegativeLength = _default("10 mm")
    #: ``supports = "points"``: x, y, z in the input's units, each near the boundary
    support_points: list[tuple[float, float, float]] = Field(default_factory=list)
    #: ``supports = "points"``: how far from its point a support reaches along the boundary
    support_radius: PositiveLength = _default("300 mm")
    #: ``supports = "ranges"``: pairs of points (x, y, z in the input's units) on the boundary
    support_ranges: list[tuple[tuple[float, float, float], tuple[float, float, float]]] = Field(
        default_factory=list
    )
    #: ``pinned``: the boundary ribs held at their anchor-bolt line (mid-depth nodes),
    #: translations only; ``fixed``: every node of those ribs (a base plate clamped by two
    #: rows of anchor bolts)
    support_fixity: Literal["pinned", "fixed"] = "pinned"
    #: ``bolted``: each panel's ribs are their own shells, the back-to-back ribs of a joint
    #: joined at the bolts by springs with EN 1993-1-8 Table 6.11 stiffness, and every bolt
    #: checked for shear, bearing and tension (:mod:`fabpanel.structure.connectors`);
    #: ``rigid``: the two ribs of a joint are one shell of twice the thickness (the joint a
    #: weld), for comparison
    joints: Literal["bolted", "rigid"] = "bolted"
    #: ``plates``: each corner stiffener an S8 plate tied to its ribs and sheets
    #: (:mod:`fabpanel.structure.stiffeners`); ``mass``: its mass lumped on the panel's corner
    #: line, its stiffness left out (the model before the plates), for comparison
    stiffeners: Literal["plates", "mass"] = "plates"
    #: span for the deflection limit (default: twice the largest plan distance to a support)
    span: PositiveLength | None = None
    #: buckling factors requested from CalculiX (the positive ones are kept; >= 5 are reported)
    buckling_modes: int = Field(default=10, ge=5, le=100)
    #: check the first buckling factor at one element per side fewer and, while it changes by
    #: 5 % or more, at finer sizes within ``max_elements`` (:mod:`fabpanel.structure.convergence`)
    buckling_convergence: bool = True
    #: also a geometrically nonlinear analysis of the imperfect shell (GNIA, EN 1993-1-6
    #: §8.7): the first buckling mode as the imperfection, both signs, the governing
    #: combination ramped with NLGEOM to its limit point (:mod:`fabpanel.structure.gnia`);
    #: each sign costs some ten static solves
    gnia: bool = False
    #: fabrication tolerance quality class (EN 1993-1-6 Table 8.8): the imperfection's size
    tolerance_class: Literal["A", "B", "C"] = "B"
    #: the imperfection's amplitude; default: EN 1993-1-6's dimple amplitude for the class
    imperfection_amplitude: PositiveLength | None = None
    #: partial factor for shell buckling resistance (EN 1993-1-6, NDP); the GNIA factor must
    #: reach it
    gamma_m1: float = Field(default=1.1, ge=1.0)
    #: CalculiX threads (default: the --jobs count, else all cores)
    threads: int | None = Field(default=None, ge=1, le=256)
    #: stop a CalculiX run after this long
    timeout: Duration = _default("30 min", "time")
    #: without CalculiX the export still completes and the summary says "not analysed";
    #: true (or ``--require-fem``) makes that an error
    required: bool = False
    #: keep CalculiX's result files (.frd for CalculiX GraphiX, .12d, .sta, .cvg) beside the
    #: decks, and the printed results (.dat) uncompressed; by default only the decks (.inp),
    #: the printed results gzipped (.dat.gz) and the logs stay, since the .frd of the demo's
    #: four runs alone is 200 MB and every figure and check of the report is read from it
    #: already (run ``ccx`` on a kept deck to get it again)
    keep_results: bool = False

    def _check(self, w: _Written) -> None:
        for mode, key in (("points", "support_points"), ("ranges", "support_ranges")):
            if self.supports == mode and not getattr(self, key):
                raise _RuleError(
                    key,
                    f'supports = "{mode}" needs {key}: '
                    + (
                        "support_points = [[x, y, z], ...] in the input's units"
                        if mode == "points"
                        else "support_ranges = [[[x, y, z], [x, y, z]], ...] in the input's units"
                    ),
                )


class OutputSection(_Section):
    """[output]: where and what to write."""

    _table = "output"

    #: output folder, relative to the job file (default: ``<input name>-fabpanel`` beside it)
    dir: str | None = None
    step: bool = True
    #: one STEP per panel in model/panels/ besides model/assembly.step (which holds every
    #: panel already, each a named assembly node)
    step_per_panel: bool = False
    glb: bool = True
    #: model/design.3dm for Rhino and Grasshopper (panel surfaces, outlines, labels on layers)
    rhino: bool = True
    dxf: bool = True
    report: bool = True


class DocsSection(_Section):
    """[docs]: the shop documents (schedules, key plan, IFC model) in docs/ and model/."""

    _table = "docs"

    #: write docs/*.csv, docs/keyplan.pdf and model/assembly.ifc after the cut stage
    write: bool = True
    #: project name in the title blocks and the IFC project (default: the input file's name)
    project: str | None = None
    #: revision letter or number in the title blocks
    revision: str = "A"
    #: spare fasteners ordered on top of the count, as a share (0.05: 5 %)
    spares: float = Field(default=0.05, ge=0, le=1)


class RunSection(_Section):
    """[run]: where the per-panel work runs."""

    _table = "run"

    #: "local": worker processes on this machine (``--jobs``); "ray": tasks on a Ray cluster
    #: (``pip install fabpanel[ray]``; every node needs fabpanel installed)
    executor: Literal["local", "ray"] = "local"
    #: the Ray cluster to join ("auto", "ray://head:10001" or "head:6379"); none starts a
    #: local Ray instance with ``--jobs`` CPUs
    address: str | None = None
    #: a Ray worker process is replaced after this many tasks, so OCCT's memory stays bounded
    worker_tasks: int = Field(default=50, ge=1, le=100000)
    #: a task whose worker died (lost node, out of memory) is run again up to this many times
    retries: int = Field(default=3, ge=0, le=100)


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
    docs: DocsSection = DocsSection()
    run: RunSection = RunSection()

    def _check(self, w: _Written) -> None:
        sandwich, cutting = self.sandwich, self.cutting
        if sandwich.buildup != "sandwich":
            return
        long_side, short_side = cutting.usable
        long_key, short_key = (f"cutting.{key}" for key in cutting.side_keys)
        # ribs and stiffeners stand between the sheets: a plate part rib_height high (more
        # where the rib plane leans against the panel normal; the nest finds that), its length
        # along the panel side
        if sandwich.rib_height > short_side:
            raise w.conflict(
                "sandwich.rib_height",
                short_key,
                (
                    f"ribs and stiffeners are cut rib_height high, the plate holds "
                    f"{format_number(short_side)} mm across inside its margins "
                    f"({w.label('cutting.plate_margin')} {w('cutting.plate_margin')} each side)"
                ),
                (
                    f"use a rib_height of at most {w.like('sandwich.rib_height', short_side)} or "
                    "wider plates"
                ),
            )
        chord = 2 * math.sin(math.radians(STIFFENED_ANGLE / 2)) * sandwich.stiffener_offset
        if chord > long_side:
            raise w.conflict(
                "sandwich.stiffener_offset",
                long_key,
                (
                    f"a corner stiffener is up to {format_number(chord)} mm long (2 sin 75 deg x "
                    f"the offset, corners up to {STIFFENED_ANGLE:g} deg), the plate holds "
                    f"{format_number(long_side)} mm inside its margins"
                ),
                (
                    "use a smaller stiffener_offset (typically about the rib height) or longer "
                    "plates"
                ),
            )
        if self.panelize.sizes_panels and sandwich.stiffener_offset >= self.panelize.panel_size:
            raise w.conflict(
                "sandwich.stiffener_offset",
                "panelize.panel_size",
                (
                    "a side needs more than twice the stiffener offset for its corner stiffeners: "
                    "panels of the target size would get none"
                ),
                (
                    "use a stiffener_offset well under half the panel size (typically about the "
                    "rib height)"
                ),
            )


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

    def __init__(
        self,
        settings: _JobModel | None = None,
        base_dir: str | Path = ".",
        source: str | Path | None = None,
        **sections: dict[str, Any],
    ):
        if settings is None:
            where = str(source) if source else "job"
            try:
                settings = _JobModel.model_validate(sections)
            except ValidationError as err:
                raise InputError(f"{where}: {_describe(err, sections)}") from None
        elif sections:
            raise TypeError("give either settings or sections, not both")
        object.__setattr__(self, "settings", settings)
        object.__setattr__(self, "base_dir", Path(base_dir).resolve())
        object.__setattr__(self, "source", Path(source) if source else None)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Job is immutable; use job.replace(section={...})")

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Job)
            and self.settings == other.settings
            and self.base_dir == other.base_dir
        )

    def __hash__(self) -> int:
        return hash((self.base_dir, repr(self.settings)))

    def __reduce__(self):
        # immutable with __slots__: pickle through the constructor (worker processes, caches)
        return (Job, (self.settings, self.base_dir, self.source))

    def __repr__(self) -> str:
        return f"Job(source={self.source}, base_dir={self.base_dir}, {self.to_dict()})"

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_dict(
        cls, data: dict[str, Any], base_dir: str | Path = ".", source: str | Path | None = None
    ) -> Job:
        if not isinstance(data, dict):
            raise InputError(
                f"{source or 'job'}: expected sections such as [input], got {type(data).__name__}"
            )
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
            raise InputError(
                f"{path}: not valid TOML ({err}); check the syntax at that line"
            ) from None
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
                raise InputError(
                    f"unknown job section [{section}]; sections are {', '.join(_SECTION_NAMES)}"
                )
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


_SIGNS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def _describe(err: ValidationError, data: Any = None) -> str:
    """One line for the first validation error: key, the value as written (looked up in the
    raw ``data`` where pydantic holds only a part of it), problem, what is allowed."""
    first = err.errors()[0]
    loc = list(first["loc"])
    # list and tuple items (int parts) belong to their key: [loads] wind_direction
    names = [str(part) for part in loc if not isinstance(part, int)]
    items = [part for part in loc if isinstance(part, int)]
    key = _key_name(names)
    kind = first["type"]
    value = first.get("input")
    if kind == "extra_forbidden":
        model: Any = _JobModel
        for part in names[:-1]:
            field = getattr(model, "model_fields", {}).get(part)
            model = field.annotation if field is not None else model
        fields = list(getattr(model, "model_fields", {}))
        allowed = ", ".join(fields) or "none"
        what = "section" if len(names) == 1 else "key"
        close = difflib.get_close_matches(names[-1], fields, n=1, cutoff=0.75)
        meant = f" (did you mean {close[0]}?)" if close else ""
        return f"unknown {what} {key}{meant}; allowed here: {allowed}"
    if kind == "value_error":
        error = first.get("ctx", {}).get("error")
        if isinstance(error, _RuleError):
            return f"{_key_name(names + error.key.split('.'))}: {error}"
        return f"{key}: {error if error is not None else first['msg']}"
    if kind == "literal_error":
        msg = first["msg"]
        return f"{key}: {as_written(value)} is not allowed; {msg[:1].lower()}{msg[1:]}"
    if kind in _SIGNS:
        limit = next(iter(first.get("ctx", {}).values()), "")
        # quantities: the limit in the unit the user wrote ("-1.5 m": > 0 m)
        if isinstance(limit, (int, float)):
            shown = format_like(float(limit), value) or format_number(limit)
        else:
            shown = str(limit)
        return f"{key}: {as_written(value)} is out of range; it must be {_SIGNS[kind]} {shown}"
    if kind == "finite_number":
        whole = _raw(data, loc[: len(loc) - len(items)])
        if items and whole is not _MISSING:
            # the whole list as written, or the item of a list of lists (a point)
            item = whole[items[0]] if len(items) > 1 and isinstance(whole, (list, tuple)) else whole
            where = f"item {items[0] + 1}, " if len(items) > 1 else ""
            return f"{key}: {where}{as_written(item)} holds nan or inf; write finite numbers"
        return f"{key}: {as_written(value)} is not a finite number; write a finite number"
    return f"{key}: {first['msg']} (got {as_written(value)})"


def _raw(data: Any, loc: list[Any]) -> Any:
    """The raw input at ``loc`` (section, key), or ``_MISSING``."""
    for part in loc:
        if not isinstance(data, dict) or part not in data:
            return _MISSING
        data = data[part]
    return data


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
