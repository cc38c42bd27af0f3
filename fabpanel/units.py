"""Quantities with units, as written in job files ("3 mm", "4.5 m", "0.56 kN/m2", "210 GPa").

Internally fabpanel works in millimetres, newtons, megapascals (N/mm2), kilograms and seconds.
Every parser returns a float in those internal units. Errors quote the value as the user wrote
it (``"5 m"``), never the internal number.
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
    # internal: metre per second (wind speeds are given so in every code and map)
    "velocity": {"m/s": 1.0, "km/h": 1.0 / 3.6},
}

#: the extent (largest plan or height, m) of a shell this tool is for: a unit that brings a
#: surface into it is the likely one where the declared unit does not
PLAUSIBLE_EXTENT_M = (2.0, 300.0)


def plausible_length_unit(extent: float, declared: str) -> str | None:
    """The first length unit other than ``declared`` under which a surface ``extent`` long in
    ``declared`` units (its largest side) is a building shell's (``PLAUSIBLE_EXTENT_M``);
    None where there is none."""
    lengths = UNITS["length"]
    low, high = PLAUSIBLE_EXTENT_M
    for unit, scale in lengths.items():
        if unit != declared and low <= extent * scale / 1000 <= high:
            return unit
    return None


#: unit of each dimension used when writing quantities back (manifest, job as run)
INTERNAL_UNIT = {
    "length": "mm",
    "pressure": "N/mm2",
    "stress": "MPa",
    "density": "kg/mm3",
    "time": "s",
    "velocity": "m/s",
}

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# the unit starts with a letter, so the digits of "1.0" stay in the number (a bare number)
_QUANTITY = re.compile(rf"^\s*({_NUMBER})\s*([A-Za-z][A-Za-z/0-9²³]*)\s*$")
_BARE_NUMBER = re.compile(rf"^\s*({_NUMBER})\s*$")


def _normalise_unit(unit: str) -> str:
    return unit.replace("²", "2").replace("³", "3")


def as_written(value: object) -> str:
    """A job value as the user wrote it in TOML: ``"5 m"`` (text in double quotes), ``0.3``,
    ``true``, ``[nan, 0.0]``."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return f"[{', '.join(as_written(item) for item in value)}]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{key} = {as_written(item)}" for key, item in value.items()) + "}"
    return str(value)


def parse_quantity(value: object, dimension: str, where: str = "") -> float:
    """Parse ``"<number> <unit>"`` into the internal unit of ``dimension``.

    Raises :class:`InputError` naming ``where`` (the job key) when the value has no unit, a unit
    of the wrong dimension, or is not finite once converted (``"1e308 m"`` is 1e311 mm: inf).
    """
    units = UNITS[dimension]
    allowed = ", ".join(units)
    first, last = next(iter(units)), list(units)[-1]
    key = f"{where}: " if where else ""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(
            f'{key}expected a {dimension} such as "3 {first}", got {as_written(value)}'
        )
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(
            f"{key}{as_written(value)} is not a finite number; write a {dimension} "
            f'with its unit, e.g. "3 {first}"'
        )
    if isinstance(value, (int, float)) or _BARE_NUMBER.match(value):
        number = value.strip() if isinstance(value, str) else value
        raise InputError(
            f"{key}the {dimension} {as_written(value)} has no unit; units are "
            f"explicit in a job file: write it with one of {allowed}, e.g. "
            f'"{number} {first}" or "{number} {last}"'
        )
    match = _QUANTITY.match(value)
    if not match:
        raise InputError(
            f"{key}cannot read {as_written(value)} as a {dimension}; write a number "
            f'and a unit ({allowed}), e.g. "3 {first}"'
        )
    number, unit = float(match.group(1)), _normalise_unit(match.group(2))
    if unit not in units:
        raise InputError(
            f'{key}unit "{unit}" in {as_written(value)} is not a {dimension} '
            f"unit fabpanel reads; use one of {allowed}"
        )
    result = number * units[unit]
    # after the scaling: "1e308 m" is a finite number but an infinite length in mm
    if not math.isfinite(result):
        raise InputError(
            f"{key}{as_written(value)} is too large: not a finite number in "
            f"{INTERNAL_UNIT[dimension]}; write a realistic {dimension}"
        )
    return result


def format_quantity(value: float, dimension: str) -> str:
    """Write an internal value back with its internal unit ("3 mm")."""
    # 15 significant digits: exact enough to round-trip, without binary noise (7.85e-06)
    return f"{value:.15g} {INTERNAL_UNIT[dimension]}"


def format_like(value: float, written: object) -> str | None:
    """An internal value in the unit of a quantity as the user wrote it: ``format_like(1480.0,
    "1.5 m")`` is ``"1.48 m"``; None when ``written`` is not a quantity with a known unit."""
    match = _QUANTITY.match(written) if isinstance(written, str) else None
    if match is None:
        return None
    unit = _normalise_unit(match.group(2))
    # a unit belongs to one dimension, or to two with the same factor (N/mm2: pressure, stress)
    factor = next((units[unit] for units in UNITS.values() if unit in units), None)
    if factor is None:
        return None
    return f"{format_number(value / factor)} {unit}"


def format_number(value: float) -> str:
    """A number for a message: four significant digits, no exponent for large ones (12346)."""
    text = f"{value:.4g}"
    return f"{value:.0f}" if "e+" in text else text


def length_scale(units: str) -> float:
    """Factor from the input's declared length unit to millimetres."""
    try:
        return UNITS["length"][units]
    except KeyError as err:
        raise InputError(f"input units {units!r} are not supported; use m or mm (or cm)") from err


def length_option(
    text: str, default_units: str | None, option: str = "--panel-size"
) -> tuple[str, str | None]:
    """A length given on the command line, as a quantity the job accepts, and a note.

    ``"1.2 m"`` comes back as it is, with no note. A bare number (``"1.2"``, ``"1200"``) is
    read in ``default_units``, the input's length unit, and comes back as ``"1.2 m"`` with a
    one-line note saying so; without ``default_units`` it raises :class:`InputError` asking for
    a unit. (In a job file a bare number stays an error: there units are explicit.)
    """
    text = text.strip()
    if _BARE_NUMBER.match(text):
        if default_units is None:
            raise InputError(
                f"{option} {text} has no unit and the input declares none; write "
                f'it with one, e.g. {option} "{text} m" or "{text} mm"'
            )
        length_scale(default_units)
        quantity = f"{text} {default_units}"
        return quantity, f"{option} {text} has no unit: read as {quantity}, the input's units"
    parse_quantity(text, "length", option)
    return text, None
