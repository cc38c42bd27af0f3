"""The sandwich build-up as one frozen value, computed once from the job.

It owns the build-up's conventions: which face lies on the design surface, where each face sits
along the outward normal, the plate thicknesses, the bolts and the tool that reaches them, the
weld and fit-up details, and the usable stock plate. The build stage, the structural model, the
global optimiser and the nest read it; none of them re-derives a thickness from the job.

Offsets along the outward normal from the design face (mm; ``t`` top sheet, ``h`` rib height,
``b`` bottom sheet; ``design_face = "top-outer"``)::

      0        top sheet outer face (design surface)
     -t        top sheet inner face = rib top
     -t-h      bottom sheet upper face = rib bottom
     -t-h-b    bottom sheet lower face

``"bottom-outer"`` adds ``t + h + b`` (the bottom sheet's lower face on the design surface),
``"middle"`` half of it. ``"cladding"`` is the top sheet alone.

Weld and fit-up details at a joint between two panels (section across the joint, top sheet)::

        sheet   |<- setback ->|   contact face    |<- setback ->|   sheet
      ==========\\             |        |          |            /==========
                 \\ fillet     |  gap   |          |   fillet  /
      rib A      |            |<------>|          |           |     rib B
                              (packing plate at each bolt when gap > 0)

The sheets stand back from the rib's contact face on interior sides, so the fillet weld joining
sheet and rib stays inside it and the neighbour's rib seats on a clean face; boundary sides stay
flush (no neighbour, and the shell's edge follows the design boundary). The plates where three
welds would meet (stiffener corners, the ends of the ribs that butt against their neighbours)
get 45-degree snipes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from .fasteners import AccessDesign
from .welds import packing_side

if TYPE_CHECKING:
    from .job import Job


@dataclass(frozen=True)
class Welds:
    """Sheet-to-rib welds and the fit-up details they need, mm.

    throat : a of the fillet welds joining the sheets to the ribs.
    setback : how far sheet edges stand back from the rib contact face on interior sides.
    snipe : leg of the 45-degree snipes on stiffener corners and butting rib ends (0: none).
    erection_gap : clear gap between the ribs of two neighbours (0: they touch).
    packing : side of the square packing plate closing the gap at each bolt (0 without a gap).
    """

    throat: float
    setback: float
    snipe: float
    erection_gap: float
    packing: float

    @property
    def leg(self) -> float:
        """Leg length of the equal-leg fillet, mm."""
        return self.throat * math.sqrt(2.0)


@dataclass(frozen=True)
class Bolts:
    """The bolts of the rib joints: hole diameter d0, largest spacing, distance from the corner
    to the first bolt (mm), the sheet the tool reaches them through, and the fit (``fitted``
    bolts stand in drilled or reamed holes)."""

    diameter: float
    spacing: float
    edge_distance: float
    access_sheet: Literal["bottom", "top", "none"]
    fit: Literal["normal", "fitted"]


@dataclass(frozen=True)
class Buildup:
    """The panels' build-up (see the module docstring); lengths in mm.

    kind : ``sandwich`` (two sheets, ribs, stiffeners) or ``cladding`` (the top sheet alone).
    offsets : the faces' offsets along the outward normal from the design face, as
        ``((name, mm), ...)``: ``top_outer``, ``top_inner`` and for a sandwich
        ``bottom_upper``, ``bottom_lower``; :meth:`offset` reads one.
    access : the tool, its position and the access slot per bolt, or None (no bolts to reach).
    usable_plate : (long, short) sides of the stock plate inside its margins.
    """

    kind: Literal["sandwich", "cladding"]
    design_face: Literal["top-outer", "bottom-outer", "middle"]
    t_top: float
    t_bot: float
    t_rib: float
    t_stf: float
    rib_height: float
    stiffener_offset: float
    offsets: tuple[tuple[str, float], ...]
    bolts: Bolts
    welds: Welds
    access: AccessDesign | None
    usable_plate: tuple[float, float]

    @property
    def sandwich(self) -> bool:
        return self.kind == "sandwich"

    @property
    def total_depth(self) -> float:
        """Outer face of the top sheet to outer face of the bottom sheet."""
        if not self.sandwich:
            return self.t_top
        return self.t_top + self.rib_height + self.t_bot

    def offset(self, face: str) -> float:
        """The offset of one face (``top_outer`` ...) along the outward normal."""
        return dict(self.offsets)[face]

    @property
    def offset_map(self) -> dict[str, float]:
        return dict(self.offsets)

    @classmethod
    def of(cls, job: Job) -> Buildup:
        """The build-up a job asks for."""
        sw, bolts, welds = job.sandwich, job.sandwich.bolts, job.sandwich.welds
        t_top, t_bot = float(sw.sheet_thickness), float(sw.bottom_thickness)
        depth = sw.total_depth
        shift = {"top-outer": 0.0, "bottom-outer": depth, "middle": depth / 2}[sw.design_face]
        faces = [("top_outer", shift), ("top_inner", shift - t_top)]
        if sw.buildup == "sandwich":
            upper = shift - t_top - float(sw.rib_height)
            faces += [("bottom_upper", upper), ("bottom_lower", upper - t_bot)]
        sandwich = sw.buildup == "sandwich"
        throat, setback = welds.sizes(min(t_top, t_bot), float(sw.rib_thickness))
        gap = float(welds.erection_gap) if sandwich else 0.0
        return cls(
            kind=sw.buildup,
            design_face=sw.design_face,
            t_top=t_top,
            t_bot=t_bot,
            t_rib=float(sw.rib_thickness),
            t_stf=float(sw.stiffener_thickness or sw.rib_thickness),
            rib_height=float(sw.rib_height),
            stiffener_offset=float(sw.stiffener_offset),
            offsets=tuple(faces),
            bolts=Bolts(
                float(bolts.diameter),
                float(bolts.spacing),
                float(bolts.edge_distance),
                bolts.access_sheet,
                bolts.fit,
            ),
            welds=Welds(
                throat=throat,
                setback=setback if sandwich else 0.0,
                snipe=float(welds.snipe) if sandwich else 0.0,
                erection_gap=gap,
                packing=packing_side(float(bolts.diameter), float(sw.rib_height)) if gap else 0.0,
            ),
            access=sw.access_design(),
            usable_plate=job.cutting.usable,
        )
