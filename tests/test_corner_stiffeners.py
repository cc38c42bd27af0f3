"""Corner stiffeners at the corners a field layout has: 45-135 degrees, not only right angles.

A valence-3 vertex of a field layout gives its panels corners of about 120 degrees, where a
stiffener meets each rib at 30 degrees; its ends must still be cut at the ribs' inner faces
(they were not: every such stiffener clashed with both ribs by about 10 cm3)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import fabpanel as fp


def _plane(folder: Path) -> Path:
    xs = np.linspace(-1000.0, 3000.0, 21)
    points = [(x, y, 0.0) for x in xs for y in xs]
    n = len(xs)
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            faces += [(a, b, c), (a, c, d)]
    path = folder / "plane.obj"
    path.write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in points)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)
    )
    return path


def _corner_angle(c2: np.ndarray) -> float:
    a, b = np.array([1200.0, 0.0]) - c2, np.array([0.0, 1200.0]) - c2
    return float(np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))


@pytest.mark.parametrize("angle", [50.0, 120.0, 135.0])
def test_a_stiffener_at_a_corner_of_any_gate_angle_clears_its_ribs(tmp_path, angle):
    # one panel (0, 0), (1200, 0), c2, (0, 1200): c2 on the diagonal sets the angle at corner 2
    scale = 1.0 + (1.0 if angle < 90 else -1.0) * np.arange(0.0, 1.5, 1e-4)
    c2 = next(
        np.array([1200.0, 1200.0]) * s
        for s in scale
        if (_corner_angle(np.array([1200.0, 1200.0]) * s) - angle) * (1 if angle < 90 else -1) <= 0
    )
    layout = tmp_path / "layout.obj"
    corners = [(0, 0), (1200, 0), tuple(c2), (0, 1200)]
    layout.write_text("".join(f"v {x} {y} 0\n" for x, y in corners) + "f 1 2 3 4\n")
    surface_path = _plane(tmp_path)
    job = fp.Job.from_dict(
        {
            "input": {"path": str(surface_path), "units": "mm"},
            "panelize": {"method": "layout", "layout": str(layout)},
            "develop": {"method": "project"},
        }
    )
    surface = fp.load_surface(surface_path, "mm")
    developed = fp.develop(fp.panelize(surface, job), surface, job)
    model = fp.build(developed, job, jobs=1)
    assert abs(_corner_angle(c2) - angle) < 0.5
    assert not [i for i in model.issues if i.code == "clash"]
    stiffener = next(p for p in model.parts if p.id == "P001-STF-2")
    # cut at both ribs' inner faces: it is shorter than the chord between the points at
    # stiffener_offset along the sides, and still a real plate
    chord = 2 * 150.0 * np.sin(np.radians(angle) / 2)
    width = float(np.ptp(stiffener.outline[:, 0]))
    assert 0.3 * chord < width < chord
    assert stiffener.volume > 0.5 * 8.0 * 150.0 * width
