"""Sprung sheets under load: the bending stress a sheet keeps when it is sprung onto its ribs
(:mod:`fabpanel.forming`) added to its largest ULS stress, against f_y.

The locked-in stress is a bending stress along the sheet's curvature, largest at its faces;
the ULS von Mises stress is taken at the faces too. Adding the two magnitudes is on the safe
side (they need not peak at the same point or direction).
"""

from __future__ import annotations

import numpy as np

from ..errors import Issue
from .mesh import ShellModel


def sprung_sheet_findings(
    shell: ShellModel, von_mises: np.ndarray, fy: float, flat, panel_ids: tuple[str, ...]
) -> tuple[dict, list[Issue]]:
    """The summary of the sprung sheets (count, the largest combined utilisation and where)
    and an error for each sheet whose ULS stress plus its locked-in bending stress exceeds
    ``fy``. ``von_mises (E,)``: each element's largest ULS von Mises stress, MPa; ``flat``: the
    cut stage's :class:`~fabpanel.data.FlatParts` (None: not checked)."""
    if flat is None or shell.panel is None:
        return {"checked": False}, []
    sprung = {p.id: p for p in flat.parts if p.spring_stress > 0}
    rolled = sum(1 for p in flat.parts if p.forming.endswith(" ROLL"))
    if not sprung:
        return {"checked": True, "sprung": 0, "rolled": rolled}, []
    names = np.array([g.name for g in shell.groups])[shell.group]
    owner = np.array(panel_ids)[shell.panel[:, 0]]
    issues, worst = [], (0.0, "", 0.0, 0.0)
    for name in ("TOP", "BOT"):
        sheet = names == name
        for pid in np.unique(owner[sheet]):
            part = sprung.get(f"{pid}-{name}")
            if part is None:
                continue
            load = float(von_mises[sheet & (owner == pid)].max())
            total = load + part.spring_stress
            if total / fy > worst[0]:
                worst = (total / fy, part.id, load, part.spring_stress)
            if total > fy:
                issues.append(
                    Issue(
                        "sheet-must-be-rolled",
                        (
                            f"{part.id} is sprung onto its ribs ({part.forming}): it keeps "
                            f"{part.spring_stress:.0f} MPa of bending, and with {load:.0f} MPa "
                            f"under the ULS loads that is {total:.0f} MPa > f_y {fy:.0f} MPa; "
                            'roll it to its radius ([cutting] forming = "roll")'
                        ),
                        part.id,
                        "error",
                    )
                )
    summary = {
        "checked": True,
        "sprung": len(sprung),
        "rolled": rolled,
        "max_combined_utilisation": round(worst[0], 4),
        "part": worst[1],
        "uls_MPa": round(worst[2], 1),
        "locked_in_MPa": round(worst[3], 1),
        "must_be_rolled": len(issues),
    }
    return summary, issues
