"""Assembly drawings (``docs/drawings.pdf``): one A3 page per panel type, vector lines.

Each page shows the type's first panel projected from its solids with hidden lines (OCCT's
hidden-line removal, :mod:`fabpanel.model.hlr`): a top view looking onto the outer face, side 0
along the sheet's x axis, corners named C0..C3 and each side dimensioned (corner to corner, and
the top sheet's edge along the surface), and a section view along side 0 with the overall
height; each view framed, with a scale bar under it. Part marks sit at the parts' centres,
bolts are numbered crosses; beside the views, the parts list (mark, kind, thickness, mass),
each rib's tilt against the panel normal (0° = square to the panel, the bevel the rib's edges
are cut at), the bolts' positions (along the side from its corner, and in the panel's frame),
and the joint detail (section across two ribs, from the sandwich build-up: sheet set-back,
fillet welds, erection gap, bolt). Title block with project, panel type, panels of the type,
revision and date.
"""

from __future__ import annotations

import io
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from datetime import date
from pathlib import Path

import numpy as np

from .keyplan import A3, MARGIN
from .schedules import panel_types
from .source import DocSource, PanelDoc, PartDoc

#: rows of a table printed on a page before "... and n more"
TABLE_ROWS = 24
#: drawings of fewer pages are drawn in this process (starting workers would cost more)
INLINE_PAGES = 4


def panel_frame(panel: PanelDoc, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A panel's centre (local frame, mm), outward normal and side-0 direction (unit)."""
    corners = panel.corners - origin
    normal = np.cross(corners[2] - corners[0], corners[3] - corners[1])
    normal /= np.linalg.norm(normal)
    side = corners[1] - corners[0]
    side -= normal * (side @ normal)
    return corners.mean(axis=0), normal, side / np.linalg.norm(side)


def rib_tilt(normal: np.ndarray | None, panel_normal: np.ndarray) -> float | None:
    """The angle between a rib's plane and the panel normal, degrees (0: square to the panel)."""
    if normal is None:
        return None
    return float(np.degrees(np.arcsin(min(abs(float(normal @ panel_normal)), 1.0))))


@dataclass(frozen=True)
class PageViews:
    """What a page needs from the solids (computed in a worker): per view, the visible and
    hidden edges and the markers (the four panel corners, part centres, then bolts), in the
    view's plane from the panel's centre, mm; each rib's tilt against the panel normal, degrees."""

    views: tuple[tuple[list[np.ndarray], list[np.ndarray], np.ndarray], ...]
    tilts: dict[str, float | None]


def write_drawings(
    source: DocSource, breps: Mapping[str, bytes], path: str | Path, workers: int = 1
) -> Path:
    """One page per panel type (module docstring) into the PDF ``path``, drawn in ``workers``
    worker processes: each draws a run of pages, its hidden-line views and the page, into a
    PDF of its own, and the runs are joined in order (pypdf). Drawn in this process, a page
    took about 0.3 s of the write stage's critical path (250 s at 1000 panel types) while the
    workers only projected the views."""
    types = [
        (name, next(p for p in source.panels if p.id == ids[0]), ids)
        for name, ids in panel_types(source)
    ]
    pages = [(name, panel, ids, _request(source, breps, panel)) for name, panel, ids in types]
    path = Path(path)
    path.write_bytes(_joined(list(_drawn_runs(source, pages, workers))))
    return path


def _drawn_runs(source: DocSource, pages: list[tuple], workers: int) -> Iterator[bytes]:
    """The pages as PDFs of a run of pages each, in order (one, drawn here, for one worker
    or a few pages)."""
    if workers <= 1 or len(pages) < INLINE_PAGES:
        from ..raster import PYPLOT

        with PYPLOT:  # the report may be drawing in another thread
            yield _drawn_pages((source, pages))
        return
    from ..parallel import worker_pool

    # a few runs per worker, so that a run of heavy panels does not leave the other idle
    size = max(1, -(-len(pages) // (4 * workers)))
    runs = [(source, pages[i : i + size]) for i in range(0, len(pages), size)]
    with worker_pool(workers, fresh=True) as pool:
        yield from pool.map(_drawn_pages, runs)


def _drawn_pages(run: tuple[DocSource, list[tuple]]) -> bytes:
    """A PDF of the pages of ``run``: (source, [(type name, panel, panel ids, request)])."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    source, pages = run
    buffer = io.BytesIO()
    with PdfPages(buffer, metadata={"CreationDate": None, "Creator": "fabpanel"}) as pdf:
        for name, panel, ids, request in pages:
            fig = _page(source, name, panel, ids, _project_page(request))
            pdf.savefig(fig)
            plt.close(fig)
    return buffer.getvalue()


def _joined(pdfs: list[bytes]) -> bytes:
    """One PDF of the pages of ``pdfs``, in order."""
    if len(pdfs) == 1:
        return pdfs[0]
    from pypdf import PdfReader, PdfWriter

    writer = PdfWriter()
    for pdf in pdfs:
        writer.append(PdfReader(io.BytesIO(pdf)))
    writer.add_metadata({"/Creator": "fabpanel"})
    buffer = io.BytesIO()
    writer.write(buffer)
    return buffer.getvalue()


def _request(source: DocSource, breps: Mapping[str, bytes], panel: PanelDoc) -> tuple:
    """A worker's input for one page: the parts' solids, the view frame, the markers."""
    parts = source.parts_of(panel.id)
    centre, normal, x_axis = panel_frame(panel, source.origin)
    markers = [p.centroid for p in parts if p.centroid is not None]
    markers += [c for p in parts for c in p.bolt_centres]
    solids = [(p.id, p.kind, breps[p.id]) for p in parts if p.id in breps]
    corners = panel.corners - source.origin
    points = np.vstack([centre, corners, np.array(markers).reshape(-1, 3) - source.origin])
    return solids, centre, normal, x_axis, points


def _project_page(request: tuple) -> PageViews:
    """The top and section views of one page's solids (:func:`_request`), and its ribs'
    tilts."""
    from ..model.hlr import hidden_line_views, plate_normal

    solids, centre, normal, x_axis, points = request
    y_axis = np.cross(normal, x_axis)
    breps = [brep for _, _, brep in solids]
    views = []
    for visible, hidden, projected in hidden_line_views(
        breps, centre, (normal, -y_axis), x_axis, points
    ):
        # coordinates from the panel's centre
        shift = projected[0]
        views.append(
            ([v - shift for v in visible], [h - shift for h in hidden], projected[1:] - shift)
        )
    tilts = {
        name: rib_tilt(plate_normal(brep), normal) for name, kind, brep in solids if kind == "rib"
    }
    return PageViews(tuple(views), tilts)


def _page(source: DocSource, name: str, panel: PanelDoc, ids, found: PageViews):
    import matplotlib.pyplot as plt
    from matplotlib.patches import PathPatch

    parts = source.parts_of(panel.id)
    centre, normal, x_axis = panel_frame(panel, source.origin)
    y_axis = np.cross(normal, x_axis)
    inch = 25.4
    fig = plt.figure(figsize=(A3[0] / inch, A3[1] / inch))
    top = fig.add_axes((0.03, 0.30, 0.50, 0.64))
    side = fig.add_axes((0.03, 0.12, 0.50, 0.15))
    titles = ("Top view (outside), side 0 along x", "Section view along side 0 (outer face up)")
    placed = [p for p in parts if p.centroid is not None]
    bolts = [(f"{p.id.split('-', 1)[1]} {p.mark}", c) for p in parts for c in p.bolt_centres]
    for ax, title, (visible, hidden, projected) in zip((top, side), titles, found.views):
        # all edges of a kind as one path: one drawing call instead of thousands
        for lines, style in (
            (hidden, {"edgecolor": "0.55", "linewidth": 0.25, "linestyle": (0, (3, 2))}),
            (visible, {"edgecolor": "k", "linewidth": 0.45}),
        ):
            if lines:
                path = _one_path(lines)
                # added as an artist with the limits from its points: add_patch walks every
                # segment as a Bezier curve to find them
                ax.add_artist(PathPatch(path, fill=False, **style))
                ax.update_datalim(path.vertices)
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=8, loc="left")
        # a frame and a scale bar, no tick labels: a view is measured by its dimensions (and
        # the ticks' layout was a third of a page's drawing time)
        ax.set_xticks([])
        ax.set_yticks([])
        corners, markers = projected[:4], projected[4:]
        if ax is top:
            # the two sheets share a centre in this view: their marks one above the other
            offsets = [{"sheet-top": 25.0, "sheet-bottom": -25.0}.get(p.kind, 0.0) for p in placed]
            where = markers[: len(placed)] + np.column_stack([np.zeros(len(placed)), offsets])
            _marks(ax, [p.mark for p in placed], where)
            _bolt_marks(ax, markers[len(placed) :])
            _side_dimensions(ax, corners, side_lengths(panel, parts))
        else:
            _depth_dimension(ax, visible)
        _scale_bar(ax)
    bolt_rows = [
        (rib, *along_side(panel, rib, c),
         *(float((c - source.origin - centre) @ a) for a in (x_axis, y_axis, normal)))
        for rib, c in bolts
    ]  # fmt: skip
    _tables(fig, parts, found.tilts, bolt_rows)
    _joint_detail(fig.add_axes((0.57, 0.12, 0.40, 0.22)), source)
    _title_block(fig, source, name, ids, parts)
    held = [pid for pid in ids if pid in source.errors]
    if held:
        first = source.errors[held[0]]
        fig.text(
            0.03, 0.965,
            f"HOLD: {sum(len(source.errors[p]) for p in held)} error-level issue(s) on "
            f"{', '.join(held[:8])}{' ...' if len(held) > 8 else ''}; not to be built as drawn "
            f"(first: {first[0][:150]})",
            fontsize=7.5, color="#b3261e", weight="bold", va="bottom",
        )  # fmt: skip
    return fig


def side_lengths(panel: PanelDoc, parts: list[PartDoc]) -> list[str]:
    """Each side's dimension text: the corner-to-corner chord (the panel's size at the rib
    faces) and the top sheet's edge length (along its curved edge, shorter by the set-backs at
    both ends: what a tape along the sheet reads), mm."""
    chords = np.linalg.norm(np.roll(panel.corners, -1, axis=0) - panel.corners, axis=1)
    sheet = next((p for p in parts if p.kind == "sheet-top"), None)
    arcs = sheet.edge_lengths_3d if sheet is not None and len(sheet.edge_lengths_3d) == 4 else None
    if arcs is None:
        return [f"{c:.1f}" for c in chords]
    return [f"{c:.1f} (sheet edge {a:.1f})" for a, c in zip(arcs, chords)]


def along_side(panel: PanelDoc, rib: str, centre: np.ndarray) -> tuple[int, float]:
    """A rib bolt's position as a fitter measures it: the rib's first corner (side s runs from
    corner s to corner s + 1) and the distance from it along the side's chord, mm."""
    side = int(rib.split()[0].rsplit("-", 1)[1])
    start, end = panel.corners[side], panel.corners[(side + 1) % 4]
    direction = (end - start) / np.linalg.norm(end - start)
    return side, float((centre - start) @ direction)


def _side_dimensions(ax, corners: np.ndarray, texts: list[str]) -> None:
    """Aligned dimension lines outside each side of the top view, corners named C0..C3."""
    middle = corners.mean(axis=0)
    size = float(np.ptp(corners, axis=0).max())
    offset = 0.07 * size
    for s, text in enumerate(texts):
        p, q = corners[s], corners[(s + 1) % 4]
        along = (q - p) / max(float(np.linalg.norm(q - p)), 1e-9)
        out = np.array([along[1], -along[0]])
        if (p + q) / 2 @ out < middle @ out:
            out = -out
        a, b = p + out * offset, q + out * offset
        for start, end in ((p, a), (q, b)):
            ax.plot(*np.c_[start + out * 0.01 * size, end + out * 0.02 * size], color="#2e7d32",
                    lw=0.3)  # fmt: skip
        ax.annotate("", a, b, arrowprops={"arrowstyle": "<|-|>", "color": "#2e7d32", "lw": 0.4,
                                          "shrinkA": 0, "shrinkB": 0, "mutation_scale": 5})  # fmt: skip
        angle = float(np.degrees(np.arctan2(along[1], along[0])))
        angle = (angle + 90.0) % 180.0 - 90.0  # read from below or from the right
        ax.text(*((a + b) / 2 + out * 0.018 * size), f"side {s}: {text}", rotation=angle,
                rotation_mode="anchor", ha="center", va="center", fontsize=5.5,
                color="#2e7d32")  # fmt: skip
    for index, corner in enumerate(corners):
        label = corner + (corner - middle) / max(float(np.linalg.norm(corner - middle)), 1e-9) * (
            0.045 * size
        )
        ax.text(*label, f"C{index}", fontsize=6.5, ha="center", va="center", weight="bold")
    ax.update_datalim(np.vstack([corners + (corners - middle) * 0.25]))
    ax.autoscale_view()


def _scale_bar(ax) -> None:
    """A bar of a round length (1, 2 or 5 x 10^k mm, at most a fifth of the view's width)
    under the view's frame at its left end; the view's limits are final (equal aspect, the
    box adjusts)."""
    x0, x1 = ax.get_xlim()
    most = (x1 - x0) / 5.0
    power = 10.0 ** np.floor(np.log10(most))
    length = max(step * power for step in (1.0, 2.0, 5.0) if step * power <= most)
    # x in the view's millimetres, y in fractions of its frame: 1.5 % of the page below it
    below = -0.015 / ax.get_position().height
    tick = 0.3 * below
    ends = [x0, x0, x0 + length, x0 + length]
    ax.plot(ends, [below + tick, below, below, below + tick], color="k", lw=0.6,
            transform=ax.get_xaxis_transform(), clip_on=False)  # fmt: skip
    ax.text(x0 + length + 0.01 * (x1 - x0), below, f"{length:g} mm", fontsize=5.5, va="center",
            transform=ax.get_xaxis_transform())  # fmt: skip


def _depth_dimension(ax, visible: list[np.ndarray]) -> None:
    """The panel's overall height in the section view (depth and rise), dimensioned at its
    right end."""
    if not visible:
        return
    points = np.concatenate(visible)
    (x0, y0), (x1, y1) = points.min(axis=0), points.max(axis=0)
    x = x1 + 0.03 * (x1 - x0)
    ax.annotate("", (x, y0), (x, y1), arrowprops={"arrowstyle": "<|-|>", "color": "#2e7d32",
                                                  "lw": 0.4, "shrinkA": 0, "shrinkB": 0,
                                                  "mutation_scale": 5})  # fmt: skip
    ax.text(x + 0.01 * (x1 - x0), (y0 + y1) / 2, f"overall {y1 - y0:.1f}", fontsize=5.5, va="center",
            color="#2e7d32")  # fmt: skip
    ax.update_datalim([(x + 0.08 * (x1 - x0), y1)])
    ax.autoscale_view()


def _one_path(lines: list[np.ndarray]):
    """Polylines as one matplotlib path (a move to the start of each)."""
    from matplotlib.path import Path as MplPath

    vertices = np.concatenate(lines)
    codes = np.full(len(vertices), MplPath.LINETO, dtype=np.uint8)
    codes[np.cumsum([0] + [len(line) for line in lines[:-1]])] = MplPath.MOVETO
    return MplPath(vertices, codes)


def _marks(ax, marks: list[str], points: np.ndarray) -> None:
    for mark, (x, y) in zip(marks, points):
        ax.annotate(
            mark,
            (x, y),
            fontsize=6.5,
            ha="center",
            va="center",
            color="#0a3d91",
            bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "#0a3d91", "lw": 0.4},
        )


def _bolt_marks(ax, points: np.ndarray) -> None:
    """Numbered crosses at the bolts (the numbers of the bolts table)."""
    if len(points):
        # one line of markers for all the crosses
        ax.plot(*np.asarray(points).T, marker="+", ls="none", color="#b3261e", markersize=5,
                mew=0.6)  # fmt: skip
    for index, (x, y) in enumerate(points, start=1):
        ax.annotate(str(index), (x, y), xytext=(2, 2), textcoords="offset points", fontsize=4.5,
                    color="#b3261e")  # fmt: skip


def _tables(fig, parts: list[PartDoc], tilts: dict, bolts: list) -> None:
    lines = ["PARTS (mark  kind  t  mass)"]
    for part in parts:
        lines.append(
            f"{part.mark:<6} {part.kind:<12} {part.thickness:4.0f} mm {part.mass:7.2f} kg"
            + (f"  tilt {tilts[part.id]:.2f}°" if tilts.get(part.id) is not None else "")
        )
    lines += ["", f"BOLTS ({len(bolts)}): along the side's chord from corner C; x, y, z from"]
    lines += ["the panel centre (x along side 0, y across it, z outward), mm"]
    lines += ["    rib  mark     from  along        x        y       z"]
    for index, (rib, corner, along, x, y, z) in enumerate(bolts[:TABLE_ROWS], start=1):
        lines.append(f"{index:>3} {rib:<12} C{corner} {along:7.1f} {x:8.1f} {y:8.1f} {z:7.1f}")
    if len(bolts) > TABLE_ROWS:
        lines.append(f"... and {len(bolts) - TABLE_ROWS} more (docs/fasteners.csv, the IFC)")
    fig.text(0.57, 0.94, "\n".join(lines), fontsize=5.6, family="DejaVu Sans Mono", va="top")


def _joint_detail(ax, source: DocSource) -> None:
    """Section across a joint: two ribs back to back (gap), the sheets set back, fillet welds,
    the bolt, drawn to scale from the sandwich build-up."""
    from matplotlib.patches import Polygon, Rectangle

    from ..buildup import Buildup

    b = Buildup.of(source.job)
    t_rib, gap, h = b.t_rib, b.welds.erection_gap, b.rib_height
    setback, leg = b.welds.setback, b.welds.leg
    reach = 6.0 * t_rib
    for sign in (-1, 1):
        inner = sign * gap / 2.0
        outer = inner + sign * t_rib
        x0, x1 = sorted((inner, outer))
        ax.add_patch(Rectangle((x0, 0.0), x1 - x0, h, fc="#d9dde3", ec="k", lw=0.6))
        # sheets from the set-back outwards, on top (t_top) and under (t_bot) the rib
        edge = inner + sign * setback
        far = inner + sign * reach
        for y, t in ((h, b.t_top), (-b.t_bot, b.t_bot)):
            if t > 0:
                lo, hi = sorted((edge, far))
                ax.add_patch(Rectangle((lo, y), hi - lo, t, fc="#bfc7d1", ec="k", lw=0.6))
        # the fillet welds in the corner between sheet edge and rib face
        for y, up in ((h, 1), (0.0, -1)):
            tri = [(edge, y), (edge - sign * leg, y), (edge, y + up * leg)]
            ax.add_patch(Polygon(tri, closed=True, fc="#e07a1f", ec="none"))
    bolt = h / 2.0
    shank = t_rib * 2 + gap
    ax.add_patch(Rectangle((-shank / 2 - 4, bolt - 6), shank + 8, 12, fc="none", ec="#b3261e",
                           lw=0.6, ls="--"))  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xlim(-reach - 5, reach + 5)
    ax.set_ylim(-b.t_bot - 10, h + b.t_top + 10)
    ax.set_title(
        f"Joint detail: ribs {t_rib:g} mm, gap {gap:g} mm, sheets set back {setback:g} mm,\n"
        f"fillet a = {b.welds.throat:.1f} mm (leg {leg:.1f}), bolt at mid-height",
        fontsize=6.5,
        loc="left",
    )
    ax.set_xticks([])
    ax.set_yticks([])


def _title_block(fig, source: DocSource, name: str, ids, parts: list[PartDoc]) -> None:
    mass = sum(p.mass for p in parts)
    listed = ", ".join(ids[:12]) + (f" and {len(ids) - 12} more" if len(ids) > 12 else "")
    text = (
        f"Project: {source.job.docs.project or source.name}    Drawing: panel type {name} "
        f"({len(ids)} panel(s): {listed})    Mass {mass:.1f} kg    Revision "
        f"{source.job.docs.revision}    {date.today().isoformat()}    fabpanel "
        f"{source.fabpanel_version}    A3, dimensions in mm, not to scale"
    )
    fig.text(MARGIN / A3[0], 0.03, text, fontsize=7, va="bottom",
             bbox={"boxstyle": "square,pad=0.6", "fc": "white", "ec": "k", "lw": 0.8})  # fmt: skip
