"""The report's content as a list of blocks, rendered twice: to HTML (``index.html``) and to
PDF (``report.pdf``), so the two carry the same content.

Values reach a table already formatted (:func:`cell`): units from the key's suffix, sensible
precision, and a nested record as ``min … / median … / max …`` or ``key value`` pairs; never a
raw dict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: key suffix -> the unit shown after the value
UNITS = {
    "_mm": "mm",
    "_kg": "kg",
    "_s": "s",
    "_m2": "m²",
    "_mm2": "mm²",
    "_mm3": "mm³",
    "_MPa": "MPa",
    "_kN": "kN",
    "_deg": "°",
    "_N": "N",
}


@dataclass(frozen=True)
class Heading:
    text: str
    level: int = 2
    anchor: str = ""


@dataclass(frozen=True)
class Text:
    text: str


@dataclass(frozen=True)
class Bullets:
    items: tuple[str, ...]


@dataclass(frozen=True)
class Table:
    """A table of formatted cells. ``sortable``: the HTML sorts by a clicked column and filters
    rows by a search box (a long per-panel table); ``key_value``: a two-column record."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    sortable: bool = False
    caption: str = ""


@dataclass(frozen=True)
class Figure:
    """A PNG figure (bytes) with its caption (also its alt text)."""

    png: bytes
    caption: str


@dataclass(frozen=True)
class Vector:
    """A vector drawing: SVG for the page, PDF bytes for the printed report."""

    svg: str
    pdf_png: bytes
    caption: str


@dataclass(frozen=True)
class Gallery:
    """Thumbnails (PNG bytes) each linking to a full image (a path relative to the report)."""

    items: tuple[tuple[bytes, str, str], ...]  # (thumbnail, link, caption)


@dataclass(frozen=True)
class Verdict:
    """One verdict on the first page: a name, ``pass`` | ``fail`` | ``not checked``, the
    governing numbers."""

    name: str
    state: str
    lines: tuple[str, ...]


@dataclass(frozen=True)
class Verdicts:
    items: tuple[Verdict, ...]
    not_modelled: tuple[str, ...] = field(default=())


Block = Heading | Text | Bullets | Table | Figure | Vector | Gallery | Verdicts


def number(value: float) -> str:
    """A number at sensible precision: 4 significant digits, thousands kept whole."""
    if not math.isfinite(value):
        return "–" if math.isnan(value) else str(value)
    magnitude = abs(value)
    if magnitude == 0 or 1e-3 <= magnitude < 1e6:
        if magnitude >= 1000:
            return f"{value:,.0f}".replace(",", " ")
        return f"{value:.4g}"
    return f"{value:.3e}"


#: keys whose values are shares, shown as percentages
SHARES = (
    "edges_in_band",
    "corners_in_60_120",
    "corners_in_45_135",
    "utilisation",
    "utilisation_min_but_last",
)


def unit_of(key: str) -> str:
    for suffix, unit in UNITS.items():
        if key.endswith(suffix):
            return unit
    return ""


def cell(value: object, key: str = "") -> str:
    """A value formatted for a table cell (module docstring)."""
    unit = unit_of(key)
    tail = f" {unit}" if unit else ""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        if key in SHARES and 0.0 <= value <= 1.0:
            return f"{value:.1%}"
        return f"{number(float(value))}{tail}"
    if isinstance(value, dict):
        if {"min", "max"} <= set(value):
            order = [k for k in ("min", "median", "mean", "p95", "max") if k in value]
            return " / ".join(f"{k} {number(float(value[k]))}" for k in order) + tail
        # an inner key without a unit of its own takes the outer key's
        return "; ".join(
            f"{k.replace('_', ' ')} {cell(v, k if unit_of(k) else key)}" for k, v in value.items()
        )
    if isinstance(value, (list, tuple)):
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            if len(value) > 8:
                return f"{len(value)} values, {number(min(value))} to {number(max(value))}{tail}"
            return ", ".join(number(float(v)) for v in value) + tail
        if len(value) > 8:
            return f"{len(value)} items: " + ", ".join(str(v) for v in value[:8]) + ", …"
        return ", ".join(cell(v) for v in value)
    return str(value)


def record_table(record: dict, skip: tuple[str, ...] = ()) -> Table:
    """A two-column table of a record's keys (spaced words, unit from the suffix) and values;
    a value that is an empty list, mapping or text has no row (it showed as a bare unit)."""
    rows = tuple(
        (label(key), cell(value, key))
        for key, value in record.items()
        if key not in skip and not (isinstance(value, (list, tuple, dict, str)) and not value)
    )
    return Table(("measure", "value"), rows)


def label(key: str) -> str:
    """``max_sheet_fit_error_mm`` -> ``max sheet fit error``."""
    for suffix in UNITS:
        if key.endswith(suffix):
            key = key[: -len(suffix)]
            break
    return key.replace("_", " ")


def header_label(key: str) -> str:
    """A column header with its unit: ``radius_min_mm`` -> ``radius min [mm]``."""
    unit = unit_of(key)
    return f"{label(key)} [{unit}]" if unit else label(key)
