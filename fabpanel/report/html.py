"""The self-contained HTML report: tables of the stage metrics and embedded PNG figures."""

from __future__ import annotations

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from .develop_figures import curvature_figure, deviation_figure

CLASS_COLOURS = {
    "planar": "#4c9be8",
    "single-curved": "#59b36b",
    "conical": "#e0b03a",
    "not-developable": "#d9534f",
}


def _png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    return base64.b64encode(buffer.getvalue()).decode()


def panel_figure(developed) -> str:
    """Base64 PNG: the panels' sample grids in 3D, coloured by class."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(8, 5))
    ax = fig.add_subplot(projection="3d")
    grids = developed.samples
    for grid, cls, pid in zip(grids, developed.classes, developed.panel_ids):
        quads = np.stack([grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]], axis=2)
        poly = Poly3DCollection(
            quads.reshape(-1, 4, 3) / 1000.0,
            facecolor=CLASS_COLOURS[cls],
            edgecolor="none",
            alpha=0.9,
        )
        ax.add_collection3d(poly)
        outline = np.concatenate([grid[:, 0], grid[-1, :], grid[::-1, -1], grid[0, ::-1]]) / 1e3
        ax.plot(*outline.T, color="k", linewidth=0.8)
        centre = grid[grid.shape[0] // 2, grid.shape[1] // 2] / 1e3
        ax.text(*centre, pid, fontsize=6, ha="center")
    points = grids.reshape(-1, 3) / 1000.0
    lo, hi = points.min(0), points.max(0)
    ax.set_xlim(lo[0], hi[0]), ax.set_ylim(lo[1], hi[1]), ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3))
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.view_init(elev=28, azim=-60)
    data = _png(fig)
    plt.close(fig)
    return data


def layout_figure(layout, surface) -> str:
    """Base64 PNG: the panel layout in plan and in 3D, singular vertices marked by valence."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..panelize.quality import singular_vertices

    corners = layout.vertices[layout.quads] / 1000.0
    closed = np.concatenate([corners, corners[:, :1]], axis=1)
    singular = singular_vertices(layout)
    fig = plt.figure(figsize=(11, 4.6))
    plan = fig.add_subplot(1, 2, 1)
    for quad in closed:
        plan.plot(quad[:, 0], quad[:, 1], color="0.3", linewidth=0.6)
    for loop in surface.boundary_loops:
        points = surface.vertices[np.append(loop, loop[0])] / 1000.0
        plan.plot(points[:, 0], points[:, 1], color="tab:blue", linewidth=1.2)
    colours = {3: "tab:orange", 5: "tab:red", 6: "tab:purple"}
    for valence in sorted({s["valence"] for s in singular}):
        points = np.array([s["position_mm"] for s in singular if s["valence"] == valence]) / 1e3
        plan.scatter(
            points[:, 0],
            points[:, 1],
            s=30,
            color=colours.get(valence, "k"),
            label=f"valence {valence}",
            zorder=3,
        )
    if singular:
        plan.legend(loc="best", fontsize=8)
    plan.set_aspect("equal")
    plan.set_xlabel("x [m]"), plan.set_ylabel("y [m]")
    plan.set_title(f"{len(layout.quads)} panels, {len(singular)} singular vertices", fontsize=10)
    view = fig.add_subplot(1, 2, 2, projection="3d")
    for quad in closed:
        view.plot(*quad.T, color="0.3", linewidth=0.5)
    points = layout.vertices / 1000.0
    lo, hi = points.min(0), points.max(0)
    view.set_box_aspect(np.maximum(hi - lo, 1e-3))
    view.view_init(elev=30, azim=-60)
    data = _png(fig)
    plt.close(fig)
    return data


def _table(rows: list[tuple[str, object]]) -> str:
    cells = "".join(
        f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(_fmt(v))}</td></tr>" for k, v in rows
    )
    return f"<table>{cells}</table>"


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (dict, list)):
        return json.dumps(value)
    return str(value)


def write_report(result, folder: Path) -> None:
    """Write ``summary.json`` and ``index.html`` into ``folder``."""
    summary = result.summary
    (folder / "summary.json").write_text(json.dumps(summary, indent=1))
    sections = [
        f"<h1>fabpanel report: {html.escape(result.surface.source.name)}</h1>",
        "<h2>Summary</h2>",
        _table(
            [(k, v) for k, v in summary.items() if not isinstance(v, dict)]
            + [("input", summary["input"])]
        ),
    ]
    for key in ("panels", "developability", "parts", "flat", "nests", "structure", "timings_s"):
        if key == "structure" and key in summary:
            from .structure_figures import structure_section

            sections.append(structure_section(result))
            continue
        if key in summary:
            sections.append(f"<h2>{key.capitalize()}</h2>")
            sections.append(_table(list(summary[key].items())))
            if key == "panels" and result.layout is not None:
                sections.append(
                    f'<img alt="panel layout" src="data:image/png;base64,'
                    f'{layout_figure(result.layout, result.surface)}">'
                )
            if key == "developability" and result.developed is not None:
                legend = " ".join(
                    f'<span style="color:{c}">&#9632; {n}</span>' for n, c in CLASS_COLOURS.items()
                )
                sections.append(
                    f'<p>{legend}</p><img alt="panels coloured by class" '
                    f'src="data:image/png;base64,{panel_figure(result.developed)}">'
                )
            if key == "developability" and result.developed is not None:
                for figure, alt in (
                    (curvature_figure, "Gaussian curvature before and after"),
                    (deviation_figure, "deviation from the design surface"),
                ):
                    data = figure(result.developed)
                    if data is not None:
                        sections.append(f'<img alt="{alt}" src="data:image/png;base64,{data}">')
                per_panel = result.developed.metrics["per_panel"]
                head = "".join(
                    f"<th>{html.escape(h)}</th>"
                    for h in ["panel", *next(iter(per_panel.values())).keys()]
                )
                body = "".join(
                    "<tr><td>"
                    + pid
                    + "</td>"
                    + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in rec.values())
                    + "</tr>"
                    for pid, rec in per_panel.items()
                )
                sections.append(
                    f"<details><summary>Per panel</summary><table><tr>{head}</tr>"
                    f"{body}</table></details>"
                )
    if result.nests is not None and result.out_dir is not None:
        sections.append("<h2>Plates</h2>")
        for plate in result.nests.plates:
            png = result.out_dir / "cut" / "nests" / f"{plate.name}.png"
            if png.exists():
                data = base64.b64encode(png.read_bytes()).decode()
                sections.append(
                    f"<h3>{plate.name}: {len(plate.placements)} parts, "
                    f"utilisation {plate.utilisation:.1%}</h3>"
                    f'<img alt="{plate.name}" style="max-width:100%" '
                    f'src="data:image/png;base64,{data}">'
                )
    if result.issues:
        sections.append(
            "<h2>Issues</h2><table>"
            + "".join(
                f"<tr><td>{i.severity}</td><td>{html.escape(i.code)}</td><td>{i.item}</td>"
                f"<td>{html.escape(i.message)}</td></tr>"
                for i in result.issues
            )
            + "</table>"
        )
    style = (
        "body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
        "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;"
        "padding:2px 6px;text-align:left;font-size:13px}th{background:#f3f3f3}"
    )
    page = (
        f"<!doctype html><html><head><meta charset='utf-8'><title>fabpanel report</title>"
        f"<style>{style}</style></head><body>{''.join(sections)}</body></html>"
    )
    (folder / "index.html").write_text(page, encoding="utf-8")
