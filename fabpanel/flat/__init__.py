"""Cut stage: flat parts (unrolled sheets, rib outlines), part DXF files, plate nests.

Public API::

    cut(model, job) -> FlatParts                     # fabpanel.flat.unroll
    write_parts(flat, folder) -> {part id: file}     # fabpanel.flat.dxf
    nest(flat, job, progress=None) -> Nests          # fabpanel.flat.nest
    validate_nests(nests, flat, job) -> [problem]
    write_nests(nests, flat, folder) -> {plate: [dxf, png]}
"""

from .dxf import audit_dxf, part_area_from_dxf, write_part_dxf, write_parts
from .nest import nest, validate_nests
from .nest_output import write_nests
from .unroll import cut

__all__ = [
    "audit_dxf",
    "cut",
    "nest",
    "part_area_from_dxf",
    "validate_nests",
    "write_nests",
    "write_part_dxf",
    "write_parts",
]
