"""Element shape functions shared by the load integration (:mod:`.loads`) and the corner
stiffeners' ties (:mod:`.stiffeners`). No imports of the model: both modules build on it."""

from __future__ import annotations

import numpy as np


def serendipity(a: np.ndarray, b: np.ndarray):
    """8-node serendipity shape functions and derivatives at (g,) points in [-1, 1]^2; node
    order as S8R (corners (-1,-1), (1,-1), (1,1), (-1,1), then mid-sides)."""
    ca, cb = np.array([-1, 1, 1, -1.0]), np.array([-1, -1, 1, 1.0])
    A, B = a[:, None], b[:, None]
    n_c = 0.25 * (1 + ca * A) * (1 + cb * B) * (ca * A + cb * B - 1)
    da_c = 0.25 * ca * (1 + cb * B) * (2 * ca * A + cb * B)
    db_c = 0.25 * cb * (1 + ca * A) * (ca * A + 2 * cb * B)
    # mid-sides: (0,-1), (1,0), (0,1), (-1,0)
    n_m = np.stack(
        [
            0.5 * (1 - A[:, 0] ** 2) * (1 - B[:, 0]),
            0.5 * (1 + A[:, 0]) * (1 - B[:, 0] ** 2),
            0.5 * (1 - A[:, 0] ** 2) * (1 + B[:, 0]),
            0.5 * (1 - A[:, 0]) * (1 - B[:, 0] ** 2),
        ],
        1,
    )
    da_m = np.stack(
        [
            -A[:, 0] * (1 - B[:, 0]),
            0.5 * (1 - B[:, 0] ** 2),
            -A[:, 0] * (1 + B[:, 0]),
            -0.5 * (1 - B[:, 0] ** 2),
        ],
        1,
    )
    db_m = np.stack(
        [
            -0.5 * (1 - A[:, 0] ** 2),
            -B[:, 0] * (1 + A[:, 0]),
            0.5 * (1 - A[:, 0] ** 2),
            -B[:, 0] * (1 - A[:, 0]),
        ],
        1,
    )
    return np.c_[n_c, n_m], np.c_[da_c, da_m], np.c_[db_c, db_m]
