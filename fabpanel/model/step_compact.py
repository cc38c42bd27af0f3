"""STEP entity text made compact without changing a single value: one entity a line, the
reals in their shortest exact form, and every point or direction written once.

OCCT's writer wraps entities at 80 columns with an indent, writes every real as
``-5.975081397337E+03``, and gives every B-spline pole, vertex and placement a
CARTESIAN_POINT of its own: an access opening's ruled wall repeats the poles of its two edge
curves, so on the demo 602,000 points held 329,000 positions, and the points were two thirds of
the file. Here, on the text of a file's DATA section:

1. whitespace outside strings goes (ISO 10303-21 separates no tokens by it), but one space
   between the records of a complex entity, ``(... ) NAMED_UNIT(*)``, so the file reads as
   before in readers that tokenise records by it; each entity ends its line;
2. a real with an exponent becomes the shortest text that parses to the same double
   (``-5975.081397337``), only where that is shorter: the reader gets the same numbers bit for
   bit, so every check on the read-back model (validity, coaxial bolts, sheet fit) is as before;
3. identical CARTESIAN_POINT and DIRECTION entities (the same name and the same coordinate
   text) become the first of them, and the references to the others point at it. Both are
   values, not topology: STEP lets any number of entities share one (a VERTEX_POINT and the
   pole of a curve ending there, two B-spline curves through the same pole). Vertices, edges,
   faces and products are never merged, so no two solids share topology.

Strings (names, descriptions) are passed through as they are.
"""

from __future__ import annotations

import re

#: a quoted string (a quote inside is two quotes)
_STRING = re.compile(rb"('(?:[^']|'')*')")
#: where a string was taken out while the rest is rewritten (no digit-dot, space or "#")
_HIDDEN = re.compile(rb"\x01(\d+)\x02")
#: a real with an exponent as OCCT writes it; never part of a reference or keyword (no '.')
_EXPONENT_REAL = re.compile(rb"(-?\d+\.\d*E[+-]?\d+)")
#: the space kept between the records of a complex entity
_RECORD_GAP = re.compile(rb"\)\s+(?=[A-Z])")
#: a value entity that may be shared: its number and its text after "="
_VALUE_ENTITY = re.compile(rb"(?m)^#(\d+)=((?:CARTESIAN_POINT|DIRECTION)\(.*);$")
_REFERENCE = re.compile(rb"#(\d+)")


def compact_entities(data: bytes) -> bytes:
    """The entities of a STEP DATA section (the text between ``DATA;`` and ``ENDSEC;``)
    rewritten compactly (module docstring): the same entities and values, fewer bytes."""
    text, strings = _hide_strings(data)
    text = _RECORD_GAP.sub(b")\0", text)
    text = text.translate(None, b" \t\r\n").replace(b"\0", b" ").replace(b";", b";\n")
    parts = _EXPONENT_REAL.split(_shared_values(text))
    parts[1::2] = [_shortest_real(real) for real in parts[1::2]]
    parts = _HIDDEN.split(b"".join(parts))
    parts[1::2] = [strings[int(index)] for index in parts[1::2]]
    return b"\n" + b"".join(parts)


def _hide_strings(data: bytes) -> tuple[bytes, list[bytes]]:
    """``data`` with every non-empty string replaced by a numbered mark, and the strings: the
    rewriting below must not touch a name's spaces, digits or "#"."""
    parts = _STRING.split(data)
    strings = [s for s in parts[1::2] if s != b"''"]
    marks = iter(range(len(strings)))
    parts[1::2] = [s if s == b"''" else b"\x01%d\x02" % next(marks) for s in parts[1::2]]
    return b"".join(parts), strings


def _shortest_real(written: bytes) -> bytes:
    """The shortest STEP real for the same double (it needs a point, and a capital E)."""
    text = repr(float(written))
    if "e" in text:
        mantissa, exponent = text.split("e")
        if "." not in mantissa:
            mantissa += "."
        text = f"{mantissa}E{exponent}"
    elif text.endswith(".0"):
        text = text[:-1]
    shorter = text.encode()
    return shorter if len(shorter) < len(written) else written


def _shared_values(text: bytes) -> bytes:
    """Each point or direction entity once: later copies dropped, references to them moved to
    the first (the file's order kept, so the result depends on nothing but the text)."""
    first: dict[bytes, bytes] = {}
    alias: dict[bytes, bytes] = {}
    for number, value in _VALUE_ENTITY.findall(text):
        kept = first.setdefault(value, number)
        if kept != number:
            alias[number] = kept
    if not alias:
        return text
    lines = text.split(b"\n")
    kept_lines = [line for line in lines if line[1 : line.find(b"=")] not in alias]
    parts = _REFERENCE.split(b"\n".join(kept_lines))
    parts[1::2] = [b"#" + alias.get(number, number) for number in parts[1::2]]
    return b"".join(parts)
