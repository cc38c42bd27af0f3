"""Corners of the outline as the field method's mesher gets them: cut corners merged."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fabpanel.data import Surface
from fabpanel.panelize.corners import outline_corners


def _outline(points: np.ndarray) -> Surface:
    """A surface that is only its outline (mm, plane z = 0): the corner finder needs no faces."""
    vertices = np.column_stack([points, np.zeros(len(points))])
    loop = np.arange(len(points))
    return Surface(vertices, np.zeros((0, 3), dtype=int), (loop,), Path("outline.obj"), "obj", "mm")


def _resampled(polygon: np.ndarray, step: float) -> np.ndarray:
    """The closed polygon's outline sampled every ``step`` of arc length (corners cut where a
    sample does not land on them, as a mesh generator cuts them)."""
    closed = np.vstack([polygon, polygon[:1]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    at = np.arange(0.0, arc[-1], step) + 0.37 * step  # off the corners on purpose
    at = at[at < arc[-1]]
    return np.column_stack([np.interp(at, arc, closed[:, i]) for i in range(2)])


def test_cut_corners_become_one_corner_each_and_their_cut_is_left_out():
    square = np.array([[0.0, 0.0], [6000.0, 0.0], [6000.0, 4000.0], [0.0, 4000.0]])
    points = _resampled(square, 200.0)
    surface = _outline(points)
    # vertex by vertex, every cut corner is two vertices turning 45 degrees each
    found = outline_corners(surface, points, corner_angle=30.0, merge=300.0)
    corners = points[found.loops[0][found.corners[0]]]
    assert len(corners) == 4
    # each corner is a vertex of the cut, within one cut's length of the true corner
    distance = np.linalg.norm(corners[:, None, :] - square[None, :, :], axis=2).min(axis=1)
    assert distance.max() < 200.0
    assert len(found.loops[0]) == len(points) - 4  # the other vertex of each cut left out
    np.testing.assert_array_equal(
        np.sort(found.cut_corners), np.sort(found.loops[0][found.corners[0]])
    )
    # without merging, each cut gives two corners 148 mm apart (the short edge it caused)
    apart = outline_corners(surface, points, corner_angle=30.0, merge=1.0)
    assert apart.corners[0].sum() == 8 and len(apart.loops[0]) == len(points)


def test_a_smooth_outline_has_no_corner_and_keeps_every_vertex():
    t = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    ellipse = np.column_stack([5000 * np.cos(t), 3000 * np.sin(t)])
    found = outline_corners(_outline(ellipse), ellipse, corner_angle=30.0, merge=300.0)
    assert not found.corners[0].any() and len(found.loops[0]) == 180
    assert not len(found.cut_corners)


def test_two_real_corners_further_apart_than_twice_merge_both_stay():
    # a slot 700 mm wide: its two corners at the end are 700 mm apart, more than 2 x merge (the
    # shortest curve the mesher can give two edges of at least merge)
    slot = np.array([[0.0, 0.0], [4000.0, 0.0], [4000.0, 700.0], [0.0, 700.0]])
    points = _resampled(slot, 100.0)
    points = np.vstack([points, slot])  # the true corners sampled too, sorted back in order
    closed = np.vstack([slot, slot[:1]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])

    def arc_of(p):
        for i in range(4):
            a, b = closed[i], closed[i + 1]
            u = np.dot(p - a, b - a) / np.dot(b - a, b - a)
            if np.linalg.norm(a + np.clip(u, 0, 1) * (b - a) - p) < 1e-6:
                return arc[i] + np.clip(u, 0, 1) * np.linalg.norm(b - a)
        raise AssertionError(p)

    points = points[np.argsort([arc_of(p) for p in points])]
    found = outline_corners(_outline(points), points, corner_angle=30.0, merge=300.0)
    corners = points[found.loops[0][found.corners[0]]]
    np.testing.assert_allclose(np.sort(corners, axis=0), np.sort(slot, axis=0), atol=1e-9)
    assert not len(found.cut_corners)  # exact corners: nothing was cut


def test_a_facet_shorter_than_twice_merge_is_one_corner():
    # a 90 degree corner cut by a 450 mm facet (two 45 degree turns): longer than merge, so
    # each end is a corner on its own, but a curve that short would get two 225 mm edges
    outline = np.array([[0.0, 0.0], [6000.0, 0.0], [6000.0, 4000.0], [318.2, 4000.0]])
    outline = np.vstack([outline, [[0.0, 3681.8]]])
    points = _resampled(outline, 100.0)
    found = outline_corners(_outline(points), points, corner_angle=30.0, merge=300.0)
    corners = points[found.loops[0][found.corners[0]]]
    assert len(corners) == 4
    near_cut = np.linalg.norm(corners - [0.0, 4000.0], axis=1) < 460.0
    assert near_cut.sum() == 1  # one corner where the facet was, at one of its ends
    cut = points[found.cut_corners]  # (every corner is cut by the resampling here)
    assert (np.linalg.norm(cut - [0.0, 4000.0], axis=1) < 460.0).sum() == 1
    kept = points[found.loops[0]]
    on_facet = (np.abs(kept[:, 1] - kept[:, 0] - 3681.8) < 1.0) & (kept[:, 0] < 318.2)
    assert on_facet.sum() <= 2  # the facet's inner samples left out
    # at merge = 1 mm the facet keeps both its corners
    apart = outline_corners(_outline(points), points, corner_angle=30.0, merge=1.0)
    assert apart.corners[0].sum() >= 5
