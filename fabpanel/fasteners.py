"""Reaching the bolts: bolt and tool sizes, the access slot a tool needs, its swept envelope.

A joint is two back-to-back ribs bolted through; each rib closes its own panel, so the fitter
reaches the nut in one panel and the bolt head in the other through the access sheet. Either
may go on either side, so both sides are designed and checked for the larger of the two.

**Joint frame** (mm), one per bolt: origin at the bolt centre on the joint plane; ``x`` along
the rib; ``y`` along the bolt axis into the panel (the rib plane's normal), the rib's inner
face at ``y = t_rib``; ``z`` in the rib plane, square to the rib line, towards the access sheet.

**The tool's path**: (1) in along ``z`` through the slot, held clear of the bolt end (the
*slid-out* position: the tool's inner end ``protrusion + 1 mm`` beyond the nut); (2) along ``y``
onto the hex; (3) turned through ``swing`` about the bolt axis (a 12-point ring needs 30 degrees
between two grips). The **envelope** is the union of the three sweeps; the **slot** is the
rounded rectangle that lets steps (1) and (3) through the sheet, ``SLOT_CLEARANCE`` round the
tool. The tool sits ``TOOL_RIB_GAP`` off the rib's inner face so the slot keeps 1 mm of sheet
before the rib; the access sheet closes the box and is welded to the ribs from outside, so there
is no inner fillet weld for the slot to clear.

Sizes: ISO 4014 (head height k), ISO 4032 (nut height m, across flats s), ISO 7089 (washer
thickness), ISO 261 (coarse pitch); normal round holes per EN 1090-2 Table 11 (d0 = d + 1 mm
for M12/M14 and smaller, + 2 mm for M16-M24, + 3 mm from M27). The bolt end stands two pitches
beyond the nut (EN 1090-2 8.2.2 asks for at least one full thread). Tool defaults are derived from
the across-flats size (a DIN 838 ring spanner: head about 1.7 s, 0.55 s thick; a socket about
1.45 s + 1 mm across) and can be set in ``[sandwich.bolts]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .geom.polygon import graded_ring

#: the tool keeps this clear of the rib's inner face, mm
TOOL_RIB_GAP = 3.0
#: the slot keeps this clear round the tool's path, mm
SLOT_CLEARANCE = 2.0
#: the slot leaves at least this much sheet before the rib's inner face, mm (a socket on the
#: washer comes closer to the rib than the slot's clearance)
SHEET_BEFORE_RIB = 1.0
#: corner radius of the slot, mm (no sharp inner corner in a plasma-cut sheet)
SLOT_CORNER = 5.0
#: a tool must cover at least this share of the hex height (two thirds, the usual rule)
MIN_ENGAGEMENT = 2.0 / 3.0


@dataclass(frozen=True)
class BoltSize:
    """A metric bolt set (bolt, nut, washer under both), mm."""

    name: str
    d: float
    pitch: float
    across_flats: float
    head_height: float
    nut_height: float
    washer: float
    hole: float

    @property
    def protrusion(self) -> float:
        """The bolt end beyond the nut: two pitches."""
        return 2 * self.pitch


def _bolt(d: float, pitch: float, s: float, k: float, m: float, washer: float) -> BoltSize:
    clearance = 1.0 if d <= 14 else 2.0 if d <= 24 else 3.0
    return BoltSize(f"M{d:g}", d, pitch, s, k, m, washer, d + clearance)


#: ISO 4014 / 4032 / 7089 / 261 values
BOLT_SIZES = (
    _bolt(8, 1.25, 13, 5.3, 6.8, 1.6),
    _bolt(10, 1.5, 16, 6.4, 8.4, 2.0),
    _bolt(12, 1.75, 18, 7.5, 10.8, 2.5),
    _bolt(14, 2.0, 21, 8.8, 12.8, 2.5),
    _bolt(16, 2.0, 24, 10.0, 14.8, 3.0),
    _bolt(20, 2.5, 30, 12.5, 18.0, 3.0),
    _bolt(22, 2.5, 34, 14.0, 19.4, 3.0),
    _bolt(24, 3.0, 36, 15.0, 21.5, 4.0),
    _bolt(27, 3.0, 41, 17.0, 23.8, 4.0),
    _bolt(30, 3.5, 46, 18.7, 25.6, 4.0),
)


def bolt_for_hole(hole: float) -> BoltSize | None:
    """The largest standard bolt a hole of ``hole`` mm takes (normal clearance), or None."""
    fitting = [b for b in BOLT_SIZES if b.hole <= hole + 1e-9]
    return fitting[-1] if fitting else None


@dataclass(frozen=True)
class Tool:
    """The fitter's tool, mm and degrees. A ring spanner is a head on a handle; a socket is a
    socket of ``socket_length`` on the hex, a ratchet head after it, the handle on the head."""

    kind: Literal["ring-spanner", "socket"]
    head_diameter: float
    head_thickness: float
    handle_width: float
    swing: float
    socket_diameter: float = 0.0
    socket_length: float = 0.0

    def describe(self) -> str:
        if self.kind == "socket":
            return (
                f"socket Ø{self.socket_diameter:g} x {self.socket_length:g} mm on a ratchet "
                f"Ø{self.head_diameter:g} mm, {self.swing:g}° swing"
            )
        return (
            f"ring spanner Ø{self.head_diameter:g} x {self.head_thickness:g} mm, "
            f"{self.swing:g}° swing"
        )


def default_tool(
    kind: Literal["ring-spanner", "socket"],
    bolt: BoltSize,
    head_diameter: float | None = None,
    head_thickness: float | None = None,
    handle_width: float | None = None,
    swing: float = 30.0,
    socket_length: float | None = None,
) -> Tool:
    """A tool for ``bolt``'s hex, the sizes not given derived from its across-flats size."""
    s = bolt.across_flats
    if kind == "socket":
        return Tool(
            kind,
            head_diameter or round(max(40.0, s + 22.0)),
            head_thickness or round(max(14.0, 0.8 * s)),
            handle_width or round(1.1 * s),
            swing,
            socket_diameter=round(1.45 * s + 1.0, 1),
            socket_length=socket_length or round(max(30.0, 2.0 * s)),
        )
    return Tool(
        kind,
        head_diameter or round(1.7 * s + 1.0),
        head_thickness or round(max(6.0, 0.55 * s), 1),
        handle_width or round(1.1 * s),
        swing,
    )


@dataclass(frozen=True)
class AccessDesign:
    """Where the tool sits and the slot it needs, in the joint frame (see the module docstring);
    one for the whole job (:func:`access_design`)."""

    bolt: BoltSize
    tool: Tool
    t_rib: float
    #: bolt axis to the access sheet's outer face along z, mm
    reach: float
    #: the tool's inner end (on the hex) along y, mm
    inner_end: float
    #: where the handle's swing plane starts along y, mm
    handle_start: float
    #: how far the tool moves along y from the slid-out position onto the hex, mm
    slide: float
    #: the share of the shorter hex (head or nut) the tool covers
    engagement: float
    #: (n, 2) float, the slot outline in (x, y), counter-clockwise
    slot: np.ndarray

    @property
    def body_length(self) -> float:
        """The tool's length along the bolt axis (socket and head), mm."""
        return self.tool.socket_length + self.tool.head_thickness

    @property
    def swing_half_width(self) -> float:
        """Half the span the handle sweeps along x where it leaves the access sheet, mm."""
        half = math.radians(self.tool.swing) / 2
        return self.reach * math.tan(half) + self.tool.handle_width / (2 * math.cos(half))

    def at_reach(self, reach: float) -> AccessDesign:
        """The same tool on a bolt ``reach`` mm from the access sheet's outer face (a rib
        tilted against the sheet puts it farther than the job's straight-down reach)."""
        return access_design(self.bolt, self.tool, self.t_rib, reach)

    def slot_size(self) -> tuple[float, float]:
        """(length along the rib, width across it), mm."""
        span = np.ptp(self.slot, axis=0)
        return float(span[0]), float(span[1])


def access_design(bolt: BoltSize, tool: Tool, t_rib: float, reach: float) -> AccessDesign:
    """The tool's position on the hex and the slot for it (see the module docstring)."""
    hex_start = t_rib + bolt.washer
    hex_end = hex_start + max(bolt.head_height, bolt.nut_height)
    if tool.kind == "socket":
        # the socket's end on the washer, the hex inside it
        inner = hex_start
        covered = min(tool.socket_length, bolt.head_height) / bolt.head_height
        handle = inner + tool.socket_length
    else:
        # the ring's outer face level with the nut's end, unless that brings it to the rib
        inner = max(t_rib + TOOL_RIB_GAP, hex_end - tool.head_thickness)
        head_cover = _overlap(
            inner, inner + tool.head_thickness, hex_start, hex_start + bolt.head_height
        )
        nut_cover = _overlap(inner, inner + tool.head_thickness, hex_start, hex_end)
        covered = min(head_cover / bolt.head_height, nut_cover / bolt.nut_height)
        handle = inner
    slide = hex_start + bolt.nut_height + bolt.protrusion + 1.0 - inner
    design = AccessDesign(bolt, tool, t_rib, reach, inner, handle, slide, covered, np.zeros((0, 2)))
    x_half = max(_largest_radius(tool), design.swing_half_width) + SLOT_CLEARANCE
    # what crosses the sheet: the tool going in (slid out) and the handle, turning or sliding
    y_low = max(min(inner + slide, handle) - SLOT_CLEARANCE, t_rib + SHEET_BEFORE_RIB)
    y_high = inner + slide + design.body_length + SLOT_CLEARANCE
    return AccessDesign(
        **{**design.__dict__, "slot": rounded_rectangle(x_half, y_low, y_high, SLOT_CORNER)}
    )


def _overlap(a0: float, a1: float, b0: float, b1: float) -> float:
    return max(0.0, min(a1, b1) - max(a0, b0))


def _largest_radius(tool: Tool) -> float:
    return max(tool.head_diameter, tool.socket_diameter) / 2


def rounded_rectangle(
    x_half: float, y_low: float, y_high: float, radius: float, step: float = 8.0
) -> np.ndarray:
    """(n, 2) float: the rectangle ``|x| <= x_half``, ``y_low <= y <= y_high`` with corners
    rounded to ``radius`` (at most half its width), counter-clockwise: the arcs a point every
    2 mm or less, the straight sides graded from 1.5 mm at the arcs to at most ``step`` mm
    (:func:`.geom.polygon.graded_ring`: a periodic cubic through them keeps within 0.02 mm of
    the outline, tests/test_openings.py)."""
    r = min(radius, x_half, (y_high - y_low) / 2)
    corners = [
        (x_half - r, y_low + r, -90.0),
        (x_half - r, y_high - r, 0.0),
        (-x_half + r, y_high - r, 90.0),
        (-x_half + r, y_low + r, 180.0),
    ]
    points = []
    for cx, cy, start in corners:
        angles = np.radians(start + np.linspace(0.0, 90.0, max(3, int(np.pi * r / 2 / 2.0) + 2)))
        arc = np.c_[cx + r * np.cos(angles), cy + r * np.sin(angles)]
        points.append(arc)
    ring = np.concatenate(points)
    return graded_ring(ring, longest=step)
