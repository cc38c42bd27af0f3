"""fabpanel: free-form steel shells to shop-floor parts.

Pipeline: load a design surface, ``panelize`` it into quad panels, ``develop`` each panel into a
developable surface, ``build`` the steel parts in OCCT, ``cut`` them flat and ``nest`` them onto
plates. ``run(job)`` does it all and writes the output folder; each stage is also public.

    import fabpanel as fp
    job = fp.Job.from_toml("job.toml")
    result = fp.run(job)
"""

__version__ = "0.1.0"

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
from .errors import FabpanelError, GeometryError, InputError, Issue, KernelError, SolverError
from .flat import cut
from .flat.nest import nest
from .job import STAGES, Job
from .model import build
from .panelize import panelize
from .pipeline import Result, load, run
from .surface import load_surface

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
