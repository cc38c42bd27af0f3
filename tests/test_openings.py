"""Access openings drawn with few points (issue 18): a periodic cubic through a slot's or a
merged opening's outline points, which is what the model files store for the hole's edges,
stays within 0.02 mm of a slot's true outline and 0.1 mm of two slots' union."""

from __future__ import annotations

import numpy as np
import shapely
import shapely.affinity
from scipy.interpolate import CubicSpline
from shapely.geometry import Polygon

from fabpanel.fasteners import SLOT_CORNER, rounded_rectangle
from fabpanel.model.openings import Opening, _joined


def _periodic_cubic(points: np.ndarray, per_chord: int = 20) -> np.ndarray:
    """Dense samples of the periodic cubic through ``points`` by chord length (as OCCT's
    interpolation in :func:`fabpanel.model.occ._hole_edges`)."""
    closed = np.vstack([points, points[:1]])
    t = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    spline = CubicSpline(t, closed, bc_type="periodic")
    return spline(np.linspace(0.0, t[-1], per_chord * len(points), endpoint=False))


def _deviation(points: np.ndarray, exact: Polygon) -> float:
    dense = _periodic_cubic(points)
    return float(max(exact.exterior.distance(shapely.Point(p)) for p in dense))


def _true_slot() -> Polygon:
    """The slot of the tests, its rounds drawn with 256 chords a quarter."""
    box = shapely.box(-22.0, -20.0, 22.0, 45.0)
    return box.buffer(-SLOT_CORNER).buffer(SLOT_CORNER, quad_segs=256)


def test_a_slot_outline_is_held_within_0_02_mm_by_its_cubic():
    slot = rounded_rectangle(22.0, -20.0, 45.0, SLOT_CORNER)
    exact = _true_slot()
    assert len(slot) < 60  # 4 rounds of 4 chords, sides every 8 mm or less
    assert _deviation(slot, exact) < 0.02


def test_a_merged_opening_is_few_points_and_held_within_0_1_mm():
    slot = rounded_rectangle(22.0, -20.0, 45.0, SLOT_CORNER)
    first = Opening(np.eye(4), slot, ((0, 0),), 40.0)
    turned = np.eye(4)
    turned[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    turned[:3, 3] = [50.0, 40.0, 0.0]  # the other rib's first bolt, 90° round, close by
    second = Opening(turned, slot, ((1, 0),), 40.0)
    joined = _joined(first, second, 3.0)
    assert joined is not None and joined.bolts == ((0, 0), (1, 0))
    # the exact opening: the same union of the true slots, rounds of 256 chords a quarter
    # (the second tool comes in along the same z, so its slot is the same on both faces)
    true_slot = _true_slot()
    theirs = shapely.affinity.affine_transform(true_slot, [0.0, -1.0, 1.0, 0.0, 50.0, 40.0])
    exact = shapely.union(true_slot, theirs)
    exact = exact.buffer(SLOT_CORNER, quad_segs=256).buffer(-SLOT_CORNER, quad_segs=256)
    assert len(joined.outline) < 140  # was about 280 at a point every 2 mm
    # measured 0.072 mm: shapely's rounding of the union (a slot alone: 0.017 mm)
    assert _deviation(joined.outline, exact) < 0.1
    steps = np.linalg.norm(np.diff(np.vstack([joined.outline, joined.outline[:1]]), axis=0), axis=1)
    assert steps.max() <= 8.0 + 1e-9
