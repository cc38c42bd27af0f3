"""The bolts of the assembly, found from the ribs' holes, and the bolt set each one needs.

Back-to-back ribs of a joint hold coaxial holes: the two holes of one bolt are a pair across
the joint's two ribs (found from the panels' neighbours), ``t_rib + gap`` apart along the axis
(plate mid-planes), far closer than two bolts of one rib (at least 2.2 d0 apart, EN 1993-1-8
Table 3.3). A hole on a boundary rib takes an anchor bolt whose length the foundation design
sets, so it is counted but not sized here. A hole on an interior rib without a partner (a joint
the build flagged as mismatched) takes no bolt: the documents list it so the joint is fixed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fasteners import BoltSize, bolt_for_hole
from .source import DocSource

#: EN ISO 4017 preferred lengths of hexagon head screws, mm (the bolt is fully threaded, so a
#: shear plane may cross the thread: the joint check takes the tensile stress area As)
ISO_4017_LENGTHS = (
    16,
    20,
    25,
    30,
    35,
    40,
    45,
    50,
    55,
    60,
    65,
    70,
    80,
    90,
    100,
    110,
    120,
    130,
    140,
    150,
) + tuple(range(160, 201, 20))
#: nut property class for each bolt grade (EN ISO 898-2; EN 1090-2 Table 16)
NUT_CLASS = {"4.6": "5", "5.6": "5", "8.8": "8", "10.9": "10"}
#: washer hardness for each bolt grade (EN ISO 7089: 200 HV up to 8.8, 300 HV for 10.9)
WASHER_CLASS = {"4.6": "200 HV", "5.6": "200 HV", "8.8": "200 HV", "10.9": "300 HV"}


@dataclass(frozen=True)
class Bolts:
    """Joint bolts: centre (n, 3) between the two ribs, unit axis (n, 3), hole diameter (n,),
    the two rib ids of each; ``anchor_holes``: holes on boundary ribs (no neighbour);
    ``unmatched``: for each interior-rib hole without a partner in the neighbour's rib (a joint
    the build flagged, or whose neighbour was not built), the id of its rib."""

    centres: np.ndarray
    axes: np.ndarray
    diameters: np.ndarray
    ribs: tuple[tuple[str, str], ...]
    anchor_holes: int
    unmatched: tuple[str, ...] = ()


@dataclass(frozen=True)
class BoltSet:
    """What one joint bolt needs: the screw, its grip and length, the nut, two washers."""

    bolt: BoltSize
    grade: str
    grip: float
    length: int

    @property
    def screw(self) -> str:
        return f"{self.bolt.name} x {self.length}"


def joint_bolts(source: DocSource) -> Bolts:
    """Pair the holes of each joint's two ribs (module docstring): the ribs are found from the
    panels' neighbours, so a hole is only ever paired with one in the rib it bolts to."""
    ribs = {p.id: p for p in source.parts if p.kind == "rib" and len(p.bolt_diameters)}
    reach = _pair_distance(source) + 1.0
    centres, axes, diameters, pairs = [], [], [], []
    anchors, unmatched = 0, []
    for panel in source.panels:
        for side, neighbour in enumerate(panel.neighbours):
            rib = ribs.get(f"{panel.id}-RIB-{side}")
            if rib is None:
                continue
            if neighbour is None:
                anchors += len(rib.bolt_diameters)
                continue
            partner = ribs.get(_partner_rib(source, panel.id, neighbour) or "")
            if partner is None:
                unmatched += [rib.id] * len(rib.bolt_diameters)
                continue
            if rib.id > partner.id:
                continue  # each joint once, from the rib with the smaller id
            a, b = _pair_holes(rib.bolt_centres, partner.bolt_centres, reach)
            centres.append((rib.bolt_centres[a] + partner.bolt_centres[b]) / 2.0)
            axes.append(rib.bolt_axes[a])
            diameters.append(np.maximum(rib.bolt_diameters[a], partner.bolt_diameters[b]))
            pairs += [(rib.id, partner.id)] * len(a)
            unmatched += [rib.id] * (len(rib.bolt_diameters) - len(a))
            unmatched += [partner.id] * (len(partner.bolt_diameters) - len(b))
    return Bolts(
        centres=np.concatenate(centres) if centres else np.zeros((0, 3)),
        axes=np.concatenate(axes) if axes else np.zeros((0, 3)),
        diameters=np.concatenate(diameters) if diameters else np.zeros(0),
        ribs=tuple(pairs),
        anchor_holes=anchors,
        unmatched=tuple(unmatched),
    )


def _partner_rib(source: DocSource, panel: str, neighbour: str) -> str | None:
    """The id of the rib of ``neighbour`` that lies against ``panel``."""
    other = next((p for p in source.panels if p.id == neighbour), None)
    if other is None or panel not in other.neighbours:
        return None
    return f"{neighbour}-RIB-{other.neighbours.index(panel)}"


def _pair_holes(a: np.ndarray, b: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the holes of ``a (n, 3)`` and ``b (m, 3)`` that are one bolt: the closest
    one-to-one assignment, kept where the two centres are within ``reach`` mm."""
    from scipy.optimize import linear_sum_assignment

    distance = np.linalg.norm(a[:, None] - b[None], axis=2)
    rows, cols = linear_sum_assignment(distance)
    keep = distance[rows, cols] <= reach
    return rows[keep], cols[keep]


def _pair_distance(source: DocSource) -> float:
    """Distance between the mid-planes of two back-to-back ribs, mm."""
    from ..buildup import Buildup

    buildup = Buildup.of(source.job)
    return buildup.t_rib + buildup.welds.erection_gap


def bolt_set(source: DocSource, hole: float) -> BoltSet | None:
    """The bolt set for a joint hole of ``hole`` mm: grip two ribs and the packing of the
    erection gap; length = grip + two washers + nut + the protrusion EN 1090-2 §8.2.2 asks
    (here two pitches), rounded up to an EN ISO 4017 length (None: no standard bolt fits)."""
    from ..buildup import Buildup

    bolt = bolt_for_hole(hole)
    if bolt is None:
        return None
    buildup = Buildup.of(source.job)
    grip = 2.0 * buildup.t_rib + buildup.welds.erection_gap
    needed = grip + 2.0 * bolt.washer + bolt.nut_height + bolt.protrusion
    length = next((n for n in ISO_4017_LENGTHS if n >= needed - 1e-9), math.ceil(needed / 10) * 10)
    return BoltSet(bolt, source.job.sandwich.bolts.grade, grip, int(length))
