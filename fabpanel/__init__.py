"""fabpanel: free-form steel shells to shop-floor parts.

Pipeline: load a design surface, ``panelize`` it into quad panels, ``develop`` each panel into a
developable surface, ``build`` the steel parts in OCCT, ``cut`` them flat and ``nest`` them onto
plates. ``run(job)`` does it all and writes the output folder; each stage is also public.

    import fabpanel as fp
    job = fp.Job.from_toml("job.toml")
    result = fp.run(job)
"""

__version__ = "0.1.0"

import sys
import types
from typing import TYPE_CHECKING

from .errors import FabpanelError, GeometryError, InputError, Issue, KernelError, SolverError
from .job import STAGES, Job

if TYPE_CHECKING:
    from .data import (
        DevelopedPanels,
        FlatPart,
        FlatParts,
        Hole,
        Model,
        Nests,
        PanelLayout,
        Part,
        Placement,
        Plate,
        Surface,
    )
    from .develop import develop
    from .flat import cut
    from .flat.nest import nest
    from .model import build
    from .panelize import panelize
    from .pipeline import Result, load, run
    from .surface import load_surface

#: the public names that load OCCT, gmsh and the rest on first use, by the module that holds
#: them: ``fabpanel --help`` and ``Job`` need none of it (3-6 s of imports)
_LAZY = {
    **dict.fromkeys(
        (
            "DevelopedPanels",
            "FlatPart",
            "FlatParts",
            "Hole",
            "Model",
            "Nests",
            "PanelLayout",
            "Part",
            "Placement",
            "Plate",
            "Surface",
        ),
        ".data",
    ),
    "develop": ".develop",
    "cut": ".flat",
    "nest": ".flat.nest",
    "build": ".model",
    "panelize": ".panelize",
    "Result": ".pipeline",
    "load": ".pipeline",
    "run": ".pipeline",
    "load_surface": ".surface",
}


#: subpackages named like the stage function they hold: ``fabpanel.panelize`` is the function
_STAGE_PACKAGES = ("develop", "panelize")


class _Package(types.ModuleType):
    """The ``fabpanel`` module: the import system binds each subpackage it loads to the
    package's attribute of that name, after the subpackage ran; a stage's package is bound to
    its function instead, as the eager ``from .panelize import panelize`` did."""

    def __setattr__(self, name: str, value: object) -> None:
        if name in _STAGE_PACKAGES and isinstance(value, types.ModuleType):
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str) -> object:
    """The lazily loaded public names (PEP 562): imported on first use, then cached."""
    if name not in _LAZY:
        raise AttributeError(f"module 'fabpanel' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "STAGES",
    "DevelopedPanels",
    "FabpanelError",
    "FlatPart",
    "FlatParts",
    "GeometryError",
    "Hole",
    "InputError",
    "Issue",
    "Job",
    "KernelError",
    "Model",
    "Nests",
    "PanelLayout",
    "Part",
    "Placement",
    "Plate",
    "Result",
    "SolverError",
    "Surface",
    "__version__",
    "build",
    "cut",
    "develop",
    "load",
    "load_surface",
    "nest",
    "panelize",
    "run",
]
