"""Sheet faces trimmed at the rib planes: every sheet edge lies exactly in its rib plane.

A developed panel's sample grid holds the sheet's design face; its other faces (the top sheet's
inner face, the bottom sheet's faces) are the grid moved along the developed normals. Where the
rib plane is bevelled against the normals (a cone's parallels: Joachimsthal), a face moved by
``o`` along the normals leaves the plane by ``o sin(bevel)``: 150 mm below a 5° bevel, 13 mm. So
each face is trimmed at the four rib planes on its own B-spline, extrapolated slightly beyond its
samples where the plane lies outside:

1. interpolate the face grid (degree 3, uniform parameters on the unit square);
2. find the corners (two planes and the surface meet: 2D Newton) and, along each side, the
   cross parameter where the surface meets that side's plane (1D Newton per station). Beyond
   its samples the face is continued by its second-order Taylor expansion at the nearest
   boundary point (:func:`continued`), not by the boundary span's own cubic: on a bottom face
   offset 150 mm along noisy normals that cubic swung 60 mm off within 40 mm of the edge and
   sent the corner Newton astray, leaving the edge untrimmed;
3. fill the parameter square between the four trim curves with a Coons patch, evaluate the
   surface there and fit that grid again, with the fewest poles within 0.001 mm of it
   (:func:`fabpanel.model.occ.fitted_surface`; the cubic through every point where none
   holds): the new surface's boundary rows lie in the planes, and a cubic interpolant or
   end-kept least-squares fit of coplanar points stays in their plane (affine invariance).

The fit error reported is the largest distance of the developed samples from the new surface,
measured across it (the trim moves boundary samples along the surface, reported as the slide).
Coons patches: Farin, "Curves and Surfaces for CAGD", chapter 22.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import KernelError
from . import occ

#: Newton stops when the surface point is this close to the plane, mm
PLANE_TOLERANCE = 1e-7
NEWTON_ITERATIONS = 30
#: halvings of a corner's Newton step before it is taken as stuck
CORNER_HALVINGS = 12
#: the trimmed face is refitted through this many points per sample interval
REFIT_DENSITY = 2

# per side: (parameter that runs along it, parameter across it, value of the latter on the side)
_SIDES = ((0, 1, 0.0), (1, 0, 1.0), (0, 1, 1.0), (1, 0, 0.0))
_CORNERS = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])


class _TrimFailed(KernelError):
    def __init__(self, message: str, sides: tuple[int, ...]) -> None:
        super().__init__(message)
        self.sides = sides


@dataclass
class TrimmedFace:
    """A sheet face whose boundary lies in the rib planes.

    surface : Geom_BSplineSurface over the unit square; side convention as
        :class:`fabpanel.data.DevelopedPanels` (side 0 at v = 0, side 1 at u = 1 ...).
    orient : +1 when ``dS/du x dS/dv`` points outward (along the developed normals).
    fit_error : mm, the developed samples against the new surface, measured across it.
    slide : (4,) float, mm, how far each side's edge moved to reach its plane.
    untrimmed : (4,) bool, sides asked to be trimmed that were left at the developed edge
        (the plane does not meet the face near it, or only after moving it by more than the
        slide limit: a rib plane nearly tangent to the sheet).
    """

    surface: object
    orient: float
    fit_error: float
    slide: np.ndarray
    untrimmed: np.ndarray

    def normals(self, uv: np.ndarray) -> np.ndarray:
        """(n, 3) float: outward unit normals at the parameters ``uv (n, 2)``."""
        _, du, dv = occ.surface_derivatives(self.surface, uv)
        n = np.cross(du, dv) * self.orient
        return n / np.linalg.norm(n, axis=1, keepdims=True)


def trimmed_face(
    grid: np.ndarray,
    normal: np.ndarray,
    planes: np.ndarray,
    trim: np.ndarray,
    slide_limit: float,
    name: str = "face",
) -> TrimmedFace:
    """Interpolate ``grid (k, k, 3)`` and trim it at ``planes (4, 4)`` (unit normals) on the
    sides where ``trim (4,) bool``; ``normal (3,)`` is the outward normal of the panel's middle
    (it fixes ``orient``). A side whose plane does not meet the face, or only after moving the
    edge by more than ``slide_limit`` mm, is left untrimmed (``TrimmedFace.untrimmed``)."""
    mask = np.asarray(trim, dtype=bool).copy()
    order = 2
    for _ in range(6):
        try:
            face = _trimmed_face(grid, normal, planes, mask, name, order)
        except _TrimFailed as err:
            if order == 2:
                # the face continued by its tangent planes instead: where the face bends
                # sharply at a corner (a bottom face offset along normals that turn), its
                # second-order continuation curls back before it reaches a rib plane only
                # millimetres away (a crown panel of a lopsided shell: 1.4 mm short at best)
                order = 1
                continue
            mask[list(err.sides)] = False
            continue
        too_far = mask & (face.slide > slide_limit)
        if too_far.any():
            mask &= ~too_far
            continue
        face.untrimmed = np.asarray(trim, dtype=bool) & ~mask
        return face
    face = _trimmed_face(grid, normal, planes, np.zeros(4, bool), name, order)
    face.untrimmed = np.asarray(trim, dtype=bool)
    return face


def _trimmed_face(
    grid: np.ndarray,
    normal: np.ndarray,
    planes: np.ndarray,
    trim: np.ndarray,
    name: str,
    order: int = 2,
) -> TrimmedFace:
    source, _ = occ.bspline_surface(grid, name)
    k = grid.shape[0]
    corners = np.array([_corner(source, c, planes, trim, name, order) for c in range(4)])
    # refit at twice the sample density, so the new surface follows the source between the
    # samples too (a refit through the k x k samples alone drifted 0.09 mm between them on a
    # panel developed from a faceted mesh); every boundary point of the refit is put on its
    # plane (between stations on a plane that crosses the parameter lines obliquely, the
    # parameters' straight line left the edge 0.9 mm off the plane)
    n = REFIT_DENSITY * (k - 1) + 1
    sides = []
    for side, (along, across, value) in enumerate(_SIDES):
        start, end = corners[side], corners[(side + 1) % 4]
        uv = np.linspace(start, end, n)
        if trim[side]:
            uv = _onto_plane(source, uv, across, planes[side], f"{name} side {side}", side, order)
        else:
            uv[:, across] = value
        sides.append(uv)
    params = coons(sides, np.linspace(0, 1, n), np.linspace(0, 1, n))
    points, _, _ = continued(source, params.reshape(-1, 2), order)
    new_grid = points.reshape(n, n, 3)
    surface = occ.fitted_surface(new_grid, name)
    fit = _samples_fit(surface, grid)
    slide = np.array(
        [
            np.linalg.norm(
                side_rows(new_grid[::REFIT_DENSITY, ::REFIT_DENSITY])[s] - side_rows(grid)[s],
                axis=1,
            ).max()
            for s in range(4)
        ]
    )
    _, du, dv = occ.surface_derivatives(surface, np.array([[0.5, 0.5]]))
    orient = 1.0 if float(np.cross(du[0], dv[0]) @ normal) >= 0 else -1.0
    return TrimmedFace(surface, orient, fit, slide, np.zeros(4, bool))


def _samples_fit(surface, grid: np.ndarray) -> float:
    """The largest distance of the developed samples ``grid (k, k, 3)`` from the new surface,
    over the samples the trimmed face still holds (those whose closest point lies inside it:
    a trim that cuts the face back leaves the samples beyond out).

    It used to compare each sample with the new grid's point of the same index, across the
    source surface. Where a trim slides the edge far along a curved face (a bottom sheet
    hanging 145 mm beyond its samples to a square rib), that point has moved along the
    surface and reads as off it by the sagitta of the move: 0.7-1.0 mm on a new user's vault,
    where the samples lie within 0.0005 mm of the sheet."""
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt

    u0, u1, v0, v1 = surface.Bounds()
    margin = 1e-9
    projector = GeomAPI_ProjectPointOnSurf()
    gaps = []
    for point in np.asarray(grid, dtype=float).reshape(-1, 3):
        projector.Init(gp_Pnt(*point), surface)
        if projector.NbPoints() == 0:
            continue
        u, v = projector.LowerDistanceParameters()
        if u0 + margin < u < u1 - margin and v0 + margin < v < v1 - margin:
            gaps.append(projector.LowerDistance())
    return float(max(gaps, default=0.0))


def side_rows(grid: np.ndarray) -> list[np.ndarray]:
    """The four boundary rows of a (k, k, ...) grid, side ``s`` from corner ``s`` to ``s + 1``."""
    return [grid[:, 0], grid[-1, :], grid[::-1, -1], grid[0, ::-1]]


def coons(sides: list[np.ndarray], s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(len(s), len(t), 2) float: bilinearly blended Coons patch of four boundary polylines.

    sides : four (k, 2) float arrays in side order (side ``i`` from corner ``i`` to ``i + 1``),
        sampled at uniform fractions; ``s`` runs along side 0, ``t`` along side 3 reversed.
    """
    k = len(sides[0])
    grid = np.linspace(0, 1, k)

    def at(curve: np.ndarray, x: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(x, grid, curve[:, 0]), np.interp(x, grid, curve[:, 1])], 1)

    bottom, top = at(sides[0], s), at(sides[2][::-1], s)
    left, right = at(sides[3][::-1], t), at(sides[1], t)
    c00, c10, c11, c01 = sides[0][0], sides[1][0], sides[2][0], sides[3][0]
    S, T = s[:, None, None], t[None, :, None]
    return (
        (1 - S) * left[None]
        + S * right[None]
        + (1 - T) * bottom[:, None]
        + T * top[:, None]
        - ((1 - S) * (1 - T) * c00 + S * (1 - T) * c10 + S * T * c11 + (1 - S) * T * c01)
    )


def continued(surface, uv: np.ndarray, order: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, dS/du and dS/dv, each (n, 3) float, of ``surface`` (over the unit square)
    continued beyond it: at ``uv (n, 2)`` outside, the Taylor expansion of ``order`` 2 (or 1:
    the tangent plane) at the nearest point of the square; inside, the surface itself. The
    derivatives are those of the continuation (along an edge the nearest point moves with the
    parameter, which brings in a derivative of one order more: without it the corner Newton
    only crept to its root)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    nearest = np.clip(uv, 0.0, 1.0)
    s, du, dv, duu, dvv, duv, _, _, duuv, duvv = occ.surface_third_derivatives(surface, nearest)
    a, b = (uv - nearest)[:, :1], (uv - nearest)[:, 1:]
    u_inside, v_inside = (a == 0.0), (b == 0.0)
    if order == 1:
        point = s + du * a + dv * b
        return point, du + u_inside * duv * b, dv + v_inside * duv * a
    point = s + du * a + dv * b + 0.5 * (duu * a**2 + 2 * duv * a * b + dvv * b**2)
    d_u = du + duu * a + duv * b + u_inside * 0.5 * duvv * b**2
    d_v = dv + duv * a + dvv * b + v_inside * 0.5 * duuv * a**2
    return point, d_u, d_v


def _onto_plane(
    surface, uv: np.ndarray, across: int, plane: np.ndarray, what: str, side: int, order: int
) -> np.ndarray:
    """Move each parameter pair along ``across`` until the surface point lies in the plane.

    The stations at the samples (every ``REFIT_DENSITY``-th) must reach it; one between them
    may find no root where the interpolant ripples between samples and the plane only grazes
    the ripple (0.47 mm short of it at a saddle's corner): it takes its parameter from its
    neighbours, as the edge did before the stations between samples were solved at all."""
    uv = uv.copy()
    for _ in range(NEWTON_ITERATIONS):
        points, du, dv = continued(surface, uv, order)
        f = points @ plane[:3] - plane[3]
        reached = np.abs(f) < PLANE_TOLERANCE
        if reached.all():
            return uv
        slope = (du if across == 0 else dv) @ plane[:3]
        moving = ~reached & (np.abs(slope) >= 1e-9)
        uv[moving, across] -= np.clip(f[moving] / slope[moving], -0.25, 0.25)
    if reached[::REFIT_DENSITY].all():
        index = np.arange(len(uv))
        uv[~reached, across] = np.interp(index[~reached], index[reached], uv[reached, across])
        return uv
    raise _TrimFailed(
        f"{what}: the rib plane does not meet the sheet near its edge "
        "(plane nearly tangent to the sheet)",
        (side,),
    )


def _corner(
    surface, corner: int, planes: np.ndarray, trim: np.ndarray, name: str, order: int
) -> np.ndarray:
    """The corner's parameters: on the planes of the trimmed sides meeting there, on the
    untrimmed sides' boundaries otherwise."""
    uv = _CORNERS[corner].copy()
    meeting = [(corner - 1) % 4, corner]
    active = [s for s in meeting if trim[s]]
    for s in meeting:
        if not trim[s]:
            uv[_SIDES[s][1]] = _SIDES[s][2]
    if not active:
        return uv
    free = [_SIDES[s][1] for s in active]

    def off_planes(at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        point, du, dv = continued(surface, at[None], order)
        f = np.array([point[0] @ planes[s][:3] - planes[s][3] for s in active])
        jac = np.array(
            [[(du[0] if axis == 0 else dv[0]) @ planes[s][:3] for axis in free] for s in active]
        )
        return f, jac

    f, jac = off_planes(uv)
    for _ in range(NEWTON_ITERATIONS):
        if np.abs(f).max() < PLANE_TOLERANCE:
            return uv
        try:
            step = np.clip(np.linalg.solve(jac, f), -0.25, 0.25)
        except np.linalg.LinAlgError:
            break
        # damped: a full step that leaves the corner farther off its planes is halved until
        # it does not (near a bottom face's corner, offset along the normals, the undamped
        # steps swung to and fro about the root, 1-10 mm off, and the side went untrimmed)
        for _ in range(CORNER_HALVINGS):
            trial = uv.copy()
            trial[free] -= step
            f_trial, jac_trial = off_planes(trial)
            if np.linalg.norm(f_trial) < np.linalg.norm(f):
                break
            step = step / 2
        else:
            break
        uv, f, jac = trial, f_trial, jac_trial
    raise _TrimFailed(
        f"{name}: corner {corner} could not be placed on its rib planes", tuple(active)
    )


def side_curve(surface, side: int, n: int) -> np.ndarray:
    """(n, 3) float: the boundary iso-curve of side ``side`` of a surface fitted to a panel grid,
    from corner ``side`` to corner ``side + 1``."""
    return occ.surface_points(surface, *_side_uv(side, n))


def _side_uv(side: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    return {
        0: (t, np.zeros(n)),
        1: (np.ones(n), t),
        2: (1 - t, np.ones(n)),
        3: (np.zeros(n), 1 - t),
    }[side]
