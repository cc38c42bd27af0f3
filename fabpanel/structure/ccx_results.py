"""Reading what CalculiX wrote: the printed results (``.dat``: reaction totals and per node,
masses, buckling factors, spring energies and displacements, tied nodes' forces, a nonlinear
step's monitored displacements) and the result file (``.frd``: nodes, elements, displacement
and stress blocks), and the knots a run made (``.12d``). Part of the CalculiX adapter
(:mod:`.ccx` re-exports every name); the quirks are listed there.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SolverError


# --------------------------------------------------------------------------------------------
# .dat
# --------------------------------------------------------------------------------------------
@dataclass
class DatResults:
    """Totals read from a ``.dat`` file, in step order."""

    forces: list[np.ndarray] = field(default_factory=list)  # (3,) per static step, N
    #: per static step: the supported nodes' ids (n,) (model index + 1) and their RF (n, 3), N
    node_forces: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    mass: list[float] = field(default_factory=list)  # total mass per print, t
    buckling: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: per static step with springs: their element ids and internal energies (N mm), and the
    #: spring nodes' ids and displacements (n, 3)
    spring_energy: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    spring_nodes: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    #: per static step, the tied nodes' ids and RF (n, 3), N (:mod:`.stiffeners`)
    tie_forces: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)


_FLOAT = r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?"


def _until_next(block: str) -> str:
    """A ``.dat`` block's rows: up to the next header line (one that holds letters)."""
    rows = []
    for line in block.split("\n"):
        if re.search(r"[a-df-zA-DF-Z]", line):
            break
        rows.append(line)
    return "\n".join(rows)


def read_dat(path: Path) -> DatResults:
    """Reaction totals (``total force``), masses (``total mass``) and buckling factors."""
    text = Path(path).read_text(errors="replace")
    result = DatResults()
    for match in re.finditer(
        r"total force \(fx,fy,fz\) for set \S+ and time\s+\S+\s*\n\s*\n?"
        rf"\s*({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})",
        text,
    ):
        result.forces.append(np.array([float(match.group(i)) for i in (1, 2, 3)]))
    parts = re.split(r"\n\s*forces \(fx,fy,fz\) for set (\S+) and time\s+\S+\s*\n", text)
    for name, block in zip(parts[1::2], parts[2::2]):
        rows = re.findall(
            rf"^\s*(\d+)\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s*$",
            _until_next(block),  # up to "total force", or the next block where none is printed
            re.MULTILINE,
        )
        ids = np.array([int(r[0]) for r in rows], int)
        values = np.array([[float(v) for v in r[1:]] for r in rows]).reshape(-1, 3)
        (result.tie_forces if name == "NTIE" else result.node_forces).append((ids, values))
    for block in re.split(
        r"\n\s*internal energy \(element, energy\) for set ESPR and time\s+\S+\s*\n", text
    )[1:]:
        rows = re.findall(rf"^\s*(\d+)\s+({_FLOAT})\s*$", _until_next(block), re.MULTILINE)
        result.spring_energy.append(
            (np.array([int(r[0]) for r in rows], int), np.array([float(r[1]) for r in rows]))
        )
    for block in re.split(
        r"\n\s*displacements \(vx,vy,vz\) for set NSPR and time\s+\S+\s*\n", text
    )[1:]:
        rows = re.findall(
            rf"^\s*(\d+)\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s*$",
            _until_next(block),
            re.MULTILINE,
        )
        result.spring_nodes.append(
            (
                np.array([int(r[0]) for r in rows], int),
                np.array([[float(v) for v in r[1:]] for r in rows]).reshape(-1, 3),
            )
        )
    for match in re.finditer(
        rf"total mass for set \S+ and time\s+\S+\s*\n\s*\n?\s*({_FLOAT})", text
    ):
        result.mass.append(float(match.group(1)))
    block = text.split("B U C K L I N G   F A C T O R   O U T P U T")
    if len(block) > 1:
        rows = re.findall(rf"^\s+(\d+)\s+({_FLOAT})\s*$", block[-1], re.MULTILINE)
        result.buckling = np.array([float(v) for _, v in rows])
    return result


def read_history(path: Path, name: str = "NMON") -> tuple[np.ndarray, np.ndarray]:
    """The step times of a nonlinear step's converged increments and the displacements of the
    node set ``name`` at each, ``(k,)`` and ``(k, n, 3)`` (``*NODE PRINT`` once an increment)."""
    text = Path(path).read_text(errors="replace")
    times, values = [], []
    heading = rf"\n\s*displacements \(vx,vy,vz\) for set {name} and time\s+({_FLOAT})\s*\n"
    parts = re.split(heading, text)
    for time_text, block in zip(parts[1::2], parts[2::2]):
        rows = re.findall(
            rf"^\s*\d+\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s*$",
            _until_next(block),
            re.MULTILINE,
        )
        times.append(float(time_text))
        values.append([[float(v) for v in r] for r in rows])
    return np.array(times), np.array(values, dtype=float).reshape(len(times), -1, 3)


# --------------------------------------------------------------------------------------------
# .frd
# --------------------------------------------------------------------------------------------
@dataclass
class FrdResults:
    """Nodal results of a ``.frd`` file (expanded 3D mesh with ``OUTPUT=3D``).

    nodes : (N, 3) expanded node coordinates, row ``i`` for node id ``node_ids[i]``.
    elements : dict element id -> connectivity, as (E,) ids and (E, nn) node ids (frd order).
    blocks : list of (name, value, step, (N, c) array aligned with ``node_ids``); ``value`` is
        the step time or the buckling factor.
    """

    node_ids: np.ndarray
    nodes: np.ndarray
    element_ids: np.ndarray
    connectivity: np.ndarray
    blocks: list[tuple[str, float, int, np.ndarray]]

    def row_of(self, ids: np.ndarray) -> np.ndarray:
        """Rows of the node arrays for frd node ids."""
        lookup = np.full(int(self.node_ids.max()) + 1, -1)
        lookup[self.node_ids] = np.arange(len(self.node_ids))
        return lookup[ids]

    def results(self, name: str) -> list[tuple[float, int, np.ndarray]]:
        return [(v, s, a) for n, v, s, a in self.blocks if n == name]


def _fixed(lines: list[bytes], start: int, width: int, count: int, kind=float) -> np.ndarray:
    """Columns of fixed width from equal-length lines, as an (n, count) array."""
    if not lines:
        return np.zeros((0, count))
    size = len(lines[0])
    blob = b"".join(lines)
    if len(blob) != size * len(lines):  # lines of unequal length: pad them (rare)
        size = max(map(len, lines))
        blob = b"".join(line.ljust(size) for line in lines)
    chars = np.frombuffer(blob, dtype=np.uint8).reshape(len(lines), size)
    cols = chars[:, start : start + width * count].copy()
    text = cols.view(f"S{width}").reshape(len(lines), count)
    return text.astype(kind)


def read_frd(path: Path) -> FrdResults:
    """Read the node, element and result blocks of an ASCII ``.frd`` (ccx 2.20 long format:
    ids as I10, values as E12.5)."""
    lines = Path(path).read_bytes().splitlines()
    node_ids: np.ndarray | None = None
    nodes: np.ndarray | None = None
    element_ids: np.ndarray | None = None
    connectivity: np.ndarray | None = None
    blocks: list[tuple[str, float, int, np.ndarray]] = []
    i, n = 0, len(lines)
    while i < n:
        line = lines[i]
        head = line[:6]
        if head == b"    2C":
            j = i + 1
            while not lines[j].startswith(b" -3"):
                j += 1
            body = lines[i + 1 : j]
            node_ids = _fixed(body, 3, 10, 1, np.int64)[:, 0]
            nodes = _fixed(body, 13, 12, 3)
            i = j + 1
        elif head == b"    3C":
            j = i + 1
            while not lines[j].startswith(b" -3"):
                j += 1
            body = lines[i + 1 : j]
            starts = [k for k, text in enumerate(body) if text.startswith(b" -1")]
            heads = [body[k] for k in starts]
            element_ids = _fixed(heads, 3, 10, 1, np.int64)[:, 0]
            per = np.diff(starts + [len(body)])
            rows = [b"".join(body[k + 1 : k + c]).replace(b" -2", b"") for k, c in zip(starts, per)]
            width = max(len(r) for r in rows) // 10
            rows = [r.ljust(10 * width) for r in rows]
            chars = np.frombuffer(b"".join(rows), np.uint8).reshape(len(rows), 10 * width)
            text = chars.copy().view("S10").reshape(len(rows), width)
            connectivity = np.where(text == b" " * 10, b"-1", text).astype(np.int64)
            i = j + 1
        elif line.startswith(b"  100CL"):
            if node_ids is None:
                raise SolverError(
                    f"{path}: a result block comes before the nodes; is the .frd complete?"
                )
            value = float(line[12:24])
            step = int(line[58:63]) if len(line) >= 63 and line[58:63].strip() else 0
            name = lines[i + 1][5:13].strip().decode()
            ncomp = int(lines[i + 1][13:18])
            j = i + 2
            while lines[j].startswith(b" -5"):
                j += 1
            start = j
            while not lines[j].startswith(b" -3"):
                j += 1
            body = lines[start:j]
            ids = _fixed(body, 3, 10, 1, np.int64)[:, 0]
            width = (len(body[0]) - 13) // 12 if body else ncomp
            values = _fixed(body, 13, 12, width)
            aligned = np.zeros((len(node_ids), width))
            lookup = np.full(int(node_ids.max()) + 1, -1)
            lookup[node_ids] = np.arange(len(node_ids))
            aligned[lookup[ids]] = values
            blocks.append((name, value, step, aligned))
            i = j + 1
        else:
            i += 1
    if node_ids is None or nodes is None or element_ids is None or connectivity is None:
        raise SolverError(f"{path} holds no mesh; did CalculiX finish?")
    return FrdResults(node_ids, nodes, element_ids, connectivity, blocks)


#: frd order of a C3D20(R) expanded from an S8R: bottom corners, top corners, bottom mid-sides,
#: mid-thickness corners, top mid-sides (pinned in tests/test_structure.py)
HE20_BOTTOM = np.r_[0:4, 8:12]
HE20_TOP = np.r_[4:8, 16:20]


def surface_nodes(frd: FrdResults, n_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``(bottom, top)`` rows (E, 8) of the expanded nodes on the two surfaces of every shell
    element, in the S8R's node order (element ``e`` is frd element ``e + 1``)."""
    if frd.connectivity.shape[1] != 20:
        raise SolverError("only S8R models (expanded to C3D20R) are read back")
    # the shells come first; springs (two nodes each) follow them
    shells = np.flatnonzero(frd.element_ids <= n_elements)
    order = shells[np.argsort(frd.element_ids[shells])]
    conn = frd.connectivity[order]
    if len(conn) != n_elements or frd.element_ids[order][-1] != n_elements:
        raise SolverError(f"the .frd holds {len(conn)} elements, the model {n_elements}")
    return frd.row_of(conn[:, HE20_BOTTOM]), frd.row_of(conn[:, HE20_TOP])


def read_knots(deck: Path) -> np.ndarray:
    """(k,) int: model node indices (0-based) where CalculiX generated a KNOT (from the
    ``.12d`` expansion map that ccx 2.15+ writes next to the deck)."""
    path = Path(deck).with_suffix(".12d")
    if not path.is_file():
        return np.zeros(0, int)
    found = re.findall(r"a KNOT was generated in node\s+(\d+)", path.read_text(errors="replace"))
    return np.array(sorted({int(v) - 1 for v in found}), int)
