"""The report's figures of the layout and the developed panels (PNG bytes)."""

from __future__ import annotations

import numpy as np

from ..raster import figure_png

CLASS_COLOURS = {
    "planar": "#4c9be8",
    "single-curved": "#59b36b",
    "conical": "#e0b03a",
    "not-developable": "#d9534f",
}


def view_3d(ax, points: np.ndarray) -> None:
    """A 3D axis fitted to ``points (n, 3)`` in m, true to scale, seen from the south-west."""
    lo, hi = points.min(0), points.max(0)
    ax.set_xlim(lo[0], hi[0]), ax.set_ylim(lo[1], hi[1]), ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3))
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.view_init(elev=28, azim=-60)


def png_bytes(fig) -> bytes:
    """The figure as a palette PNG (110 dpi, trimmed), without a time stamp."""
    return figure_png(fig, dpi=110, bbox_inches="tight")


def panel_figure(developed) -> bytes:
    """PNG: the panels' sample grids in 3D, coloured by class (their ids are on the key plan:
    labels in a 3D view show through from the back)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(8, 5))
    ax = fig.add_subplot(projection="3d")
    grids = developed.samples
    for grid, cls in zip(grids, developed.classes):
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
    view_3d(ax, grids.reshape(-1, 3) / 1000.0)
    data = png_bytes(fig)
    plt.close(fig)
    return data


def layout_figure(layout, surface) -> bytes:
    """PNG: the panel layout in plan and in 3D, singular vertices marked by valence, the
    surface's fold lines dashed."""
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
    folds: tuple[np.ndarray, ...] = tuple(getattr(surface, "folds", ()))
    for index, chain in enumerate(folds):
        points = surface.vertices[chain] / 1000.0
        plan.plot(
            points[:, 0],
            points[:, 1],
            color="tab:green",
            linewidth=1.6,
            linestyle="--",
            label="fold line" if index == 0 else None,
            zorder=2,
        )
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
    if singular or folds:
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
    data = png_bytes(fig)
    plt.close(fig)
    return data
