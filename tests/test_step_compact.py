"""The compact STEP text: the same entities and numbers in fewer bytes (issue 18)."""

from __future__ import annotations

import re

import build123d as bd
import numpy as np

from fabpanel.model import occ
from fabpanel.model.step_compact import compact_entities

# as OCCT writes them: wrapped, indented, reals with exponents, a point written twice, names
# with spaces, digits, "#" and a doubled quote
DATA = b"""
#1 = APPLICATION_CONTEXT(
  'core data for automotive mechanical design processes');
#2 = CARTESIAN_POINT('',(-5.975081397337E+03,3.999999999966E+03,
    -1.549300875124E-12));
#3 = CARTESIAN_POINT('',(-5.975081397337E+03,3.999999999966E+03,
    -1.549300875124E-12));
#4 = VERTEX_POINT('',#2);
#5 = VERTEX_POINT('',#3);
#6 = DIRECTION('',(0.E+00,0.E+00,1.E+00));
#7 = DIRECTION('',(0.E+00,0.E+00,1.E+00));
#8 = B_SPLINE_CURVE_WITH_KNOTS('',3,(#2,#3,#3,#2),.UNSPECIFIED.,.F.,.F.,(4,4),(0.,
    1.E+00),.UNSPECIFIED.);
#9 = REPRESENTATION_CONTEXT('Context #3  and E+03 ; it''s',
  '3D Context with UNIT and UNCERTAINTY');
#10 = ( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) );
#11 = UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(2.E-06),#10,
  'distance_accuracy_value','confusion accuracy');
#12 = AXIS2_PLACEMENT_3D('',#3,#7,#6);
"""


def _entities(text: bytes) -> dict[bytes, bytes]:
    return dict(re.findall(rb"(?m)^#(\d+)=(.*);$", text))


def test_one_entity_a_line_with_names_kept_and_records_apart():
    out = compact_entities(DATA)
    lines = [line for line in out.split(b"\n") if line]
    assert all(re.fullmatch(rb"#\d+=.*;", line) for line in lines)
    entities = _entities(out)
    assert (
        entities[b"1"]
        == b"APPLICATION_CONTEXT('core data for automotive mechanical design processes')"
    )
    # the string keeps its spaces, its "#3" (not a reference), its "E+03" and its quote
    assert entities[b"9"] == (
        b"REPRESENTATION_CONTEXT('Context #3  and E+03 ; it''s','3D Context with UNIT and UNCERTAINTY')"
    )
    assert entities[b"10"] == b"(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.))"
    assert entities[b"11"].startswith(b"UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(2.E-06),#10,")


def test_reals_shortest_and_the_same_doubles():
    out = compact_entities(DATA)
    before = [
        float(x)
        for x in re.findall(rb"-?\d+\.\d*(?:E[+-]?\d+)?", DATA.split(b"#2 =")[1].split(b";")[0])
    ]
    point = _entities(out)[b"2"]
    assert point == b"CARTESIAN_POINT('',(-5975.081397337,3999.999999966,-1.549300875124E-12))"
    after = [float(x) for x in re.findall(rb"-?\d+\.\d*(?:E[+-]?\d+)?", point)]
    assert after == before  # bit for bit
    assert _entities(out)[b"6"] == b"DIRECTION('',(0.,0.,1.))"


def test_points_and_directions_shared_topology_not():
    out = compact_entities(DATA)
    entities = _entities(out)
    assert b"3" not in entities and b"7" not in entities  # the second copies went
    assert entities[b"4"] == b"VERTEX_POINT('',#2)"
    assert entities[b"5"] == b"VERTEX_POINT('',#2)"  # two vertices still, on one point
    assert entities[b"8"].startswith(b"B_SPLINE_CURVE_WITH_KNOTS('',3,(#2,#2,#2,#2),")
    assert entities[b"12"] == b"AXIS2_PLACEMENT_3D('',#2,#6,#6)"
    # every reference outside the strings is defined
    refs = set(re.findall(rb"#(\d+)", re.sub(rb"'(?:[^']|'')*'", b"", out)))
    assert refs <= set(entities)


def test_a_real_solid_reads_back_the_same(tmp_path):
    """A rolled sheet (two B-spline faces, ruled sides) beside a plate with a cylinder hole,
    written by OCCT and compacted: valid, smaller, the same volume and edge points."""
    from fabpanel.model.step_chunks import compact_file

    xs, ys = np.meshgrid(np.linspace(0, 900, 7), np.linspace(0, 600, 6), indexing="ij")
    grid = np.stack([xs, ys, 0.0004 * (xs - 450) ** 2], axis=-1)
    top, _ = occ.bspline_surface(grid)
    bottom, _ = occ.bspline_surface(grid - [0, 0, 3])
    sheet = bd.Solid(occ.slab(top, bottom, "sheet"))
    plate = bd.Box(900, 600, 40) - bd.Cylinder(60, 100)
    path = tmp_path / "parts.step"
    bd.export_step(bd.Compound([sheet, plate]), str(path))
    original = bd.import_step(str(path))
    size = path.stat().st_size
    compact_file(path)
    text = path.read_bytes()
    assert path.stat().st_size < 0.8 * size
    points = re.findall(rb"(?m)^#\d+=(CARTESIAN_POINT\(.*\));$", text)
    assert len(points) == len(set(points))
    again = bd.import_step(str(path))
    assert occ.is_valid(again.wrapped)
    assert again.volume == original.volume
    np.testing.assert_array_equal(
        occ.shape_points(again.wrapped), occ.shape_points(original.wrapped)
    )
