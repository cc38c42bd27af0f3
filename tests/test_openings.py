"""Access openings drawn with few points (issue 18): a periodic cubic through a slot's or a
merged opening's outline points stays within 0.02 mm of a slot's true outline and 0.1 mm of two
slots' union (the points are the cut file's), and the model's hole edges, cubics fitted to the
points with double knots where runs meet rounds, keep 0.01 mm with half the poles (a merged
opening's 0.1 mm of the exact union with 48 poles for 126 points)."""

from __future__ import annotations

import numpy as np
import pytest
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


def _merged_opening() -> tuple[np.ndarray, Polygon]:
    """Two slots merged into one opening (as in the test above): its outline points and the
    exact union of the true slots."""
    slot = rounded_rectangle(22.0, -20.0, 45.0, SLOT_CORNER)
    turned = np.eye(4)
    turned[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    turned[:3, 3] = [50.0, 40.0, 0.0]
    joined = _joined(
        Opening(np.eye(4), slot, ((0, 0),), 40.0), Opening(turned, slot, ((1, 0),), 40.0), 3.0
    )
    assert joined is not None
    theirs = shapely.affinity.affine_transform(_true_slot(), [0.0, -1.0, 1.0, 0.0, 50.0, 40.0])
    exact = shapely.union(_true_slot(), theirs)
    exact = exact.buffer(SLOT_CORNER, quad_segs=256).buffer(-SLOT_CORNER, quad_segs=256)
    return joined.outline, exact


@pytest.mark.parametrize(
    ("opening", "most_poles", "within"),
    [
        # a slot: 53 points, 26 poles at 0.005 mm (the cubic through every point: 53)
        ("slot", 30, 0.01),
        # a merged opening: no fit holds 0.005 mm at its concave fillets; 126 points become 48
        # poles at LOOSE_LOOP_TOLERANCE (0.02 mm), against 126 through every point; its points
        # stand for the exact union within 0.072 mm (the test above)
        ("merged", 55, 0.1),
    ],
)
def test_an_opening_in_a_rolled_sheet_is_a_cubic_of_few_poles_within_its_tolerance(
    opening: str, most_poles: int, within: float
):
    """The model's hole edges (issue 18): on a sheet rolled to 1.5 m, an opening's 3D edges
    have the fewest poles that keep its outline points (double knots where its runs meet its
    rounds), they lie on the exact opening's prism, and the sheet is a valid solid."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from fabpanel.model import occ

    radius, thickness = 1500.0, 3.0
    x, y = np.meshgrid(np.linspace(-150, 150, 9), np.linspace(-150, 150, 9), indexing="ij")

    def rolled(r: float) -> np.ndarray:
        angle = y / radius  # the same angles on both faces: their grids lie on common normals
        return np.stack([x, r * np.sin(angle), r * np.cos(angle) - radius], axis=-1)

    outer, _ = occ.bspline_surface(rolled(radius))
    inner, _ = occ.bspline_surface(rolled(radius - thickness))
    if opening == "slot":  # its frame's z is the sheet's
        outline = rounded_rectangle(22.0, -20.0, 45.0, SLOT_CORNER)
        exact = shapely.box(-22.0, -20.0, 22.0, 45.0).buffer(-SLOT_CORNER)
        exact = exact.buffer(SLOT_CORNER, quad_segs=256)
    else:
        outline, exact = _merged_opening()
        outline, exact = outline - [25.0, 10.0], shapely.affinity.translate(exact, -25.0, -10.0)
    uv = [
        occ.project_to_surface(s, np.c_[outline, np.full(len(outline), z)])
        for s, z in ((outer, 0.0), (inner, -thickness))
    ]
    # the loops must cut the faces where the prism along z does: move each point there
    for surface, loop in ((outer, uv[0]), (inner, uv[1])):
        for _ in range(6):
            _, du, dv = occ.surface_derivatives(surface, loop)
            miss = outline - occ.surface_points(surface, loop[:, 0], loop[:, 1])[:, :2]
            jac = np.stack([du[:, :2], dv[:, :2]], axis=2)
            loop += np.linalg.solve(jac, miss[..., None])[..., 0]
    solid = occ.slab(outer, inner, "slotted", holes=[(uv[0], uv[1])])
    occ.check_valid(solid, "slotted")
    explorer, found = TopExp_Explorer(solid, TopAbs_EDGE), []
    while explorer.More():
        edge = TopoDS.Edge(explorer.Current())
        explorer.Next()
        first, last = BRep_Tool.Range_s(edge)
        curve = BRep_Tool.Curve_s(edge, first, last)
        start, end = curve.Value(first), curve.Value(last)
        if start.Distance(end) > 1e-9 or abs(start.X()) > 60:  # the hole's closed edges only
            continue
        found.append(curve.NbPoles())
        ts = np.linspace(first, last, 800)
        xy = np.array([[curve.Value(float(t)).X(), curve.Value(float(t)).Y()] for t in ts])
        assert max(exact.exterior.distance(shapely.Point(p)) for p in xy) < within
    assert len(found) == 4 and max(found) <= most_poles  # each edge met once per face it bounds
