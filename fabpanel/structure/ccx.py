"""The one adapter to CalculiX (``ccx``, tested with 2.20 as packaged by Debian): write the deck,
run the solver, read ``.dat`` and ``.frd`` (the readers are in :mod:`.ccx_results`, re-exported
here). Every quirk it relies on is pinned in ``tests/test_kernel_quirks.py`` or
``tests/test_structure.py``; the measured facts are in ``notes/fem.md``.

Quirks handled here:

- each load case is one ``*STATIC`` step with ``OP=NEW`` loads, combined linearly afterwards;
  a ``*BUCKLE`` step drops all earlier loads and scales only its own, so it carries the fully
  factored combination;
- ``*NODE FILE`` / ``*EL FILE`` stay at the default ``OUTPUT=3D``: stresses at the expanded
  top and bottom surface nodes include bending (``OUTPUT=2D`` averages it away, 6x low);
- ``RF`` is the external force: reaction plus loads applied at the supported node;
- buckling under stabilising loads gives negative factors; the caller keeps the positive ones;
- ccx exits 0 on some errors: the log is searched for ``*ERROR`` too.

Threads: ``OMP_NUM_THREADS`` and the ``CCX_NPROC_*`` variables (ccx uses one thread unless told).
"""

from __future__ import annotations

import gzip
import logging
import os
import re
import resource
import shutil
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SolverError
from ..parallel import child_preexec
from .ccx_results import (
    DatResults,
    FrdResults,
    read_dat,
    read_frd,
    read_history,
    read_knots,
    surface_nodes,
)
from .loads import GRAVITY
from .mesh import ShellModel

__all__ = [
    "LIMIT_REACHED",
    "CcxMissing",
    "CcxRun",
    "DatResults",
    "FrdResults",
    "LoadCase",
    "NonlinearStep",
    "ccx_version",
    "combine",
    "find_ccx",
    "gravity_vector",
    "read_dat",
    "read_frd",
    "read_history",
    "read_knots",
    "require_ccx",
    "run_ccx",
    "run_ccx_together",
    "surface_nodes",
    "write_deck",
]

log = logging.getLogger(__name__)

#: what to tell a user whose machine has no ccx
INSTALL_HINT = "install CalculiX with `sudo apt-get install calculix-ccx`"


class CcxMissing(SolverError):
    """``ccx`` is not on the PATH. The message says how to install it."""

    exit_code = 2


def find_ccx() -> str | None:
    """Path of the ``ccx`` executable (``FABPANEL_CCX`` or the PATH), ``None`` if missing."""
    explicit = os.environ.get("FABPANEL_CCX")
    if explicit:
        return shutil.which(explicit)
    return shutil.which("ccx")


def require_ccx() -> str:
    path = find_ccx()
    if path is None:
        raise CcxMissing(f"CalculiX (ccx) was not found on the PATH; {INSTALL_HINT}")
    return path


def ccx_version(executable: str) -> str:
    """The version line ccx prints with ``-v`` ("2.20"), or "" if it says none."""
    try:
        out = subprocess.run(
            [executable, "-v"], capture_output=True, text=True, timeout=20, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return ""
    found = re.search(r"[Vv]ersion\s+([\d.]+)", out.stdout + out.stderr)
    return found.group(1) if found else ""


# --------------------------------------------------------------------------------------------
# load cases and the deck
# --------------------------------------------------------------------------------------------
#: nodal load components below this share of a case's largest are not written: the
#: roundings of zeros (x forces of a pressure on faces parallel to x) that were a third of
#: the demo's wind decks; what they leave out is below a ten-thousandth of a newton a node
LOAD_FLOOR = 1e-9


@dataclass(frozen=True)
class LoadCase:
    """One linear load case.

    name : short label ("G", "S", "W+x").
    gravity : (3,) acceleration, mm/s2, applied to every element's mass (``*DLOAD GRAV``), or
        ``None``. Lumped masses of the model are loaded as nodal forces with it.
    forces : (n, 3) nodal forces, N, or ``None`` (``*CLOAD``).
    superposed : ``((name, factor), ...)`` when this case's loads are exactly that sum of other
        cases' (each solved, none superposed itself): its results are the same sum of theirs
        (the model is linear) and CalculiX does not solve it; empty for a case of its own.
    """

    name: str
    gravity: np.ndarray | None = None
    forces: np.ndarray | None = None
    superposed: tuple[tuple[str, float], ...] = ()

    def scaled(self, factor: float) -> LoadCase:
        return LoadCase(
            self.name,
            None if self.gravity is None else factor * self.gravity,
            None if self.forces is None else factor * self.forces,
        )


def combine(cases: list[LoadCase], factors: list[float], name: str) -> LoadCase:
    """The load case ``sum(factor * case)`` (several gravity cases add up)."""
    gravity, forces = None, None
    for case, factor in zip(cases, factors):
        if factor == 0:
            continue
        if case.gravity is not None:
            gravity = factor * case.gravity if gravity is None else gravity + factor * case.gravity
        if case.forces is not None:
            forces = factor * case.forces if forces is None else forces + factor * case.forces
    return LoadCase(name, gravity, forces)


@dataclass(frozen=True)
class NonlinearStep:
    """A geometrically nonlinear static step (``*STEP, NLGEOM``): ``case`` ramped from nothing
    at step time 0 to all of it at 1 by CalculiX's automatic increments (``first``, ``largest``
    and ``smallest`` fractions of the step, at most ``increments``); the ``monitor`` nodes'
    displacements are printed at every converged increment (:func:`read_history`). Past a limit
    point CalculiX cuts the increment down to ``smallest`` and stops with
    :data:`LIMIT_REACHED`."""

    case: LoadCase
    monitor: np.ndarray
    first: float = 0.2
    largest: float = 0.2
    smallest: float = 1e-3
    increments: int = 200


#: how CalculiX ends a load-controlled nonlinear step that meets a limit point
LIMIT_REACHED = "increment size smaller than minimum"


def _ids(values: np.ndarray, per_line: int = 16) -> str:
    values = np.asarray(values).ravel() + 1
    lines = [", ".join(map(str, values[i : i + per_line])) for i in range(0, len(values), per_line)]
    return "\n".join(lines)


def _rows(table: np.ndarray, ids: np.ndarray) -> str:
    """``id, v1, v2...`` lines (ids 1-based)."""
    body = np.c_[ids + 1, table]
    fmt = "%d" + ", %d" * table.shape[1] if table.dtype.kind in "iu" else None
    if fmt:
        return "\n".join(fmt % tuple(row) for row in body)
    return "\n".join(f"{int(row[0])}, " + ", ".join(f"{v:.9g}" for v in row[1:]) for row in body)


def write_deck(
    model: ShellModel,
    path: Path,
    cases: Sequence[LoadCase] = (),
    buckle: LoadCase | None = None,
    modes: int = 10,
    title: str = "fabpanel",
    nonlinear: NonlinearStep | None = None,
    shared_model: str | None = None,
    replace_shared: bool = False,
) -> Path:
    """Write a CalculiX deck: the mesh, sections, supports, one ``*STATIC`` step per case,
    optionally one ``*BUCKLE`` step with ``modes`` factors and optionally one geometrically
    nonlinear step. Node and element numbers are the model's indices + 1. Returns ``path``.

    shared_model : a file name beside ``path`` for the model data (everything before the first
        step), which the deck reads with ``*INCLUDE``: the decks of one model share it (the
        demo's two static decks and its buckling deck held three copies of a 3.4 MB mesh). It
        is written where it is missing or ``replace_shared`` (the first deck of an analysis);
        where it holds another model's data the deck keeps its own model data inline."""
    path = Path(path)
    nq = len(model.quads)
    header = f"** {title}: written by fabpanel (units N, mm, t, s)"
    out: list[str] = []
    out.append("*NODE, NSET=NALL")
    out.append(
        "\n".join(f"{i + 1}, {x:.9g}, {y:.9g}, {z:.9g}" for i, (x, y, z) in enumerate(model.nodes))
    )
    all_sets = []
    for g, group in enumerate(model.groups):
        for conn, etype, offset in ((model.quads, group.element, 0), (model.triangles, "S6", nq)):
            members = np.nonzero(model.group[offset : offset + len(conn)] == g)[0]
            if len(members) == 0:
                continue
            name = f"E{group.name}{'_S6' if etype == 'S6' else ''}"
            all_sets.append(name)
            out.append(f"*ELEMENT, TYPE={etype}, ELSET={name}")
            out.append(_rows(conn[members] + 1, members + offset))
    out.append("*ELSET, ELSET=EALL")
    out.append(", ".join(all_sets))
    supported = np.unique(model.supports)
    if len(supported):
        out += ["*NSET, NSET=NSUPP", _ids(supported)]
    for c, (nodes, _) in enumerate(model.constraints):
        out += [f"*NSET, NSET=NFIX{c}", _ids(np.unique(nodes))]
    # the lumped masses when any is non-zero (None otherwise)
    lumped_mass = model.lumped_mass
    if lumped_mass is not None and not np.any(lumped_mass):
        lumped_mass = None
    for g, group in enumerate(model.groups):
        mat = model.material
        density = mat.density * group.density_factor * 1e-3  # kg/mm3 -> t/mm3
        out += [
            f"*MATERIAL, NAME=M{group.name}",
            "*ELASTIC",
            f"{mat.E:.9g}, {mat.nu:.9g}",
            "*DENSITY",
            f"{density:.9g}",
        ]
        sets = [s for s in all_sets if s == f"E{group.name}" or s == f"E{group.name}_S6"]
        for name in sets:
            out += [
                f"*SHELL SECTION, ELSET={name}, MATERIAL=M{group.name}",
                f"{group.thickness:.9g}",
            ]
    springs = model.springs if model.springs is not None and len(model.springs.nodes) else None
    if springs is not None:
        out += _spring_cards(springs, nq + len(model.triangles))
    ties = model.ties if model.ties is not None and len(model.ties.nodes) else None
    tied = ties is not None
    if ties is not None:
        out += _tie_cards(ties)
        out += ["*NSET, NSET=NTIE", _ids(ties.nodes)]
    if nonlinear is not None:  # model data: before the first step
        out += ["*NSET, NSET=NMON", _ids(np.unique(nonlinear.monitor))]
    out.append("*BOUNDARY")
    if len(supported):
        out.append("NSUPP, 1, 3")
    for c, (_, dofs) in enumerate(model.constraints):
        out += [f"NFIX{c}, {d}, {d}" for d in dofs]
    lumped_nodes = np.nonzero(lumped_mass)[0] if lumped_mass is not None else np.zeros(0, int)
    text = "\n".join(out) + "\n"
    if shared_model is not None and _shared(path.parent / shared_model, text, replace_shared):
        out = [header, f"*INCLUDE, INPUT={shared_model}"]
    else:
        out.insert(0, header)

    def loads(case: LoadCase) -> list[str]:
        lines = ["*DLOAD, OP=NEW"]
        if case.gravity is not None and np.any(case.gravity):
            g = float(np.linalg.norm(case.gravity))
            d = case.gravity / g
            lines.append(f"EALL, GRAV, {g:.9g}, {d[0]:.9g}, {d[1]:.9g}, {d[2]:.9g}")
        forces = np.zeros((len(model.nodes), 3)) if case.forces is None else case.forces.copy()
        if case.gravity is not None and lumped_mass is not None and len(lumped_nodes):
            forces += lumped_mass[:, None] * case.gravity[None] * 1e-3
        lines.append("*CLOAD, OP=NEW")
        # a component below LOAD_FLOOR of the case's largest is the rounding of a zero (a
        # pressure square to an axis): left out, as the digits past the ninth of the rest
        floor = LOAD_FLOOR * float(np.abs(forces).max(initial=0.0))
        node, dof = np.nonzero(np.abs(forces) > floor)
        lines += [f"{i + 1}, {d + 1}, {forces[i, d]:.9g}" for i, d in zip(node, dof)]
        return lines

    for s, case in enumerate(cases):
        out += [f"** load case {case.name}", "*STEP", "*STATIC"] + loads(case)
        if len(supported):
            # per node (the reactions per support) and the total
            out += ["*NODE PRINT, NSET=NSUPP, TOTALS=YES", "RF"]
        if tied:
            # CalculiX leaves a tie's pull on a restrained master out of its RF
            # (balance.with_tie_pull)
            out += ["*NODE PRINT, NSET=NTIE", "RF"]
        if s == 0:
            out += ["*EL PRINT, ELSET=EALL, TOTALS=ONLY", "EMAS"]
        if springs is not None:
            # no spring forces are printed: their energies and the nodes' displacements are
            out += ["*EL PRINT, ELSET=ESPR", "ELSE", "*NODE PRINT, NSET=NSPR", "U"]
        out += ["*NODE FILE", "U", "*EL FILE", "S", "*END STEP"]
    if buckle is not None:
        out += [f"** buckling under {buckle.name}", "*STEP", "*BUCKLE", f"{int(modes)}"]
        out += loads(buckle)
        if not cases:
            out += ["*EL PRINT, ELSET=EALL, TOTALS=ONLY", "EMAS"]
        out += ["*NODE FILE", "U", "*END STEP"]
    if nonlinear is not None:
        n = nonlinear
        out += [
            f"** {n.case.name} ramped, geometrically nonlinear",
            f"*STEP, NLGEOM, INC={n.increments}",
        ]
        out += ["*STATIC", f"{n.first:.6g}, 1.0, {n.smallest:.6g}, {n.largest:.6g}"]
        out += loads(n.case)
        out += ["*NODE PRINT, NSET=NMON", "U", "*END STEP"]
    path.write_text("\n".join(out) + "\n")
    return path


def _shared(path: Path, text: str, replace: bool) -> bool:
    """Whether the shared model file ``path`` holds ``text``, written first where it is
    missing or ``replace`` is set."""
    if replace or not path.is_file():
        path.write_text(text)
        return True
    return path.read_text() == text


def _tie_cards(ties) -> list[str]:
    """``*EQUATION`` for each tied node and translation: ``u - sum w u_master = 0`` (weights
    below 1e-12 left out), four terms a line as CalculiX reads them."""
    out = ["*EQUATION"]
    for node, masters, weights in zip(ties.nodes, ties.masters, ties.weights, strict=True):
        keep = np.abs(weights) > 1e-12
        for d in (1, 2, 3):
            terms = [f"{node + 1}, {d}, 1.0"]
            terms += [f"{m + 1}, {d}, {-w:.12g}" for m, w in zip(masters[keep], weights[keep])]
            out.append(str(len(terms)))
            out += [", ".join(terms[i : i + 4]) for i in range(0, len(terms), 4)]
    return out


def _spring_cards(springs, first: int) -> list[str]:
    """``SPRING2`` elements, one per node pair and local direction of non-zero stiffness
    (pair ``c``, direction ``d`` is element ``first + 3 c + d + 1``), each pair with its own
    ``*ORIENTATION`` (its frame's rows 1 and 2)."""
    out: list[str] = []
    for c, ((a, b), frame, k) in enumerate(
        zip(springs.nodes, springs.frames, springs.stiffness, strict=True)
    ):
        x, y = frame[0], frame[1]
        out += [
            f"*ORIENTATION, NAME=OS{c + 1}",
            ", ".join(f"{v:.12g}" for v in (*x, *y)),
        ]
        for d in np.flatnonzero(k > 0):
            element = first + 3 * c + d + 1
            out += [
                f"*ELEMENT, TYPE=SPRING2, ELSET=ES{c + 1}_{d + 1}",
                f"{element}, {a + 1}, {b + 1}",
                f"*SPRING, ELSET=ES{c + 1}_{d + 1}, ORIENTATION=OS{c + 1}",
                f"{d + 1}, {d + 1}",
                f"{float(k[d]):.9e}",
            ]
    elements = first + 1 + np.flatnonzero(springs.stiffness.ravel() > 0)
    out += ["*ELSET, ELSET=ESPR", _ids(elements - 1)]
    out += ["*NSET, NSET=NSPR", _ids(np.unique(springs.nodes))]
    return out


# --------------------------------------------------------------------------------------------
# running
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CcxRun:
    """A finished ccx run: the files it wrote and what it cost."""

    deck: Path
    dat: Path
    frd: Path
    log: Path
    seconds: float
    peak_memory_mb: float
    threads: int


def run_ccx(
    deck: Path,
    threads: int = 1,
    timeout: float | None = None,
    executable: str | None = None,
    tolerate: str | None = None,
) -> CcxRun:
    """Run ccx on ``deck`` in its folder. Raises :class:`CcxMissing` without ccx and
    :class:`~fabpanel.errors.SolverError` (with the first error line of the log) when the run
    fails; a run whose only error line contains ``tolerate`` (such as :data:`LIMIT_REACHED`)
    has not failed."""
    return run_ccx_together([deck], threads, timeout, executable, tolerate)[0]


def run_ccx_together(
    decks: list[Path],
    threads: int = 1,
    timeout: float | None = None,
    executable: str | None = None,
    tolerate: str | None = None,
) -> list[CcxRun]:
    """Run ccx on each of ``decks`` at the same time, ``threads`` each, all started from this
    thread (a ``preexec_fn`` is not safe from other threads) and waited for; the first failure
    raises as :func:`run_ccx` does, after every process has ended."""
    executable = executable or require_ccx()
    env = dict(os.environ)
    threads = max(1, int(threads))
    for key in (
        "OMP_NUM_THREADS",
        "CCX_NPROC_STIFFNESS",
        "CCX_NPROC_EQUATION_SOLVER",
        "CCX_NPROC_RESULTS",
        "NUMBER_OF_CPUS",
    ):
        env[key] = str(threads)
    started = time.perf_counter()
    running = []
    for deck in map(Path, decks):
        stem = deck.with_suffix("")
        log_path = stem.parent / f"{stem.name}.log"
        handle = log_path.open("w")
        proc = subprocess.Popen(
            [executable, "-i", stem.name],
            cwd=stem.parent,
            env=env,
            stdout=handle,
            stderr=subprocess.STDOUT,
            preexec_fn=child_preexec,  # noqa: PLW1509 - started from the calling thread only
        )
        running.append((deck, stem, log_path, handle, proc))
    try:
        return _finish(running, started, timeout, threads, tolerate)
    except BaseException:  # a signal or an error: no CalculiX is left running
        for *_, proc in running:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        raise


def _finish(
    running: list, started: float, timeout: float | None, threads: int, tolerate: str | None
) -> list[CcxRun]:
    """Wait for the ``running`` CalculiX processes and read how each ended."""
    runs, failure = [], None
    for deck, stem, log_path, handle, proc in running:
        left = None if timeout is None else max(0.0, timeout - (time.perf_counter() - started))
        try:
            proc.wait(timeout=left)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            failure = failure or SolverError(
                f"CalculiX did not finish {deck.name} within {timeout:g} s; use a "
                f"coarser [structure] element_size or a longer timeout"
            )
        finally:
            handle.close()
        seconds = time.perf_counter() - started
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
        text = log_path.read_text(errors="replace")
        error = next(
            (
                line.strip()
                for line in text.splitlines()
                if "*ERROR" in line and not (tolerate and tolerate in line)
            ),
            None,
        )
        dat, frd = stem.with_suffix(".dat"), stem.with_suffix(".frd")
        # ccx exits 201 at a tolerated error (a limit point reached)
        tolerated = bool(tolerate) and tolerate in text
        code_failed = proc.returncode != 0 and not tolerated
        if failure is None and (code_failed or error or not dat.is_file()):
            detail = error or f"exit code {proc.returncode}"
            failure = SolverError(f"CalculiX failed on {deck.name}: {detail} (log: {log_path})")
        log.info("ccx %s: %.1f s, %d threads", deck.name, seconds, threads)
        runs.append(CcxRun(deck, dat, frd, log_path, seconds, peak, threads))
    if failure is not None:
        raise failure
    return runs


#: what CalculiX writes beside a deck that the report does not need once it is read
RESULT_SUFFIXES = (".frd", ".12d", ".sta", ".cvg")


def tidy_results(folder: Path, since: float) -> None:
    """Tidy what CalculiX wrote in ``folder`` beside a deck since ``since`` (a ``time.time()``):
    the result files read already (``RESULT_SUFFIXES``, ``spooles.out``) removed, the printed
    results (``.dat``, 3.5 MB a static deck on the demo) gzip-compressed to ``.dat.gz``.
    Nothing older, and nothing that is not beside a deck, is touched."""
    stems = {deck.stem for deck in folder.glob("*.inp")}
    for path in sorted(folder.iterdir()):
        if not path.is_file() or path.stat().st_mtime < since - 1.0:
            continue
        if (path.suffix in RESULT_SUFFIXES and path.stem in stems) or path.name == "spooles.out":
            path.unlink()
        elif path.suffix == ".dat" and path.stem in stems:
            gzipped(path)


def gzipped(path: Path) -> Path:
    """``path`` compressed to ``path.gz`` (no time stamp or name inside: the same text gives
    the same bytes), the original removed; written beside and renamed, so an interrupted run
    leaves one whole file."""
    target = path.with_name(path.name + ".gz")
    partial = path.with_name(path.name + ".gz.part")
    with (
        open(path, "rb") as source,
        open(partial, "wb") as raw,
        gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=6) as out,
    ):
        shutil.copyfileobj(source, out)
    partial.replace(target)
    path.unlink()
    return target


def gravity_vector(magnitude: float = GRAVITY) -> np.ndarray:
    return np.array([0.0, 0.0, -magnitude])
