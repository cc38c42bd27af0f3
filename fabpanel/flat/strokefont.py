"""A tiny single-stroke vector font for etching labels with a plasma or marking tool.

Plasma CAM programs etch lines, not filled glyphs, so labels are written as open polylines. Glyphs
are drawn on a 4 x 6 grid (cap height 6 units, advance 5.5 units); characters: ``A-Z``, ``0-9``,
``-``, ``+`` (``R934+``: a forming radius opening up), ``_``, ``.`` and space (lower case is
upper-cased, anything else becomes a space). For steel parts a cap height of 15-30 mm reads
well from a few metres after cutting.
"""

from __future__ import annotations

import logging

import numpy as np

log = logging.getLogger(__name__)

#: glyph height in font units
CAP = 6.0
#: horizontal advance per character in font units
ADVANCE = 5.5

# strokes separated by ";", points "x y" separated by ","
_GLYPHS: dict[str, str] = {
    "A": "0 0,0 4,2 6,4 4,4 0;0 3,4 3",
    "B": "0 0,0 6,3 6,4 5,4 4,3 3,0 3;3 3,4 2,4 1,3 0,0 0",
    "C": "4 1,3 0,1 0,0 1,0 5,1 6,3 6,4 5",
    "D": "0 0,0 6,2 6,4 4,4 2,2 0,0 0",
    "E": "4 0,0 0,0 6,4 6;0 3,3 3",
    "F": "0 0,0 6,4 6;0 3,3 3",
    "G": "4 5,3 6,1 6,0 5,0 1,1 0,3 0,4 1,4 3,2 3",
    "H": "0 0,0 6;4 0,4 6;0 3,4 3",
    "I": "1 0,3 0;2 0,2 6;1 6,3 6",
    "J": "0 1,1 0,2 0,3 1,3 6;2 6,4 6",
    "K": "0 0,0 6;4 6,0 2;1 3,4 0",
    "L": "0 6,0 0,4 0",
    "M": "0 0,0 6,2 3,4 6,4 0",
    "N": "0 0,0 6,4 0,4 6",
    "O": "1 0,0 1,0 5,1 6,3 6,4 5,4 1,3 0,1 0",
    "P": "0 0,0 6,3 6,4 5,4 4,3 3,0 3",
    "Q": "1 0,0 1,0 5,1 6,3 6,4 5,4 1,3 0,1 0;2 2,4 0",
    "R": "0 0,0 6,3 6,4 5,4 4,3 3,0 3;2 3,4 0",
    "S": "0 1,1 0,3 0,4 1,4 2,3 3,1 3,0 4,0 5,1 6,3 6,4 5",
    "T": "0 6,4 6;2 6,2 0",
    "U": "0 6,0 1,1 0,3 0,4 1,4 6",
    "V": "0 6,2 0,4 6",
    "W": "0 6,1 0,2 4,3 0,4 6",
    "X": "0 0,4 6;0 6,4 0",
    "Y": "0 6,2 3,4 6;2 3,2 0",
    "Z": "0 6,4 6,0 0,4 0",
    "0": "1 0,0 1,0 5,1 6,3 6,4 5,4 1,3 0,1 0;0 1,4 5",
    "1": "1 5,2 6,2 0;1 0,3 0",
    "2": "0 5,1 6,3 6,4 5,4 4,0 0,4 0",
    "3": "0 5,1 6,3 6,4 5,4 4,3 3,4 2,4 1,3 0,1 0,0 1;1 3,3 3",
    "4": "3 0,3 6,0 2,4 2",
    "5": "4 6,0 6,0 3,3 3,4 2,4 1,3 0,0 0",
    "6": "4 5,3 6,1 6,0 5,0 1,1 0,3 0,4 1,4 2,3 3,0 3",
    "7": "0 6,4 6,1 0",
    "8": "1 3,0 4,0 5,1 6,3 6,4 5,4 4,3 3,1 3,0 2,0 1,1 0,3 0,4 1,4 2,3 3",
    "9": "0 1,1 0,3 0,4 1,4 5,3 6,1 6,0 5,0 4,1 3,4 3",
    "-": "0.5 3,3.5 3",
    "+": "0.5 3,3.5 3;2 1.5,2 4.5",
    "_": "0 0,4 0",
    ".": "1.6 0,2.4 0,2.4 0.8,1.6 0.8,1.6 0",
    " ": "",
}


def _parse(spec: str) -> tuple[np.ndarray, ...]:
    return tuple(
        np.array([[float(v) for v in point.split()] for point in stroke.split(",")])
        for stroke in spec.split(";")
        if stroke.strip()
    )


_STROKES = {char: _parse(spec) for char, spec in _GLYPHS.items()}

#: the characters the font draws
CHARACTERS = frozenset(_STROKES)


def text_width(text: str, height: float) -> float:
    """Width of a text line, mm, for cap height ``height`` mm."""
    return max(len(text) * ADVANCE - (ADVANCE - 4.0), 0.0) * height / CAP


def text_strokes(
    text: str, x: float, y: float, height: float, angle_deg: float = 0.0, align: str = "center"
) -> list[np.ndarray]:
    """Single-stroke polylines of a text line.

    ``(x, y)`` is the insertion point, mm: the centre of the line for ``align="center"``, the
    lower-left corner for ``align="left"``. ``height`` is the cap height, mm; ``angle_deg`` turns
    the line counter-clockwise about the insertion point. Returns a list of (k, 2) float arrays.
    """
    scale = height / CAP
    unknown = {c for c in text.upper() if c not in _STROKES}
    if unknown:
        log.warning("stroke font has no glyph for %s; drawn as spaces", "".join(sorted(unknown)))
    strokes = [
        glyph * scale + [i * ADVANCE * scale, 0.0]
        for i, char in enumerate(text.upper())
        for glyph in _STROKES.get(char, ())
    ]
    if not strokes:
        return []
    shift = (
        np.array([0.0, 0.0])
        if align == "left"
        else np.array([text_width(text, height) / 2, height / 2])
    )
    angle = np.deg2rad(angle_deg)
    rotation = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    return [(stroke - shift) @ rotation + [x, y] for stroke in strokes]
