"""Write a panel layout as a quad mesh (``model/panels.obj``).

One object ``panels`` with one quad face per panel, in panel order, corners counter-clockwise
seen from the outer side, vertices in millimetres; a comment line before each face names its
panel. The file reads back as a user layout (``[panelize] method = "layout"``, ``units = "mm"``)
to the same quads, so a designer can edit the layout in any modeller and run it again.
"""

from __future__ import annotations

from pathlib import Path

from ..data import PanelLayout

#: panel ids per header comment line
IDS_PER_LINE = 16


def write_layout_obj(layout: PanelLayout, path: str | Path) -> Path:
    """Write ``layout`` as an OBJ quad mesh in millimetres; returns the path written.

    Vertices are written with 9 decimals (nanometres), so reading the file back gives the
    layout's vertices to well within 1e-6 mm. The parent folder is created when missing.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ids = list(layout.panel_ids)
    lines = [
        (
            "# fabpanel panel layout: one quad face per panel, corners counter-clockwise "
            "seen from the outer side"
        ),
        "# units: mm",
        f"# method: {layout.method}",
        f"# panels: {len(ids)}, vertices: {len(layout.vertices)}",
        "# panel ids in face order:",
    ]
    lines += [
        "#   " + " ".join(ids[i : i + IDS_PER_LINE]) for i in range(0, len(ids), IDS_PER_LINE)
    ]
    lines.append("o panels")
    # in the design's own frame (the layout is local), so the file reads back as a user layout
    world = layout.vertices + layout.origin
    lines += [f"v {x:.9f} {y:.9f} {z:.9f}" for x, y, z in world.tolist()]
    for pid, quad in zip(ids, layout.quads.tolist()):
        lines.append(f"# {pid}")
        lines.append("f " + " ".join(str(i + 1) for i in quad))
    path.write_text("\n".join(lines) + "\n")
    return path


__all__ = ["write_layout_obj"]
