"""fabpanel: free-form steel shells to shop-floor parts.

Pipeline: load a design surface, ``panelize`` it into quad panels, ``develop`` each panel into a
developable surface, ``build`` the steel parts in OCCT, ``cut`` them flat and ``nest`` them onto
plates. ``run(job)`` does it all and writes the output folder; each stage is also public.

    import fabpanel as fp
    job = fp.Job.from_toml("job.toml")
    result = fp.run(job)
"""

__version__ = "0.1.0"

from .data import (DevelopedPanels, FlatPart, FlatParts, Hole, Model, Nests, PanelLayout, Part,
                   Placement, Plate, Surface)
from .errors import FabpanelError, GeometryError, InputError, Issue, KernelError, SolverError
from .job import STAGES, Job
from .pipeline import Result, load, run


from .develop import develop
from .flat import cut
from .flat.nest import nest
from .model import build
from .panelize import panelize
from .surface import load_surface

__all__ = [
    "__version__", "Job", "STAGES", "run", "load", "Result", "load_surface", "panelize",
    "develop", "build", "cut", "nest", "Surface", "PanelLayout", "DevelopedPanels", "Model",
    "Part", "Hole", "FlatPart", "FlatParts", "Placement", "Plate", "Nests", "Issue",
    "FabpanelError", "InputError", "GeometryError", "KernelError", "SolverError",
]
