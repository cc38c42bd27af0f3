"""Rolled or sprung: how a single-curved sheet takes its shape, and the stress it keeps.

A sheet that curves in one direction can be rolled to its radius (plastic: it keeps no
bending stress worth counting) or laid flat on its curved ribs and pulled down onto them
(sprung: elastic, cheaper, no roll needed). Sprung, it keeps the bending stress
``E t / (2 R)`` for good (``../shared/notes/eurocode.md`` §7): 79 MPa for 3 mm at R 4 m. The
cut stage decides (``[cutting] forming``): ``auto`` springs a sheet whose locked-in stress is at
most ``SPRING_SHARE`` of f_y, leaving the rest for the loads, and rolls the others; ``roll``
rolls every curved sheet. The forming instruction etched on the part ends in ``SPRING`` or
``ROLL``. The structure stage adds the locked-in stress to each sprung sheet's largest ULS
stress and asks for a sheet whose sum exceeds f_y to be rolled
(:func:`fabpanel.structure.forming.sprung_sheet_findings`).
"""

from __future__ import annotations

import dataclasses

#: a sheet is sprung when E t / (2 R) is at most this share of f_y (``forming = "auto"``)
SPRING_SHARE = 0.5


def springing_stress(thickness: float, radius: float, modulus: float) -> float:
    """The bending stress a sheet ``thickness`` mm thick keeps when sprung to ``radius`` mm,
    MPa (``modulus`` E in MPa)."""
    return modulus * thickness / (2.0 * radius)


def formed(flat, job):
    """``flat`` (a :class:`~fabpanel.data.FlatPart`) with its forming method: single-curved
    sheets sprung or rolled by ``[cutting] forming`` (module docstring); other parts as
    given."""
    if not flat.kind.startswith("sheet") or flat.bend_radius <= 0:
        return flat
    material = job.material
    stress = springing_stress(flat.thickness, flat.bend_radius, material.E)
    sprung = job.cutting.forming == "auto" and stress <= SPRING_SHARE * material.fy
    return dataclasses.replace(
        flat,
        forming=f"{flat.forming} {'SPRING' if sprung else 'ROLL'}",
        spring_stress=stress if sprung else 0.0,
    )
