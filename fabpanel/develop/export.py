"""Write developed panels as one sample mesh (``model/developed.obj``).

One group per panel (``g P001``...), each panel's k x k samples as its own vertices (so panels
that part, as the loft baseline's do, show their gaps), (k-1)^2 quads per panel, millimetres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data import DevelopedPanels


def write_developed_obj(developed: DevelopedPanels, path: str | Path) -> Path:
    """Write the developed sample grids as an OBJ with one group per panel; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    m, k = developed.samples.shape[:2]
    ids = np.arange(k * k).reshape(k, k)
    cells = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    lines = [
        "# fabpanel developed panels: k x k samples per panel, one group per panel",
        "# units: mm",
        f"# method: {developed.method}, panels: {m}, samples per side: {k}",
    ]
    world = developed.samples.reshape(-1, 3) + developed.layout.origin  # the design's frame
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in world.tolist()]
    for panel, pid in enumerate(developed.panel_ids):
        lines.append(f"g {pid}")
        offset = panel * k * k + 1
        lines += ["f " + " ".join(str(offset + int(i)) for i in cell) for cell in cells]
    path.write_text("\n".join(lines) + "\n")
    return path
