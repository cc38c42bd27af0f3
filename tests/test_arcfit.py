"""Arc fitting: every polyline vertex stays within the tolerance, corners stay sharp."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LineString, Point

from fabpanel.geom.arcfit import ARC_TOLERANCE, bulge_polyline, fit_arcs


def largest_miss(points: np.ndarray, vertices: np.ndarray, bulges: np.ndarray) -> float:
    """Largest distance of a polyline's vertices from the fitted lines and arcs."""
    path = bulge_polyline(vertices, bulges, chord_tolerance=1e-4)
    ring = LineString(np.vstack([path, path[:1]]))
    return max(ring.distance(Point(p)) for p in points)


def rounded_rectangle(width=800.0, height=300.0, radius=40.0, per_side=40, per_corner=16):
    corners = [
        (width - radius, radius),
        (width - radius, height - radius),
        (radius, height - radius),
        (radius, radius),
    ]
    out = []
    for k, (cx, cy) in enumerate(corners):
        start = -np.pi / 2 + k * np.pi / 2
        angle = np.linspace(start, start + np.pi / 2, per_corner)
        arc = np.stack([cx + radius * np.cos(angle), cy + radius * np.sin(angle)], axis=1)
        nxt = corners[(k + 1) % 4]
        n_start = -np.pi / 2 + (k + 1) * np.pi / 2
        end = np.array([nxt[0] + radius * np.cos(n_start), nxt[1] + radius * np.sin(n_start)])
        side = arc[-1] + np.linspace(0, 1, per_side)[1:-1, None] * (end - arc[-1])
        out += [arc, side]
    return np.concatenate(out)


@pytest.mark.parametrize("shape", ["ellipse", "rounded-rectangle", "wavy"])
def test_fit_holds_every_vertex(shape):
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    points = {
        "ellipse": np.stack([600 * np.cos(t), 300 * np.sin(t)], axis=1),
        "rounded-rectangle": rounded_rectangle(),
        "wavy": np.stack(
            [(500 + 30 * np.sin(5 * t)) * np.cos(t), (500 + 30 * np.sin(5 * t)) * np.sin(t)], axis=1
        ),
    }[shape]
    vertices, bulges = fit_arcs(points)
    assert len(vertices) < len(points) / 4  # far fewer pieces than chords
    assert np.abs(bulges).max() <= 1.0 and np.any(bulges != 0)
    # vertices are polyline points, and the pieces hold every other point
    assert all(np.min(np.linalg.norm(points - v, axis=1)) < 1e-9 for v in vertices)
    assert largest_miss(points, vertices, bulges) <= ARC_TOLERANCE + 1e-6


def test_rounded_rectangle_is_four_lines_and_four_arcs():
    _, bulges = fit_arcs(rounded_rectangle())
    assert np.count_nonzero(bulges) == 4 and np.count_nonzero(bulges == 0) == 4
    # a quarter circle: bulge tan(90 deg / 4), counter-clockwise
    np.testing.assert_allclose(bulges[bulges != 0], np.tan(np.pi / 8), rtol=1e-9)


def test_sharp_corners_stay_sharp():
    s = np.linspace(0, 100, 51)[:-1]
    square = np.concatenate(
        [
            np.stack([s, 0 * s], 1),
            np.stack([100 + 0 * s, s], 1),
            np.stack([100 - s, 100 + 0 * s], 1),
            np.stack([0 * s, 100 - s], 1),
        ]
    )
    vertices, bulges = fit_arcs(square)
    np.testing.assert_array_equal(bulges, 0)
    assert sorted(map(tuple, vertices)) == [(0, 0), (0, 100), (100, 0), (100, 100)]
    # a polygon with a corner of only 2 degrees is not smoothed into an arc either
    t = np.linspace(0, np.pi, 60)
    arch = np.stack([300 * np.cos(t), 300 * np.sin(t)], axis=1)
    kinked = np.concatenate([arch, [[-300, -10.0], [300, -10.0]]])
    vertices, bulges = fit_arcs(kinked)
    assert largest_miss(kinked, vertices, bulges) <= ARC_TOLERANCE + 1e-6
    assert any(np.allclose(v, [300, -10.0]) for v in vertices)


def test_open_polyline_keeps_its_ends():
    t = np.linspace(0, np.pi / 2, 50)
    quarter = np.stack([200 * np.cos(t), 200 * np.sin(t)], axis=1)
    vertices, bulges = fit_arcs(quarter, closed=False)
    np.testing.assert_allclose(vertices[[0, -1]], quarter[[0, -1]])
    assert len(vertices) == 2 and bulges[-1] == 0
    np.testing.assert_allclose(bulges[0], np.tan(np.pi / 8), rtol=1e-9)


@pytest.mark.parametrize("sides", [12, 16, 20])
def test_coarse_polygons_on_a_circle_keep_their_corners(sides):
    t = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    polygon = np.stack([100 * np.cos(t), 100 * np.sin(t)], axis=1)
    vertices, bulges = fit_arcs(polygon)
    np.testing.assert_array_equal(bulges, 0)
    assert len(vertices) == sides
