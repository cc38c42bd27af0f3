"""Weld and fit-up rules of the sandwich joints: the default fillet throat and sheet set-back, the
packing plate size (see :mod:`fabpanel.buildup` for the detail they describe). Below the job
module, which checks a job against them."""

from __future__ import annotations

import math

#: EN 1993-1-8 §4.5.2(2): a load-bearing fillet weld's throat is at least 3 mm; the default
#: throat is this or the largest equal-leg fillet the sheet's edge holds, whichever is smaller
MAX_DEFAULT_THROAT = 3.0
#: fillet throat of the plate-to-plate welds (rib to rib at the corners, stiffeners all round),
#: mm: the smallest load-bearing fillet EN 1993-1-8 §4.5.2(2) allows. The structural check
#: designs the sheet-to-rib welds and the stiffeners' (at most this throat); the rib-to-rib
#: corner welds carry the corners' fit-up, and the engineer confirms them
PLATE_THROAT = 3.0
#: fit-up allowance added to the weld leg for the default set-back, mm
SETBACK_FIT_UP = 1.0
#: a sheet set back from the rib's contact face keeps at least this much of the rib under it, mm
#: (fabpanel's rule: the fit-up tolerance of placing a sheet on a rib)
MIN_SHEET_BEARING = 2.0
#: packing plates reach this many hole diameters from the hole's edge on every side
#: (EN 1993-1-8 Table 3.3: e1, e2 >= 1.2 d0), rounded up to PACKING_ROUND mm
PACKING_EDGE = 1.2
PACKING_ROUND = 5.0


def default_throat(thinnest_sheet: float, rib: float) -> float:
    """The default fillet weld throat a between a sheet of ``thinnest_sheet`` mm and a rib of
    ``rib`` mm: an equal-leg fillet whose leg a sqrt 2 fits the sheet's edge and, with the
    fit-up allowance, leaves the sheet 2 mm of the rib to sit on; at most 3 mm."""
    room = max(rib - MIN_SHEET_BEARING - SETBACK_FIT_UP, 0.5)
    return min(MAX_DEFAULT_THROAT, min(thinnest_sheet, room) / math.sqrt(2.0))


def default_setback(throat: float) -> float:
    """The default sheet set-back behind the rib's contact face: the weld leg plus the fit-up
    allowance, rounded up to 0.5 mm."""
    return math.ceil((throat * math.sqrt(2.0) + SETBACK_FIT_UP) * 2.0 - 1e-9) / 2.0


def packing_side(hole: float, rib_height: float) -> float:
    """Side of a square packing plate around a hole of ``hole`` mm (edge distance 1.2 d0 on
    every side, rounded up to 5 mm), at most the rib height."""
    side = (1.0 + 2.0 * PACKING_EDGE) * hole
    return min(math.ceil(side / PACKING_ROUND - 1e-9) * PACKING_ROUND, rib_height)
