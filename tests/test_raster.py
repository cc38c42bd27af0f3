"""Figures as palette PNGs: a quarter of the bytes, no visible change, the same bytes twice."""

from __future__ import annotations

import io

import numpy as np


def _colour_map_figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x, y = np.meshgrid(np.linspace(0, 1, 200), np.linspace(0, 1, 120))
    field = ax.pcolormesh(x, y, np.sin(6 * x) * np.cos(4 * y), cmap="RdYlGn_r")
    fig.colorbar(field, label="utilisation [-]")
    ax.plot([0, 1], [0, 1], color="black")
    ax.set_title("a colour map, a line and text")
    return fig, plt


def test_a_colour_map_figure_keeps_its_colours_in_a_quarter_of_the_bytes():
    from PIL import Image

    from fabpanel.raster import figure_png

    fig, plt = _colour_map_figure()
    full = io.BytesIO()
    fig.savefig(full, format="png", dpi=100, metadata={"Software": None})
    packed = figure_png(fig, dpi=100)
    again = figure_png(fig, dpi=100)
    plt.close(fig)
    assert packed == again
    assert len(packed) < len(full.getvalue()) / 2.5
    with Image.open(io.BytesIO(packed)) as image:
        assert image.mode == "P"
        paletted = np.asarray(image.convert("RGB"), dtype=float)
    with Image.open(full) as image:
        original = np.asarray(image.convert("RGB"), dtype=float)
    assert paletted.shape == original.shape
    error = np.abs(paletted - original).max(axis=2)
    # a few levels of 256 per channel are invisible in a plot (a colour map's neighbouring
    # steps differ by about 4): no pixel far off, nearly every pixel within a few levels
    assert error.max() <= 24 and np.percentile(error, 99) <= 16 and error.mean() < 3.0
