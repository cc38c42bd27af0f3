"""The bolts of the assembly, found from the ribs' holes, and the bolt set each one needs.

Back-to-back ribs of a joint hold coaxial holes: the two holes of one bolt are the nearest
pair across two parts, ``2 t_rib + gap`` apart along the axis (plate mid-planes), far closer
than two bolts of one rib (at least 2.2 d0 apart, EN 1993-1-8 Table 3.3). A hole without a
partner sits on a boundary rib: it takes an anchor bolt whose length the foundation design sets,
so it is counted but not sized here.
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
    the two rib ids of each; ``anchor_holes``: holes without a partner (boundary ribs)."""

    centres: np.ndarray
    axes: np.ndarray
    diameters: np.ndarray
    ribs: tuple[tuple[str, str], ...]
    anchor_holes: int


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
    """Pair every rib bolt hole with its partner in the neighbouring rib (module docstring)."""
    from scipy.spatial import cKDTree

    holes = [
        (part.id, c, a, d)
        for part in source.parts
        for c, a, d in zip(part.bolt_centres, part.bolt_axes, part.bolt_diameters)
    ]
    if not holes:
        return Bolts(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), (), 0)
    owner = [h[0] for h in holes]
    centres = np.array([h[1] for h in holes])
    axes = np.array([h[2] for h in holes])
    diameters = np.array([h[3] for h in holes])
    reach = _pair_distance(source) + 1.0
    distance, nearest = cKDTree(centres).query(centres, k=min(3, len(centres)))
    distance, nearest = np.atleast_2d(distance), np.atleast_2d(nearest)
    pairs: list[tuple[int, int]] = []
    for i in range(len(centres)):
        for d, j in zip(distance[i, 1:], nearest[i, 1:]):
            # each pair once; the partner is another part's hole, mutually nearest
            if d <= reach and owner[j] != owner[i] and i < j and nearest[j, 1] == i:
                pairs.append((i, int(j)))
                break
    paired = {k for pair in pairs for k in pair}
    a, b = (np.array([p[k] for p in pairs], dtype=int) for k in (0, 1))
    return Bolts(
        centres=(centres[a] + centres[b]) / 2.0 if pairs else np.zeros((0, 3)),
        axes=axes[a] if pairs else np.zeros((0, 3)),
        diameters=np.maximum(diameters[a], diameters[b]) if pairs else np.zeros(0),
        ribs=tuple((owner[i], owner[j]) for i, j in pairs),
        anchor_holes=len(centres) - len(paired),
    )


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
