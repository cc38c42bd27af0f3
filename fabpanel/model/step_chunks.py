"""The STEP assembly written in chunks of panels by worker processes, merged into one file.

OCCT's STEP writer holds the whole model in one process while it transfers it: at a thousand
panels that was most of an 11 GB peak and a single core's minutes. Each chunk of
``STEP_CHUNK_PANELS`` panels is written by a worker as a file of its own (the same XCAF
document as one file would hold: named, coloured parts with material and properties, grouped
per panel, under a node for the chunk placed in the design's frame). The chunks are merged
entity by entity: every chunk's entity numbers get the chunk's index as their last digits
(:func:`merged_entities`), and the chunks' root products (each chunk file's top node) become
the one root of the merged file: the first chunk's root is kept, the others' are left out and
their chunk nodes point at the kept one. The tree reads fabpanel > P001-P016 > P001 > P001-TOP.
"""

from __future__ import annotations

import itertools
import re
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..data import Part
from ..errors import KernelError
from .step_compact import compact_entities

#: panels a chunk: about 2-3 MB of STEP and a few hundred MB of OCCT model in its worker
STEP_CHUNK_PANELS = 16
#: a name, description or other string argument of an entity (no quotes inside in our files)
_TEXT = rb"\s*'[^']*'\s*,"
_NAUO = re.compile(rb"NEXT_ASSEMBLY_USAGE_OCCURRENCE\(" + _TEXT * 3 + rb"\s*#(\d+)\s*,\s*#(\d+)")


def chunk_groups(panel_ids: list[str]) -> list[list[str]]:
    """The panels cut into chunks of ``STEP_CHUNK_PANELS`` in layout order (a fixed size, so
    the file does not depend on the number of workers)."""
    return [
        panel_ids[i : i + STEP_CHUNK_PANELS] for i in range(0, len(panel_ids), STEP_CHUNK_PANELS)
    ]


def write_chunk(
    index: int,
    count: int,
    groups: list[tuple[str, list[Part]]],
    origin: tuple[float, float, float],
    density: float | None,
) -> tuple[bytes, bytes]:
    """Chunk ``index`` of ``count`` written as a STEP file and cut up for merging: (header,
    entities) with the entities renumbered and, after the first chunk, its root product left
    out (module docstring)."""
    from .export import write_step_document

    with tempfile.TemporaryDirectory(prefix="fabpanel-step-") as folder:
        path = Path(folder) / "chunk.step"
        label = f"{groups[0][0]}-{groups[-1][0]}"  # a range (readers turn spaces and dots to _)
        write_step_document(groups, label, origin, path, density)
        text = path.read_bytes()
    start = text.index(b"DATA;") + len(b"DATA;")
    end = text.rindex(b"ENDSEC;")
    return text[:start], merged_entities(compact_entities(text[start:end]), index, count)


def merged_entities(data: bytes, index: int, count: int) -> bytes:
    """The entities of chunk ``index`` of ``count`` numbered apart from every other chunk's:
    #n becomes #1kn, where k is the chunk's index in a fixed number of digits (the 1 keeps
    them from reading as leading zeros), so no two chunks share a number, and the change is
    one byte replacement, no call per number (a string holding "#" changes too: only names
    such as 'Context #1' do). The root's definition and representation take the numbers every
    chunk shares (the index ``count``, which no chunk has); after the first chunk, the root's
    own entities are left out."""
    width = len(str(count))
    definition, representation, root_only = _root(data)
    if index:
        data = re.sub(
            rb"(?m)^#(?:" + b"|".join(b"%d" % n for n in sorted(root_only)) + rb")\s*=[^;]*;\n",
            b"",
            data,
        )
    prefix = b"#1%0*d" % (width, index)
    data = data.replace(b"#", prefix)
    shared = b"#1%0*d" % (width, count)
    for old, tail in ((definition, b"1"), (representation, b"2")):
        data = re.sub(re.escape(prefix) + rb"%d(?!\d)" % old, shared + tail, data)
    return data


def _root(data: bytes) -> tuple[int, int, set[int]]:
    """The chunk file's root: its product definition (the one that is a parent in an assembly
    usage but nobody's child), its shape representation, and the entities that only make the
    root (definition, shape, product, formation, category, representation and its link)."""
    usages = [(int(a), int(b)) for a, b in _NAUO.findall(data)]
    roots = {a for a, _ in usages} - {b for _, b in usages}
    if len(roots) != 1:
        raise KernelError(f"a STEP chunk has {len(roots)} root assemblies, not one")
    definition = roots.pop()
    shape = _find(
        data, rb"#(\d+)\s*=\s*PRODUCT_DEFINITION_SHAPE\(" + _TEXT * 2 + rb"\s*#%d\s*\)", definition
    )
    link, representation = (
        int(n)
        for n in _search(
            data, rb"#(\d+)\s*=\s*SHAPE_DEFINITION_REPRESENTATION\(\s*#%d\s*,\s*#(\d+)" % shape
        ).groups()
    )
    formation = _find(
        data, rb"#%d\s*=\s*PRODUCT_DEFINITION\(" % definition + _TEXT * 2 + rb"\s*#(\d+)"
    )
    product = _find(
        data, rb"#%d\s*=\s*PRODUCT_DEFINITION_FORMATION\(" % formation + _TEXT * 2 + rb"\s*#(\d+)"
    )
    category = re.findall(
        rb"#(\d+)\s*=\s*PRODUCT_RELATED_PRODUCT_CATEGORY\([^;]*\(\s*#%d\s*\)\s*\)" % product, data
    )
    only = {definition, shape, link, representation, formation, product}
    return definition, representation, only | {int(n) for n in category}


def _search(data: bytes, pattern: bytes) -> re.Match:
    found = re.search(pattern, data)
    if found is None:
        raise KernelError("a STEP chunk's root product is not as OCCT writes it")
    return found


def _find(data: bytes, pattern: bytes, *numbers: int) -> int:
    """The number the pattern (formatted with ``numbers``) captures first."""
    return int(_search(data, pattern % numbers if numbers else pattern).group(1))


def compact_file(path: Path) -> None:
    """A STEP file OCCT wrote, rewritten compactly (:mod:`fabpanel.model.step_compact`) with
    its assembly usages numbered 1, 2, ... in order."""
    text = path.read_bytes()
    start = text.index(b"DATA;") + len(b"DATA;")
    end = text.rindex(b"ENDSEC;")
    data = number_usages(compact_entities(text[start:end]), itertools.count(1))
    path.write_bytes(text[:start] + data + text[end:])


def number_usages(data: bytes, count: Iterator[int]) -> bytes:
    """``data`` with its assembly usages numbered from ``count`` in order."""

    def numbered(match: re.Match) -> bytes:
        # on one line: the writer wraps at 80 characters, where depends on the old id's width
        rest = re.sub(rb"\n\s*", b"", match.group(1))
        return b"NEXT_ASSEMBLY_USAGE_OCCURRENCE('%d'%s;" % (next(count), rest)

    return re.sub(rb"NEXT_ASSEMBLY_USAGE_OCCURRENCE\('\d+'([^;]*);", numbered, data)


def merged_step(chunks: Iterable[tuple[bytes, bytes]], path: Path) -> Path:
    """Write the chunks (in order) as one file: the first chunk's header, every chunk's
    entities, the assembly usages numbered 1, 2, ... in file order."""
    count = itertools.count(1)
    with path.open("wb") as handle:
        for k, (header, entities) in enumerate(chunks):
            if k == 0:
                handle.write(header + b"\n")
            handle.write(number_usages(entities, count))
        handle.write(b"ENDSEC;\nEND-ISO-10303-21;\n")
    return path
