"""Classic shell benchmarks run through fabpanel's own model building (``patch_model``,
``area_forces``/``edge_forces``, ``write_deck``) and CalculiX: they validate the element, the
load integration, the deck and the result reading together. References: MacNeal & Harder, "A
proposed standard set of problems to test finite element accuracy" (1985); Timoshenko &
Woinowsky-Krieger, "Theory of plates and shells" (1959), k = 4 for a square plate; Fung &
Kaplan, "Buckling of low arches or curved beams of small curvature", NACA TN 2840 (1952), and
Timoshenko & Gere, "Theory of elastic stability" (1961), for the shallow arch's snap-through.

Each function writes its deck into ``folder`` and returns ``{"value", "reference", "error",
"elements", "seconds"}`` plus what the tests pin.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .ccx import LoadCase, read_dat, read_frd, run_ccx, surface_nodes, write_deck
from .loads import area_forces, edge_forces
from .mesh import Material, ShellModel, patch_model

#: Scordelis-Lo roof: vertical deflection at the free-edge midpoint, 0.3024 ft in mm
SCORDELIS_LO_MM = 92.17
#: pinched hemisphere: radial displacement under the loads
PINCHED_HEMISPHERE = 0.094
#: simply supported 1000 x 1000 x 10 mm plate, E 210 GPa, nu 0.3: k = 4 critical stress, MPa
PLATE_BUCKLING_MPA = 4 * np.pi**2 * 210000.0 / (12 * (1 - 0.3**2)) * (10 / 1000) ** 2


def _solve(folder, name, model, cases=(), buckle=None, modes=5, threads=2):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    deck = write_deck(model, folder / f"{name}.inp", list(cases), buckle=buckle, modes=modes)
    run = run_ccx(deck, threads=threads)
    return run, read_dat(run.dat), read_frd(run.frd)


def mid_surface_value(frd, model, node: int, block: int = 0, name: str = "DISP") -> np.ndarray:
    """A shell node's mid-surface result: mean of its expanded bottom and top nodes."""
    element, local = (int(v[0]) for v in np.nonzero(model.quads == node))
    bottom, top = surface_nodes(frd, model.n_elements)
    values = frd.results(name)[block][2]
    return 0.5 * (values[bottom[element, local]] + values[top[element, local]])


def _result(value, reference, model, run, **extra) -> dict:
    return {
        "value": float(value),
        "reference": float(reference),
        "error": float(value / reference - 1),
        "elements": model.n_elements,
        "seconds": round(run.seconds, 2),
        **extra,
    }


def scordelis_lo(folder, n: int = 16) -> dict:
    """Full roof, n x n S8R, in mm: R 7.62 m, L 15.24 m, t 76.2 mm, E 20.684 GPa, nu 0, 4309.2 Pa
    of surface; rigid diaphragms at the ends (u_y = u_z = 0), u_x fixed at the centre."""
    radius, length, t = 7620.0, 15240.0, 76.2
    phi = np.radians(np.linspace(-40.0, 40.0, 2 * n + 1))
    x = np.linspace(-length / 2, length / 2, 2 * n + 1)
    P, X = np.meshgrid(phi, x, indexing="ij")
    grid = np.stack([X, radius * np.sin(P), radius * np.cos(P)], axis=-1)
    model, index = patch_model(grid, t, Material("SL", 2.0684e4, 0.0, 1e-9, 1.0))
    ends = np.r_[index[:, 0], index[:, -1]]
    model = model.replace(constraints=((ends[ends >= 0], (2, 3)), (np.array([index[n, n]]), (1,))))
    load = area_forces(model, 4.3092e-3, (0, 0, -1))
    run, _, frd = _solve(folder, "scordelis", model, [LoadCase("q", forces=load)])
    u = mid_surface_value(frd, model, index[0, n])
    return _result(
        -u[2],
        SCORDELIS_LO_MM,
        model,
        run,
        load_N=load.sum(axis=0).tolist(),
        area_mm2=float(radius * np.radians(80.0) * length),
    )


def pinched_hemisphere(folder, n: int = 16) -> dict:
    """Full hemisphere with an 18 degree hole, n x n S8R per quarter: R 10, t 0.04,
    E 6.825e7, nu 0.3, loads 2 outwards on x and inwards on y at the equator. Six translations
    are fixed where the double symmetry keeps them zero (no reactions)."""
    radius = 10.0
    phi = np.linspace(0.0, 2 * np.pi, 8 * n + 1)
    theta = np.radians(np.linspace(18.0, 90.0, 2 * n + 1))
    F, T = np.meshgrid(phi, theta, indexing="ij")
    grid = radius * np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], -1)
    model, index = patch_model(grid, 0.04, Material("H", 6.825e7, 0.3, 1e-9, 1.0), tolerance=1e-6)
    q = 2 * n  # grid rows at 0, 90, 180, 270 degrees
    east, north, west, south = (index[r, -1] for r in (0, q, 2 * q, 3 * q))
    model = model.replace(
        constraints=(
            (np.array([east]), (2, 3)),
            (np.array([west]), (3,)),
            (np.array([north]), (1,)),
            (np.array([index[0, 0]]), (2,)),
            (np.array([index[q, 0]]), (1,)),
        )
    )
    forces = np.zeros((len(model.nodes), 3))
    forces[[east, west, north, south]] = [[2, 0, 0], [-2, 0, 0], [0, -2, 0], [0, 2, 0]]
    run, _, frd = _solve(folder, "hemisphere", model, [LoadCase("pinch", forces=forces)])
    u_east = mid_surface_value(frd, model, east)
    u_north = mid_surface_value(frd, model, north)
    return _result(u_east[0], PINCHED_HEMISPHERE, model, run, inward_at_y=float(-u_north[1]))


def square_plate(n: int = 16, a: float = 1000.0, t: float = 10.0):
    """A flat a x a S8R plate in the xy plane: ``(model, grid index, edge nodes)``."""
    x = np.linspace(0.0, a, 2 * n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    model, index = patch_model(np.stack([X, Y, np.zeros_like(X)], axis=-1), t, Material())
    edge = np.unique(np.r_[index[0], index[-1], index[:, 0], index[:, -1]])
    return model, index, edge[edge >= 0]


def plate_buckling(folder, n: int = 16) -> dict:
    """Simply supported 1000 x 1000 x 10 mm plate (E 210 GPa, nu 0.3) under 1 MPa uniform
    compression along x (consistent edge loads): the buckling factors are the critical
    stresses in MPa."""
    model, index, edge = square_plate(n)
    model = model.replace(
        constraints=(
            (edge, (3,)),
            (index[0][index[0] >= 0], (1,)),
            (index[:, 0][index[:, 0] >= 0], (2,)),
        )
    )
    load = edge_forces(model.nodes, index[-1], (-10.0, 0.0, 0.0))  # 1 MPa x 10 mm
    run, dat, frd = _solve(
        folder, "plate", model, buckle=LoadCase("compression", forces=load), modes=5
    )
    factors = np.sort(dat.buckling[dat.buckling > 0])
    return _result(
        factors[0],
        PLATE_BUCKLING_MPA,
        model,
        run,
        factors=factors.tolist(),
        frd_factors=[v for v, _, _ in frd.results("DISP")],
        dat_factors=dat.buckling.tolist(),
        load_N=load.sum(axis=0).tolist(),
    )


def arch_limit_load(span: float, t: float, rise: float, E: float, width: float) -> float:
    """Snap-through load q0 (N per mm of span) of a shallow pinned sinusoidal arch under the
    load q0 sin(pi x / L), both ends immovable (Fung & Kaplan 1952): with the shape a sin(pi x / L)
    under load, bending and the axial force N = E A (pi/L)^2 (e^2 - a^2) / 4 balance
    q0 (L/pi)^4 / (E A) = r^2 (e - a) + a (e^2 - a^2) / 4 (r^2 = I / A), whose maximum over a is at
    a^2 = (e^2 - 4 r^2) / 3. Valid for 2 r < e < 4.69 r: a lower arch does not snap, a higher
    one bifurcates into the antisymmetric mode first."""
    r2 = t * t / 12.0
    if not 4.0 * r2 < rise * rise < 22.0 * r2:
        raise ValueError(f"rise {rise} is outside the symmetric snap-through range for t = {t}")
    a = math.sqrt((rise * rise - 4.0 * r2) / 3.0)
    area = width * t
    return (np.pi / span) ** 4 * E * area * (r2 * (rise - a) + a * (rise * rise - a * a) / 4.0)


def shallow_arch(folder, n: int = 24) -> dict:
    """A flat strip 1000 x 40 x 10 mm (E 210 GPa, nu 0: a beam) given a half-sine imperfection
    of 3.5 radii of gyration (10.1 mm) by :func:`.gnia.imperfect`, its ends pinned and
    immovable, under a half-sine load ramped with NLGEOM (:func:`.gnia.load_path`) to 1.3 x
    the analytic snap-through load (:func:`arch_limit_load`): the limit factor found against
    1.0. Exercises the whole GNIA chain: the imperfection, the NLGEOM deck, the increments and
    the limit read back."""
    from .gnia import imperfect, load_path

    span, width, t = 1000.0, 40.0, 10.0
    rise = 3.5 * t / math.sqrt(12.0)
    x = np.linspace(0.0, span, 2 * n + 1)
    y = np.linspace(0.0, width, 3)
    X, Y = np.meshgrid(x, y, indexing="ij")
    flat, index = patch_model(
        np.stack([X, Y, np.zeros_like(X)], axis=-1), t, Material("ARCH", 2.1e5, 0.0, 1e-9, 1.0)
    )
    ends = np.r_[index[0], index[-1]]
    flat = flat.replace(constraints=((ends[ends >= 0], (1, 2, 3)), (np.array([index[n, 0]]), (2,))))
    shape = np.zeros_like(flat.nodes)
    shape[:, 2] = np.sin(np.pi * flat.nodes[:, 0] / span)
    arch = imperfect(flat, shape, rise)
    q0 = arch_limit_load(span, t, rise, 2.1e5, width)
    # nodal forces of a pressure q0 sin(pi x / L) / width: the unit pressure's nodal forces
    # weighted by the sine at the node (within 0.2 % of the integrated load at 24 elements)
    weights = np.sin(np.pi * arch.nodes[:, 0] / span)[:, None]
    forces = area_forces(arch, q0 / width, (0.0, 0.0, -1.0)) * weights
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = load_path(
        arch, LoadCase("q", forces=forces), 1.3, int(index[n, 0]), folder, "arch", 2, None, None
    )
    return {
        "value": path.limit,
        "reference": 1.0,
        "error": path.limit - 1.0,
        "elements": arch.n_elements,
        "seconds": round(path.seconds, 2),
        "limit_reached": path.limit_reached,
        "increments": len(path.factors),
        "q0_N_per_mm": q0,
        "rise_mm": rise,
        "crown_drop_mm": float(path.displacement[-1]),
    }


def lap_chain_forces(
    bolts: int, pitch: float, end: float, k: float, axial: float
) -> tuple[np.ndarray, float]:
    """Hand calculation of a lap joint of ``bolts`` bolts in a row: two bars of axial
    stiffness ``axial`` (E A, N), ``pitch`` mm between bolts, each bar running ``end`` mm
    past its outer bolt to its held or loaded end, the bolts shear springs ``k`` N/mm. Unit
    load. Returns each bolt's share of the load (bolt 1 nearest plate A's held end) and the
    joint's stretch between the two ends per newton (mm/N).

    The bars' displacements at the bolts are ``a`` (plate A, held at its end) and ``b``
    (plate B, pulled at its end): nodal equilibrium of the chain, a symmetric system of
    2 n unknowns, solved as it stands (the classic Volkersen-type result for bolts: the
    end bolts carry more than the middle ones)."""
    n = bolts
    ka, kp = axial / end, axial / pitch
    stiffness = np.zeros((2 * n + 1, 2 * n + 1))  # a_1..a_n, b_1..b_n, the loaded end

    def spring(i: int, j: int | None, value: float) -> None:
        stiffness[i, i] += value
        if j is not None:
            stiffness[j, j] += value
            stiffness[i, j] -= value
            stiffness[j, i] -= value

    spring(0, None, ka)  # plate A from its held end to bolt 1
    for i in range(n - 1):
        spring(i, i + 1, kp)  # plate A between bolts
        spring(n + i, n + i + 1, kp)  # plate B between bolts
    for i in range(n):
        spring(i, n + i, k)  # the bolts
    spring(2 * n - 1, 2 * n, ka)  # plate B from bolt n to its loaded end
    load = np.zeros(2 * n + 1)
    load[-1] = 1.0
    u = np.linalg.solve(stiffness, load)
    return k * (u[n : 2 * n] - u[:n]), float(u[-1])


def joined_patches(a, b, springs, supports, constraints=()) -> ShellModel:
    """One model of two :func:`patch_model` patches ``a`` and ``b`` (b's nodes numbered after
    a's), joined only by ``springs`` (node pairs in that numbering), held at ``supports``,
    every node kept in the patches' plane (z) and ``constraints`` added: a joint in plane."""
    return ShellModel(
        nodes=np.r_[a.nodes, b.nodes],
        quads=np.r_[a.quads, b.quads + len(a.nodes)],
        triangles=np.zeros((0, 6), int),
        group=np.zeros(len(a.quads) + len(b.quads), int),
        groups=a.groups,
        material=a.material,
        supports=supports,
        constraints=((np.arange(len(a.nodes) + len(b.nodes)), (3,)), *constraints),
        springs=springs,
    )


def lap_joint(folder, bolts: int = 3, pitch: float = 60.0, step: float = 10.0) -> dict:
    """Two 8 mm S235 plates 60 mm wide lapped over ``bolts`` M12 8.8 bolts in a row
    ``pitch`` mm apart, 30 mm from the plates' ends (e1), each bolt a spring between the plates' coincident nodes with the
    stiffness of EN 1993-1-8 Table 6.11 (:class:`.connectors.BoltDesign`, as the shell model's
    joints have), plate A held at its end, plate B pulled 30 kN in plane. The bolts' forces
    read back from the springs' energies (:func:`.connectors.station_forces`, as the bolt
    checks do) against :func:`lap_chain_forces`, and the worst bolt's shear utilisation
    against F_v,Rd = 0.6 f_ub A_s / gamma_M2 = 0.6 x 800 x 84.3 / 1.25 by hand."""
    from ..fasteners import bolt_for_hole
    from .bolt_checks import case_spring_forces
    from .connectors import BoltDesign
    from .mesh import Springs

    steel = Material()
    t, width, end, load, e1 = 8.0, 60.0, 100.0, 30000.0, 30.0
    bolt = bolt_for_hole(13.0)
    assert bolt is not None  # M12 takes a 13 mm hole
    design = BoltDesign(bolt, "8.8", t_rib=t, gap=0.0, fu_plate=360.0, E=steel.E)
    span = (bolts - 1) * pitch
    ys = np.linspace(0.0, width, 5)

    def plate(x0: float, x1: float):
        xs = np.linspace(x0, x1, 2 * round((x1 - x0) / step) + 1)
        grid = np.stack([*np.meshgrid(xs, ys, indexing="ij"), np.zeros((len(xs), 5))], -1)
        model, index = patch_model(grid, t, steel)
        at_bolts = [index[np.argmin(np.abs(xs - i * pitch)), 2] for i in range(bolts)]
        return model, index, np.array(at_bolts)

    a, index_a, bolts_a = plate(-end, span + e1)
    b, index_b, bolts_b = plate(-e1, span + end)
    offset = len(a.nodes)
    shear = design.shear_stiffness
    frame = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # axis, along, across
    springs = Springs(
        np.stack([bolts_a, bolts_b + offset], 1),
        np.repeat(frame[None], bolts, 0),
        np.tile([design.axial_stiffness, shear, shear], (bolts, 1)),
    )
    # in plane: no deflection, and plate B held across at its loaded end's middle
    model = joined_patches(
        a, b, springs, index_a[0], ((np.array([index_b[-1, 2] + offset]), (2,)),)
    )
    forces = np.zeros((len(model.nodes), 3))
    forces[index_b[-1] + offset, 0] = load * np.array([1, 4, 2, 4, 1]) / 12.0  # Simpson
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    deck = write_deck(model, folder / "lap.inp", [LoadCase("pull", forces=forces)])
    run = run_ccx(deck, threads=1)
    fem = case_spring_forces(model, read_dat(run.dat))[0][:, 1]
    share, _ = lap_chain_forces(bolts, pitch, end, shear, steel.E * width * t)
    hand_resistance = 0.6 * 800.0 * 84.3 / 1.25
    worst = float(np.abs(fem).max())
    return {
        "value": worst,
        "reference": float(share.max() * load),
        "error": worst / float(share.max() * load) - 1,
        "elements": model.n_elements,
        "seconds": round(run.seconds, 2),
        "bolt_forces_N": fem.tolist(),
        "hand_forces_N": (share * load).tolist(),
        "shear_stiffness_N_per_mm": shear,
        "utilisation": worst / design.shear_resistance,
        "hand_utilisation": float(share.max() * load) / hand_resistance,
    }


def vault_snow_reactions(
    radius: float, length: float, snow: float, supports_x: tuple[float, float], lighter: float
) -> tuple[float, float, float]:
    """Hand statics of a circular barrel vault (axis along y, crown over x = 0, springings at
    x = -radius and +radius) under snow on the plan: ``snow`` (N/mm2) x mu_1 of the local
    pitch (0.8 up to 30 degrees, 0 from 60), the half x < 0 at ``lighter`` of it (1: the
    undrifted case). Two supports at ``supports_x`` (mm), their lines level and along the
    axis: the vertical reactions follow from moments about each support line (horizontal
    thrusts act at the springing level and do not enter). Returns the total load and the
    two vertical reactions, N, from one-dimensional quadrature on the arc."""
    theta = np.linspace(-np.pi / 2, np.pi / 2, 200_001)
    x = radius * np.sin(theta)
    pitch = np.degrees(np.abs(theta))
    mu = np.clip(0.8 * (60.0 - pitch) / 30.0, 0.0, 0.8)
    share = np.where(x < 0, lighter, 1.0)
    per_theta = snow * length * mu * share * radius * np.cos(theta)  # N per radian
    total = float(np.trapezoid(per_theta, theta))
    left, right = supports_x
    right_reaction = float(np.trapezoid(per_theta * (x - left), theta)) / (right - left)
    return total, total - right_reaction, right_reaction
