"""Bolted joints between back-to-back ribs: where the bolts go, and the frame of each bolt.

Bolt stations are computed from data both panels of a joint hold identically: the shared side's
developed samples and normals (the side polyline of one panel is the other's reversed) and the
shared rib plane. Stations are spread evenly between ``edge_distance`` from both corners at most
``spacing`` apart, a set that is symmetric under reversal, so the two ribs get their holes at the
same points (coaxial) without talking to each other.

Hole sizes: a 13 mm hole takes an M12 bolt (EN 1993-1-8 Table 3.3 spacing limits: edge distance
>= 1.2 d0 = 16 mm, spacing >= 2.2 d0 = 29 mm; the defaults 60/250 mm are far inside them).
"""

from __future__ import annotations

import numpy as np

#: clear distance between a rib's inner face and the edge of an access opening, mm: room for the
#: fillet weld of the rib to the sheet and for the washer under the nut
ACCESS_CLEARANCE = 10.0


def bolt_stations(
    length: float, spacing: float, edge_distance: float, end_distance: float | None = None
) -> np.ndarray:
    """(n,) float: arc lengths of the bolts along a side of ``length`` mm, evenly spread
    between ``edge_distance`` from the start and ``end_distance`` (default the same) from the
    end, at most ``spacing`` apart; one bolt in the middle of a side too short for two. The set
    read from the other end (``length - s``, reversed) is the one with the distances swapped."""
    end = edge_distance if end_distance is None else end_distance
    usable = length - edge_distance - end
    if usable <= 0:
        return np.array([length / 2])
    count = int(np.ceil(usable / spacing - 1e-9)) + 1
    return np.linspace(edge_distance, length - end, count)


def along_polyline(points: np.ndarray, stations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points at arc lengths ``stations (n,)`` on the polyline ``points (k, 3)`` and the
    fractional sample index of each (for interpolating values stored per sample)."""
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    index = np.interp(stations, lengths, np.arange(len(points)))
    lower = np.minimum(np.floor(index).astype(int), len(points) - 2)
    frac = (index - lower)[:, None]
    return points[lower] * (1 - frac) + points[lower + 1] * frac, index


def bolt_centres(
    side_points: np.ndarray,
    side_normals: np.ndarray,
    plane: np.ndarray,
    depth: float,
    spacing: float,
    edge_distance: float,
    stations: np.ndarray | None = None,
) -> np.ndarray:
    """(n, 3) float: bolt hole centres of one joint, in the rib plane, mm.

    side_points, side_normals : (k, 3) float, the shared side's developed samples and normals.
    plane : (4,) float, unit normal, ``n . x = d``.
    depth : offset along the normals from the design face to the middle of the rib height
        (negative: below the design face).
    stations : arc lengths of the bolts (default :func:`bolt_stations` with ``spacing`` and
        ``edge_distance``): the build moves a joint's end bolts where the tool cannot reach them.
    """
    length = float(np.linalg.norm(np.diff(side_points, axis=0), axis=1).sum())
    if stations is None:
        stations = bolt_stations(length, spacing, edge_distance)
    points, index = along_polyline(side_points, stations)
    lower = np.minimum(np.floor(index).astype(int), len(side_points) - 2)
    frac = (index - lower)[:, None]
    normals = side_normals[lower] * (1 - frac) + side_normals[lower + 1] * frac
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    centres = points + depth * normals
    return centres - (centres @ plane[:3] - plane[3])[:, None] * plane[:3]


def joint_frames(
    side_points: np.ndarray, plane: np.ndarray, centres: np.ndarray, towards: np.ndarray
) -> np.ndarray:
    """(n, 4, 4) float: the joint frame of each bolt (see :mod:`fabpanel.fasteners`): x along
    the rib (the side's direction at the bolt, in the rib plane), y the rib plane's normal (into
    the panel), z = x cross y turned to point along ``towards`` (the access sheet), origin the
    bolt centre ``centres (n, 3)``."""
    segments = np.diff(side_points, axis=0)
    mids = (side_points[:-1] + side_points[1:]) / 2
    nearest = np.argmin(np.linalg.norm(centres[:, None] - mids[None], axis=2), axis=1)
    y = plane[:3] / np.linalg.norm(plane[:3])
    x = segments[nearest] - (segments[nearest] @ y)[:, None] * y
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = np.cross(x, y)
    flip = np.where(z @ towards < 0, -1.0, 1.0)[:, None]
    x, z = x * flip, z * flip
    frames = np.tile(np.eye(4), (len(centres), 1, 1))
    frames[:, :3, 0], frames[:, :3, 1], frames[:, :3, 2], frames[:, :3, 3] = x, y, z, centres
    return frames
