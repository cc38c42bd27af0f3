"""Tolerances in one place, each with the reason for its default (mm unless stated).

Tests switch on ``STRICT`` to run the expensive invariant checks inside the stages too.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    #: a panel whose samples lie this close to one plane is cut flat: 0.5 mm over a 1-2 m panel is
    #: pulled out when the sheet is bolted to its ribs
    planar_panel: float = 0.5
    #: ribs and stiffeners are cut from flat plate; 0.05 mm is far below the plasma tolerance of
    #: +-0.5 mm, so the kernel's own flatness (not the cut) limits the fit between parts
    rib_planarity: float = 0.05
    #: a sheet edge (the developed panel side) against its rib plane: the rib is planar by
    #: construction, so this is the gap between sheet and rib, which 0.5 mm (the plasma
    #: tolerance) lets a bolted joint pull shut
    rib_edge: float = 0.5
    #: B-spline sheet surfaces through the sample grid; 0.05 mm keeps the fit invisible at the
    #: plasma tolerance
    sheet_fit: float = 0.05
    #: unrolled edge length against the 3D edge length of a sheet: 0.1 mm, a fifth of the plasma
    #: tolerance, so edges of neighbouring sheets meet after forming
    unrolled_edge: float = 0.1
    #: back-to-back ribs of neighbouring panels must touch to be bolted tight
    rib_contact_gap: float = 0.1
    #: clash check on tessellations: every part is shrunk by this depth first, so parts that
    #: touch (a rib on a curved sheet, whose tessellation chords cut up to ~0.05 mm into it)
    #: leave a gap; an overlap shallower than this is not a clash (it is welded shut anyway)
    clash_depth: float = 0.2
    #: ... and what still overlaps must stay under this share of the smaller part's volume:
    #: a rib misplaced by 1 mm into its neighbour shares 1/8 of its volume
    clash_volume: float = 1e-3
    #: a sheet edge may slide this far (relative to the build-up depth) along the sheet to
    #: reach its rib plane; farther, the plane is nearly tangent to the sheet and the edge stays
    trim_slide: float = 1.0
    #: ... and an edge left untrimmed may stand this far off its rib plane, mm: a gap a fillet
    #: weld still bridges (EN ISO 5817's root-gap allowance); farther, the sheet does not meet
    #: its rib and the panel cannot be closed as built (an error)
    untrimmed_gap: float = 2.0
    #: bolt holes of back-to-back ribs: 0.1 mm, far inside the 1 mm clearance of a 13 mm
    #: hole for an M12 bolt
    bolt_coaxial: float = 0.1
    #: re-imported STEP volumes against the built solids (relative)
    step_volume: float = 1e-3
    #: below this bending radius a sheet is press-formed instead of rolled (3-10 mm mild steel
    #: on a plate roll with about 150 mm rolls)
    press_forming_radius: float = 300.0
    #: degrees: a rib plane within this angle of its sheet lies nearly flat instead of standing
    #: between the sheets (the build reports it); a boundary side whose design edge would need
    #: a rib leaning that far, or further than ``trim_slide`` lets the sheets reach, cuts the
    #: chord instead (develop, ``largest_rib_lean``)
    rib_tangent_deg: float = 30.0
    #: degrees: a side whose best-fitting plane leans more than this from square to its sheet,
    #: and that lies within ``rib_edge`` of the square plane, gets the square plane: within the
    #: edge tolerance a rib stands square. A vault's springing lines on the ground, straight to
    #: 0.3 mm but exactly level, gave level base ribs under sheets rising at 38-46 degrees: at
    #: two corners the bottom sheet never met its rib (121 mm off) and the rib would not
    #: extrude, at the other two the ribs took their corner stiffeners' seat (clashes). A rib
    #: leaning further than this also explains a stiffener that finds no seat (build)
    square_rib_lean_deg: float = 15.0


TOLERANCES = Tolerances()

#: run expensive invariant checks inside the stages (the test suite sets this)
STRICT = False
