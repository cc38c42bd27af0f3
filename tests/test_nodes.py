"""Nodes (fabpanel.model.nodes): a rib's end is cut at every other rib plane of its node, so
two panels that meet only at a vertex cannot overlap below the top sheet when the rib planes
there do not share one axis.

Fixture: the domed plate round a round opening of tests/test_boundary_chords.py, developed by
``global`` without its square-rib preference: the interior ribs then lean 6.8 degrees about
their nearly straight sides, the two panels on either side of each corner of the opening
(each beside its upright chord) overlapped by 2.6-3.7 cm3 (12 clashes) before the node cuts.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from test_boundary_chords import _plate, _ring_layout

from fabpanel import Job, build
from fabpanel.develop import develop
from fabpanel.develop.sides import side_planes
from fabpanel.model.nodes import facing, node_planes


def test_node_planes_are_the_other_edges_at_each_corner():
    layout = _ring_layout()
    k = 5
    t = np.linspace(0, 1, k)
    corners = layout.vertices[layout.quads]  # (m, 4, 3): a flat bilinear grid per panel
    u, v = t[:, None, None], t[None, :, None]
    samples = (
        (1 - u) * (1 - v) * corners[:, None, None, 0]
        + u * (1 - v) * corners[:, None, None, 1]
        + u * v * corners[:, None, None, 2]
        + (1 - u) * v * corners[:, None, None, 3]
    )
    normals = np.broadcast_to([0.0, 0.0, 1.0], samples.shape)
    planes, *_ = side_planes(samples, normals)
    nodes = node_planes(layout, planes, erection_gap=4.0)
    # P002 = quad (1, 5, 6, 2): at its corner 1, vertex 5 (the opening's corner), its own
    # sides 1-5 and 5-6; the others there are 4-5 (a joint) and 5-9 (the opening's chord)
    at_five = nodes[1][1]
    assert len(at_five) == 2
    expected = {
        (4, 5): 2.0,  # half the erection gap
        (5, 9): 0.0,  # a boundary side: its rib stands on the contact plane
    }
    for (a, b), stand_off in expected.items():
        start, end = layout.vertices[a], layout.vertices[b]
        match = [
            row
            for row in at_five
            if abs(row[:3] @ start - row[3]) < 1e-6 and abs(row[:3] @ end - row[3]) < 1e-6
        ]
        assert len(match) == 1 and match[0][4] == stand_off
    # the outer corner of P001 (vertex 0) is no node: only its own two sides meet there
    assert len(nodes[0][0]) == 0


def test_a_node_plane_faces_the_rib_it_cuts():
    plane = np.array([1.0, 0.0, 0.0, 10.0, 2.0])  # x = 10, stand-off 2
    assert facing(plane, np.array([50.0, 0.0, 0.0])) == pytest.approx([1, 0, 0, 12])
    assert facing(plane, np.array([-50.0, 0.0, 0.0])) == pytest.approx([-1, 0, 0, -8])


def test_panels_meeting_only_at_a_vertex_do_not_overlap_where_the_rib_planes_twist(
    monkeypatch,
):
    optimise = importlib.import_module("fabpanel.develop.optimise")
    monkeypatch.setattr(optimise, "SQUARE_RIB_SHARE", 0.0)
    surface, layout = _plate(), _ring_layout()
    job = Job.from_dict(
        {"input": {"path": "plate.obj", "units": "mm"}, "develop": {"method": "global"}}
    )
    developed = develop(layout, surface, job)
    twist = developed.metrics["rib_normal_angle_deg_max"]
    assert twist > 5.0  # the interior rib planes lean about their nearly straight sides
    model = build(developed, job, jobs=2)
    assert not [i for i in model.issues if i.severity == "error"]
    # without the node cuts the same panels clash
    builder = importlib.import_module("fabpanel.model.build")
    monkeypatch.setattr(
        builder, "node_planes", lambda layout, *_: [(np.empty((0, 5)),) * 4] * len(layout.quads)
    )
    uncut = build(developed, job, jobs=2)
    clashes = [i for i in uncut.issues if i.code == "clash"]
    assert len(clashes) >= 4
    # the cuts take slivers off the rib ends, growing with depth: at most the planes' lean
    # across the depth at the bottom, at both ends (two other planes at a corner)
    depth = 150.0
    sliver = 0.5 * depth * depth * np.tan(np.radians(twist))
    cut = {p.id: p.area for p in model.parts if p.kind == "rib"}
    removed = {p.id: p.area - cut[p.id] for p in uncut.parts if p.kind == "rib"}
    assert min(removed.values()) > -1.0  # nothing added
    assert 0 < max(removed.values()) < 2 * 2 * sliver
    assert sum(1 for r in removed.values() if r > 1.0) < len(removed)  # only at the nodes
