"""Rationalisation figures: Gaussian curvature before and after (the thesis's Figures 24-25) and
the deviation from the design surface, in plan, every sample-grid cell coloured."""

from __future__ import annotations

import numpy as np

from ..geom.quads import angle_defects

#: the colour scale of the curvature figures reaches at least this |K| (1/m^2, a sphere of 100 m
#: radius): a panel of any practical size that curved unrolls within tolerance, so on an already
#: developable design the round-off noise (1e-14) stays white instead of filling the scale
CURVATURE_SCALE_FLOOR = 1e-4


def gaussian_curvature(samples: np.ndarray) -> np.ndarray:
    """(m, k-1, k-1) 1/m^2: discrete Gaussian curvature per grid cell.

    The angle defect at an interior sample divided by a quarter of its four cells' areas
    (Gauss-Bonnet), carried to the panel's border samples from the nearest interior one, then
    averaged over each cell's four corners.
    """
    cells = _cell_areas(samples)  # (m, k-1, k-1) mm^2
    vertex_area = 0.25 * (
        cells[:, :-1, :-1] + cells[:, 1:, :-1] + cells[:, 1:, 1:] + cells[:, :-1, 1:]
    )
    curvature = angle_defects(samples) / vertex_area * 1e6  # 1/m^2
    full = np.pad(curvature, ((0, 0), (1, 1), (1, 1)), mode="edge")
    return _cell_means(full)


def _cell_areas(samples: np.ndarray) -> np.ndarray:
    a, b = samples[:, :-1, :-1], samples[:, 1:, :-1]
    c, d = samples[:, 1:, 1:], samples[:, :-1, 1:]
    return 0.5 * np.linalg.norm(np.cross(c - a, d - b), axis=-1)


def _cell_means(values: np.ndarray) -> np.ndarray:
    return 0.25 * (
        values[:, :-1, :-1] + values[:, 1:, :-1] + values[:, 1:, 1:] + values[:, :-1, 1:]
    )


#: a figure is drawn in 3D when some panel keeps less than this share of its area in plan (a
#: vault's steep sides, where a plan view squashes the cells)
PLAN_SHARE = 0.4


def steep(samples: np.ndarray) -> bool:
    """Whether a plan view would squash some panel (``PLAN_SHARE``)."""
    true = _cell_areas(samples).sum(axis=(1, 2))
    flat = samples.copy()
    flat[..., 2] = 0.0
    return bool(np.any(_cell_areas(flat).sum(axis=(1, 2)) < PLAN_SHARE * true))


def _axes(fig, rows: int, columns: int, index: int, samples: np.ndarray):
    return fig.add_subplot(rows, columns, index, projection="3d" if steep(samples) else None)


def _plan_cells(ax, samples: np.ndarray, values: np.ndarray, **style):
    """Every grid cell as a filled quad, coloured by ``values``: in plan (x, y in m), or in 3D
    when ``ax`` is a 3D axis."""
    from matplotlib.collections import PolyCollection

    if hasattr(ax, "zaxis"):
        return _cells_3d(ax, samples, values, **style)

    corners = (
        np.stack(
            [samples[:, :-1, :-1], samples[:, 1:, :-1], samples[:, 1:, 1:], samples[:, :-1, 1:]],
            axis=3,
        )[..., :2]
        / 1000.0
    )
    # matplotlib's stubs want a Sequence; an (N, 4, 2) array is documented and takes a fast path
    cells = PolyCollection(
        corners.reshape(-1, 4, 2),  # type: ignore[arg-type]
        array=values.ravel(),
        edgecolors="none",
        **style,
    )
    ax.add_collection(cells)
    outline = (
        np.concatenate(
            [samples[:, :, 0], samples[:, -1, :], samples[:, ::-1, -1], samples[:, 0, ::-1]], axis=1
        )[..., :2]
        / 1000.0
    )
    for line in outline:
        ax.plot(line[:, 0], line[:, 1], color="k", linewidth=0.3)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]")
    return cells


def _cells_3d(ax, samples: np.ndarray, values: np.ndarray, cmap: str, clim):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    from .figures import view_3d

    corners = np.stack(
        [samples[:, :-1, :-1], samples[:, 1:, :-1], samples[:, 1:, 1:], samples[:, :-1, 1:]],
        axis=3,
    ).reshape(-1, 4, 3)
    cells = Poly3DCollection(corners / 1000.0, cmap=cmap, edgecolor="none")
    cells.set_array(values.ravel())
    cells.set_clim(*clim)
    ax.add_collection3d(cells)
    # the panel outlines, as in plan: a developable design is white all over (K = 0 at the
    # middle of the diverging scale), and without them the 3D view of the demo looked empty
    outline = np.concatenate(
        [samples[:, :, 0], samples[:, -1, :], samples[:, ::-1, -1], samples[:, 0, ::-1]], axis=1
    )
    ax.add_collection3d(Line3DCollection(outline / 1000.0, colors="k", linewidths=0.3))
    view_3d(ax, samples.reshape(-1, 3) / 1000.0)
    return cells


def curvature_figure(developed) -> bytes | None:
    """PNG: Gaussian curvature of the panels on the design surface and after
    development, on one colour scale; ``None`` when the panels did not move."""
    if developed.design_samples is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figures import png_bytes

    before = gaussian_curvature(developed.design_samples)
    after = gaussian_curvature(developed.samples)
    limit = max(float(np.percentile(np.abs(before), 99)), CURVATURE_SCALE_FLOOR)
    fig = plt.figure(figsize=(11, 4.8), constrained_layout=True)
    axes = [_axes(fig, 1, 2, i, developed.samples) for i in (1, 2)]
    for ax, grids, values, title in (
        (axes[0], developed.design_samples, before, "design surface"),
        (axes[1], developed.samples, after, f"after '{developed.method}'"),
    ):
        cells = _plan_cells(ax, grids, values, cmap="RdBu_r", clim=(-limit, limit))
        ax.set_title(
            f"Gaussian curvature, {title}: |K| max {np.abs(values).max():.3g} 1/m²", fontsize=10
        )
    # the scale is clipped at the design's 99th percentile, so one sharp cell does not wash
    # out the rest: the colour bar says so
    fig.colorbar(
        cells, ax=axes, shrink=0.8, extend="both", label=f"K [1/m²], clipped at ±{limit:.3g}"
    )
    data = png_bytes(fig)
    plt.close(fig)
    return data


def deviation_figure(developed) -> bytes | None:
    """PNG: distance of the developed panels from the design surface, mm."""
    if developed.deviation is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figures import png_bytes

    # each cell coloured by its largest corner value, so the colour bar ends at the maximum
    # the title names
    d = developed.deviation
    values = np.maximum.reduce([d[:, :-1, :-1], d[:, 1:, :-1], d[:, 1:, 1:], d[:, :-1, 1:]])
    fig = plt.figure(figsize=(6.5, 4.8), constrained_layout=True)
    ax = _axes(fig, 1, 1, 1, developed.samples)
    cells = _plan_cells(
        ax, developed.samples, values, cmap="viridis", clim=(0.0, max(float(values.max()), 1e-3))
    )
    ax.set_title(
        f"deviation from the design surface: max {developed.deviation.max():.2f} mm, "
        f"mean {developed.deviation.mean():.2f} mm",
        fontsize=10,
    )
    fig.colorbar(cells, ax=ax, shrink=0.8, label="mm")
    data = png_bytes(fig)
    plt.close(fig)
    return data
