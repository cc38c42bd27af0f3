"""The key plan (``docs/keyplan.pdf``): every panel with its id and erection number, on one A3
sheet with a title block, as vector PDF (matplotlib's PDF backend).

The view is the plan (seen from above) when every panel keeps at least ``PLAN_SHARE`` of its
area in it; a vault's steep sides would shrink to slivers there, so otherwise the layout is
drawn developed: its conformal flattening (:func:`fabpanel.geom.conformal.conformal_flattening`),
which keeps every panel's angles, so each panel stays a recognisable quad. Each label is sized
to fit inside its panel (never below ``MIN_FONT`` pt, the smallest a printed A3 is read at).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import date
from pathlib import Path

import numpy as np

from .panels import erection_sequence
from .source import DocSource

#: the plan view is used when every panel keeps this share of its true area in plan
PLAN_SHARE = 0.4
#: A3 landscape, mm, and the drawing's frame inside it (left, bottom, right, top margins and
#: the title block's height along the bottom)
A3 = (420.0, 297.0)
MARGIN = 10.0
TITLE_HEIGHT = 28.0
#: label font sizes, pt: the largest used and the smallest legible on a printed A3
MAX_FONT = 14.0
MIN_FONT = 3.5
POINT_MM = 25.4 / 72.0
#: a label's width per character, in font sizes (a sans-serif's digits and capitals)
CHAR_WIDTH = 0.62


@dataclass(frozen=True)
class KeyPlanView:
    """The drawn panels: ``quads (m, 4, 2)`` on the paper, mm, and how they were projected."""

    panel_ids: tuple[str, ...]
    quads: np.ndarray
    view: str


@dataclass(frozen=True)
class Label:
    """A panel's label on the sheet: text, centre (mm), font size (pt) and the angle its lines
    run at (degrees, along the panel's longer mid-line)."""

    panel_id: str
    text: str
    centre: tuple[float, float]
    font_pt: float
    angle_deg: float


def _shared_vertices(source: DocSource) -> tuple[np.ndarray, np.ndarray]:
    """The panels' corners merged into one vertex list (n, 3) and quads (m, 4)."""
    corners = np.array([p.corners for p in source.panels]).reshape(-1, 3)
    _, first, inverse = np.unique(
        np.round(corners, 1), axis=0, return_index=True, return_inverse=True
    )
    return corners[first], inverse.reshape(-1, 4)


def _projected(source: DocSource) -> tuple[np.ndarray, str]:
    vertices, quads = _shared_vertices(source)
    true_area = _quad_areas_3d(vertices[quads])
    plan_area = np.abs(_quad_areas_2d(vertices[quads][..., :2]))
    if np.all(plan_area >= PLAN_SHARE * true_area):
        return vertices[quads][..., :2], "plan, seen from above"
    from ..geom.conformal import conformal_flattening

    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    edges = np.sort(np.concatenate([quads[:, [i, (i + 1) % 4]] for i in range(4)]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = np.unique(unique[counts == 1])
    flat, _ = conformal_flattening(vertices, triangles, boundary)
    # turned so its longer principal axis runs along the sheet's length
    centred = flat - flat.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    turned = centred @ axes.T
    if np.linalg.det(axes) < 0:  # a rotation, not a mirror image
        turned[:, 1] *= -1.0
    return turned[quads], "developed (conformal flattening of the layout)"


def _quad_areas_3d(quads: np.ndarray) -> np.ndarray:
    a = np.cross(quads[:, 1] - quads[:, 0], quads[:, 2] - quads[:, 0])
    b = np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 0])
    return 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1))


def _quad_areas_2d(quads: np.ndarray) -> np.ndarray:
    x, y = quads[..., 0], quads[..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1)


def keyplan_view(source: DocSource) -> KeyPlanView:
    """The panels projected and scaled into the drawing frame of an A3 sheet."""
    quads, view = _projected(source)
    lo, hi = quads.reshape(-1, 2).min(axis=0), quads.reshape(-1, 2).max(axis=0)
    frame_lo = np.array([MARGIN, MARGIN + TITLE_HEIGHT + 4.0])
    frame_size = np.array([A3[0] - 2 * MARGIN, A3[1] - 2 * MARGIN - TITLE_HEIGHT - 4.0])
    scale = float(np.min(frame_size / np.maximum(hi - lo, 1e-9)))
    offset = frame_lo + (frame_size - (hi - lo) * scale) / 2.0
    return KeyPlanView(tuple(p.id for p in source.panels), (quads - lo) * scale + offset, view)


def labels(source: DocSource, view: KeyPlanView) -> list[Label]:
    """One label per panel: ``id`` over its erection number, at the panel's centre, its font
    the largest (up to ``MAX_FONT``) whose two lines fit the panel's inscribed box."""
    from shapely import affinity
    from shapely.geometry import Polygon, box

    sequence = erection_sequence(source)
    found = []
    for pid, quad in zip(view.panel_ids, view.quads):
        polygon = Polygon(quad)
        centre = np.asarray(polygon.representative_point().coords[0])
        if polygon.contains(polygon.centroid):
            centre = np.asarray(polygon.centroid.coords[0])
        angle = _reading_angle(quad)
        text = f"{pid}\n{sequence[pid]}"
        chars = max(len(line) for line in text.split("\n"))
        font = MAX_FONT
        while font > MIN_FONT:
            half_w = CHAR_WIDTH * font * POINT_MM * chars / 2.0
            half_h = 1.25 * font * POINT_MM  # two lines
            frame = box(*(centre - (half_w, half_h)), *(centre + (half_w, half_h)))
            if polygon.contains(affinity.rotate(frame, angle, origin=tuple(centre))):
                break
            font -= 0.25
        found.append(Label(pid, text, (float(centre[0]), float(centre[1])), font, angle))
    return found


def _reading_angle(quad: np.ndarray) -> float:
    """The direction of a panel's longer mid-line, degrees, turned to read left to right; a
    label stays horizontal unless its panel stands at least 1.3 times taller than wide."""
    first = (quad[1] + quad[2] - quad[0] - quad[3]) / 2.0
    second = (quad[2] + quad[3] - quad[0] - quad[1]) / 2.0
    along = first if np.linalg.norm(first) >= np.linalg.norm(second) else second
    angle = float(np.degrees(np.arctan2(along[1], along[0])))
    angle = (angle + 90.0) % 180.0 - 90.0  # read left to right
    horizontal_extent = np.ptp(quad[:, 0])
    vertical_extent = np.ptp(quad[:, 1])
    if abs(angle) > 45.0 and vertical_extent < 1.3 * horizontal_extent:
        return 0.0
    return angle if abs(angle) > 5.0 else 0.0


def write_keyplan(source: DocSource, path: str | Path) -> Path:
    """Draw the key plan (module docstring) to ``path`` (PDF)."""
    path = Path(path)
    draw_keyplan(source, path, "pdf")
    return path


def draw_keyplan(source: DocSource, target, file_format: str) -> None:
    """Draw the key plan to ``target`` (a path or a file object) as ``pdf``, ``svg`` or
    ``png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    view = keyplan_view(source)
    inch = 25.4
    # SVG ids from a fixed salt and text kept as text: the same run gives the same page, and
    # the panel ids can be searched in a browser
    matplotlib.rcParams["svg.hashsalt"] = "fabpanel"
    matplotlib.rcParams["svg.fonttype"] = "none"
    fig = plt.figure(figsize=(A3[0] / inch, A3[1] / inch))
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, A3[0]), ax.set_ylim(0, A3[1])
    ax.set_axis_off()
    classes = {p.id: p.panel_class for p in source.panels}
    colours = {"not-developable": "#f4cccc"}
    ax.add_collection(
        PolyCollection(
            list(view.quads),
            facecolors=[colours.get(classes[pid], "#eef3f8") for pid in view.panel_ids],
            edgecolors="0.15",
            linewidths=0.35,
        )
    )
    for label in labels(source, view):
        ax.text(
            *label.centre,
            label.text,
            fontsize=label.font_pt,
            ha="center",
            va="center",
            rotation=label.angle_deg,
            rotation_mode="anchor",
            linespacing=1.1,
            family="DejaVu Sans",
        )
    _title_block(ax, source, view)
    # no creation time: the same run gives the same file
    metadata = {
        "pdf": {"CreationDate": None, "Creator": "fabpanel"},
        "svg": {"Date": None, "Creator": "fabpanel"},
        "png": {"Software": "fabpanel"},
    }[file_format]
    fig.savefig(target, format=file_format, metadata=metadata, dpi=150)
    plt.close(fig)


def _title_block(ax, source: DocSource, view: KeyPlanView) -> None:
    from matplotlib.patches import Rectangle

    x0, y0, width = MARGIN, MARGIN, A3[0] - 2 * MARGIN
    ax.add_patch(Rectangle((x0, y0), width, TITLE_HEIGHT, fill=False, linewidth=0.8))
    rows = [
        ("Project", source.job.docs.project or source.name),
        ("Drawing", "Key plan: panel ids (upper) and erection sequence (lower)"),
        ("View", view.view),
        (
            "Panels",
            f"{len(view.panel_ids)}; red: not developable within tolerance",
        ),
        (
            "Revision",
            (
                f"{source.job.docs.revision}   {date.today().isoformat()}   "
                f"fabpanel {source.fabpanel_version}   A3, not to scale"
            ),
        ),
    ]
    for i, (key, value) in enumerate(rows):
        y = y0 + TITLE_HEIGHT - 5.0 - i * 5.2
        ax.text(x0 + 3.0, y, key, fontsize=7, weight="bold", va="center")
        ax.text(x0 + 28.0, y, value, fontsize=7, va="center")
