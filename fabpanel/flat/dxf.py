"""The one ezdxf adapter: flat parts and plates as plasma-ready DXF.

Conventions (what SheetCam, ProNest and similar CAM programs expect): DXF R2010, millimetres
(``$INSUNITS = 4``, ``$MEASUREMENT = 1``), closed LWPOLYLINE contours of lines and circular arcs
(bulges fitted within 0.02 mm of the part's polyline: :mod:`fabpanel.geom.arcfit`), CIRCLE for
round holes, no SPLINE/ELLIPSE/TEXT. Layers by operation:

``CUT-OUTER``  outer contours (cut last)
``CUT-INNER``  holes (cut first)
``ETCH``       labels as single-stroke polylines, bend lines (ticks at the edges by default),
               drill centre crosses (marked)
``DRILL``      round holes too small for the plasma (drilled after cutting, not pierced)
``PLATE``      the stock plate outline (nests only; never cut, not plotted)

Plate files hold one block per part mark and an INSERT per part (:mod:`.nest_output`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

import ezdxf
import numpy as np
from ezdxf.entities import LWPolyline
from ezdxf.path import make_path

from ..data import FlatPart, FlatParts
from ..geom.arcfit import fit_arcs
from ..geom.polygon import polygon_area
from .strokefont import text_strokes

log = logging.getLogger(__name__)

DXF_VERSION = "R2010"
#: layer name -> ACI colour
LAYERS = {"CUT-OUTER": 7, "CUT-INNER": 1, "ETCH": 3, "DRILL": 5, "PLATE": 8}
#: entity types a plasma DXF must not contain
FORBIDDEN = ("SPLINE", "ELLIPSE", "TEXT", "MTEXT")
#: decimals of a coordinate in the file, mm: 1 um, a hundred times finer than any plasma or
#: laser holds, where the full 17 digits of a float made half of every nest file
DECIMALS = 3


def new_document() -> ezdxf.document.Drawing:
    """An empty R2010 drawing in millimetres with the cutting layers.

    The same job writes the same file: ezdxf's fixed metadata stands in for the times and
    GUIDs it would stamp on every save (the cut files of two runs, or of a local and a Ray
    run, compare byte for byte)."""
    ezdxf.options.write_fixed_meta_data_for_testing = True
    doc = ezdxf.new(DXF_VERSION, setup=False)
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    doc.units = 4
    for name, colour in LAYERS.items():
        doc.layers.add(name, color=colour)
    return doc


def _apply(transform: np.ndarray | None, points: np.ndarray) -> np.ndarray:
    """Points moved into the drawing and rounded to ``DECIMALS`` (what the file stores)."""
    points = np.asarray(points, dtype=float)
    if transform is not None:
        points = points @ transform[:2, :2].T + transform[:2, 2]
    # + 0.0 turns -0.0 into 0.0
    return np.round(points, DECIMALS) + 0.0


def etch_polylines(part: FlatPart) -> list[np.ndarray]:
    """(k, 2) polylines to etch for a part in its flat frame: etch, bend lines, label strokes."""
    lines = [np.asarray(p, dtype=float) for p in part.etch]
    lines += bend_marks(part)
    for text, x, y, height, angle in part.labels:
        lines += text_strokes(text, x, y, height, angle)
    for hole in part.drill_holes:  # a centre cross for the drill
        centre, arm = np.asarray(hole.centre, dtype=float), 0.75 * hole.diameter
        lines += [centre + [[-arm, 0.0], [arm, 0.0]], centre + [[0.0, -arm], [0.0, arm]]]
    return lines


#: a bend line piece ending this close to the outline ends at the sheet's edge, mm
EDGE_GAP = 1.0


def bend_marks(part: FlatPart) -> list[np.ndarray]:
    """The bend lines to etch: whole, or (``part.bend_tick`` > 0) a tick that long from each
    end at the sheet's edge, the roller's guide, leaving the sheet's face unmarked between."""
    lines = [np.asarray(b, dtype=float) for b in part.bend_lines]
    if part.bend_tick <= 0:
        return lines
    from shapely.geometry import Point, Polygon

    edge = Polygon(part.outline).exterior
    ticks = []
    for start, end in lines:
        length = float(np.linalg.norm(end - start))
        if length < 1e-9:
            continue
        step = (end - start) / length * min(part.bend_tick, length / 2)
        for tip, inward in ((start, step), (end, -step)):
            if edge.distance(Point(tip)) <= EDGE_GAP:
                ticks.append(np.array([tip, tip + inward]))
    return ticks


def add_part(msp, part: FlatPart, transform: np.ndarray | None = None, etch: bool = True) -> None:
    """Add one part's entities to a modelspace in cut order: etch, holes, outer contour.

    transform : (3, 3) float or None, flat frame -> drawing, mm (a rigid motion).
    """
    if etch:
        for line in etch_polylines(part):
            msp.add_lwpolyline(_apply(transform, line).tolist(), dxfattribs={"layer": "ETCH"})
    for contour in part.holes:
        add_contour(msp, contour, "CUT-INNER", transform)
    for hole in part.round_holes:
        centre = _apply(transform, np.array([hole.centre]))[0]
        msp.add_circle(centre.tolist(), hole.diameter / 2, dxfattribs={"layer": "CUT-INNER"})
    for hole in part.drill_holes:
        centre = _apply(transform, np.array([hole.centre]))[0]
        msp.add_circle(centre.tolist(), hole.diameter / 2, dxfattribs={"layer": "DRILL"})
    add_contour(msp, part.outline, "CUT-OUTER", transform)


def add_contour(msp, points: np.ndarray, layer: str, transform: np.ndarray | None = None) -> None:
    """A closed contour as one LWPOLYLINE of lines and arcs (bulges survive rigid motions)."""
    vertices, bulges = _arcs_of(np.ascontiguousarray(points, dtype=float))
    rows = np.column_stack([_apply(transform, vertices), bulges])
    msp.add_lwpolyline(rows.tolist(), format="xyb", close=True, dxfattribs={"layer": layer})


#: contours whose arcs a worker keeps: a mark's contours recur on every plate that holds one of
#: its parts (in the plate's block), and fitting was a third of a plate DXF's time
_FITTED_CONTOURS = 2048
#: a contour's fitted vertices and bulges, by its coordinates' shape and bytes
ContourArcs = dict[tuple[tuple[int, ...], bytes], tuple[np.ndarray, np.ndarray]]
_fitted: ContourArcs = {}
#: fits handed to this process (:func:`given_arcs`), looked up before any is made
_given: ContourArcs = {}


def _arcs_of(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`fit_arcs` of a contour, remembered by its coordinates' bytes (the same contour,
    the same fit: the fit is deterministic)."""
    key = (points.shape, points.tobytes())
    if key in _given:
        return _given[key]
    if key not in _fitted:
        if len(_fitted) >= _FITTED_CONTOURS:
            _fitted.pop(next(iter(_fitted)))  # the oldest
        _fitted[key] = fit_arcs(points)
    return _fitted[key]


def contour_arcs(parts: Iterable[FlatPart]) -> ContourArcs:
    """The arcs of every fitted contour of ``parts`` (outline and inner contours), by the
    contour's coordinates: what a plate writer in another process needs so as not to fit its
    parts' contours again (:func:`given_arcs`)."""
    found: ContourArcs = {}
    for part in parts:
        for contour in (part.outline, *part.holes):
            points = np.ascontiguousarray(contour, dtype=float)
            found[(points.shape, points.tobytes())] = _arcs_of(points)
    return found


@contextmanager
def given_arcs(arcs: ContourArcs) -> Iterator[None]:
    """Within the block, contours of ``arcs`` (:func:`contour_arcs`) take their fits from it."""
    _given.update(arcs)
    try:
        yield
    finally:
        _given.clear()


def save(doc, path: str | Path, extents: tuple[tuple, tuple] | None = None) -> Path:
    """Audit and save a drawing; raise if the auditor finds errors it could not fix.
    ``extents``: the drawing's (low, high) corners where they are known (a plate: its
    outline holds every part), else measured from the entities."""
    auditor = doc.audit()
    if auditor.has_errors:
        messages = "; ".join(str(e.message) for e in auditor.errors[:5])
        raise RuntimeError(f"DXF audit of {path} failed: {messages}")
    _set_extents(doc, extents)
    # ezdxf adds a CLASS per entity type in use on saving, in the order of a set of strings,
    # which Python's hash seed changes from process to process: added here in name order
    # first, they keep that order (the same job, the same file, whichever worker wrote it)
    for dxftype in sorted(doc.entitydb.dxf_types_in_use()):
        doc.classes.add_class(dxftype)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    doc.saveas(path)
    return path


def _set_extents(doc, extents: tuple[tuple, tuple] | None = None) -> None:
    """$EXTMIN/$EXTMAX from the drawing's entities (or the ``extents`` given): a viewer or CAM
    program that trusts the header (rather than scanning the file) zooms to the parts."""
    from ezdxf import bbox

    msp = doc.modelspace()
    if extents is not None:
        low, high = (*map(float, extents[0][:2]), 0.0), (*map(float, extents[1][:2]), 0.0)
        msp.dxf.extmin, msp.dxf.extmax = low, high
        doc.header["$EXTMIN"], doc.header["$EXTMAX"] = low, high
        return
    box = bbox.extents(msp, fast=True)
    if box.has_data:
        low, high = (box.extmin.x, box.extmin.y, 0.0), (box.extmax.x, box.extmax.y, 0.0)
        # ezdxf copies the layout's extents into the header when it writes the file, unless
        # one of them is the zero vector (then the header's stay): set both
        msp.dxf.extmin, msp.dxf.extmax = low, high
        doc.header["$EXTMIN"], doc.header["$EXTMAX"] = low, high


def write_part_dxf(part: FlatPart, path: str | Path) -> Path:
    """One part as a plasma DXF (flat frame, mm)."""
    doc = new_document()
    add_part(doc.modelspace(), part)
    return save(doc, path)


def write_parts(flat: FlatParts, folder: str | Path) -> dict[str, str]:
    """Write one ``<mark>.dxf`` per part mark into ``folder`` (the mark's first part, as every
    part of the mark is the same within 0.1 mm; ``<part id>.dxf`` for an unmarked part);
    returns part id -> file name for every part."""
    folder = Path(folder)
    files: dict[str, str] = {}
    written: dict[str, str] = {}
    for part in flat.parts:
        key = part.mark or part.id
        if key not in written:
            written[key] = f"{key}.dxf"
            write_part_dxf(part, folder / written[key])
        files[part.id] = written[key]
    log.info("wrote %d part DXF files for %d parts to %s", len(written), len(files), folder)
    return files


def audit_dxf(path: str | Path) -> list[str]:
    """Problems of a written DXF: auditor errors, wrong units, forbidden entity types."""
    try:
        doc = ezdxf.readfile(str(path))
    except (OSError, ezdxf.DXFStructureError) as err:
        return [f"cannot read {path}: {err}"]
    problems = [str(e.message) for e in doc.audit().errors]
    if doc.header.get("$INSUNITS") != 4:
        problems.append(f"$INSUNITS is {doc.header.get('$INSUNITS')}, not 4 (mm)")
    entities = exploded(doc.modelspace())
    kinds = {e.dxftype() for e in entities}
    problems += [f"{kind} entity present" for kind in FORBIDDEN if kind in kinds]
    problems += [
        f"open contour on {e.dxf.layer}"
        for e in entities
        if isinstance(e, LWPolyline) and e.dxf.layer.startswith("CUT") and not e.closed
    ]
    return problems


def exploded(layout) -> list:
    """A layout's entities in file order, every INSERT replaced by its block's entities placed
    as inserted (ezdxf virtual entities): what a CAM program cuts."""
    out = []
    for entity in layout:
        if entity.dxftype() == "INSERT":
            out += exploded(entity.virtual_entities())
        else:
            out.append(entity)
    return out


def _polyline_area(entities: Iterable) -> float:
    """Enclosed area of closed LWPOLYLINEs, arcs included (flattened to 1 micron)."""
    total = 0.0
    for entity in entities:
        points = np.array([(v.x, v.y) for v in make_path(entity).flattening(0.001)])
        total += abs(polygon_area(points))
    return total


def part_area_from_dxf(path: str | Path) -> float:
    """Net part area, mm2: CUT-OUTER polylines minus CUT-INNER polylines and circles and the
    DRILL circles."""
    entities = exploded(ezdxf.readfile(str(path)).modelspace())

    def of(kind: str, *layers: str) -> list:
        return [e for e in entities if e.dxftype() == kind and e.dxf.layer in layers]

    outer = _polyline_area(of("LWPOLYLINE", "CUT-OUTER"))
    inner = _polyline_area(of("LWPOLYLINE", "CUT-INNER"))
    circles = sum(np.pi * c.dxf.radius**2 for c in of("CIRCLE", "CUT-INNER", "DRILL"))
    return float(outer - inner - circles)
