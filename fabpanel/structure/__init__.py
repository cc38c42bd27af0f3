"""Structure stage: a preliminary structural check of the panelled shell with CalculiX (ccx).

``analyse(model, job)`` builds a shell model of every sheet and rib (:mod:`.mesh`), applies
self-weight, snow and wind (:mod:`.loads`), runs CalculiX through its one adapter (:mod:`.ccx`)
and checks mass, reactions, deflection, von Mises utilisation and linear buckling
(:mod:`.checks`, :mod:`.analysis`). The mesh, load and deck functions also take generic shell
patches (:func:`patch_model`), which is how the solver is validated against the classic shell
benchmarks in ``tests/test_structure.py``.
"""

from .analysis import Structure, analyse, choose_divisions, element_counts, shell_of
from .cases import load_cases
from .ccx import CcxMissing, LoadCase, find_ccx, read_dat, read_frd, run_ccx, write_deck
from .convergence import buckling_text
from .loads import area_forces, edge_forces, gravity_forces, wind_exposed
from .mesh import Material, ShellGroup, ShellModel, patch_model, sandwich_model


def describe(structure: Structure) -> str:
    """One line for the progress output."""
    s = structure.summary
    if not structure.analysed:
        return f"not analysed: {s['reason']}"
    b = s["buckling"]
    gnia = b.get("gnia")
    return (
        f"{element_counts(s['mesh'])}, utilisation {s['stress']['utilisation']:.2f}, "
        f"deflection {s['deflection']['ratio']}, buckling factor {buckling_text(b)} "
        f"(>= {b['required']:.3g})"
        + (f", GNIA {gnia['factor']:.2f} (>= {gnia['required']:g})" if gnia else "")
        + f": {'ok' if s['ok'] else 'check failed'}"
    )


__all__ = [
    "CcxMissing",
    "LoadCase",
    "Material",
    "ShellGroup",
    "ShellModel",
    "Structure",
    "analyse",
    "area_forces",
    "choose_divisions",
    "describe",
    "edge_forces",
    "find_ccx",
    "gravity_forces",
    "load_cases",
    "patch_model",
    "read_dat",
    "read_frd",
    "run_ccx",
    "sandwich_model",
    "shell_of",
    "wind_exposed",
    "write_deck",
]
