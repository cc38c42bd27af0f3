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


def _rounded_rectangle(width: float, depth: float, radius: float, step: float) -> np.ndarray:
    """A rectangle's outline with rounded corners, sampled about every ``step`` mm."""
    from shapely.geometry import box

    core = box(-width / 2 + radius, -depth / 2 + radius, width / 2 - radius, depth / 2 - radius)
    ring = np.asarray(core.buffer(radius, quad_segs=64).exterior.coords)[:-1]
    return _resampled(ring, step)


def test_a_rounding_tighter_than_a_panel_is_one_corner_in_its_middle():
    # 90 degree roundings of 800 mm radius: 1257 mm of arc, turning 21 degrees within the
    # 300 mm that makes a corner of a cut, 72 within a panel
    points = _rounded_rectangle(8000.0, 5000.0, 800.0, 100.0)
    without = outline_corners(_outline(points), points, corner_angle=30.0, merge=300.0)
    assert not without.corners[0].any()
    found = outline_corners(_outline(points), points, 30.0, 300.0, panel_size=1000.0)
    corners = points[found.loops[0][found.corners[0]]]
    assert len(corners) == 4
    # each in the middle of its rounding: on the diagonal through the rounding's centre
    middles = np.array([3200.0, 1700.0]) + 800.0 * np.array([np.sqrt(0.5), np.sqrt(0.5)])
    np.testing.assert_allclose(np.sort(np.abs(corners), axis=0)[0], middles, atol=60.0)
    # the rounding's vertices within half a panel of the corner are left out of the outline
    kept = points[found.loops[0]]
    gap = np.linalg.norm(kept[:, None, :] - corners[None, :, :], axis=2).min(axis=1)
    assert gap[gap > 0].min() > 400.0


def test_wide_roundings_and_rounded_ends_stay_smooth():
    # 2 m roundings at 1 m panels turn 29 degrees within a panel: smooth
    wide = _rounded_rectangle(8000.0, 6000.0, 2000.0, 100.0)
    found = outline_corners(_outline(wide), wide, 30.0, 300.0, panel_size=1000.0)
    assert not found.corners[0].any()
    # a stadium's 600 mm round ends turn 180 degrees within two panels: no one corner takes it
    stadium = _rounded_rectangle(6000.0, 1200.0, 600.0, 100.0)
    found = outline_corners(_outline(stadium), stadium, 30.0, 300.0, panel_size=1000.0)
    assert not found.corners[0].any()


def _plate_with_openings(
    openings: list[tuple[float, float, float]], step: float = 150.0
) -> Surface:
    """A planar 12 x 8 m plate (mm) with round openings (x, y, radius) sampled about every
    ``step``, meshed by Delaunay."""
    from scipy.spatial import Delaunay

    outer = _resampled(np.array([[0, 0], [12000, 0], [12000, 8000], [0, 8000]], float), 200.0)
    rings = []
    for x, y, r in openings:
        count = max(16, int(2 * np.pi * r / step))
        t = np.linspace(0, 2 * np.pi, count, endpoint=False)[::-1]  # clockwise: a hole
        rings.append(np.column_stack([x + r * np.cos(t), y + r * np.sin(t)]))
    grid = np.array([(x, y) for x in range(100, 12000, 250) for y in range(100, 8000, 250)], float)
    clear = np.ones(len(grid), dtype=bool)
    for x, y, r in openings:
        clear &= np.hypot(grid[:, 0] - x, grid[:, 1] - y) > r + 120.0
    points = np.vstack([outer, *rings, grid[clear]])
    tri = Delaunay(points).simplices
    centre = points[tri].mean(axis=1)
    inside = np.ones(len(tri), dtype=bool)
    for x, y, r in openings:
        inside &= np.hypot(centre[:, 0] - x, centre[:, 1] - y) > r
    tri = tri[inside]
    loops, start = [np.arange(len(outer))], len(outer)
    for ring in rings:
        loops.append(start + np.arange(len(ring)))
        start += len(ring)
    vertices = np.column_stack([points, np.zeros(len(points))])
    return Surface(vertices, tri, tuple(loops), Path("plate.obj"), "obj", "mm")


def test_a_small_round_opening_reaches_the_mesher_as_a_square_set_to_the_field():
    from fabpanel.panelize.corners import small_openings

    surface = _plate_with_openings([(4000.0, 4000.0, 450.0), (8500.0, 4000.0, 1500.0)])
    flat = surface.vertices[:, :2]
    found = outline_corners(surface, flat, 30.0, 300.0, panel_size=1000.0)
    small = small_openings(found, surface, flat, 1000.0)
    assert small is not None and small.indices == (1,)
    kept, mesher = small.kept, small.squared
    # filled in for the punched layout: only the outer loop and the 3 m opening are meshed
    assert len(small.filled.loops) == 2 and len(small.filled.loops[1]) == len(found.loops[2])
    # the 0.9 m opening (2.8 m round, under 5 panel sizes): four corners a quarter apart
    square = flat[mesher.loops[1]]
    assert len(square) == 4 and mesher.corners[1].all()
    np.testing.assert_array_equal(np.sort(kept.loops[1][kept.corners[1]]), np.sort(mesher.loops[1]))
    sides = np.linalg.norm(np.roll(square, -1, axis=0) - square, axis=1)
    # (corners are vertices of the 18-gon, so a quarter round is 4 or 5 of its sides)
    np.testing.assert_allclose(sides, 450.0 * np.sqrt(2), rtol=0.12)
    # set square to the plate's sides (the field of the outline): corners on the diagonals
    directions = np.degrees(np.arctan2(square[:, 1] - 4000.0, square[:, 0] - 4000.0)) % 90.0
    np.testing.assert_allclose(directions, 45.0, atol=8.0)
    # the 3 m opening (9.4 m round) stays a smooth loop, every vertex given to the mesher
    assert not mesher.corners[2].any() and len(mesher.loops[2]) == len(surface.boundary_loops[2])
    # with no small opening, none
    plain = _plate_with_openings([(6000.0, 4000.0, 1500.0)])
    found = outline_corners(plain, plain.vertices[:, :2], 30.0, 300.0, panel_size=1000.0)
    assert small_openings(found, plain, plain.vertices[:, :2], 1000.0) is None


def test_a_small_rectangular_opening_keeps_its_four_corners():
    from fabpanel.panelize.corners import small_openings

    turn = np.radians(30.0)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    corners = np.array([[-400, -240], [400, -240], [400, 240], [-400, 240]], float) @ rotation.T
    hole = _resampled(corners + [4000.0, 3000.0], 100.0)[::-1]  # clockwise, corners cut
    outer = _resampled(np.array([[0, 0], [8000, 0], [8000, 6000], [0, 6000]], float), 200.0)
    points = np.vstack([outer, hole])
    vertices = np.column_stack([points, np.zeros(len(points))])
    loops = (np.arange(len(outer)), len(outer) + np.arange(len(hole)))
    surface = Surface(vertices, np.zeros((0, 3), dtype=int), loops, Path("o.obj"), "obj", "mm")
    found = outline_corners(surface, points, 30.0, 300.0, panel_size=1000.0)
    # its 0.48 m ends are shorter than twice the 0.3 m merge: their corners merged in pairs
    assert found.corners[1].sum() == 2
    small = small_openings(found, surface, points, 1000.0)
    assert small is not None and small.indices == (1,)
    kept = points[small.kept.loops[1][small.kept.corners[1]]]
    assert len(kept) == 4
    # each within the cut of a true corner (samples 100 mm apart, none on a corner)
    gaps = np.linalg.norm(kept[:, None] - (corners + [4000.0, 3000.0])[None], axis=2)
    assert np.all(gaps.min(axis=1) < 60.0) and len(set(gaps.argmin(axis=1))) == 4
    assert np.array_equal(small.squared.loops[1], small.kept.loops[1][small.kept.corners[1]])
    assert len(small.filled.loops) == 1
    # cut corners: the two merged ones no longer, the hole's four own cuts instead (no sample
    # lands on a corner, so each of the four is cut by its neighbours within 100 mm)
    hole_ids = loops[1]
    assert np.isin(found.cut_corners, hole_ids).sum() == 2
    on_hole = small.kept.cut_corners[np.isin(small.kept.cut_corners, hole_ids)]
    assert set(on_hole) == set(small.kept.loops[1][small.kept.corners[1]])
    # an opening under four of the gates' shortest edges round stays a loop of its own
    tiny = _resampled(corners * 0.25 + [4000.0, 3000.0], 40.0)[::-1]
    points = np.vstack([outer, tiny])
    vertices = np.column_stack([points, np.zeros(len(points))])
    loops = (np.arange(len(outer)), len(outer) + np.arange(len(tiny)))
    surface = Surface(vertices, np.zeros((0, 3), dtype=int), loops, Path("o.obj"), "obj", "mm")
    found = outline_corners(surface, points, 30.0, 300.0, panel_size=1000.0)
    assert small_openings(found, surface, points, 1000.0) is None


def test_a_round_hole_that_turns_like_a_corner_within_merge_is_still_a_small_opening():
    from fabpanel.panelize.corners import small_openings

    # a 1 m round hole in 100 mm steps turns 35° within the 0.3 m merge: "corners" by the
    # outline's rule, so it was neither smooth nor four-cornered and kept its ring
    surface = _plate_with_openings([(4000.0, 4000.0, 500.0)], step=100.0)
    flat = surface.vertices[:, :2]
    found = outline_corners(surface, flat, 30.0, 300.0, panel_size=1000.0)
    assert found.corners[1].any()
    small = small_openings(found, surface, flat, 1000.0)
    assert small is not None and small.indices == (1,)
    square = flat[small.squared.loops[1]]
    sides = np.linalg.norm(np.roll(square, -1, axis=0) - square, axis=1)
    np.testing.assert_allclose(sides, 500.0 * np.sqrt(2), rtol=0.12)


def test_a_slot_gets_its_corners_where_its_straight_sides_meet_its_round_ends():
    from fabpanel.panelize.corners import _oblong_corners

    # a 1.1 x 0.5 m slot (round ends of 0.25 m) turned 15°, sampled every ~50 mm
    t = np.linspace(-np.pi / 2, np.pi / 2, 16)
    right = np.column_stack([300.0 + 250.0 * np.cos(t), 250.0 * np.sin(t)])
    top = np.column_stack([np.linspace(250.0, -250.0, 11), np.full(11, 250.0)])
    slot = np.vstack([right, top, -right, -top])
    turn = np.radians(15.0)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    picked = _oblong_corners(slot @ rotation.T)
    assert picked is not None and len(np.unique(picked)) == 4
    local = slot[picked]
    # two on each round end (beyond the straight sides), one either side of the axis
    assert np.all(np.abs(local[:, 0]) > 300.0) and np.all(np.abs(local[:, 1]) > 100.0)
    assert sorted(np.sign(local[:, 0]) * np.sign(local[:, 1])) == [-1, -1, 1, 1]
    # a round hole is not oblong: its four are set to the cross field instead
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    assert _oblong_corners(np.column_stack([np.cos(t), np.sin(t)]) * 500.0) is None
