"""Linear buckling (LBA) of the governing ULS combination, and the mode's extent.

CalculiX's ``*BUCKLE`` runs on the combination with the largest compressive membrane force
(chosen in :mod:`.analysis`); at least ``MIN_POSITIVE_MODES`` positive factors are wanted, so
the request is doubled (up to four times) while fewer come back. Each positive mode is
reported with its factor and the panels it moves (:func:`.checks.mode_extent`); a mesh of
fewer than ``LOCAL_BUCKLING_DIVISIONS`` elements per panel side is said to show the global
modes only. The mesh study is :mod:`.convergence`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Issue
from . import ccx
from .checks import mode_extent, panel_labels
from .mesh import ShellModel
from .static import MODEL

#: fewer elements per panel side than this cannot resolve a sheet's local buckling between its
#: ribs (one half-wave per panel; S8R plates need about 4 per half-wave for a few per cent)
LOCAL_BUCKLING_DIVISIONS = 4
#: at least this many positive buckling factors are reported (thesis: "not fewer than 5")
MIN_POSITIVE_MODES = 5


@dataclass(frozen=True)
class Buckling:
    """What the buckling run found.

    factors : every factor CalculiX returned (positive and negative), in its order.
    modes : the positive modes, smallest factor first: ``mode``, ``factor``, ``panels`` (the
        first 20 it moves) and ``panel_count``.
    mode_shape : (n, 3) float, the first positive mode at the shell nodes, largest length 1.
    first : the smallest positive factor (inf when none); required : 1 / knock-down.
    note : why the factors cover the global modes only (a coarse mesh), or None.
    divisions : elements per panel side (from the top sheets' element count).
    run : the CalculiX run; issues : what the run leaves to say.
    beside : the runs of the decks run beside the first one (the mesh study's coarser mesh).
    """

    factors: np.ndarray
    modes: list[dict]
    mode_shape: np.ndarray | None
    first: float
    required: float
    note: str | None
    divisions: int
    run: ccx.CcxRun
    issues: tuple[Issue, ...]
    beside: tuple[ccx.CcxRun, ...] = ()


def buckle_deck(shell, case, folder: Path, modes: int, stem: str = "buckle") -> Path:
    """Write the ``*BUCKLE`` deck of ``case`` asking ``modes`` (``folder/stem.inp``); the main
    one reads the static decks' model data (:data:`.static.MODEL`) where it is the same."""
    return ccx.write_deck(
        shell,
        folder / f"{stem}.inp",
        buckle=case,
        modes=modes,
        title=f"fabpanel buckling under {case.name}",
        shared_model=MODEL if stem == "buckle" else None,
    )


def buckle_results(run: ccx.CcxRun) -> tuple[np.ndarray, list[np.ndarray]]:
    """``(factors, mode shapes)`` of a finished ``*BUCKLE`` run."""
    dat = ccx.read_dat(run.dat)
    frd = ccx.read_frd(run.frd)
    blocks = frd.results("DISP")
    factors = dat.buckling if len(dat.buckling) else np.array([v for v, _, _ in blocks])
    shapes = [a for _, _, a in blocks][-len(factors) :] if len(factors) else []
    return np.asarray(factors, float), shapes


def buckle(
    shell, case, folder: Path, modes: int, st, executable: str, stem="buckle", beside=()
) -> tuple[np.ndarray, list[np.ndarray], ccx.CcxRun, list[ccx.CcxRun]]:
    """``(factors, mode shapes, run, beside's runs)`` of a ``*BUCKLE`` run of ``case`` asking
    ``modes``, with the decks ``beside`` (written by the caller) run at the same time."""
    deck = buckle_deck(shell, case, folder, modes, stem)
    # one thread each: SPOOLES on two threads let the higher buckling factors of a model with
    # spring joints vary in their fourth digit from run to run (751.1 / 751.2), and the same
    # job must give the same output; a second thread gains SPOOLES about 12 % (notes/fem.md)
    runs = ccx.run_ccx_together([deck, *beside], 1, st.timeout, executable)
    factors, shapes = buckle_results(runs[0])
    return factors, shapes, runs[0], runs[1:]


def linear_buckling(
    shell: ShellModel,
    cases,
    governing,
    surfaces,
    panel_ids,
    job,
    folder: Path,
    executable: str,
    beside=(),
) -> Buckling:
    """The buckling run of the ``governing`` combination of ``cases``; ``surfaces`` are the
    (bottom, top) rows of the expanded nodes (:func:`.ccx.surface_nodes`); the decks ``beside``
    run at the same time as the first run (their runs in :attr:`Buckling.beside`)."""
    st = job.structure
    bottom, top = surfaces
    case = ccx.combine(cases, list(governing.factors), governing.name)
    asked = st.buckling_modes
    factors, shapes, run, beside_runs = buckle(
        shell, case, folder, asked, st, executable, beside=beside
    )
    if (factors > 0).sum() < MIN_POSITIVE_MODES and asked < 4 * st.buckling_modes:
        asked *= 2
        factors, shapes, run, _ = buckle(shell, case, folder, asked, st, executable)
    positive = np.nonzero(factors > 0)[0]
    positive = positive[np.argsort(factors[positive])]
    el_panel, _ = panel_labels(shell)
    modes: list[dict] = []
    mode_shape = None
    for rank, j in enumerate(positive):
        middle = 0.5 * (shapes[j][bottom][..., :3] + shapes[j][top][..., :3])
        panels, _ = mode_extent(
            np.linalg.norm(middle, axis=-1).max(axis=1), el_panel, len(panel_ids)
        )
        modes.append(
            {
                "mode": rank + 1,
                "factor": significant(factors[j], 4),
                "panels": [panel_ids[p] for p in panels[:20]],
                "panel_count": len(panels),
            }
        )
        if rank == 0:
            mode_shape = node_values(shell, middle)
            mode_shape /= max(np.linalg.norm(mode_shape, axis=1).max(), 1e-300)
    issues = []
    if len(positive) < MIN_POSITIVE_MODES:
        issues.append(
            Issue(
                "few-buckling-modes",
                f"only {len(positive)} positive buckling factors among {asked} requested",
            )
        )
    divisions = round(math.sqrt((shell.group == 0).sum() / max(len(panel_ids), 1)))
    note = None
    if divisions < LOCAL_BUCKLING_DIVISIONS:
        note = (
            f"{divisions} element(s) per panel side cannot show the sheets buckling "
            f"between their ribs: the factors cover the global modes only; refine "
            f"with [structure] element_size (about a quarter of the panel size)"
        )
        issues.append(Issue("coarse-buckling-mesh", note))
    return Buckling(
        factors=factors,
        modes=modes,
        mode_shape=mode_shape,
        first=float(factors[positive[0]]) if len(positive) else math.inf,
        required=1.0 / job.loads.buckling_knockdown,
        note=note,
        divisions=int(divisions),
        run=run,
        issues=tuple(issues),
        beside=tuple(beside_runs),
    )


def node_values(shell: ShellModel, per_element_node: np.ndarray) -> np.ndarray:
    """(n, c): element-node values (E, 8, c) averaged at the shell nodes."""
    c = per_element_node.shape[-1]
    total = np.zeros((len(shell.nodes), c))
    count = np.zeros(len(shell.nodes))
    np.add.at(total, shell.quads.ravel(), per_element_node.reshape(-1, c))
    np.add.at(count, shell.quads.ravel(), 1)
    return total / np.maximum(count, 1)[:, None]


def significant(value: float, digits: int) -> float:
    """``value`` to ``digits`` significant digits. Results are rounded where CalculiX's own
    round-off shows: its eigenvalues vary in the 7th digit between runs of the same deck."""
    value = float(value)
    if value == 0 or not math.isfinite(value):
        return value
    return round(value, digits - 1 - math.floor(math.log10(abs(value))))
