"""Geometrically nonlinear analysis of the imperfect shell (GNIA, EN 1993-1-6 §8.7), optional.

The linear buckling factor (LBA, :mod:`.buckling`) of a perfect shell overstates what a real
one carries; the code's knock-down covers that on average. A GNIA follows the imperfect shell
instead: every node of the model (sheets and ribs) is moved by the first LBA mode scaled to the
equivalent imperfection amplitude, and the governing ULS combination is ramped with ``NLGEOM``
(CalculiX's automatic increments) to 1.2 x the LBA factor, or 1.2 x the factor at which the
linear analysis first yields where that is lower (but at least 1.2 x gamma_M1). The load factor of the last converged
increment, where CalculiX can no longer find equilibrium under more load, is the limit point
(the load-controlled step cannot pass it, so a snap-back after it is not followed). Both signs
of the mode are run; the smaller limit governs. Elastic: yielding is not modelled (that would
be a GMNIA), so the von Mises check stays the linear one.

The amplitude (§8.7.2, for dimple imperfections, with the tolerance class of Table 8.8):
``max(l_g U_n1, n_i t U_n2)`` with ``U_n1 = U_n2`` = 0.010 / 0.016 / 0.025 for classes A / B / C,
``n_i = 25``, ``l_g = 4 sqrt(r t)`` (the meridional gauge length of §8.4.4), ``t`` the thinnest
element at the mode's peak and ``r`` the shell's smallest radius of curvature there (from the
elements' mid-side nodes). A flat field has no radius: its gauge length is capped at the panel
size, the longest dimple the ribs let form (fabpanel's choice). ``[structure]
imperfection_amplitude`` replaces the formula.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Issue
from . import ccx
from .buckling import significant
from .mesh import ShellModel

#: EN 1993-1-6:2007 Table 8.8, U_n1 = U_n2 per fabrication tolerance quality class
DIMPLE_PARAMETER = {"A": 0.010, "B": 0.016, "C": 0.025}
#: n_i of §8.7.2 (recommended value, an NDP)
N_I = 25.0
#: the load is ramped to this multiple of the LBA factor, or of the factor at which the linear
#: analysis first yields where that is lower: an imperfect shell's limit lies below its
#: bifurcation, a plate's stable post-buckling can carry it past (no limit is then found), and
#: past the first yield the elastic path is no longer the steel's
RAMP_OVER_LBA = 1.2


@dataclass(frozen=True)
class Amplitude:
    """The imperfection's size, mm, and where it comes from.

    value : the amplitude given to the mode's largest displacement.
    source : ``"job"`` or the class it was computed for (``"EN 1993-1-6 class B"``).
    thickness, radius, gauge_length : what the formula used (None for ``"job"``; radius inf on
        a flat field, whose gauge length is the panel size).
    """

    value: float
    source: str
    thickness: float | None = None
    radius: float | None = None
    gauge_length: float | None = None


@dataclass(frozen=True)
class LoadPath:
    """One nonlinear run: ``factors`` the load factors of the converged increments and
    ``displacement`` the monitored node's displacement at each (mm); ``limit`` the last factor
    and ``limit_reached`` whether CalculiX stopped there (False: the ramp's end was reached
    without a limit)."""

    sign: int
    factors: np.ndarray
    displacement: np.ndarray
    limit: float
    limit_reached: bool
    seconds: float


@dataclass(frozen=True)
class Gnia:
    """Both signs' load paths and what they give: ``factor`` the smaller limit (a lower bound
    ``>= factor`` where no limit was reached), ``lba`` the perfect shell's first factor,
    ``first_yield`` the factor at which the combination's linear von Mises stress reaches f_y,
    ``ok`` whether ``factor >= gamma_m1``."""

    amplitude: Amplitude
    paths: tuple[LoadPath, ...]
    factor: float
    lba: float
    first_yield: float
    gamma_m1: float
    ok: bool
    issues: tuple[Issue, ...]

    def summary(self) -> dict:
        a = self.amplitude
        return {
            "factor": significant(self.factor, 4),
            "limit_reached": all(p.limit_reached for p in self.paths),
            "lba": significant(self.lba, 4),
            "ratio_to_lba": round(self.factor / self.lba, 3) if self.lba > 0 else None,
            "first_yield_linear": significant(self.first_yield, 4),
            "required": self.gamma_m1,
            "amplitude_mm": round(a.value, 2),
            "amplitude_source": a.source,
            "thickness_mm": a.thickness,
            "radius_mm": None if a.radius is None or math.isinf(a.radius) else round(a.radius),
            "gauge_length_mm": None if a.gauge_length is None else round(a.gauge_length, 1),
            "paths": [
                {
                    "sign": "+" if p.sign > 0 else "-",
                    "limit": significant(p.limit, 4),
                    "limit_reached": p.limit_reached,
                    "increments": len(p.factors),
                    "displacement_at_limit_mm": round(float(p.displacement[-1]), 2)
                    if len(p.displacement)
                    else None,
                    "seconds": round(p.seconds, 1),
                }
                for p in self.paths
            ],
            "ok": self.ok,
        }


def normal_curvature(shell: ShellModel, elements: np.ndarray) -> np.ndarray:
    """(k,) the largest normal curvature along the four sides of each S8R element, 1/mm: a side
    of chord ``c`` whose mid-side node stands ``s`` off the chord along the element's normal
    bends with ``8 s / c^2`` (a circle through the three nodes)."""
    quads = shell.quads[elements]
    p = shell.nodes[quads]  # (k, 8, 3)
    normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    a, b, m = p[:, :4], np.roll(p[:, :4], -1, axis=1), p[:, 4:]
    chord = np.linalg.norm(b - a, axis=2)
    sagitta = np.abs(np.einsum("ksj,kj->ks", m - 0.5 * (a + b), normal))
    return (8.0 * sagitta / np.maximum(chord, 1e-300) ** 2).max(axis=1)


def dimple_amplitude(
    shell: ShellModel, mode_shape: np.ndarray, tolerance_class: str, panel_size: float
) -> Amplitude:
    """EN 1993-1-6's equivalent dimple amplitude where the mode moves most (module docstring)."""
    peak = int(np.argmax(np.linalg.norm(mode_shape, axis=1)))
    elements = np.flatnonzero((shell.quads == peak).any(axis=1))
    t = float(shell.thickness[elements].min())
    kappa = float(normal_curvature(shell, elements).max())
    radius = 1.0 / kappa if kappa > 0 else math.inf
    gauge = min(4.0 * math.sqrt(radius * t), panel_size) if math.isfinite(radius) else panel_size
    u = DIMPLE_PARAMETER[tolerance_class]
    value = max(gauge * u, N_I * t * u)
    return Amplitude(value, f"EN 1993-1-6 class {tolerance_class}", t, radius, gauge)


def imperfect(shell: ShellModel, mode_shape: np.ndarray, amplitude: float) -> ShellModel:
    """The shell with every node moved by the mode, its largest displacement ``amplitude``."""
    largest = float(np.linalg.norm(mode_shape, axis=1).max())
    return shell.replace(nodes=shell.nodes + (amplitude / largest) * mode_shape)


def load_path(
    shell: ShellModel,
    case: ccx.LoadCase,
    ramp_to: float,
    monitor: int,
    folder: Path,
    stem: str,
    threads: int,
    timeout: float | None,
    executable: str | None,
    sign: int = 1,
) -> LoadPath:
    """``case`` ramped from 0 to ``ramp_to`` times itself on ``shell`` with NLGEOM; the
    converged increments' load factors and the ``monitor`` node's displacement."""
    step = ccx.NonlinearStep(case.scaled(ramp_to), np.array([monitor]))
    deck = ccx.write_deck(
        shell, folder / f"{stem}.inp", nonlinear=step, title=f"fabpanel GNIA under {case.name}"
    )
    started = time.perf_counter()
    run = ccx.run_ccx(deck, threads, timeout, executable, tolerate=ccx.LIMIT_REACHED)
    times, u = ccx.read_history(run.dat)
    reached = ccx.LIMIT_REACHED in run.log.read_text(errors="replace")
    factors = ramp_to * times
    return LoadPath(
        sign=sign,
        factors=factors,
        displacement=np.linalg.norm(u[:, 0], axis=1) if len(u) else np.zeros(0),
        limit=float(factors[-1]) if len(factors) else 0.0,
        limit_reached=reached,
        seconds=time.perf_counter() - started,
    )


def gnia(
    shell: ShellModel,
    case: ccx.LoadCase,
    mode_shape: np.ndarray,
    factors: tuple[float, float],
    job,
    folder: Path,
    threads: int,
    executable: str,
) -> Gnia:
    """The GNIA of ``case`` (the governing ULS combination) with ``mode_shape`` (the first LBA
    mode) as the imperfection, both signs; ``factors`` are the LBA factor and the factor at
    which ``case`` first yields in the linear analysis."""
    lba, first_yield = factors
    st = job.structure
    if st.imperfection_amplitude is not None:
        amplitude = Amplitude(float(st.imperfection_amplitude), "job")
    else:
        amplitude = dimple_amplitude(
            shell, mode_shape, st.tolerance_class, float(job.panelize.panel_size)
        )
    monitor = int(np.argmax(np.linalg.norm(mode_shape, axis=1)))
    # past the first yield the elastic path is not the steel's: the ramp stops there too
    ramp_to = RAMP_OVER_LBA * min(lba, max(first_yield, st.gamma_m1))
    paths = tuple(
        load_path(
            imperfect(shell, sign * mode_shape, amplitude.value),
            case,
            ramp_to,
            monitor,
            folder,
            f"gnia{'+' if sign > 0 else '-'}",
            threads,
            st.timeout,
            executable,
            sign,
        )
        for sign in (1, -1)
    )
    factor = min(p.limit for p in paths)
    issues: list[Issue] = []
    if not all(p.limit_reached for p in paths):
        issues.append(
            Issue(
                "gnia-no-limit",
                f"the GNIA found no limit point up to {ramp_to:.3g} x {case.name} "
                f"({RAMP_OVER_LBA:g} x the smaller of the LBA factor and the first yield) for at "
                "least one sign of the imperfection: the shell carries at least that much",
                severity="info",
            )
        )
    if factor > first_yield:
        issues.append(
            Issue(
                "gnia-above-yield",
                f"the elastic GNIA carries {factor:.3g} x {case.name}, but the linear analysis "
                f"reaches f_y at {first_yield:.3g} x: the steel yields first, so the limit is "
                "not reached as computed (a GMNIA would find the lower, plastic one); the stress "
                "and LBA checks govern",
                severity="info",
            )
        )
    ok = factor >= st.gamma_m1
    if not ok:
        issues.append(
            Issue(
                "gnia-limit-low",
                f"the imperfect shell's limit load factor {factor:.3g} under {case.name} "
                f"(imperfection {amplitude.value:.3g} mm, {amplitude.source}) is below "
                f"gamma_M1 = {st.gamma_m1:g}: stiffen the shell or reduce the loads",
                severity="error",
            )
        )
    return Gnia(amplitude, paths, factor, lba, first_yield, st.gamma_m1, ok, tuple(issues))
