"""Example shapes for the panelisation methods, written as OBJ meshes in metres (and one STEP).

Each generator is deterministic (numpy and scipy only, no random numbers) and writes a triangle
mesh in **metres**, as a designer's mesh export would be; the job files beside them declare
``units = "m"``. The shapes follow the test cases of the thesis (section 7.1):

- ``one-opening.obj``: a gently double-curved roof, 16 x 12 m, rounded corners, crown 3.6 m,
  with one elliptical opening off-centre: the topology of the test surface of Oval et al. (2018),
  used in section 7.1.1 to prove the skeleton method.
- ``pavilion.obj``: a "Chengdu Flowers"-like canopy (section 7.1.2): about 20 m across, 5.8 m
  high, a lobed outer boundary with convex and concave stretches, and three supports where the
  shell dips down to the ground as trumpet-shaped column shells: each support is an opening whose
  rim is a small circle (radius 0.7 m) at z = 0, flaring out into the canopy. The surface is a
  graph z(x, y), so its projection onto the XY plane does not overlap itself (the skeleton
  method works on that projection).
- ``formfound.obj``: a form-found square shell on four corner supports (force density method,
  Schek 1974): 14 x 14 m between supports, rise 4 m, edge arches pulled inwards by stiffer edge
  cables; the "form-found mesh input" case, four-sided.
- ``patch.obj`` and ``patch.step``: a four-sided doubly curved (saddle) patch, 10 x 8 m, for the
  grid method; the STEP holds one exact B-spline face (millimetres), so a four-sided B-rep input
  exists beside the barrel vault's cylinder.

Run::

    python examples/shapes.py              # writes all shapes and job files into examples/
    python examples/shapes.py some/folder  # ... into another folder
    fabpanel export examples/pavilion.toml
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

# --------------------------------------------------------------------------------------------
# parameters (metres)
# --------------------------------------------------------------------------------------------
#: one-opening roof: half-extents of the superellipse outline, its exponent (5: corners rounded
#: with a radius of about 2 m), eave and crown heights
ROOF_HALF = (8.0, 6.0)
ROOF_EXPONENT = 5.0
ROOF_EAVE, ROOF_CROWN = 1.2, 3.6
#: the opening: centre, semi-axes, rotation (degrees)
OPENING_CENTRE, OPENING_AXES, OPENING_ANGLE = (3.0, 1.2), (1.8, 1.2), 25.0

#: pavilion: outer boundary r(t) = R + A3 cos 3(t - t0) - A6 cos 6(t - t0), lobes at t0 + k 120
PAVILION_RADIUS, PAVILION_LOBE, PAVILION_WAVE = 10.0, 1.4, 0.3
PAVILION_LOBE_ANGLE = 90.0
#: supports: distance from the centre (in the lobe directions), rim radius, trumpet flare length
SUPPORT_DISTANCE, SUPPORT_RADIUS, SUPPORT_FLARE = 5.5, 0.7, 1.1
#: canopy: height at the centre, mean edge height at r = R, up/down wave of the edge
PAVILION_CROWN, PAVILION_EDGE, PAVILION_EDGE_WAVE = 5.8, 3.6, 0.8

#: form-found shell: corner supports at (+-half, +-half, 0), rise, force density of the edge
#: cables relative to the net's, per net division (the edge arches then sag inwards by about
#: 1 / (8 x 1.25) = 10 % of the span in plan at any resolution)
FORMFOUND_HALF, FORMFOUND_RISE, FORMFOUND_EDGE_Q = 7.0, 4.0, 1.25

#: patch: half-extents and z = Z0 + CX (x/a)^2 - CY (y/b)^2 + CXY (x/a)(y/b)
PATCH_HALF = (5.0, 4.0)
PATCH_Z0, PATCH_CX, PATCH_CY, PATCH_CXY = 3.0, 1.4, 1.0, 0.5


# --------------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------------
def write_obj(
    path: str | Path, vertices: np.ndarray, faces: np.ndarray, header: str, digits: int = 4
) -> Path:
    """Write a mesh as OBJ (1-based indices). ``digits`` decimals: 4 in metres is 0.1 mm."""
    path = Path(path)
    fmt = f"v {{:.{digits}f}} {{:.{digits}f}} {{:.{digits}f}}"
    lines = [f"# {line}" for line in header.splitlines()]
    # rounding first and adding 0.0 turns -0.0 into 0.0, so no "-0.0000" is written
    lines += [fmt.format(*v) for v in np.round(np.asarray(vertices, dtype=float), digits) + 0.0]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in np.asarray(faces)]
    path.write_text("\n".join(lines) + "\n")
    return path


def resample_closed(points: np.ndarray, spacing: float) -> np.ndarray:
    """(k, 2) points evenly spaced by arc length along a closed polyline (first not repeated).

    points : (n, 2) float, densely sampled closed curve. The count is ``ceil(length / spacing)``.
    """
    closed = np.vstack([points, points[:1]])
    cumulative = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    count = max(8, math.ceil(cumulative[-1] / spacing))
    targets = np.linspace(0.0, cumulative[-1], count, endpoint=False)
    return np.stack([np.interp(targets, cumulative, closed[:, c]) for c in range(2)], axis=1)


def points_in_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(n,) bool: even-odd test of 2D points against a closed polygon ``(k, 2)``."""
    x, y = points[:, :1], points[:, 1:2]
    a, b = polygon, np.roll(polygon, -1, axis=0)
    straddles = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (np.count_nonzero(straddles & (x < x_cross), axis=1) % 2) == 1


def triangular_lattice(low: np.ndarray, high: np.ndarray, spacing: float) -> np.ndarray:
    """(n, 2) points of an equilateral triangle lattice covering the box ``low..high``."""
    dy = spacing * math.sqrt(3.0) / 2.0
    rows = np.arange(low[1], high[1] + dy, dy)
    cols = np.arange(low[0], high[0] + spacing, spacing)
    X, Y = np.meshgrid(cols, rows)
    X = X + 0.5 * spacing * (np.arange(len(rows)) % 2)[:, None]
    return np.stack([X.ravel(), Y.ravel()], axis=1)


def triangulate_domain(
    outer: np.ndarray, holes: list[np.ndarray], interior: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a planar domain: outer loop minus holes, with given interior points.

    outer, holes : (k, 2) float closed loops (first point not repeated), sampled finely enough
        that every boundary segment is a Delaunay edge (spacing below about 0.6 x the distance to
        the nearest interior point).
    interior : (p, 2) float points strictly inside the domain.
    Returns ``points (n, 2)`` (boundary samples first: outer, then holes in order) and
    ``triangles (m, 3) int`` counter-clockwise. Delaunay triangles whose centroid lies outside
    the domain are dropped (the culling step of the thesis, section 7.1.1 b). Raises
    ``RuntimeError`` when a boundary segment did not come out as a triangle edge.
    """
    from scipy.spatial import Delaunay

    loops = [outer, *holes]
    points = np.vstack([*loops, interior])
    triangles = Delaunay(points).simplices
    centroids = points[triangles].mean(axis=1)
    inside = points_in_polygon(centroids, outer)
    for hole in holes:
        inside &= ~points_in_polygon(centroids, hole)
    triangles = triangles[inside]
    a, b, c = (points[triangles[:, k]] for k in range(3))
    signed = 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )
    triangles = np.where((signed < 0)[:, None], triangles[:, ::-1], triangles)
    triangles = triangles[np.abs(signed) > 1e-12 * float(np.ptp(points, axis=0).max()) ** 2]
    # every boundary segment must be an edge of exactly one triangle, and no other edge may be
    # a boundary edge
    edges = np.sort(
        np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2).reshape(-1, 2), axis=1
    )
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    expected, start = [], 0
    for loop in loops:
        ids = np.arange(start, start + len(loop))
        expected.append(np.sort(np.stack([ids, np.roll(ids, -1)], axis=1), axis=1))
        start += len(loop)
    expected = np.unique(np.vstack(expected), axis=0)
    boundary = unique[counts == 1]
    if counts.max() > 2 or len(boundary) != len(expected) or not np.array_equal(boundary, expected):
        raise RuntimeError(
            "the triangulation does not follow the boundary; sample the "
            "boundary more finely relative to the interior spacing"
        )
    return points, triangles


def _keep_clear(points: np.ndarray, loops: list[np.ndarray], clearance: float) -> np.ndarray:
    """Points farther than ``clearance`` from every boundary sample."""
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(np.vstack(loops)).query(points)
    return points[distance > clearance]


# --------------------------------------------------------------------------------------------
# one opening
# --------------------------------------------------------------------------------------------
def one_opening_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Roof height z(x, y), m: a cosine bump from the eave height to the crown, slightly tilted."""
    a, b = ROOF_HALF
    bump = np.cos(0.5 * np.pi * x / (1.08 * a)) * np.cos(0.5 * np.pi * y / (1.08 * b))
    return ROOF_EAVE + (ROOF_CROWN - ROOF_EAVE) * bump + 0.15 * x / a


def one_opening_mesh(spacing: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) m and triangles (m, 3) of the one-opening roof; ``spacing`` in m.

    Outline ``|x / 8|^5 + |y / 6|^5 = 1``; elliptical opening centred at (3.0, 1.2), semi-axes
    1.8 x 1.2 m, turned 25 degrees. spacing 0.3 m gives about 4 700 triangles.
    """
    a, b = ROOF_HALF
    t = np.linspace(0.0, 2.0 * np.pi, 4000, endpoint=False)
    power = 2.0 / ROOF_EXPONENT
    dense = np.stack(
        [
            a * np.sign(np.cos(t)) * np.abs(np.cos(t)) ** power,
            b * np.sign(np.sin(t)) * np.abs(np.sin(t)) ** power,
        ],
        axis=1,
    )
    outer = resample_closed(dense, 0.5 * spacing)
    angle = math.radians(OPENING_ANGLE)
    ex, ey = OPENING_AXES[0] * np.cos(t), OPENING_AXES[1] * np.sin(t)
    hole = np.stack(
        [
            OPENING_CENTRE[0] + ex * math.cos(angle) - ey * math.sin(angle),
            OPENING_CENTRE[1] + ex * math.sin(angle) + ey * math.cos(angle),
        ],
        axis=1,
    )
    hole = resample_closed(hole, 0.5 * spacing)
    lattice = triangular_lattice(np.array([-a, -b]), np.array([a, b]), spacing)
    lattice = lattice[points_in_polygon(lattice, outer) & ~points_in_polygon(lattice, hole)]
    lattice = _keep_clear(lattice, [outer, hole], 0.6 * spacing)
    points, triangles = triangulate_domain(outer, [hole], lattice)
    z = one_opening_height(points[:, 0], points[:, 1])
    return np.column_stack([points, z]), triangles


def write_one_opening(path: str | Path, spacing: float = 0.3) -> Path:
    """Write the one-opening roof as OBJ in metres (see :func:`one_opening_mesh`)."""
    vertices, triangles = one_opening_mesh(spacing)
    return write_obj(
        path,
        vertices,
        triangles,
        "one-opening roof, 16 x 12 m, crown 3.6 m, one elliptical opening "
        f"(Oval et al. 2018 topology)\nunits: metres; {len(triangles)} triangles",
    )


# --------------------------------------------------------------------------------------------
# pavilion ("Chengdu Flowers"-like)
# --------------------------------------------------------------------------------------------
def pavilion_supports() -> np.ndarray:
    """(3, 2) centres of the three support openings, m."""
    angles = np.radians(PAVILION_LOBE_ANGLE + np.array([0.0, 120.0, 240.0]))
    return SUPPORT_DISTANCE * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def pavilion_outline(t: np.ndarray) -> np.ndarray:
    """(n, 2) points of the lobed outer boundary at polar angles ``t`` (radians), m."""
    s = t - math.radians(PAVILION_LOBE_ANGLE)
    r = PAVILION_RADIUS + PAVILION_LOBE * np.cos(3 * s) - PAVILION_WAVE * np.cos(6 * s)
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def pavilion_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Canopy height z(x, y), m; exactly 0 on the three support rims.

    z = C(x, y) * prod_i tanh((r_i - rho) / s): C is a smooth dome, crown 5.8 m, whose edge rises
    over the lobes and sinks between them (a cubic harmonic); each factor is 0 on the rim of
    support i (r_i = rho = 0.7 m from its centre), rises with slope 1 / s there, so the shell
    leaves the ground steeply (about 79 degrees) as a trumpet, and is 1 beyond a few s.
    """
    r2 = x * x + y * y
    s = math.radians(PAVILION_LOBE_ANGLE)
    # Re(((x + i y) e^{-i s})^3) = r^3 cos 3(t - s)
    u, v = x * math.cos(s) + y * math.sin(s), -x * math.sin(s) + y * math.cos(s)
    cubic = (u**3 - 3 * u * v * v) / PAVILION_RADIUS**3
    canopy = (
        PAVILION_CROWN
        - (PAVILION_CROWN - PAVILION_EDGE) * r2 / PAVILION_RADIUS**2
        + PAVILION_EDGE_WAVE * cubic
    )
    factor = np.ones_like(x)
    for cx, cy in pavilion_supports():
        ri = np.hypot(x - cx, y - cy)
        factor *= np.tanh(np.maximum(ri - SUPPORT_RADIUS, 0.0) / SUPPORT_FLARE)
    return canopy * factor


def pavilion_mesh(spacing: float = 0.32, rim_points: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) m and triangles (m, 3) of the pavilion; ``spacing`` in m.

    The domain is the lobed outline minus the three rim circles. Around each support, rings of
    points graded from 0.04 m (at the rim, where the trumpet is steep) to ``spacing`` resolve the
    flare out to 2.2 m from the rim; the rest is a triangle lattice of ``spacing``. The defaults
    give about 8 900 triangles (250 KB as OBJ).
    """
    t = np.linspace(0.0, 2.0 * np.pi, 6000, endpoint=False)
    outer = resample_closed(pavilion_outline(t), 0.5 * spacing)
    supports = pavilion_supports()
    flare_zone = SUPPORT_RADIUS + 2.0 * SUPPORT_FLARE
    holes, rings = [], []
    for cx, cy in supports:
        angles = np.linspace(0.0, 2.0 * np.pi, rim_points, endpoint=False)
        holes.append(
            np.stack(
                [cx + SUPPORT_RADIUS * np.cos(angles), cy + SUPPORT_RADIUS * np.sin(angles)], axis=1
            )
        )
        radius, step = SUPPORT_RADIUS, 0.04 * spacing / 0.32
        while True:
            radius += step
            if radius > flare_zone:
                break
            count = max(rim_points, math.ceil(2 * np.pi * radius / spacing))
            # rings are aligned with the rim samples while the count stays the same
            angles = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
            rings.append(
                np.stack([cx + radius * np.cos(angles), cy + radius * np.sin(angles)], axis=1)
            )
            step = min(1.18 * step, spacing)
    rings = np.vstack(rings)
    box = np.abs(outer).max()
    lattice = triangular_lattice(np.array([-box, -box]), np.array([box, box]), spacing)
    lattice = lattice[points_in_polygon(lattice, outer)]
    clear = np.ones(len(lattice), dtype=bool)
    for cx, cy in supports:
        clear &= np.hypot(lattice[:, 0] - cx, lattice[:, 1] - cy) > flare_zone + 0.6 * spacing
    lattice = _keep_clear(lattice[clear], [outer], 0.6 * spacing)
    rings = rings[points_in_polygon(rings, outer)]
    points, triangles = triangulate_domain(outer, holes, np.vstack([rings, lattice]))
    z = pavilion_height(points[:, 0], points[:, 1])
    rim = np.arange(len(outer), len(outer) + sum(len(h) for h in holes))
    z[rim] = 0.0
    return np.column_stack([points, z]), triangles


def write_pavilion(path: str | Path, spacing: float = 0.32, rim_points: int = 40) -> Path:
    """Write the pavilion as OBJ in metres (see :func:`pavilion_mesh`)."""
    vertices, triangles = pavilion_mesh(spacing, rim_points)
    return write_obj(
        path,
        vertices,
        triangles,
        "pavilion after 'Chengdu Flowers' (thesis 7.1.2): about 20 m across, 5.8 m "
        "high,\nthree support openings, rim radius 0.7 m at z = 0\n"
        f"units: metres; {len(triangles)} triangles",
    )


# --------------------------------------------------------------------------------------------
# form-found shell
# --------------------------------------------------------------------------------------------
def formfound_mesh(divisions: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) m and triangles (m, 3) of a shell form-found on four corner supports.

    Force density method (Schek 1974): a ``divisions x divisions`` quad net with force density 1
    in every bar and ``FORMFOUND_EDGE_Q x divisions`` in the edge cables (the net's pull on a
    unit length of edge does not depend on the division, the cable force must not either), the
    four corners fixed at
    (+-7, +-7, 0), a unit load on every free node. The linear equilibrium ``D x_f = p - D_fc x_c``
    is solved per coordinate with scipy.sparse; the hanging net is inverted and scaled to a rise
    of 4 m (the shape does not depend on the load's size). Each quad is split along its shorter
    diagonal.
    """
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    n = divisions + 1
    index = np.arange(n * n).reshape(n, n)
    bars = np.vstack(
        [
            np.stack([index[:-1, :].ravel(), index[1:, :].ravel()], axis=1),
            np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], axis=1),
        ]
    )
    on_edge = np.zeros((n, n), dtype=bool)
    on_edge[[0, -1], :] = on_edge[:, [0, -1]] = True
    on_edge = on_edge.ravel()
    edge_bar = on_edge[bars[:, 0]] & on_edge[bars[:, 1]]
    q = np.where(edge_bar, FORMFOUND_EDGE_Q * divisions, 1.0)
    m = len(bars)
    C = sparse.coo_matrix(
        (
            np.concatenate([np.ones(m), -np.ones(m)]),
            (np.concatenate([np.arange(m)] * 2), bars.T.ravel()),
        ),
        shape=(m, n * n),
    ).tocsr()
    D = (C.T @ sparse.diags(q) @ C).tocsr()
    corners = np.array([index[0, 0], index[0, -1], index[-1, -1], index[-1, 0]])
    free = np.setdiff1d(np.arange(n * n), corners)
    h = FORMFOUND_HALF
    xyz = np.zeros((n * n, 3))
    xyz[corners] = [[-h, -h, 0.0], [-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0]]
    load = np.zeros((n * n, 3))
    load[free, 2] = -1.0
    Dff, Dfc = D[free][:, free].tocsc(), D[free][:, corners]
    xyz[free] = spsolve(Dff, load[free] - Dfc @ xyz[corners]).reshape(-1, 3)
    xyz[:, 2] *= FORMFOUND_RISE / xyz[:, 2].min()  # invert the hanging net
    v00 = index[:-1, :-1].ravel()
    quads = np.stack([v00, v00 + n, v00 + n + 1, v00 + 1], axis=1)
    d02 = np.linalg.norm(xyz[quads[:, 2]] - xyz[quads[:, 0]], axis=1)
    d13 = np.linalg.norm(xyz[quads[:, 3]] - xyz[quads[:, 1]], axis=1)
    split02 = d02 <= d13
    triangles = np.vstack(
        [
            np.where(split02[:, None], quads[:, [0, 1, 2]], quads[:, [0, 1, 3]]),
            np.where(split02[:, None], quads[:, [0, 2, 3]], quads[:, [1, 2, 3]]),
        ]
    )
    # counter-clockwise seen from above (outer side of the vault)
    a, b, c = (xyz[triangles[:, k], :2] for k in range(3))
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    triangles = np.where((signed < 0)[:, None], triangles[:, ::-1], triangles)
    return xyz, triangles


def write_formfound(path: str | Path, divisions: int = 40) -> Path:
    """Write the form-found shell as OBJ in metres (see :func:`formfound_mesh`)."""
    vertices, triangles = formfound_mesh(divisions)
    return write_obj(
        path,
        vertices,
        triangles,
        "form-found shell on four corner supports (force density method), "
        "14 x 14 m, rise 4 m\n"
        f"units: metres; {len(triangles)} triangles from a {divisions} x "
        f"{divisions} quad net",
    )


# --------------------------------------------------------------------------------------------
# four-sided patch
# --------------------------------------------------------------------------------------------
def patch_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Saddle height z(x, y), m: a quadratic, so a bicubic B-spline reproduces it exactly."""
    a, b = PATCH_HALF
    return (
        PATCH_Z0 + PATCH_CX * (x / a) ** 2 - PATCH_CY * (y / b) ** 2 + PATCH_CXY * (x / a) * (y / b)
    )


def patch_mesh(nx: int = 50, ny: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) m and triangles (m, 3) of the saddle patch on an ``nx x ny`` grid."""
    a, b = PATCH_HALF
    X, Y = np.meshgrid(np.linspace(-a, a, nx + 1), np.linspace(-b, b, ny + 1), indexing="ij")
    vertices = np.stack([X, Y, patch_height(X, Y)], axis=-1).reshape(-1, 3)
    return vertices, grid_triangles(nx, ny)


def grid_triangles(nx: int, ny: int) -> np.ndarray:
    """Triangles (2 nx ny, 3) of an (nx + 1) x (ny + 1) point grid numbered along y first
    (``meshgrid(..., indexing="ij")``), counter-clockwise seen from above."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    v00 = (i * (ny + 1) + j).ravel()
    return np.vstack(
        [
            np.stack([v00, v00 + ny + 1, v00 + ny + 2], axis=1),
            np.stack([v00, v00 + ny + 2, v00 + 1], axis=1),
        ]
    )


def write_patch_obj(path: str | Path, nx: int = 50, ny: int = 40) -> Path:
    """Write the saddle patch as OBJ in metres (see :func:`patch_mesh`)."""
    vertices, triangles = patch_mesh(nx, ny)
    return write_obj(
        path,
        vertices,
        triangles,
        "four-sided saddle patch, 10 x 8 m, z from 1.5 to 4.9 m\n"
        f"units: metres; {len(triangles)} triangles",
    )


def write_patch_step(path: str | Path, nx: int = 10, ny: int = 8) -> Path:
    """Write the saddle patch as one B-spline face in STEP, millimetres.

    A bicubic B-spline is fitted through ``(nx + 1) x (ny + 1)`` grid points
    (``GeomAPI_PointsToBSplineSurface``, tolerance 1e-4 mm); the quadratic z makes it exact. u runs
    along x and v along y, so the face normal points up (the outer side).
    """
    from OCP.Approx import Approx_IsoParametric
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.collections import Array2_gp_Pnt as TColgp_Array2OfPnt
    from OCP.GeomAbs import GeomAbs_C2
    from OCP.GeomAPI import GeomAPI_PointsToBSplineSurface
    from OCP.gp import gp_Pnt
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    a, b = PATCH_HALF
    xs, ys = np.linspace(-a, a, nx + 1), np.linspace(-b, b, ny + 1)
    grid = TColgp_Array2OfPnt(1, nx + 1, 1, ny + 1)
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            z = float(patch_height(x, y))
            grid.SetValue(i + 1, j + 1, gp_Pnt(1000.0 * x, 1000.0 * y, 1000.0 * z))
    # least squares with parameters spaced like the grid (not by chord length): a quadratic is in
    # the space of bicubics, so the fit finds it exactly (one 4 x 4-pole patch). Interpolate()
    # would not: its end conditions bend the surface by up to 0.5 mm near the corners.
    fitter = GeomAPI_PointsToBSplineSurface()
    fitter.Init(grid, Approx_IsoParametric, 3, 3, GeomAbs_C2, 1e-4)
    if not fitter.IsDone():
        raise RuntimeError("B-spline interpolation of the patch failed")
    maker = BRepBuilderAPI_MakeFace(fitter.Surface(), 1e-6)
    if not maker.IsDone():
        raise RuntimeError("could not make a face of the patch's B-spline surface")
    writer = STEPControl_Writer()
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer.Transfer(maker.Face(), STEPControl_AsIs)
    path = Path(path)
    if writer.Write(str(path)) != IFSelect_RetDone:
        raise RuntimeError(f"could not write {path}")
    return path


# --------------------------------------------------------------------------------------------
# job files
# --------------------------------------------------------------------------------------------
JOB_TEMPLATE = """\
# fabpanel job: {title}
# Written by examples/shapes.py. Lengths, pressures, stresses, densities and times carry their
# unit ("3 mm", "1.2 m", "0.56 kN/m2", "210 GPa", "7850 kg/m3", "5 s"). Every output is in
# millimetres. Remove a key to use its default; unknown keys are refused.

[input]
path = "{input}"{input_pad}# design surface: OBJ, STL, PLY, OFF, GLB, STEP, IGES or BREP
{units_line}

[panelize]
method = "auto"                # auto (grid if four-sided and it passes the gates, else field, or the better of field and skeleton) | grid | skeleton | field | layout
panel_size = "{panel_size}"{size_pad}# target panel edge length; an unrolled sheet must fit the plate
# grid_u = 10                  # grid: explicit panel counts along the grid directions
# grid_v = 8
corner_angle = 30.0            # degrees; boundary vertices turning more than this are corners
# layout = "my-layout.obj"     # layout: a hand-drawn quad mesh, in the input's units
density = "strips"             # skeleton: densify per strip (strips) or by catmull-clark levels
relax = true                   # skeleton: relax the dense layout on the surface

[develop]
method = "global"              # global: optimise all panels at once (developable, planar ribs)
                               # loft: the thesis's per-panel ruled surfaces | project: as designed
samples = 9                    # k x k samples per panel (9 = the thesis's subdivision level 3)
strain_tolerance = 0.0005      # largest unroll strain of a developable panel (0.05 %)
# deviation_tolerance = "20 mm"  # a panel farther from the design surface is a warning

[sandwich]
buildup = "sandwich"           # sandwich (top + bottom sheet, ribs) | cladding (one sheet)
design_face = "top-outer"      # face on the design surface: top-outer | bottom-outer | middle
sheet_thickness = "3 mm"
# bottom_sheet_thickness = "3 mm"   # default: same as the top sheet
rib_height = "150 mm"          # clear height of the ribs between the sheets
rib_thickness = "8 mm"
stiffener_offset = "150 mm"    # corner stiffeners join the points this far along both edges
# stiffener_thickness = "8 mm"      # default: rib thickness

[sandwich.bolts]
diameter = "13 mm"             # M12 bolts in 13 mm holes
spacing = "250 mm"
edge_distance = "60 mm"
access_sheet = "bottom"        # sheet with the slots the tool reaches the bolts through: bottom | top | none
tool = "ring-spanner"          # the fitter's tool (ring-spanner | socket): the slots are sized for it
# tool_swing = 30.0            # degrees between two grips; head sizes default from the bolt

[material]
name = "S235"
E = "210 GPa"
nu = 0.3
density = "7850 kg/m3"
fy = "235 MPa"

[cutting]
plate_length = "3000 mm"
plate_width = "1500 mm"
kerf = "2 mm"                  # plasma kerf (the CAM compensates; checked against the spacing)
part_spacing = "10 mm"         # clear gap between parts, at least the kerf
plate_margin = "10 mm"         # clear border along the plate edges
nest_time = "0 s"              # improvement time per material/thickness group; 0 s = reproducible
rotations = [0, 90, 180, 270]
neutral_fibre = "mid"          # sheets are unrolled at this fibre: mid | outer | inner
min_plasma_hole = 1.0          # holes under this many thicknesses are drilled (DRILL layer)
seed = 0                       # same seed, same nest

[loads]
code = "en1991"                # EN 1991 loads, EN 1990 combinations; "thesis": §7.3's simple loads
snow_ground = "0.7 kN/m2"      # s_k from the national snow map (0.7: the Netherlands)
snow_exposure = 1.0            # C_e: windswept 0.8, normal 1.0, sheltered 1.2
snow_thermal = 1.0             # C_t
wind_speed = "25 m/s"          # v_b,0 from the national wind map
terrain = "II"                 # terrain category 0, I, II, III, IV
base_height = "0 m"            # the shell's lowest point above the ground
# wind_directions = [0.0, 90.0, 180.0, 270.0]   # default: along and across the plan's axes
internal_pressure = [0.2, -0.3]  # c_pi under the shell, both used
gamma_g_sup = 1.35             # EN 1990 Table A1.2(B); national annex values go here
gamma_g_inf = 1.0
gamma_q = 1.5
psi0_snow = 0.5                # Table A1.1, sites up to 1000 m
psi0_wind = 0.6
# code = "thesis" uses these instead:
# snow = "0.56 kN/m2"          # on the horizontal projection
# wind = "0.8 kN/m2"
# wind_direction = [1.0, 0.0]  # horizontal direction; both signs are checked
# gamma_g = 1.2
buckling_knockdown = 0.166667  # 1/6: a linear buckling factor of 6 is required
deflection_limit = 300.0       # span / 300

[output]
# dir = "{name}-fabpanel"{dir_pad}# default: <input name>-fabpanel beside the job file
step = true
glb = true
rhino = true                   # model/design.3dm for Rhino and Grasshopper
dxf = true
report = true
"""

#: per example: title, input file, units (None: the file carries them), panel size
JOBS = {
    "one-opening": (
        "one-opening roof, 16 x 12 m, one elliptical opening",
        "one-opening.obj",
        "m",
        "1.2 m",
    ),
    "pavilion": (
        ("'Chengdu Flowers'-like pavilion, about 20 m across, three support openings"),
        "pavilion.obj",
        "m",
        "1.0 m",
    ),
    "formfound": (
        "form-found shell on four corner supports, 14 x 14 m (grid method on a mesh)",
        "formfound.obj",
        "m",
        "1.2 m",
    ),
    "patch": (
        "four-sided saddle patch, 10 x 8 m, one B-spline face (grid in its parameters)",
        "patch.step",
        None,
        "1.2 m",
    ),
}


def job_text(name: str) -> str:
    """The job file of example ``name`` (a key of ``JOBS``)."""
    title, source, units, panel_size = JOBS[name]

    def pad(text: str, width: int = 31) -> str:
        return " " * max(1, width - len(text))

    if units is None:
        key = '# units = "m"'
        note = (
            f"# STEP carries its units; {source.rsplit('.', 1)[0]}.obj (the same shape as a "
            f'mesh) needs "m"'
        )
    else:
        key = f'units = "{units}"'
        note = "# length unit of the mesh coordinates: m, cm or mm"
    units_line = key + pad(key) + note

    return JOB_TEMPLATE.format(
        title=title,
        input=source,
        input_pad=pad(f'path = "{source}"'),
        units_line=units_line,
        panel_size=panel_size,
        size_pad=pad(f'panel_size = "{panel_size}"'),
        name=name,
        dir_pad=pad(f'# dir = "{name}-fabpanel"', 35),
    )


def write_all(folder: str | Path) -> list[Path]:
    """Write every example shape and its job file into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = [
        write_one_opening(folder / "one-opening.obj"),
        write_pavilion(folder / "pavilion.obj"),
        write_formfound(folder / "formfound.obj"),
        write_patch_obj(folder / "patch.obj"),
        write_patch_step(folder / "patch.step"),
    ]
    for name in JOBS:
        path = folder / f"{name}.toml"
        path.write_text(job_text(name))
        written.append(path)
    return written


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent
    for written_path in write_all(target):
        print(f"{written_path}  ({written_path.stat().st_size / 1024:.0f} KB)")
