"""What crosses the process boundary of the build: one panel's payload in, its result out.

Both are frozen and hold only numpy arrays, numbers, strings and the frozen build-up, so they
pickle cheaply and a worker cannot change what the main process keeps. A part inside a result is
still a plain record (BREP bytes, outline, holes ...): it becomes a :class:`~fabpanel.data.Part`
in the main process, which owns the part contract.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..buildup import Buildup
from ..errors import Finding


@dataclass(frozen=True)
class PanelPayload:
    """One panel to build.

    samples, normals : (k, k, 3) float, the developed grid and its normals (mm).
    planes : (4, 4) float, the rib contact planes (unit normal into the panel, offset).
    interior : (4,) bool, sides with a neighbour (bolted).
    packs : (4,) bool, interior sides whose packing plates this panel supplies (one panel per
        joint, the one with the lower index).
    buildup : the build-up (:mod:`fabpanel.buildup`).
    slide_limit : mm a sheet edge may move along the sheet to reach its rib plane.
    fibre : the sheets' unrolled fibre (``mid``, ``outer``, ``inner``).
    stations : ``((side, stations), ...)``: bolt stations (mm along the side) that replace the
        even spacing of a side, after end bolts were moved for the tool.
    origin : (3,) float, mm: the layout's origin, so that findings can say where they are in
        the model's own coordinates (``local + origin``).
    nodes : per corner, the other rib planes at its vertex (:mod:`fabpanel.model.nodes`),
        which cut the ends of the ribs there; empty: none.
    """

    panel_id: str
    samples: np.ndarray
    normals: np.ndarray
    planes: np.ndarray
    interior: np.ndarray
    packs: np.ndarray
    buildup: Buildup
    slide_limit: float
    fibre: str
    stations: tuple[tuple[int, np.ndarray], ...] = ()
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    nodes: tuple[np.ndarray, ...] = ()

    def stations_of(self, side: int) -> np.ndarray | None:
        """The moved bolt stations of ``side``, or None (evenly spaced)."""
        return dict(self.stations).get(side)

    def with_stations(self, side: int, stations: np.ndarray) -> PanelPayload:
        """This payload with ``side``'s bolt stations replaced."""
        moved = dict(self.stations)
        moved[side] = np.asarray(stations, float)
        return dataclasses.replace(self, stations=tuple(sorted(moved.items())))


@dataclass(frozen=True)
class Failure:
    """Why a panel could not be built: the part being built, the reason, the traceback."""

    part: str
    reason: str
    traceback: str


@dataclass(frozen=True)
class PanelResult:
    """One built panel (or its failure).

    parts : part records (see :func:`fabpanel.model.panel.build_panel`).
    measures : the panel's measures (fit, slide, planarity, bolts, reach ...).
    findings : ``(code, part id, message[, severity])`` each.
    bolts : side -> (n, 3) float bolt centres on the rib contact plane.
    top_edges : (4,) of (n, 3) float, the top sheet's outer edges at the rib planes.
    failure : set when the panel was not built (then everything else is empty).
    """

    panel_id: str
    parts: tuple[dict[str, Any], ...] = ()
    measures: dict[str, Any] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    bolts: dict[int, np.ndarray] = field(default_factory=dict)
    top_edges: tuple[np.ndarray, ...] = ()
    failure: Failure | None = None

    @property
    def built(self) -> bool:
        return self.failure is None
