"""The coarse quad layout of a planar domain: the skeleton method's result, densification's input.

Vertices are identified by id through every step (never by rounded coordinates: the public
implementation of the skeleton method crashes on exactly that, see shared/notes/quadmesh.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class CoarseLayout:
    """A coarse quad decomposition of a planar domain with holes, in the projection plane (mm).

    vertices : (n, 2) float
        coarse vertices in plane coordinates.
    quads : (m, 4) int
        counter-clockwise in the plane (positive signed area), four distinct vertex ids each.
    edge_curves : dict[(int, int), (k, 2) float]
        the geometry of every coarse edge, keyed by the sorted vertex pair ``(a, b)`` with
        ``a < b``; the polyline runs from vertex ``a`` to vertex ``b`` (first and last points equal
        to those vertices). Boundary edges follow the domain boundary; interior edges follow the
        skeleton branches (or are straight).
    loop_of_vertex : (n,) int
        index of the boundary loop a vertex lies on (0 = outer boundary, 1.. = openings), -1 for
        interior vertices.
    corner : (n,) bool
        boundary vertices that are corners of the domain (kept in place by relaxation).
    singular : (s,) int
        ids of the interior vertices whose valence is not 4 (the singular points).
    loops : tuple of (k, 2) float
        the domain's boundary loops as sampled (outer counter-clockwise, holes clockwise).
    info : dict
        what the decomposition did (branch counts, corrections applied), JSON-ready.
    """

    vertices: np.ndarray
    quads: np.ndarray
    edge_curves: dict
    loop_of_vertex: np.ndarray
    corner: np.ndarray
    singular: np.ndarray
    loops: tuple[np.ndarray, ...] = ()
    info: dict = field(default_factory=dict)

    def edge_curve(self, a: int, b: int) -> np.ndarray:
        """(k, 2) polyline of the coarse edge from vertex ``a`` to vertex ``b``."""
        if a < b:
            return self.edge_curves[(a, b)]
        return self.edge_curves[(b, a)][::-1]
