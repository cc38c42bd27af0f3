"""The static cases in CalculiX: one deck, or several run side by side.

Each static step makes CalculiX rebuild and factorise the constrained system (the knots of the
rib/sheet junctions dominate), and SPOOLES gains little from a second thread: two steps of the
demo take 25 s on one thread and 17.9 s on two. So the cases are split into as many decks as
there are threads, each run on one thread at the same time, when the machine's memory holds
that many CalculiX processes (``MEMORY_PER_KNOT`` per knot, measured on the examples, against
``MEMORY_SHARE`` of the machine's total memory: the total, not what is free, so one machine
always splits the same way). Otherwise one deck runs on all threads. SPOOLES' results differ in
the last digits between one and several threads, never between runs of one job on one machine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from . import ccx
from .mesh import ShellModel

#: CalculiX's memory per process: a base and a share per junction node (a knot), MB; from
#: the barrel vault (1.3 GB, 3443 knots) and the pavilion (3.3 GB, 9375 knots)
MEMORY_BASE_MB = 150.0
MEMORY_PER_KNOT_MB = 0.34
#: split only while the processes' estimate stays within this share of the total memory
MEMORY_SHARE = 0.5
#: the model data the static decks and the buckling deck of the analysed mesh read
#: (``*INCLUDE``): one copy of the mesh in the output folder, not one a deck
MODEL = "model.inp"


@dataclass(frozen=True)
class StaticResults:
    """The static cases' results in case order, whichever decks ran them."""

    dat: ccx.DatResults
    displacement: list[np.ndarray]
    stress: list[np.ndarray]
    bottom: np.ndarray
    top: np.ndarray
    knots: np.ndarray
    seconds: float
    peak_memory_mb: float
    log: Path
    decks: int


def junction_nodes(shell: ShellModel) -> int:
    """The nodes shared by a rib and a sheet element (CalculiX makes each a knot)."""
    if shell.side is None:
        return 0
    nq = len(shell.quads)
    ribs = shell.side[:nq] >= 0
    on_rib = np.zeros(len(shell.nodes), bool)
    on_sheet = np.zeros(len(shell.nodes), bool)
    on_rib[shell.quads[ribs].ravel()] = True
    on_sheet[shell.quads[~ribs].ravel()] = True
    return int((on_rib & on_sheet).sum())


def deck_count(shell: ShellModel, cases: int, threads: int, total_memory_mb: float) -> int:
    """How many decks to run side by side (see the module docstring)."""
    estimate = MEMORY_BASE_MB + MEMORY_PER_KNOT_MB * junction_nodes(shell)
    fits = int(MEMORY_SHARE * total_memory_mb // max(estimate, 1.0))
    return max(1, min(threads, cases, fits))


def run_static(
    shell: ShellModel,
    cases: list[ccx.LoadCase],
    folder: Path,
    threads: int,
    timeout: float,
    executable: str,
) -> StaticResults:
    """Run the static ``cases`` (``static.inp``, or ``static-1.inp``... side by side) and
    gather their results in case order; a case ``superposed`` of others is their sum."""
    solved = [case for case in cases if not case.superposed]
    run = _run_solved(shell, solved, folder, threads, timeout, executable)
    if len(solved) == len(cases):
        return run
    return superpose(shell, run, solved, cases)


def superpose(
    shell: ShellModel,
    run: StaticResults,
    solved: list[ccx.LoadCase],
    cases: list[ccx.LoadCase],
) -> StaticResults:
    """``run``'s results of the ``solved`` cases, for every one of ``cases``: a superposed
    case's displacements, stresses, reactions and spring forces are the sum of its terms'
    (a linear model: stresses are components, not yet von Mises; the springs' energies are
    quadratic, so their signed forces are summed and the energies made again from them)."""
    from .bolt_checks import case_spring_forces, spring_energies

    index = {case.name: k for k, case in enumerate(solved)}
    springs = case_spring_forces(shell, run.dat) if run.dat.spring_energy else []
    dat = ccx.DatResults(mass=run.dat.mass, buckling=run.dat.buckling)
    displacement, stress = [], []

    def total(values: list[np.ndarray], terms: list[tuple[int, float]]) -> np.ndarray:
        return sum((factor * values[k] for k, factor in terms), np.zeros_like(values[0]))

    def same_ids(pairs: list[tuple[np.ndarray, np.ndarray]], terms) -> tuple:
        ids = pairs[terms[0][0]][0]
        if any(not np.array_equal(pairs[k][0], ids) for k, _ in terms):
            raise ccx.SolverError("superposed cases whose printed node sets differ")
        return ids, total([values for _, values in pairs], terms)

    for case in cases:
        if case.superposed:
            missing = [name for name, _ in case.superposed if name not in index]
            if missing:
                raise ValueError(f"case {case.name} superposes unsolved cases {missing}")
            terms = [(index[name], factor) for name, factor in case.superposed]
        else:
            terms = [(index[case.name], 1.0)]
        displacement.append(total(run.displacement, terms))
        stress.append(total(run.stress, terms))
        dat.forces.append(total(run.dat.forces, terms))
        dat.node_forces.append(same_ids(run.dat.node_forces, terms))
        if run.dat.tie_forces:
            dat.tie_forces.append(same_ids(run.dat.tie_forces, terms))
        if springs:
            dat.spring_nodes.append(same_ids(run.dat.spring_nodes, terms))
            ids = run.dat.spring_energy[terms[0][0]][0]
            dat.spring_energy.append((ids, spring_energies(shell, total(springs, terms), ids)))
    return replace(run, dat=dat, displacement=displacement, stress=stress)


def _run_solved(
    shell: ShellModel,
    cases: list[ccx.LoadCase],
    folder: Path,
    threads: int,
    timeout: float,
    executable: str,
) -> StaticResults:
    """Run the ``cases`` in CalculiX (see :func:`run_static`)."""
    import psutil

    decks = deck_count(shell, len(cases), threads, psutil.virtual_memory().total / 2**20)
    if decks == 1:
        paths = [
            ccx.write_deck(
                shell,
                folder / "static.inp",
                cases,
                title="fabpanel static",
                shared_model=MODEL,
                replace_shared=True,
            )
        ]
        runs = [ccx.run_ccx(paths[0], threads, timeout, executable)]
    else:
        size = math.ceil(len(cases) / decks)
        chunks = [cases[k : k + size] for k in range(0, len(cases), size)]
        paths = [
            ccx.write_deck(
                shell,
                folder / f"static-{k + 1}.inp",
                chunk,
                title=f"fabpanel static {k + 1}",
                shared_model=MODEL,
                replace_shared=k == 0,
            )
            for k, chunk in enumerate(chunks)
        ]
        runs = ccx.run_ccx_together(paths, 1, timeout, executable)
    merged = ccx.DatResults()
    displacement, stress = [], []
    bottom = top = np.zeros((0, 8), int)
    for k, run in enumerate(runs):
        dat, frd = ccx.read_dat(run.dat), ccx.read_frd(run.frd)
        merged.forces += dat.forces
        merged.node_forces += dat.node_forces
        merged.spring_energy += dat.spring_energy
        merged.spring_nodes += dat.spring_nodes
        merged.tie_forces += dat.tie_forces
        merged.mass += dat.mass if k == 0 else []
        displacement += [a for _, _, a in sorted(frd.results("DISP"), key=lambda r: r[1])]
        stress += [a for _, _, a in sorted(frd.results("STRESS"), key=lambda r: r[1])]
        if k == 0:
            bottom, top = ccx.surface_nodes(frd, shell.n_elements)
    if len(displacement) != len(cases) or len(merged.forces) != len(cases):
        raise ccx.SolverError(
            f"CalculiX wrote {len(displacement)} displacement and {len(merged.forces)} "
            f"reaction blocks for {len(cases)} load cases"
        )
    return StaticResults(
        dat=merged,
        displacement=displacement,
        stress=stress,
        bottom=bottom,
        top=top,
        knots=ccx.read_knots(paths[0]),
        seconds=max(r.seconds for r in runs),
        peak_memory_mb=sum(r.peak_memory_mb for r in runs),
        log=runs[0].log,
        decks=len(runs),
    )
