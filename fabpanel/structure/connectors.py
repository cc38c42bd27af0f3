"""The bolted joints in the shell model: springs between the back-to-back ribs at the bolts, and
every bolt's forces checked against EN 1993-1-8.

**Model.** With ``[structure] joints = "bolted"`` each panel's ribs are their own shells on
their own mid-planes and its sheets stop there (:mod:`.mesh`): the two panels of a joint share
no node. They are joined at the rib's element corners ("stations", ``n + 1`` per side) by
``SPRING2`` elements in the joint's frame: direction 1 along the bolt axis (the rib plane's
normal), 2 along the rib line, 3 across it in the rib plane. At each station the shear springs
(2, 3) join the mid-depth nodes; the axial stiffness is split in halves at the two sheet-level
nodes. So the joint has the bolt's axial stiffness in tension, and in bending about the rib
line the bolt row's about the compressed sheet, where the ribs bear on each other
(``k_10 (h/2)^2``); axial springs at mid-depth alone made every joint a hinge (a vault at one
element per side buckled at 0.86). Each bolt's stiffness is shared between the two stations
either side of it in proportion to its distance from them (linear interpolation along the
side), so a station carries the bolts near it. The bolts are the built
ribs' holes (their positions after any move for the tool); a panel not built takes its
neighbour's rib, a joint with neither the job's spacing.

**Stiffness** (per bolt, EN 1993-1-8 Table 6.11, N/mm = E k):

- shear (directions 2 and 3): the bolt in shear, ``E k_11 = 16 d^2 f_ub / d_M16``, in series
  with bearing in each of the two ribs, ``E k_12 = 24 k_b k_t d f_u`` with
  ``k_t = min(1.5 t / d_M16, 2.5)`` and ``k_b = 1.25`` (its upper bound: end and pitch
  distances at least 3 d); 34.2 kN/mm for M12 8.8 in two 8 mm S235 ribs;
- axial (direction 1): the bolt in tension, ``E k_10 = 1.6 E A_s / L_b``, ``L_b`` the grip
  (two ribs, the erection gap, two washers) plus half the head and half the nut. Compression
  across the joint is carried by the ribs' contact, far stiffer; taking the bolt's value both
  ways makes the joint softer in bending than it is: on the safe side for deflection and
  buckling (``notes/eurocode.md`` §5).

The clearance slip of a snug-tight bolt in a normal hole (up to ``d_0 - d``) is not modelled;
the report says so.

**Forces.** CalculiX prints no spring forces, but it prints each spring element's internal
energy ``E = F^2 / 2k``: the magnitude of a station's force is ``sqrt(2 k E)``, its sign that of
the stations' relative displacement (printed too). A bolt's force is the interpolated relative
displacement times its stiffness; its tension, with the ribs bearing at the compressed sheet,
``N + |M| / (h/2) = 2 max(F_top, F_bottom)`` of the two sheet-level axial forces.

**Checks** (EN 1993-1-8 Table 3.4, category A bearing type and D tension, not preloaded), per
bolt and ULS combination: shear ``F_v,Rd = alpha_v f_ub A_s / gamma_M2`` (shear plane through
the thread), bearing in the thinner rib ``F_b,Rd = k_1 alpha_b f_u d t / gamma_M2`` (inner
bolt values, ``k_1 = 2.5`` as the rib is wide against the bolt, ``alpha_b`` from the pitch),
capped at ``1.5 f_u d t / gamma_M2`` for a single-lap joint with one bolt row (§3.6.1 (10)),
tension ``F_t,Rd = 0.9 f_ub A_s / gamma_M2``, and shear with tension
``F_v/F_v,Rd + F_t/(1.4 F_t,Rd) <= 1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..fasteners import BoltSize
from ..model.joints import bolt_stations
from .mesh import ShellModel, Springs

#: EN 1993-1-8 Table 6.11's reference diameter, mm
D_M16 = 16.0
#: bearing coefficient k_b at its upper bound (end and pitch distances >= 3 d... see docstring)
K_B = 1.25
GAMMA_M2 = 1.25
#: EN ISO 898-1 / EN 1993-1-8 Table 3.1: (f_yb, f_ub) MPa
BOLT_GRADES = {
    "4.6": (240.0, 400.0),
    "5.6": (300.0, 500.0),
    "8.8": (640.0, 800.0),
    "10.9": (900.0, 1000.0),
}
#: Table 3.4: alpha_v for a shear plane through the thread
ALPHA_V = {"4.6": 0.6, "5.6": 0.6, "8.8": 0.6, "10.9": 0.5}
#: tensile stress area A_s, mm2 (ISO 898-1)
STRESS_AREA = {8: 36.6, 10: 58.0, 12: 84.3, 14: 115.0, 16: 157.0, 20: 245.0, 22: 303.0, 24: 353.0}


@dataclass(frozen=True)
class BoltDesign:
    """One joint bolt's size, grade, the plates it clamps and what follows: stiffness (N/mm)
    and resistances (N)."""

    bolt: BoltSize
    grade: str
    t_rib: float
    gap: float
    fu_plate: float
    E: float

    @property
    def stress_area(self) -> float:
        return STRESS_AREA.get(round(self.bolt.d), 0.78 * np.pi * self.bolt.d**2 / 4)

    @property
    def fub(self) -> float:
        return BOLT_GRADES[self.grade][1]

    @property
    def shear_stiffness(self) -> float:
        d = self.bolt.d
        k11 = 16 * d**2 * self.fub / D_M16
        k_t = min(1.5 * self.t_rib / D_M16, 2.5)
        k12 = 24 * K_B * k_t * d * self.fu_plate
        return 1.0 / (1.0 / k11 + 2.0 / k12)

    @property
    def axial_stiffness(self) -> float:
        b = self.bolt
        grip = 2 * self.t_rib + self.gap + 2 * b.washer
        length = grip + (b.head_height + b.nut_height) / 2
        return 1.6 * self.E * self.stress_area / length

    @property
    def shear_resistance(self) -> float:
        return ALPHA_V[self.grade] * self.fub * self.stress_area / GAMMA_M2

    @property
    def tension_resistance(self) -> float:
        return 0.9 * self.fub * self.stress_area / GAMMA_M2

    def bearing_resistance(self, pitch: float, end: float = np.inf) -> float:
        """In the thinner rib (both are ``t_rib``), with bolts ``pitch`` mm apart and the bolt
        ``end`` mm from the nearer end of its rib, for a shear of any direction in the rib's
        plane: the smaller of the two directions' Table 3.4 values.

        - along the rib: ``alpha_d`` is ``p1 / (3 d0) - 1/4`` between bolts and
          ``e1 / (3 d0)`` towards the rib's end, the smaller of the two (the load may push
          either way); ``k_1 = 2.5``, the rib's edges across being its welds to the sheets;
        - across the rib: ``alpha_d`` is not limiting (the bolt bears towards a sheet the rib
          is welded to), ``k_1 = min(2.8 e2 / d0 - 1.7, 2.5)`` with ``e2`` the end distance.

        Each capped at ``1.5 f_u d t / gamma_M2`` (one bolt row in a single lap)."""
        d0 = self.bolt.hole
        base = self.fu_plate * self.bolt.d * self.t_rib / GAMMA_M2
        alpha_d = min(pitch / (3 * d0) - 0.25, end / (3 * d0))
        along = 2.5 * min(alpha_d, self.fub / self.fu_plate, 1.0)
        across = max(min(2.8 * end / d0 - 1.7, 2.5), 0.0) * min(self.fub / self.fu_plate, 1.0)
        return min(along, across, 1.5) * base


def bolt_design(job) -> BoltDesign:
    """The joint bolt of the job: the largest standard bolt its hole takes."""
    from ..buildup import Buildup
    from ..fasteners import bolt_for_hole

    bu, bolts = Buildup.of(job), job.sandwich.bolts
    bolt = bolt_for_hole(float(bolts.diameter))
    if bolt is None:
        raise InputError(
            f"[sandwich.bolts] diameter = {float(bolts.diameter):g} mm takes no standard bolt "
            "(M8 needs a 9 mm hole); make it larger"
        )
    return BoltDesign(
        bolt=bolt,
        grade=bolts.grade,
        t_rib=bu.t_rib,
        gap=bu.welds.erection_gap,
        fu_plate=float(job.material.fu),
        E=float(job.material.E),
    )


def attach(shell: ShellModel, model, job) -> tuple[ShellModel, JointBolts | None]:
    """The shell model with its joints' springs when ``[structure] joints = "bolted"`` (and
    the bolts they stand for), unchanged otherwise."""
    if shell.rib_stations is None or job.structure.joints != "bolted":
        return shell, None
    bolts = job.sandwich.bolts
    springs, joint = joint_springs(
        shell,
        model.developed,
        model.parts,
        bolt_design(job),
        float(bolts.spacing),
        float(bolts.edge_distance),
    )
    return shell.replace(springs=springs), joint


@dataclass(frozen=True)
class JointBolts:
    """The bolts of the model's joints and the springs they are shared between.

    names : (b,) str, ``P012-RIB-1 bolt 2`` (the lower-numbered panel's rib).
    points : (b, 3) float, mm.
    stations : (b, 2, 3) int, the springs (rows of ``Springs``) at the two stations either
        side of each bolt: at the top sheet, at mid-depth, at the bottom sheet (-1: none).
    weights : (b, 2) float, each bolt's share of the two stations (summing to 1).
    pitch : (b,) float, mm, distance to the nearest other bolt of its joint (its side's
        length for a lone bolt).
    end : (b,) float, mm, distance along the rib to its nearer end (the model's rib line).
    """

    names: tuple[str, ...]
    points: np.ndarray
    stations: np.ndarray
    weights: np.ndarray
    pitch: np.ndarray
    end: np.ndarray


class _SpringList:
    """Springs gathered joint by joint: per station, the bolt axis at the two sheets (half the
    axial stiffness each: the joint's bending, see the module docstring) and shear at
    mid-depth."""

    def __init__(self, design: BoltDesign) -> None:
        self.design = design
        self.pairs: list[tuple[int, int]] = []
        self.frames: list[np.ndarray] = []
        self.stiffness: list[tuple[float, float, float]] = []

    def add_joint(
        self,
        mine: np.ndarray,
        theirs: np.ndarray,
        line: np.ndarray,
        axis: np.ndarray,
        shares: np.ndarray,
    ) -> np.ndarray:
        """Springs between the stations ``mine`` and ``theirs`` ((n + 1, 3) nodes: top, mid,
        bottom; ``line`` the mid nodes' points) carrying ``shares (n + 1,)`` bolts each, the
        bolt ``axis`` the rib plane's normal; returns their rows, (n + 1, 3)."""
        rows = np.full(mine.shape, -1)
        axial, shear = self.design.axial_stiffness, self.design.shear_stiffness
        last = len(line) - 1
        for j in (int(i) for i in np.flatnonzero(shares > 0)):
            tangent = line[min(j + 1, last)] - line[max(j - 1, 0)]
            tangent = tangent - (tangent @ axis) * axis
            tangent /= np.linalg.norm(tangent)
            frame = np.stack([axis, tangent, np.cross(axis, tangent)])
            k = shares[j]
            for level, stiffness in (
                (0, (k * axial / 2, 0.0, 0.0)),
                (1, (0.0, k * shear, k * shear)),
                (2, (k * axial / 2, 0.0, 0.0)),
            ):
                rows[j, level] = len(self.pairs)
                self.pairs.append((int(mine[j, level]), int(theirs[j, level])))
                self.frames.append(frame)
                self.stiffness.append(stiffness)
        return rows

    def springs(self) -> Springs:
        return Springs(
            nodes=np.asarray(self.pairs, int).reshape(-1, 2),
            frames=np.asarray(self.frames, float).reshape(-1, 3, 3),
            stiffness=np.asarray(self.stiffness, float).reshape(-1, 3),
        )


def joint_springs(
    shell: ShellModel, developed, parts, design: BoltDesign, spacing: float, edge: float
) -> tuple[Springs, JointBolts]:
    """The springs joining each joint's two ribs at their stations and the bolts they stand
    for (see the module docstring). ``spacing`` and ``edge`` (mm): the job's bolt spacing and
    corner distance, for a joint neither of whose panels was built."""
    assert shell.rib_stations is not None
    stations = shell.rib_stations
    neighbours = np.asarray(developed.layout.side_neighbours)
    planes = np.asarray(developed.side_planes, float)
    holes = _rib_holes(parts)
    ids = list(developed.panel_ids)
    gathered = _SpringList(design)
    names: list[str] = []
    points, rows, weights, pitches, ends = [], [], [], [], []
    for p, s in zip(*np.nonzero(neighbours >= 0), strict=True):
        q = int(neighbours[p, s])
        if q < p:
            continue
        mine = stations[p, s]
        t = _matching_side(neighbours, q, p, s, stations[..., 1], shell.nodes)
        line = shell.nodes[mine[:, 1]]
        along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))]
        bolts = _bolts_of_joint(holes, ids[p], s, ids[q], t, line, along, spacing, edge)
        position = _arc_position(line, along, bolts)
        lower = np.clip(np.searchsorted(along, position, side="right") - 1, 0, len(along) - 2)
        share = (position - along[lower]) / (along[lower + 1] - along[lower])
        w = np.stack([1.0 - share, share], axis=1)
        per_station = np.zeros(len(mine))
        np.add.at(per_station, lower, w[:, 0])
        np.add.at(per_station, lower + 1, w[:, 1])
        axis = planes[p, s, :3] / np.linalg.norm(planes[p, s, :3])
        row_of = gathered.add_joint(mine, stations[q, t][::-1], line, axis, per_station)
        names += [f"{ids[p]}-RIB-{s} bolt {b}" for b in range(len(position))]
        points.append(bolts)
        rows.append(np.stack([row_of[lower], row_of[lower + 1]], axis=1))
        weights.append(w)
        pitches.append(_nearest_other(position, float(along[-1])))
        ends.append(np.minimum(position, along[-1] - position))
    joint = JointBolts(
        names=tuple(names),
        points=np.concatenate(points) if points else np.zeros((0, 3)),
        stations=np.concatenate(rows) if rows else np.zeros((0, 2, 3), int),
        weights=np.concatenate(weights) if weights else np.zeros((0, 2)),
        pitch=np.concatenate(pitches) if pitches else np.zeros(0),
        end=np.concatenate(ends) if ends else np.zeros(0),
    )
    return gathered.springs(), joint


def _nearest_other(position: np.ndarray, length: float) -> np.ndarray:
    """(b,) float: each bolt's distance to the nearest other along its side (the side's
    ``length`` for a lone bolt)."""
    near = np.full(len(position), length)
    if len(position) > 1:
        order = np.argsort(position)
        gaps = np.diff(position[order])
        near[order] = np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf])
    return near


def _matching_side(neighbours, q: int, p: int, s: int, stations, nodes) -> int:
    """The side of panel ``q`` that faces side ``s`` of panel ``p`` (the nearest rib)."""
    candidates = np.flatnonzero(neighbours[q] == p)
    if len(candidates) == 1:
        return int(candidates[0])
    mid = nodes[stations[p, s]].mean(axis=0)
    gaps = [np.linalg.norm(nodes[stations[q, t]].mean(axis=0) - mid) for t in candidates]
    return int(candidates[int(np.argmin(gaps))])


def _rib_holes(parts) -> dict[str, np.ndarray]:
    """Rib part id -> its bolt holes' centres in the world, (h, 3) mm."""
    out = {}
    for part in parts:
        if part.kind != "rib" or not part.holes or part.frame is None:
            continue
        flat = np.array([(*h.centre, 0.0, 1.0) for h in part.holes if h.purpose == "bolt"])
        if len(flat):
            out[part.id] = (flat @ np.asarray(part.frame, float).T)[:, :3]
    return out


def _bolts_of_joint(holes, pid, s, qid, t, line, along, spacing, edge) -> np.ndarray:
    """(b, 3) float: the joint's bolts, from the lower-numbered panel's built rib, else its
    neighbour's, else the job's spacing along the stations' line."""
    for rib in (f"{pid}-RIB-{s}", f"{qid}-RIB-{t}"):
        if rib in holes:
            return holes[rib]
    at = bolt_stations(float(along[-1]), spacing, edge)
    return np.stack([np.interp(at, along, line[:, i]) for i in range(3)], axis=1)


def _arc_position(line: np.ndarray, along: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(b,) float: where each point falls along the polyline ``line`` (arc length, mm)."""
    a, b = line[:-1], line[1:]
    seg = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-12)
    t = np.clip(np.einsum("bij,ij->bi", points[:, None] - a[None], seg) / length2, 0.0, 1.0)
    foot = a[None] + t[..., None] * seg[None]
    best = np.argmin(np.linalg.norm(points[:, None] - foot, axis=2), axis=1)
    pick = np.arange(len(points))
    return along[best] + t[pick, best] * np.sqrt(length2[best])


def station_forces(springs: Springs, energy: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """(c, 3) float, N: each station's spring forces along its local directions (the relative
    displacement's sign), from the springs' internal energies ``energy (c, 3)`` (N mm) and the nodes' relative displacement
    ``relative (c, 3)`` (second node minus first, world, mm) for the sign."""
    magnitude = np.sqrt(2.0 * springs.stiffness * np.maximum(energy, 0.0))
    local = np.einsum("cij,cj->ci", springs.frames, relative)
    return np.where(local < 0, -magnitude, magnitude)


def bolt_forces(
    springs: Springs, bolts: JointBolts, forces: np.ndarray, design: BoltDesign
) -> np.ndarray:
    """(b, 3) float, N: each bolt's force from the stations' spring ``forces (c, 3)``: along
    its axis (positive: tension), along the rib and across it (shear). Each is the bolt's
    interpolated relative displacement times its stiffness; the tension is that of a bolt
    row with the ribs bearing on each other at the compressed sheet, ``N + |M| / (h / 2)``,
    which is twice the larger of the two sheet-level axial forces."""
    k = springs.stiffness
    slip = np.divide(forces, k, out=np.zeros_like(forces), where=k > 0)  # (c, 3) mm

    def at_bolt(level: int, direction: int) -> np.ndarray:
        rows = bolts.stations[:, :, level]
        valid = rows >= 0
        return (slip[np.maximum(rows, 0), direction] * valid * bolts.weights).sum(axis=1)

    half = design.axial_stiffness / 2
    axial = 2 * np.maximum(at_bolt(0, 0) * half, at_bolt(2, 0) * half)
    shear = design.shear_stiffness
    return np.stack([axial, at_bolt(1, 1) * shear, at_bolt(1, 2) * shear], axis=1)
