"""Quantities with units, as written in job files ("3 mm", "4.5 m", "0.56 kN/m2", "210 GPa").

Internally fabpanel works in millimetres, newtons, megapascals (N/mm2), kilograms and seconds.
Every parser returns a float in those internal units.
"""

from __future__ import annotations

import math
import re

from .errors import InputError

#: factor from each accepted unit to the internal unit of its dimension
UNITS: dict[str, dict[str, float]] = {
    # internal: millimetre
    "length": {"mm": 1.0, "cm": 10.0, "m": 1000.0},
    # internal: N/mm2 = MPa. 1 kN/m2 = 1e3 N / 1e6 mm2 = 1e-3 N/mm2
    "pressure": {"kN/m2": 1e-3, "kPa": 1e-3, "N/m2": 1e-6, "Pa": 1e-6, "N/mm2": 1.0},
    # internal: N/mm2 = MPa
    "stress": {"MPa": 1.0, "N/mm2": 1.0, "GPa": 1e3, "kN/mm2": 1e3},
    # internal: kg/mm3
    "density": {"kg/m3": 1e-9, "t/m3": 1e-6, "kg/mm3": 1.0},
    # internal: second
    "time": {"s": 1.0, "min": 60.0},
}

#: unit of each dimension used when writing quantities back (manifest, job as run)
INTERNAL_UNIT = {"length": "mm", "pressure": "N/mm2", "stress": "MPa", "density": "kg/mm3",
                 "time": "s"}

_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z/0-9²³]+)\s*$")


def _normalise_unit(unit: str) -> str:
    return unit.replace("²", "2").replace("³", "3")


def parse_quantity(value: object, dimension: str, where: str = "") -> float:
    """Parse ``"<number> <unit>"`` into the internal unit of ``dimension``.

    Raises :class:`InputError` naming ``where`` (the job key) when the value has no unit, a unit
    of the wrong dimension, or is not finite.
    """
    units = UNITS[dimension]
    allowed = ", ".join(units)
    key = f"{where}: " if where else ""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(f"{key}expected a {dimension} such as \"3 {next(iter(units))}\", "
                         f"got {value!r}")
    if isinstance(value, (int, float)):
        raise InputError(f"{key}the {dimension} {value!r} has no unit; write it with one of "
                         f"{allowed}, e.g. \"{value} {next(iter(units))}\"")
    match = _QUANTITY.match(value)
    if not match:
        raise InputError(f"{key}cannot read {value!r} as a {dimension}; write a number and a unit "
                         f"({allowed}), e.g. \"3 {next(iter(units))}\"")
    number, unit = float(match.group(1)), _normalise_unit(match.group(2))
    if unit not in units:
        raise InputError(f"{key}unit {unit!r} is not a {dimension} unit; use one of {allowed}")
    if not math.isfinite(number):
        raise InputError(f"{key}{value!r} is not a finite number")
    return number * units[unit]


def format_quantity(value: float, dimension: str) -> str:
    """Write an internal value back with its internal unit ("3 mm")."""
    # 15 significant digits: exact enough to round-trip, without binary noise (7.85e-06)
    return f"{value:.15g} {INTERNAL_UNIT[dimension]}"


def length_scale(units: str) -> float:
    """Factor from the input's declared length unit to millimetres."""
    try:
        return UNITS["length"][units]
    except KeyError as err:
        raise InputError(f"input units {units!r} are not supported; use m or mm (or cm)") from err
