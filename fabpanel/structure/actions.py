"""Actions on the shell by EN 1991: wind (EN 1991-1-4) and snow (EN 1991-1-3), as values per
element of the top sheet. Units: metres and seconds for the wind's profile, kN/m2 for pressures
(callers convert: 1 kN/m2 = 1e-3 N/mm2).

Sources and status (``../shared/notes/eurocode.md``): the profile (4.1)-(4.10), the terrain
table 4.1, mu_1 of Table 5.2 and the internal pressure of §7.2.9 Note 2 are checked in two
sources each. **The external pressure coefficients of a free-form shell are approximate**: no
figure of EN 1991-1-4 covers a free-form shell (the vault and dome figures 7.11 and 7.12 were not
available digitised), so each top-sheet element takes the c_pe,10 of a duopitch roof at its own
pitch (Table 7.4a, wind normal to the ridge): zone H where the element faces the wind, zone I
where it faces away. The report says so; a wind-tunnel or CFD study replaces it for a final
design.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: EN 1991-1-4 Table 4.1: terrain category -> (z_0, z_min), m
TERRAIN = {
    "0": (0.003, 1.0),
    "I": (0.01, 1.0),
    "II": (0.05, 2.0),
    "III": (0.3, 5.0),
    "IV": (1.0, 10.0),
}
#: z_0 of terrain category II, m (4.5)
Z0_II = 0.05
#: the profile's top, m
Z_MAX = 200.0

#: Table 7.4a (duopitch roof, theta = 0), c_pe,10 by pitch in degrees: (suction, pressure)
#: of zone H (the windward slope away from its edges) and zone I (the leeward slope). Where the
#: table gives one value, both are that value; below 5 degrees the 5-degree row, above 75 the
#: 75-degree row
PITCHES = np.array([5.0, 15.0, 30.0, 45.0, 60.0, 75.0])
ZONE_H = np.array([[-0.6, 0.0], [-0.3, 0.2], [-0.2, 0.4], [0.0, 0.6], [0.7, 0.7], [0.8, 0.8]])
ZONE_I = np.array([[-0.6, 0.0], [-0.4, 0.0], [-0.4, 0.0], [-0.2, 0.0], [-0.2, -0.2], [-0.2, -0.2]])
#: §7.2.9(6) Note 2: the more onerous of these where the openings' ratio is not known
INTERNAL_PRESSURE = (0.2, -0.3)


@dataclass(frozen=True)
class WindProfile:
    """The peak velocity pressure by EN 1991-1-4 §4 (orography left out: c_0 = 1)."""

    v_b0: float  # basic wind velocity, m/s (the national map)
    terrain: str = "II"
    c_dir: float = 1.0
    c_season: float = 1.0
    rho: float = 1.25  # air density, kg/m3
    k_i: float = 1.0  # turbulence factor

    @property
    def v_b(self) -> float:
        """The basic wind velocity (4.1), m/s."""
        return self.c_dir * self.c_season * self.v_b0

    @property
    def q_b(self) -> float:
        """The basic velocity pressure (4.10), kN/m2."""
        return 0.5 * self.rho * self.v_b**2 * 1e-3

    def exposure(self, z: float) -> float:
        """c_e(z) = q_p / q_b (4.9) at height ``z`` m above ground."""
        z0, z_min = TERRAIN[self.terrain]
        k_r = 0.19 * (z0 / Z0_II) ** 0.07
        log = math.log(min(max(z, z_min), Z_MAX) / z0)
        c_r = k_r * log
        i_v = self.k_i / log
        return (1 + 7 * i_v) * c_r**2

    def peak_pressure(self, z: float) -> float:
        """q_p(z) (4.8), kN/m2."""
        return self.exposure(z) * self.q_b


def external_coefficients(normals: np.ndarray, wind: np.ndarray) -> np.ndarray:
    """(E, 2) float: c_pe,10 of each element (suction, pressure) for the horizontal ``wind``
    direction (3,) from its outward unit normal ``normals (E, 3)``: the duopitch rule of the
    module docstring (zone H facing the wind, zone I facing away)."""
    pitch = np.degrees(np.arccos(np.clip(normals[:, 2], -1.0, 1.0)))
    facing = normals @ wind < 0
    out = np.empty((len(normals), 2))
    for k, zone in ((0, ZONE_H), (1, ZONE_I)):
        rows = facing if k == 0 else ~facing
        for j in range(2):
            out[rows, j] = np.interp(pitch[rows], PITCHES, zone[:, j])
    return out


def snow_shape(pitch_deg: np.ndarray, fenced: bool = False) -> np.ndarray:
    """mu_1 of EN 1991-1-3 Table 5.2 at roof pitches in degrees: 0.8 up to 30 degrees, falling
    linearly to 0 at 60; at least 0.8 where something stops the snow sliding (``fenced``)."""
    pitch = np.asarray(pitch_deg, float)
    mu = np.clip(0.8 * (60.0 - pitch) / 30.0, 0.0, 0.8)
    return np.maximum(mu, 0.8) if fenced else mu


def snow_load(s_k: float, c_e: float = 1.0, c_t: float = 1.0) -> float:
    """C_e C_t s_k (5.1) without the shape coefficient, kN/m2 of plan."""
    return c_e * c_t * s_k
