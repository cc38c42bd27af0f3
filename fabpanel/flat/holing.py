"""Which round holes the plasma burns and which are drilled.

A plasma cut face is not square to the plate: ISO 9013 (thermal cutting, classification of
cuts) bounds its perpendicularity/angularity deviation by ``u = u0 + k t`` mm over a cut of
thickness ``t``, in five ranges (1 best). A burnt hole is therefore conical, its diameter up to
about ``u`` off the nominal somewhere along the bore. A bolt hole may be burnt only when that
stays within the hole's tolerance (``[cutting] hole_tolerance``, ±0.5 mm for normal round holes
as EN 1090-2 is commonly read; check the execution specification); fitted bolts always stand in
drilled (or reamed) holes. Every hole smaller than ``[cutting] min_plasma_hole`` plate
thicknesses is drilled whatever its purpose: the plasma cannot pierce and round it cleanly.

The range coefficients are those of ISO 9013:2017 Table 3 (perpendicularity or angularity
tolerance); range 1 checked against a published calculator (0.055 mm at 1.5 mm), the others as
tabulated in the standard and not independently checked here.
"""

from __future__ import annotations

from typing import Literal

from ..data import Hole

#: ISO 9013 perpendicularity ranges: range -> (u0 mm, k), u = u0 + k t
PERPENDICULARITY: dict[int, tuple[float, float]] = {
    1: (0.05, 0.003),
    2: (0.15, 0.007),
    3: (0.4, 0.01),
    4: (0.8, 0.02),
    5: (1.2, 0.035),
}


def perpendicularity(quality: int, thickness: float) -> float:
    """ISO 9013 perpendicularity tolerance u (mm) of range ``quality`` over ``thickness`` mm."""
    u0, k = PERPENDICULARITY[quality]
    return u0 + k * thickness


def is_drilled(
    hole: Hole,
    thickness: float,
    *,
    min_plasma_hole: float,
    quality: int,
    tolerance: float,
    fit: Literal["normal", "fitted"],
) -> bool:
    """Whether ``hole`` in a plate of ``thickness`` mm is drilled rather than burnt (see the
    module docstring)."""
    if hole.diameter < min_plasma_hole * thickness:
        return True
    if hole.purpose != "bolt":
        return False
    return fit == "fitted" or perpendicularity(quality, thickness) > tolerance + 1e-12
