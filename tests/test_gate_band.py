"""The smoothing that holds corners and edges in the layout gates' bands (panelize/gate_band)."""

from __future__ import annotations

import numpy as np

from fabpanel.panelize.gate_band import BandMeasures, GateBand, band_measures, gate_band
from fabpanel.panelize.quality import corner_angles
from fabpanel.panelize.untangle import _corners, _energy_and_gradient, untangle


def _flat(vertices: np.ndarray) -> np.ndarray:
    return np.column_stack([vertices, np.zeros(len(vertices))])


def _three_quads_round_a_vertex() -> tuple[np.ndarray, np.ndarray]:
    """A regular hexagon of 1 m sides cut into three quads at its centre (a valence-3 vertex)."""
    angles = np.radians(np.arange(6) * 60.0)
    ring = 1000.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    vertices = np.vstack([[0.0, 0.0], ring])
    quads = np.array([[0, 1, 2, 3], [0, 3, 4, 5], [0, 5, 6, 1]])
    return vertices, quads


def test_the_energy_gradient_with_the_band_matches_finite_differences():
    rng = np.random.default_rng(3)
    xs, ys = np.meshgrid(np.arange(4.0), np.arange(4.0))
    flat = 1000.0 * np.column_stack([xs.ravel(), ys.ravel()]) + rng.normal(0, 150, (16, 2))
    ids = np.arange(16).reshape(4, 4)
    quads = np.stack([ids[:-1, :-1], ids[:-1, 1:], ids[1:, 1:], ids[1:, :-1]], -1).reshape(-1, 4)
    on_surface = np.column_stack([flat, 2e-4 * (flat**2).sum(axis=1) / 1000.0])  # a paraboloid
    reference = np.full(4 * len(quads), 900.0)
    band = gate_band(flat, on_surface, quads, reference, 1000.0)
    # narrow the limits so that every term is active somewhere
    band = GateBand(
        band.lower + 0.3, band.upper - 0.5, band.metric, band.hard_lower + 0.5, band.hard_upper
    )
    free = np.zeros(16, dtype=bool)
    free[[5, 6, 9, 10]] = True
    args = (flat, free, _corners(quads), reference, 1e-4, None, band)
    x = flat[free].ravel()
    _, gradient = _energy_and_gradient(x, *args)
    numeric = np.array(
        [
            (_energy_and_gradient(x + step, *args)[0] - _energy_and_gradient(x - step, *args)[0])
            / 2e-3
            for step in 1e-3 * np.eye(len(x))
        ]
    )
    assert np.abs(gradient - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_one_corner_of_a_valence_3_vertex_takes_the_excess_over_120_degrees():
    vertices, quads = _three_quads_round_a_vertex()
    vertices[0] += (40.0, -25.0)  # off centre, so that the smoothing has work to do
    movable = np.zeros(len(vertices), dtype=bool)
    movable[0] = True
    plain, _ = untangle(vertices, quads, movable)
    at_centre = corner_angles(_flat(plain)[quads])[:, 0]
    assert np.allclose(at_centre, 120.0, atol=0.5)  # squaring alone shares the excess
    band = gate_band(vertices, _flat(vertices), quads, np.full(12, 1000.0), 1000.0)
    held, _ = untangle(vertices, quads, movable, band=band)
    at_centre = np.sort(corner_angles(_flat(held)[quads])[:, 0])
    assert (at_centre[:2] < 120.0).all() and 120.0 < at_centre[2] < 133.5  # the gate: 60-120°
    assert abs(at_centre.sum() - 360.0) < 1e-6


def test_a_corner_of_the_outline_gets_no_limits():
    vertices, quads = _three_quads_round_a_vertex()
    band = gate_band(vertices, _flat(vertices), quads, np.full(12, 1000.0), 1000.0)
    outline_corner = np.flatnonzero(quads.ravel() == 2)  # a ring vertex of one quad
    assert band.lower[outline_corner] == 0.0 and band.upper[outline_corner] == 2.0 * np.pi


def test_the_band_measures_of_a_square_grid_pass_and_fall_with_a_bad_corner():
    xs, ys = np.meshgrid(np.arange(5.0), np.arange(5.0))
    flat = 1000.0 * np.column_stack([xs.ravel(), ys.ravel()])
    ids = np.arange(25).reshape(5, 5)
    quads = np.stack([ids[:-1, :-1], ids[:-1, 1:], ids[1:, 1:], ids[1:, :-1]], -1).reshape(-1, 4)
    assert band_measures(_flat(flat), quads, 1000.0) == BandMeasures(2.0, True)
    flat[12] += (200.0, 200.0)  # corners of 62-117° at the neighbours, edges 0.8-1.2 m
    assert band_measures(_flat(flat), quads, 1000.0) == BandMeasures(2.0, True)
    flat[12] += (400.0, 400.0)  # a corner of 16° and 3 m edges: both shares fall, and 0.5
    angles = corner_angles(_flat(flat)[quads])
    good = np.mean((angles >= 60.0) & (angles <= 120.0))
    measures = band_measures(_flat(flat), quads, 1000.0)
    assert measures.score < good + 1.0 - 0.5 and not measures.passes
