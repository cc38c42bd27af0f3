"""Quasi-structured quads of a flattened domain by gmsh (run as a script, in its own process).

    python gmsh_quads.py IN.npz OUT.npz

gmsh's quasi-structured quad mesher (``Mesh.Algorithm = 11``, Reberol et al. 2021) can abort the
whole process on some inputs, so :mod:`.field` runs this file as a child process; it imports
only numpy, scipy and gmsh.

IN holds the setting of QQS's topology steps (``topology``, a value of
``Mesh.QuadqsTopologyOptimizationMethods``, see :data:`.field.TOPOLOGIES`), the flattened
design surface (``flat`` (n, 2), ``faces`` (m, 3), ``scale`` (n,): flat length per surface
length), the boundary loops (``loops`` concatenated, ``loop_starts``), which
loop vertices are corners (``corners`` bool, per concatenated entry), points to embed
(``points`` (p, 2)), the fold lines to mesh along (``folds`` (f, 2) concatenated,
``fold_starts``; :mod:`fabpanel.surface.folds`), the target surface edge length ``h`` and
the surface ``area``. The size
field is ``h / k x scale`` in the flat domain; gmsh's edges come out at about ``0.46 x`` the
field (layout.md §2.3), so ``k`` starts at 0.46 and is corrected from the measured median until
the median surface edge is within 4 % of ``h``; then a few factors around it are meshed and the
mesh with the best gate score is kept.

OUT holds ``nodes`` (q, 2), ``quads`` (r, 4) 0-based, ``on_curve`` (q,) bool (nodes on the
boundary curves, not on the folds), ``factor`` (the chosen k), ``median`` (the
surface-equivalent median edge),
``score`` and ``meshes`` (how many were made); and up to ``FINER_MESHES`` meshes with more
quads (``finer_nodes``, ``finer_quads``, ``finer_on_curve`` concatenated, ``finer_node_counts``
and ``finer_quad_counts`` per mesh, ``finer_factors``, ``finer_scores``), fewest quads
first.
"""

from __future__ import annotations

import sys
import time

import gmsh
import numpy as np
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

#: first guess of the ratio final edge / size field value (layout.md §2.3, measured 0.44-0.49)
FIRST_FACTOR = 0.46
#: accept the median surface edge within this share of the target
MEDIAN_TOLERANCE = 0.04
CALIBRATION_ROUNDS = 3
#: the calibrated size factor and its neighbours, each meshed, the best kept: QQS's result
#: changes in steps with the size (one more strip round an opening), not smoothly
CANDIDATES = (1.0, 0.96, 1.04, 0.92)
#: ... only the first two on a domain of more panels than this (area / h²): there a mesh takes
#: 0.6 s, and the count changes less in steps with the size
FEWER_CANDIDATES_ABOVE = 800
#: where the calibration did not converge, factors further out round the one whose median
#: came nearest are meshed too: on a small domain (a dozen panels across) QQS's count jumps
#: with the factor (16, 74, 132, 297 quads at 0.2, 0.22, 0.3, 0.46 on an 11 m rounded square)
#: and the calibration's guesses jump about with it
FURTHER = (1.15, 1.3, 1.5, 0.85, 0.75)
#: ... on small domains only (area / h² up to this): on the pavilion (407) the calibration does
#: not converge either, down its trumpets, and five more meshes of it tripled its time
FURTHER_MAX_PANELS = 300

#: meshes with more quads than the chosen one returned beside it, fewest first: where the
#: chosen one's panels miss the plate, the next finer mesh at the same size often fits, where
#: a plate round (12 % smaller everywhere) would add a third more panels
FINER_MESHES = 2

#: the point tags that end a boundary curve (the others only guide a spline)
_END_POINTS: set[int] = set()


def _loop_curves(points: np.ndarray, corners: np.ndarray) -> list[int]:
    """gmsh OCC curves of one closed boundary loop: splines from corner to corner."""
    tags = [gmsh.model.occ.addPoint(x, y, 0.0) for x, y in points]
    split = list(np.flatnonzero(corners))
    if len(split) == 1:  # a closed spline through one kink would smooth it: split opposite too
        split.append((split[0] + len(points) // 2) % len(points))
    if not split:
        _END_POINTS.add(tags[0])
        return [gmsh.model.occ.addSpline([*tags, tags[0]])]
    split.sort()
    _END_POINTS.update(tags[i] for i in split)
    curves = []
    for start, end in zip(split, [*split[1:], split[0] + len(points)]):
        run = [tags[i % len(points)] for i in range(start, end + 1)]
        curves.append(
            gmsh.model.occ.addSpline(run) if len(run) > 2 else gmsh.model.occ.addLine(*run)
        )
    return curves


def _domain(data) -> list[int]:
    """The flat domain as OCC plane surfaces (outer loop first, openings as holes), split
    along the fold lines (``folds`` concatenated, ``fold_starts``) so that the quads of the
    faces on either side meet along them."""
    loops = np.split(data["loops"], data["loop_starts"][1:])
    corners = np.split(data["corners"], data["loop_starts"][1:])
    flat = data["flat"]
    areas = [abs(_polygon_area(flat[loop])) for loop in loops]
    order = np.argsort(areas)[::-1]
    wires = []
    for index in order:
        curves = _loop_curves(flat[loops[index]], corners[index])
        wires.append(gmsh.model.occ.addCurveLoop(curves))
    gmsh.model.occ.addPlaneSurface(wires)
    # the splines' interpolation points are free model points: meshed as lone nodes otherwise
    ends = {tag for _, tag in gmsh.model.occ.getEntities(0)} & _END_POINTS
    free = [(0, tag) for _, tag in gmsh.model.occ.getEntities(0) if tag not in ends]
    gmsh.model.occ.remove(free)
    # without healing, QQS left zero-length edges and inverted quads on trimmed faces
    # (layout.md §2.4); it is also what merges the spline ends into one vertex per corner
    gmsh.model.occ.healShapes()
    # the folds split the healed face (healing after would sew the faces back into one)
    folds = _fold_curves(data)
    if folds:
        surfaces = gmsh.model.occ.getEntities(2)
        gmsh.model.occ.fragment(surfaces, [(1, tag) for tag in folds])
        gmsh.model.occ.synchronize()
        # the folds' guiding points, and their ends where the fragment made new ones, are
        # free points now: each would be meshed as a lone node
        free = [
            (0, tag)
            for _, tag in gmsh.model.getEntities(0)
            if not len(gmsh.model.getAdjacencies(0, tag)[0])
        ]
        gmsh.model.occ.remove(free)
    gmsh.model.occ.synchronize()
    faces = [tag for _, tag in gmsh.model.getEntities(2)]
    if not folds and len(faces) != 1:
        raise RuntimeError(f"the flat domain became {len(faces)} faces when healed")
    return faces


def _fold_curves(data) -> list[int]:
    """One spline per fold line through its flat points (its ends end the curve)."""
    if "folds" not in data or not len(data["folds"]):
        return []
    curves = []
    for points in np.split(data["folds"], data["fold_starts"][1:]):
        tags = [gmsh.model.occ.addPoint(x, y, 0.0) for x, y in points]
        _END_POINTS.update((tags[0], tags[-1]))
        curves.append(
            gmsh.model.occ.addSpline(tags) if len(tags) > 2 else gmsh.model.occ.addLine(*tags)
        )
    return curves


def _boundary_curves() -> list[int]:
    """The curves bounding one face only: the outline and the openings, not the folds."""
    return [
        tag
        for _, tag in gmsh.model.getEntities(1)
        if len(gmsh.model.getAdjacencies(1, tag)[0]) == 1
    ]


def _embed_points(points: np.ndarray, faces: list[int]) -> None:
    """Each singular point embedded as a mesh node of the face that holds it."""
    for x, y in points:
        tag = gmsh.model.occ.addPoint(x, y, 0.0)
        gmsh.model.occ.synchronize()
        inside = [f for f in faces if gmsh.model.isInside(2, f, [x, y, 0.0])]
        gmsh.model.mesh.embed(0, [tag], 2, inside[0] if inside else faces[0])


def _polygon_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _size_view(flat: np.ndarray, faces: np.ndarray, values: np.ndarray) -> int:
    """A list-based scalar view ("ST") of per-vertex values on the flat triangles."""
    tri = flat[faces]
    data = np.concatenate(
        [tri[:, :, 0], tri[:, :, 1], np.zeros((len(faces), 3)), values[faces]], axis=1
    )
    view = gmsh.view.add("size")
    gmsh.view.addListData(view, "ST", len(faces), data.ravel().tolist())
    return view


def _guiding_view(
    flat: np.ndarray, faces: np.ndarray, values: np.ndarray, angle: np.ndarray
) -> int:
    """A list-based vector view ("VT"): one branch of each triangle's cross, as long as the
    size field; gmsh then packs its quads along it instead of its own boundary-aligned field
    (layout.md §4.3)."""
    tri = flat[faces]
    size = values[faces]  # (m, 3)
    vx = size * np.cos(angle)[:, None]
    vy = size * np.sin(angle)[:, None]
    vectors = np.stack([vx, vy, np.zeros_like(vx)], axis=2).reshape(len(faces), 9)
    data = np.concatenate([tri[:, :, 0], tri[:, :, 1], np.zeros((len(faces), 3)), vectors], axis=1)
    view = gmsh.view.add("guiding")
    gmsh.view.addListData(view, "VT", len(faces), data.ravel().tolist())
    return view


def _mesh(data, factor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    gmsh.model.mesh.clear()
    for view in gmsh.view.getTags():
        gmsh.view.remove(view)
    size = float(data["h"]) / factor * data["scale"]
    if "cross" in data:
        view = _guiding_view(data["flat"], data["faces"], size, data["cross"])
    else:
        view = _size_view(data["flat"], data["faces"], size)
    field = gmsh.model.mesh.field.add("PostView")
    gmsh.model.mesh.field.setNumber(field, "ViewTag", view)
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.field.remove(field)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    index = np.full(int(tags.max()) + 1, -1)
    index[tags] = np.arange(len(tags))
    types, _, nodes = gmsh.model.mesh.getElements(2)
    quads = np.zeros((0, 4), dtype=np.int64)
    for kind, element_nodes in zip(types, nodes):
        if kind != 3:
            raise RuntimeError(f"gmsh left {len(element_nodes) // 3} non-quad elements")
        quads = index[np.asarray(element_nodes, dtype=np.int64).reshape(-1, 4)]
    on_curve = np.zeros(len(tags), dtype=bool)
    for curve in _boundary_curves():
        curve_tags, _, _ = gmsh.model.mesh.getNodes(1, curve, includeBoundary=True)
        on_curve[index[curve_tags]] = True
    return coords.reshape(-1, 3)[:, :2], quads, on_curve


def _surface_lengths(data, nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Edge lengths on the surface: flat length / interpolated scale at the midpoint."""
    flat, scale = data["flat"], data["scale"]
    linear = LinearNDInterpolator(flat, scale)
    nearest = NearestNDInterpolator(flat, scale)
    edges = np.unique(
        np.sort(np.stack([quads, np.roll(quads, -1, 1)], 2).reshape(-1, 2), 1), axis=0
    )
    mids = 0.5 * (nodes[edges[:, 0]] + nodes[edges[:, 1]])
    local = linear(mids)
    local = np.where(np.isfinite(local), local, nearest(mids))
    return np.linalg.norm(nodes[edges[:, 0]] - nodes[edges[:, 1]], axis=1) / local


def _calibrated_factor(data, meshed: dict) -> tuple[float, bool]:
    """The size factor whose mesh has its median surface edge within 4 % of ``h`` (or the
    next guess after ``CALIBRATION_ROUNDS``), and whether it converged; every mesh made on the
    way is kept in ``meshed`` (factor -> (score, median, mesh))."""
    factor = FIRST_FACTOR
    h = float(data["h"])
    for _ in range(CALIBRATION_ROUNDS):
        median = _mesh_and_score(data, factor, meshed)[1]
        if abs(median / h - 1.0) <= MEDIAN_TOLERANCE:
            return factor, True
        factor *= median / h
    return factor, False


def _nearest_median(data, meshed: dict) -> float:
    """The factor meshed so far whose median surface edge came nearest ``h`` (on a small
    domain the median jumps with the factor, 935 mm to 2422 mm between 0.221 and 0.207, and
    the calibration's next guess can land far off)."""
    h = float(data["h"])
    return min(meshed, key=lambda f: abs(np.log(meshed[f][1] / h)))


def _mesh_and_score(data, factor: float, meshed: dict) -> tuple:
    """(score, median, (nodes, quads, on_curve)) of the mesh at ``factor``, made once."""
    if factor not in meshed:
        mesh = _mesh(data, factor)
        meshed[factor] = (*_score(data, mesh[0], mesh[1]), mesh)
    return meshed[factor]


def _corner_angles(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    corners = nodes[quads]
    to_next = np.roll(corners, -1, axis=1) - corners
    to_prev = np.roll(corners, 1, axis=1) - corners
    cos = np.einsum("mci,mci->mc", to_next, to_prev) / np.maximum(
        np.linalg.norm(to_next, axis=2) * np.linalg.norm(to_prev, axis=2), 1e-300
    )
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _score(data, nodes: np.ndarray, quads: np.ndarray) -> tuple[float, float]:
    """The layout gates' score (fabpanel.panelize.gates.layout_score) as the flat domain shows
    it (the flattening is conformal: angles as on the surface, lengths / scale), and the
    median surface edge."""
    h = float(data["h"])
    lengths = _surface_lengths(data, nodes, quads) / h
    angles = _corner_angles(nodes, quads)
    band = float(np.mean((lengths >= 0.5) & (lengths <= 1.25)))
    good = float(np.mean((angles >= 60) & (angles <= 120)))
    ratio = len(quads) / max(float(data["area"]) / h**2, 1e-9)
    score = band + good - 2.0 * max(0.0, ratio - 1.3) - 0.5 * float(ratio > 1.3)
    score -= 0.5 * float(lengths.min() < 0.3) + 0.5 * float(((angles < 45) | (angles > 135)).any())
    return score, float(np.median(lengths) * h)


def _meshes_of_topology(data, topology: int, meshed: dict) -> float:
    """Mesh the domain with one setting of QQS's topology steps: the calibrated size factor
    and its neighbours (and factors further out where the calibration does not converge on a
    small domain), each kept in ``meshed`` (factor -> (score, median, mesh)); returns the
    calibrated factor."""
    gmsh.option.setNumber("Mesh.QuadqsTopologyOptimizationMethods", topology)
    factor, converged = _calibrated_factor(data, meshed)
    panels = float(data["area"]) / float(data["h"]) ** 2
    for candidate in factor * np.asarray(
        CANDIDATES[:2] if panels > FEWER_CANDIDATES_ABOVE else CANDIDATES
    ):
        _mesh_and_score(data, float(candidate), meshed)
    if not converged and panels <= FURTHER_MAX_PANELS:
        for candidate in _nearest_median(data, meshed) * np.asarray(FURTHER):
            _mesh_and_score(data, float(candidate), meshed)
    return factor


def _finer_factors(meshed: dict, count: int) -> list[float]:
    """Per quad count above ``count`` among the meshes made, the factor of the best-scoring
    one, fewest quads first, at most ``FINER_MESHES``."""
    best: dict[int, float] = {}
    for factor, (score, _, mesh) in meshed.items():
        quads = len(mesh[1])
        if quads > count and (quads not in best or score > meshed[best[quads]][0]):
            best[quads] = factor
    return [best[quads] for quads in sorted(best)][:FINER_MESHES]


def main(source: str, target: str) -> None:
    data = dict(np.load(source))
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        options = {
            "Mesh.Algorithm": 11,
            "Mesh.QuadqsSizemapMethod": 0,
            "Mesh.MaxNumThreads2D": 1,  # reproducible
            "Mesh.MeshSizeFromPoints": 0,
            "Mesh.MeshSizeExtendFromBoundary": 0,
            "General.NumThreads": 1,
        }
        for name, value in options.items():
            gmsh.option.setNumber(name, value)
        faces = _domain(data)
        _embed_points(data["points"].reshape(-1, 2), faces)
        started = time.perf_counter()
        topology = int(data["topology"])
        meshed: dict = {}
        calibrated = _meshes_of_topology(data, topology, meshed)
        # the best score; among equals the factor nearest the calibrated one
        factor = max(meshed, key=lambda f: (meshed[f][0], -abs(f - calibrated)))
        score, median, (nodes, quads, on_curve) = meshed[factor]
        finer_factors = _finer_factors(meshed, len(quads))
        finer = [meshed[f][2] for f in finer_factors]
        np.savez(
            target,
            nodes=nodes,
            quads=quads,
            on_curve=on_curve,
            finer_nodes=np.concatenate([m[0] for m in finer] or [np.zeros((0, 2))]),
            finer_node_counts=np.array([len(m[0]) for m in finer], dtype=np.int64),
            finer_quads=np.concatenate([m[1] for m in finer] or [np.zeros((0, 4), np.int64)]),
            finer_quad_counts=np.array([len(m[1]) for m in finer], dtype=np.int64),
            finer_on_curve=np.concatenate([m[2] for m in finer] or [np.zeros(0, bool)]),
            finer_factors=np.array(finer_factors, dtype=float),
            finer_scores=np.array([meshed[f][0] for f in finer_factors], dtype=float),
            factor=factor,
            median=median,
            score=score,
            meshes=len(meshed),
            seconds=time.perf_counter() - started,
        )
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
