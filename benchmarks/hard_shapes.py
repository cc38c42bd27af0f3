"""Hard test shapes for the panel layout, each harder than the examples in another way (metres).

    .venv/bin/python benchmarks/hard_shapes.py [FOLDER]   # writes <name>.obj for every shape

- ``canopy4``: a four-support canopy, rounded square 12 m (corner radius 2 m), four openings of
  1.1-1.6 m at uneven places: many small openings per panel width (the issue's first shape);
- ``dome_oculus``: a spherical cap 12 m across, 4 m rise, a 2.4 m oculus at the top: slopes up
  to 67°, a projection that stretches 2.6 x radially;
- ``hypar_hole``: a hyperbolic paraboloid 8 x 6 m (corners ±1.2 m) with one off-centre, rotated
  elliptical opening: negative curvature and a sharp-cornered outline;
- ``funnel``: two lobes (8 m and 5 m) joined by a 3 m neck: strips run from wide into narrow;
- ``wavy_strip``: a 24 m strip 2.5-5 m wide on a sinusoidal centre line, wavy in height: only
  two to five panels across, everything near a boundary;
- ``quarry``: a plaza with 100° corners and a concave notch, two openings 0.8 m apart and one
  0.6 m from the outline: gaps narrower than a panel;
- ``ellipse_shell``: an elliptic shell 12 x 5 m, 2 m rise: its ends round off at 1.04 m radius,
  about one panel, with no corner for the layout's corners to sit on;
- ``kidney``: a smooth kidney-shaped outline 11 x 5 m with blunt ends and a 1.4 m opening near
  its waist: no corner anywhere, and an opening only 1.4 panels across;
- ``triangle_roof``: a rounded triangle 14 m (corner radius 1.5 m) with a 2 m opening off the
  centre: three corners of 60°, the least a quad layout can meet with two panels;
- ``l_slab``: an L-shaped slab 14 x 11 m with one round and one rectangular opening, its
  reflex corner cut by a 112 mm facet: a 270° corner and a short facet together;
- ``saddle_ring``: an annulus (radii 7 and 3 m) on a saddle: a genus-0 surface with two
  boundary loops and negative curvature all round, no corner anywhere;
- ``flower``: a dome on a five-lobed outline (r = 6 + 1.3 cos 5θ): concave and convex turns
  alternate every 36° round the rim;
- ``crescent``: a crescent moon 12 m long whose tips meet at about 30°, sharper than any panel
  corner may be: the layout must say the tips are the design's, not its own;
- ``slab_hole``: a slab 10.4 x 4.7 m (under five panels across) with 1.13 m rounded corners and
  a round opening 0.91 m across, smaller than a panel: the layout can neither ring the opening
  nor turn the corners with one panel;
- ``rounded_slab``: a gently domed slab 10.8 x 9.5 m whose corners round off at 3 m, no
  openings: a smooth outline that gmsh's pattern-based faces mesh as a disk, rings of panels
  growing to twice the size at the rim;
- ``skylights``: a gently domed 11 x 8 m roof with three openings about a panel across, two of
  them rectangles turned off the outline's axes (0.8 x 0.48 m at 30°, 1.2 x 0.7 m at 65°,
  sides shorter than the gates' 0.6 m merge of close corners) and a 0.9 m round one: the grid
  should run past each as past a missing panel;
- ``steep_vault``: a half-cylinder of 4 m radius and 10 m long with two windows in its flanks:
  walls that stand vertical at the springing, where a plan projection fails.

Generated with the planar-domain helpers of ``examples/shapes.py`` (boundary resampled, a
triangular lattice inside, Delaunay culled to the domain, lifted by a height function), so the
meshes are deterministic.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
from shapely import affinity
from shapely.geometry import Point, Polygon, box
from shapely.ops import unary_union

_spec = importlib.util.spec_from_file_location(
    "example_shapes", Path(__file__).resolve().parents[1] / "examples" / "shapes.py"
)
_shapes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_shapes)

#: triangle size of the generated meshes, m
SPACING = 0.2


def _ring(geometry) -> np.ndarray:
    return np.asarray(geometry.coords)[:-1, :2]


def _mesh(
    polygon: Polygon, height, spacing: float = SPACING, keep_corners: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """A planar domain (shapely polygon with holes) triangulated and lifted by ``height``;
    with ``keep_corners``, every vertex of the polygon turning over 20° stays a mesh vertex
    (as a CAD export keeps a corner), else the loops are resampled evenly and cut corners."""
    resample = _resampled_keeping_corners if keep_corners else _shapes.resample_closed
    outer = resample(_ring(polygon.exterior), spacing)
    holes = [resample(_ring(hole), 0.8 * spacing) for hole in polygon.interiors]
    if Polygon(outer).exterior.is_ccw is False:
        outer = outer[::-1]
    low, high = np.min(outer, axis=0), np.max(outer, axis=0)
    lattice = _shapes.triangular_lattice(low, high, spacing)
    inside = _shapes.points_in_polygon(lattice, outer)
    for hole in holes:
        inside &= ~_shapes.points_in_polygon(lattice, hole)
    interior = _shapes._keep_clear(lattice[inside], [outer, *holes], 0.6 * spacing)
    points, triangles = _shapes.triangulate_domain(outer, holes, interior)
    return np.column_stack([points, height(points[:, 0], points[:, 1])]), triangles


def _resampled_keeping_corners(ring: np.ndarray, spacing: float) -> np.ndarray:
    """A closed ring resampled about every ``spacing`` between its corners (vertices turning
    more than 20°), which stay."""
    ahead = np.roll(ring, -1, axis=0) - ring
    behind = ring - np.roll(ring, 1, axis=0)
    turn = np.abs(
        np.degrees(
            np.arctan2(
                behind[:, 0] * ahead[:, 1] - behind[:, 1] * ahead[:, 0],
                np.einsum("ij,ij->i", behind, ahead),
            )
        )
    )
    corners = np.flatnonzero(turn > 20.0)
    if not len(corners):
        return _shapes.resample_closed(ring, spacing)
    points = []
    for start, end in zip(corners, [*corners[1:], corners[0] + len(ring)]):
        run = ring[np.arange(start, end + 1) % len(ring)]
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(run, axis=0), axis=1))])
        count = max(1, math.ceil(arc[-1] / spacing))
        at = np.linspace(0.0, arc[-1], count, endpoint=False)
        points.append(
            np.column_stack([np.interp(at, arc, run[:, 0]), np.interp(at, arc, run[:, 1])])
        )
    return np.vstack(points)


def _rounded_square(half: float, radius: float) -> Polygon:
    return box(-half + radius, -half + radius, half - radius, half - radius).buffer(
        radius, quad_segs=32
    )


def canopy4_mesh() -> tuple[np.ndarray, np.ndarray]:
    openings = [((3.3, 3.1), 0.55), ((-3.1, 3.3), 0.65), ((-3.3, -3.0), 0.75), ((3.0, -3.4), 0.8)]
    domain = _rounded_square(6.0, 2.0)
    for centre, radius in openings:
        domain = domain.difference(Point(centre).buffer(radius, quad_segs=16))
    return _mesh(domain, lambda x, y: 1.5 * (1 - (x**2 + y**2) / 72.0))


def dome_oculus_mesh() -> tuple[np.ndarray, np.ndarray]:
    rise, base = 4.0, 6.0
    sphere = (base**2 + rise**2) / (2 * rise)
    # plan radius of the oculus rim: 1.2 m measured along the surface from the crown
    rim = sphere * math.sin(1.2 / sphere)
    domain = Point(0, 0).buffer(base, quad_segs=64).difference(Point(0, 0).buffer(rim, 32))
    return _mesh(
        domain,
        lambda x, y: np.sqrt(np.maximum(sphere**2 - x**2 - y**2, 0.0)) - (sphere - rise),
        spacing=0.12,
    )


def hypar_hole_mesh() -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    angle = math.radians(30)
    ellipse = np.column_stack([0.8 * np.cos(t), 0.5 * np.sin(t)])
    rotation = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    hole = ellipse @ rotation.T + np.array([1.8, -0.8])
    domain = box(-4, -3, 4, 3).difference(Polygon(hole))
    return _mesh(domain, lambda x, y: 0.1 * x * y)


def funnel_mesh() -> tuple[np.ndarray, np.ndarray]:
    lobes = unary_union(
        [Point(-3.0, 0).buffer(4.0, quad_segs=48), Point(5.0, 0).buffer(2.5, quad_segs=48)]
    )
    neck = box(-1.0, -1.5, 4.0, 1.5)
    domain = unary_union([lobes, neck]).buffer(0.6, quad_segs=16).buffer(-0.6, quad_segs=16)
    return _mesh(domain, lambda x, y: 1.5 * np.exp(-((x + 1) ** 2 + y**2) / 40.0))


def wavy_strip_mesh() -> tuple[np.ndarray, np.ndarray]:
    x = np.linspace(-12, 12, 241)
    centre = 2.0 * np.sin(2 * np.pi * x / 12)
    slope = np.gradient(centre, x)
    normal = np.column_stack([-slope, np.ones_like(x)]) / np.sqrt(1 + slope**2)[:, None]
    half = 0.5 * (3.75 + 1.25 * np.cos(2 * np.pi * x / 24))
    line = np.column_stack([x, centre])
    left, right = line + half[:, None] * normal, line - half[:, None] * normal
    domain = Polygon(np.vstack([right, left[::-1]])).buffer(0)
    return _mesh(domain, lambda x, y: 0.3 + 1.0 * np.sin(2 * np.pi * x / 10) * np.cos(y / 6))


def quarry_mesh() -> tuple[np.ndarray, np.ndarray]:
    outline = Polygon(
        [(-8, -6), (-1, -6), (0.5, -4.2), (2, -6), (8, -5), (7, 6), (-2, 6), (-8, 3.5)]
    )
    holes = [Point(-3.0, 0.5).buffer(1.2, 24), Point(-0.2, 0.5).buffer(0.8, 24)]
    holes.append(Point(5.0, 4.2).buffer(0.9, 24))  # 0.6 m from the upper edge (y = 6 - ...)
    domain = outline
    for hole in holes:
        domain = domain.difference(hole)
    return _mesh(domain, lambda x, y: 0.8 + 0.012 * (x**2 - y**2))


def ellipse_shell_mesh() -> tuple[np.ndarray, np.ndarray]:
    domain = affinity.scale(Point(0, 0).buffer(1.0, quad_segs=64), 6.0, 2.5)
    return _mesh(domain, lambda x, y: 2.0 * (1 - (x / 6) ** 2 - (y / 2.5) ** 2))


def kidney_mesh() -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    radius = 4 + 1.2 * np.cos(2 * t) + 0.6 * np.sin(3 * t)
    domain = Polygon(np.column_stack([1.3 * radius * np.cos(t), 0.8 * radius * np.sin(t)]))
    domain = domain.difference(Point(1.5, 0.3).buffer(0.7, 24))
    return _mesh(domain, lambda x, y: 1.5 * np.exp(-(x**2 + y**2) / 30))


def triangle_roof_mesh() -> tuple[np.ndarray, np.ndarray]:
    radius = 1.5
    corners = np.array([[0.0, 8.0], [-7.0, -4.1], [7.0, -4.1]])
    inner = Polygon(corners).buffer(-radius, join_style=2)
    domain = inner.buffer(radius, quad_segs=24).difference(Point(1.0, -0.5).buffer(1.0, 32))
    return _mesh(domain, lambda x, y: 1.8 * np.exp(-(x**2 + (y - 0.5) ** 2) / 25.0))


def l_slab_mesh() -> tuple[np.ndarray, np.ndarray]:
    outline = Polygon([(0, 0), (14, 0), (14, 5), (6.08, 5), (6.0, 5.08), (6, 11), (0, 11)])
    domain = outline.difference(Point(3.0, 8.0).buffer(1.1, 32)).difference(
        box(9.0, 1.8, 11.5, 3.2)
    )
    return _mesh(domain, lambda x, y: 0.6 * np.sin(np.pi * x / 14) * np.sin(np.pi * y / 11))


def saddle_ring_mesh() -> tuple[np.ndarray, np.ndarray]:
    domain = Point(0, 0).buffer(7.0, quad_segs=64).difference(Point(0, 0).buffer(3.0, 32))
    return _mesh(domain, lambda x, y: 0.04 * (x**2 - y**2))


def flower_mesh() -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    radius = 6.0 + 1.3 * np.cos(5 * t)
    domain = Polygon(np.column_stack([radius * np.cos(t), radius * np.sin(t)]))
    return _mesh(domain, lambda x, y: 2.5 * (1 - (x**2 + y**2) / 55.0))


def crescent_mesh() -> tuple[np.ndarray, np.ndarray]:
    outer = Point(0, 0).buffer(6.0, quad_segs=64)
    bite = Point(3.2, 0).buffer(5.2, quad_segs=64)
    domain = outer.difference(bite)
    return _mesh(domain, lambda x, y: 1.2 * (1 - (x**2 + y**2) / 40.0))


def steep_vault_mesh() -> tuple[np.ndarray, np.ndarray]:
    # the vault unrolled: u along the arc (0..pi r), v along the axis; windows cut in the flanks
    radius, length = 4.0, 10.0
    arc = math.pi * radius
    domain = box(0, 0, arc, length)
    for u, v in ((0.25 * arc, 3.0), (0.75 * arc, 7.0)):
        domain = domain.difference(box(u - 0.8, v - 1.0, u + 0.8, v + 1.0))
    points, triangles = _mesh(domain, lambda x, y: np.zeros_like(x))
    angle = points[:, 0] / radius
    return np.column_stack(
        [radius * np.cos(angle), points[:, 1], radius * np.sin(angle)]
    ), triangles


def slab_hole_mesh() -> tuple[np.ndarray, np.ndarray]:
    width, depth, radius = 10.4, 4.7, 1.13
    slab = box(-width / 2 + radius, -depth / 2 + radius, width / 2 - radius, depth / 2 - radius)
    domain = slab.buffer(radius, quad_segs=16).difference(Point(0.58, 0.51).buffer(0.455, 24))
    return _mesh(
        domain,
        lambda x, y: (
            1.05 * np.exp(-(x**2 + y**2) / 27.0) - 0.01 * x * y - 0.011 * x**2 + 0.012 * y**2
        ),
    )


def rounded_slab_mesh() -> tuple[np.ndarray, np.ndarray]:
    # corners rounded at 3 m, no openings: the mesher's pattern-based faces made it a disk
    core = box(-5.4 + 3.0, -4.75 + 3.0, 5.4 - 3.0, 4.75 - 3.0)
    return _mesh(core.buffer(3.0, quad_segs=16), lambda x, y: 0.8 * np.exp(-(x**2 + y**2) / 30.0))


def skylights_mesh() -> tuple[np.ndarray, np.ndarray]:
    roof = box(-5.5, -4.0, 5.5, 4.0)
    small = affinity.rotate(box(-0.4, -0.24, 0.4, 0.24), 30)
    large = affinity.rotate(box(-0.6, -0.35, 0.6, 0.35), 65)
    domain = (
        roof.difference(affinity.translate(small, -2.6, 1.1))
        .difference(affinity.translate(large, 2.4, -0.9))
        .difference(Point(0.3, 2.2).buffer(0.45, 24))
    )
    return _mesh(
        domain,
        lambda x, y: 0.9 * np.exp(-(x**2 + y**2) / 30.0) + 0.01 * x * y,
        keep_corners=True,
    )


SHAPES = {
    "canopy4": canopy4_mesh,
    "dome_oculus": dome_oculus_mesh,
    "hypar_hole": hypar_hole_mesh,
    "funnel": funnel_mesh,
    "wavy_strip": wavy_strip_mesh,
    "quarry": quarry_mesh,
    "ellipse_shell": ellipse_shell_mesh,
    "kidney": kidney_mesh,
    "triangle_roof": triangle_roof_mesh,
    "l_slab": l_slab_mesh,
    "saddle_ring": saddle_ring_mesh,
    "flower": flower_mesh,
    "crescent": crescent_mesh,
    "steep_vault": steep_vault_mesh,
    "slab_hole": slab_hole_mesh,
    "rounded_slab": rounded_slab_mesh,
    "skylights": skylights_mesh,
}


def write_obj(path: str | Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    return _shapes.write_obj(path, vertices, faces, f"fabpanel hard shape {Path(path).stem}, m")


def main() -> None:
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    folder.mkdir(parents=True, exist_ok=True)
    for name, make in SHAPES.items():
        vertices, faces = make()
        write_obj(folder / f"{name}.obj", vertices, faces)
        print(f"{name}: {len(faces)} triangles", file=sys.stderr)


if __name__ == "__main__":
    main()
