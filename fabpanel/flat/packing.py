"""One plate's packing: parts prepared as packing items, the packers, and the ways a plate is
filled (used by :mod:`fabpanel.flat.nest` and :mod:`fabpanel.flat.stock`).

Packers, each placing items (grown part shapes) on one plate or a strip of the plate's height:
spyrrow's strip packing of the irregular shapes (:func:`pack_strip`, :func:`pack_on_plate`);
rectpack's MaxRects on the shapes' bounding boxes, over as many plates as needed
(:func:`box_plates`); and the boxes packed as near the plate's start as they go (:func:`rows_pack`).
A plate is then filled: the smallest waiting parts added while everything still packs
(:func:`fill_plate`), and the strip past its large parts packed on its own with small ones
(:func:`tail_fill`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import rectpack
import shapely
import spyrrow
from shapely.geometry import Polygon

from ..data import FlatPart
from ..errors import SolverError
from ..geom.polygon import polygon_area

#: Douglas-Peucker tolerance for the packing shapes, mm (covered by growing them as much more)
SIMPLIFY_TOLERANCE = 0.5
#: extra gap on top of half the part spacing, absorbs spyrrow's single-precision geometry, mm
SAFETY_GAP = 0.05
#: constructive packs per plate when adding small parts to it (binary search)
FILL_PROBES = 6
#: the box assignment packs at most this many items at once (:func:`box_plates`)
BOX_CHUNK = 2000
#: parts under this share of a plate's largest part's area are the small ones its free strip
#: is filled with (:func:`tail_fill`)
SMALL_SHARE = 0.25


@dataclass(frozen=True)
class Item:
    """A part prepared for packing: grown shape, allowed rotations.

    Parts of one mark share their mark's shape (``key``: the mark), in the frame of the mark's
    first part; ``to_shape`` (3, 3) maps the part's own flat frame to it, so that spyrrow packs
    them as one item with a quantity."""

    part: FlatPart
    shape: np.ndarray  # (k, 2) float, counter-clockwise, not closed
    rotations: tuple[int, ...]
    key: str = ""
    to_shape: np.ndarray = field(default_factory=lambda: np.eye(3))
    #: the grown shape's area, mm2 (the fills sort the waiting parts by it, plate after plate)
    area: float = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "area", abs(polygon_area(self.shape)))


def rotation_matrix(degrees: float) -> np.ndarray:
    """(2, 2) float; exact for multiples of 90 degrees."""
    quarter = degrees / 90.0
    if abs(quarter - round(quarter)) < 1e-6:
        c, s = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][round(quarter) % 4]
    else:
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[c, -s], [s, c]], dtype=float)


def transform_points(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (3, 3) 2D transform to (n, 2) points."""
    return np.asarray(points, dtype=float) @ transform[:2, :2].T + transform[:2, 2]


def validate_outline(outline: np.ndarray, name: str) -> np.ndarray:
    """(n, 2) float: a finite, simple, non-degenerate outline, counter-clockwise, not closed.

    Raises ValueError naming the part when the outline cannot be nested.
    """
    points = np.asarray(outline, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        raise ValueError(f"{name}: outline must be (n >= 3, 2), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError(f"{name}: outline has non-finite coordinates")
    if np.allclose(points[0], points[-1]):
        points = points[:-1]
    area = polygon_area(points)
    if abs(area) < 1e-6:
        raise ValueError(f"{name}: outline has zero area")
    if not shapely.is_valid(Polygon(points)):
        raise ValueError(
            f"{name}: outline is not simple ({shapely.is_valid_reason(Polygon(points))})"
        )
    return points if area > 0 else points[::-1].copy()


def packing_shape(outline: np.ndarray, grow: float) -> np.ndarray:
    """(k, 2) float: the outline grown by ``grow`` mm (mitre joins) and simplified, CCW.

    The result holds every point within ``grow - SIMPLIFY_TOLERANCE`` of the outline.
    """
    grown = Polygon(outline).buffer(grow + SIMPLIFY_TOLERANCE, join_style="mitre", mitre_limit=4.0)
    simple = grown.simplify(SIMPLIFY_TOLERANCE, preserve_topology=True)
    simple = shapely.geometry.polygon.orient(Polygon(simple.exterior), 1.0)
    return np.asarray(simple.exterior.coords)[:-1]


def narrowest_frame(shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The shape turned so that its narrowest bounding rectangle (shapely's minimum rotated
    rectangle) lies along x, and the (3, 3) turn (shape frame -> turned frame).

    A skewed sheet's box along its first side can be far wider than the sheet itself (a new
    9 x 6 m shell: 1684 x 1513 mm along the side, 1854 x 1301 mm at its narrowest)."""
    rectangle = np.asarray(Polygon(shape).minimum_rotated_rectangle.exterior.coords)[:3]
    sides = np.diff(rectangle, axis=0)
    along = sides[int(np.argmax(np.linalg.norm(sides, axis=1)))]
    c, s = along / np.linalg.norm(along)
    turn = np.eye(3)
    turn[:2, :2] = [[c, s], [-s, c]]
    return shape @ turn[:2, :2].T, turn


def box_fits(width, height, length: float, plate_height: float):
    """Whether boxes (float or arrays) fit a plate's usable ``length`` x ``plate_height``: the
    same rounding as the box assignment (0.1 mm up, plate down), and strictly inside: spyrrow
    fails on a shape exactly as high as its strip."""
    return (
        (np.ceil(np.multiply(width, 10)) <= np.floor(length * 10))
        & (np.ceil(np.multiply(height, 10)) <= np.floor(plate_height * 10))
        & (np.less(width, length - 1e-3))
        & (np.less(height, plate_height - 1e-3))
    )


def fitting_rotations(
    shape: np.ndarray, rotations: list[int], length: float, height: float
) -> tuple[int, ...]:
    size = shape.max(axis=0) - shape.min(axis=0)
    fits = []
    for r in rotations:
        w, h = size if r % 180 == 0 else size[::-1]
        if box_fits(w, h, length, height):
            fits.append(int(r))
    return tuple(fits)


def pack_strip(
    items: list[Item], height: float, seconds: int, seed: int
) -> tuple[list[np.ndarray], float]:
    """Pack items in a strip; returns one (3, 3) transform (shape frame -> strip) per item.

    Items of one key (parts of one mark) go to spyrrow as one item with their quantity."""
    kinds: dict[str, list[int]] = {}
    for index, item in enumerate(items):
        kinds.setdefault(item.key or item.part.id, []).append(index)
    members = list(kinds.values())
    spy_items = [
        spyrrow.Item(
            str(k),
            [tuple(p) for p in items[indices[0]].shape.tolist()],
            demand=len(indices),
            allowed_orientations=[float(r) for r in items[indices[0]].rotations],
        )
        for k, indices in enumerate(members)
    ]
    try:
        instance = spyrrow.StripPackingInstance("fabpanel", float(height), spy_items)
        config = spyrrow.StripPackingConfig(
            early_termination=True,
            num_workers=1,
            total_computation_time=int(seconds),
            seed=int(seed),
        )
        solution = instance.solve(config)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:  # spyrrow panics arrive as BaseException
        raise SolverError(f"spyrrow failed to pack {len(items)} parts: {err}") from err
    transforms: list[np.ndarray | None] = [None] * len(items)
    waiting = [list(indices) for indices in members]
    for placed in solution.placed_items:
        t = np.eye(3)
        t[:2, :2] = rotation_matrix(placed.rotation)
        t[:2, 2] = placed.translation
        queue = waiting[int(placed.id)]
        if queue:
            transforms[queue.pop(0)] = t
    placed_transforms: list[np.ndarray] = []
    for transform in transforms:
        if transform is None:
            raise SolverError("spyrrow left parts unplaced in an unbounded strip")
        placed_transforms.append(transform)
    return placed_transforms, float(solution.width)


def round_seconds(seconds: float) -> int:
    return max(int(seconds), 0)


@dataclass
class Packing:
    """One plate being filled: its items and their transforms (part frame -> usable area)."""

    items: list[Item]
    transforms: list[np.ndarray]


def x_spans(items: list[Item], transforms: list[np.ndarray]) -> np.ndarray:
    """(n, 2) float: x range of each placed item's shape."""
    return np.array(
        [
            [(x := transform_points(t, it.shape)[:, 0]).min(), x.max()]
            for it, t in zip(items, transforms)
        ]
    )


def pack_on_plate(
    items: list[Item], length: float, height: float, seconds: int, seed: int
) -> Packing | None:
    """Pack items into one plate (a strip ``length`` long) or return None when they need more."""
    transforms, _ = pack_strip(items, height, seconds, seed)
    spans = x_spans(items, transforms)
    if spans[:, 1].max() - spans[:, 0].min() > length + 1e-6:
        return None
    shift = np.eye(3)
    shift[0, 2] = -spans[:, 0].min()
    return Packing(list(items), [shift @ t for t in transforms])


def _packer(algorithm, rotate: bool):
    """A rectpack packer (offline, best-fit bins) with the given MaxRects rule."""
    return rectpack.newPacker(
        mode=rectpack.PackingMode.Offline,
        bin_algo=rectpack.PackingBin.BFF,
        pack_algo=algorithm,
        rotation=rotate,
    )


def _boxes(items: list[Item]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each item's first allowed rotation and its bounding box in it, in 0.1 mm (rounded up)."""
    base = [rotation_matrix(it.rotations[0]) for it in items]
    boxes = [np.ceil(np.ptp(it.shape @ r.T, axis=0) * 10).astype(int) for it, r in zip(items, base)]
    return base, boxes


def _kept_from_turning(item: Item) -> bool:
    """Whether an item is kept from quarter turns: none of its rotations is one."""
    return all((r - item.rotations[0]) % 180 != 90 for r in item.rotations)


def _unturnable(box: np.ndarray, plate: tuple[int, int]) -> np.ndarray:
    """An item's box (0.1 mm) grown so that rectpack cannot turn it on the plate, where only
    the strict fit of :func:`box_fits` kept the turn from the item: a part within 0.1 mm of
    the plate's width as long (rectpack takes a box as long as the plate's side)."""
    if box[1] > plate[0] or box[0] > plate[1]:
        return box  # the turned box does not fit rectpack's plate either
    grown = box.copy()
    if plate[1] + 1 <= plate[0]:
        grown[0] = max(box[0], plate[1] + 1)
    else:
        grown[1] = max(box[1], plate[0] + 1)
    return grown


def box_plates(items: list[Item], length: float, height: float, rotate: bool) -> list[Packing]:
    """A first, always feasible assignment: the items' bounding boxes packed onto plates by
    rectpack (MaxRects, best-fit bins, quarter turns when ``rotate``), boxes rounded up to
    0.1 mm and the plate down, so every shape lies in its box on its plate.

    Best-fit bins try every box on every open plate, so rectpack's time grows with the square
    of the parts (4758 ribs: 2 s; three times as many: 18 s). More than ``BOX_CHUNK`` items are
    packed in runs of that many, largest boxes first (rectpack's own order), each run on
    plates of its own."""
    # each box in the item's first allowed rotation; a turned box is a quarter turn more
    _, boxes = _boxes(items)
    plate = (int(length * 10), int(height * 10))
    if rotate:
        boxes = [
            _unturnable(box, plate) if _kept_from_turning(it) else box
            for it, box in zip(items, boxes)
        ]
    order = list(range(len(items)))
    if len(items) > BOX_CHUNK:
        order = sorted(order, key=lambda k: int(boxes[k][0]) * int(boxes[k][1]), reverse=True)
    plates = []
    for first in range(0, len(order), BOX_CHUNK):
        run = order[first : first + BOX_CHUNK]
        plates += _box_run([items[k] for k in run], [boxes[k] for k in run], plate, rotate)
    if sum(len(p.items) for p in plates) != len(items):
        raise SolverError(
            f"rectpack placed {sum(len(p.items) for p in plates)} of {len(items)} parts"
        )
    return plates


def _box_run(
    items: list[Item], boxes: list[np.ndarray], plate: tuple[int, int], rotate: bool
) -> list[Packing]:
    """The items' boxes (0.1 mm) packed by rectpack onto as many ``plate`` (0.1 mm) as needed."""
    packer = _packer(rectpack.MaxRectsBssf, rotate)
    for index, box_size in enumerate(boxes):
        packer.add_rect(int(box_size[0]), int(box_size[1]), rid=index)
    packer.add_bin(*plate, count=float("inf"))
    packer.pack()
    plates = []
    for plate_bin in packer:
        members, transforms = [], []
        for rect in plate_bin:
            item = items[rect.rid]
            turned = (rect.width, rect.height) != tuple(boxes[rect.rid])
            first = item.rotations[0]
            rotation = next(
                (r for r in item.rotations if ((r - first) % 180 == 90) == turned), None
            )
            if rotation is None:
                raise SolverError(f"rectpack turned {item.part.id}, which may not turn")
            t = np.eye(3)
            t[:2, :2] = rotation_matrix(rotation)
            t[:2, 2] = np.array([rect.x, rect.y]) / 10 - (item.shape @ t[:2, :2].T).min(axis=0)
            members.append(item)
            transforms.append(t)
        plates.append(Packing(members, transforms))
    return plates


def _area(item: Item) -> float:
    return item.area


def fill_plate(
    plate: Packing, waiting: list[Item], length: float, height: float, seconds: int, seed: int
) -> Packing:
    """Add parts from ``waiting`` to a plate while everything still packs onto it.

    The smallest waiting parts, by a binary search on how many (at most ``FILL_PROBES``
    constructive packs, bounded by the free area); with a time budget, one more part is tried
    with spyrrow's improvement phase.
    """
    free = length * height - sum(it.area for it in plate.items)
    extras = sorted(waiting, key=_area)
    areas = np.array([it.area for it in extras])
    low, high = 0, int(np.searchsorted(np.cumsum(areas), free, side="right"))
    best = plate
    for _ in range(FILL_PROBES):
        if low >= high:
            break
        middle = (low + high + 1) // 2
        packed = pack_on_plate(plate.items + extras[:middle], length, height, 0, seed)
        if packed is None:
            high = middle - 1
        else:
            low, best = middle, packed
    if seconds > 0 and low < len(extras) and areas[: low + 1].sum() <= free:
        packed = pack_on_plate(plate.items + extras[: low + 1], length, height, seconds, seed)
        best = packed or best
    return best


def shortest_pack(
    items: list[Item], length: float, height: float, seed: int, rotate: bool
) -> Packing | None:
    """The items on one plate, as spyrrow's constructive pack or as their bounding boxes
    (rectpack), whichever ends sooner along the plate; None when neither fits one plate. Many
    equal long parts (ribs) box-pack in clean rows where spyrrow's pack staggers them."""
    packs = [pack_on_plate(items, length, height, 0, seed), rows_pack(items, length, height)]
    try:
        boxes = box_plates(items, length, height, rotate)
    except SolverError:
        boxes = []  # a box larger than the plate: rectpack leaves it out
    if len(boxes) == 1:
        packs.append(boxes[0])
    fitting = [p for p in packs if p is not None]
    if not fitting:
        return None
    return min(fitting, key=lambda p: float(x_spans(p.items, p.transforms)[:, 1].max()))


def rows_pack(items: list[Item], length: float, height: float) -> Packing | None:
    """The items' bounding boxes (first allowed rotation) packed as far towards the plate's
    start as they go, or None when they need more than one plate: rectpack's bottom-left
    MaxRects on the plate turned a quarter, so its "lowest first" is "nearest the start"."""
    packer = _packer(rectpack.MaxRectsBl, False)
    base, boxes = _boxes(items)
    for index, (w, h) in enumerate(boxes):
        packer.add_rect(int(h), int(w), rid=index)
    packer.add_bin(int(height * 10), int(length * 10), count=1)
    packer.pack()
    placed = [rect for plate_bin in packer for rect in plate_bin]
    if len(placed) != len(items):
        return None
    members, transforms = [], []
    for rect in sorted(placed, key=lambda r: r.rid):
        item, rotation = items[rect.rid], base[rect.rid]
        t = np.eye(3)
        t[:2, :2] = rotation
        t[:2, 2] = np.array([rect.y, rect.x]) / 10 - (item.shape @ rotation.T).min(axis=0)
        members.append(item)
        transforms.append(t)
    return Packing(members, transforms)


def tail_fill(
    plate: Packing,
    waiting: list[Item],
    length: float,
    height: float,
    seed: int,
    rotate: bool,
) -> Packing:
    """The plate with the free strip past its large parts filled with small ones.

    spyrrow repacks a whole plate from scratch, and its constructive pack of large parts and a
    few small ones spreads over the plate's length (the demo's 1.25 m ribs, two to a 3 m plate,
    left a 0.5 m strip holding 2 of the 150 mm stiffeners that fit there). So the large parts
    (at least ``SMALL_SHARE`` of the largest one's area) are packed alone, and the strip from
    their furthest grown edge to the plate's end is packed on its own with the plate's small
    parts and as many of the smallest waiting ones as fit (a binary search, as :func:`fill_plate`),
    moved behind the large ones (packed the shorter way: :func:`shortest_pack`). Kept when it
    holds more part area than ``plate``.
    """
    largest = max(it.area for it in plate.items)
    large = [it for it in plate.items if it.area >= SMALL_SHARE * largest]
    small = [it for it in plate.items if it.area < SMALL_SHARE * largest]
    base = shortest_pack(large, length, height, seed, rotate) if small or waiting else None
    if base is None:
        return plate
    used = float(x_spans(base.items, base.transforms)[:, 1].max())
    extras = small + sorted((it for it in waiting if it.area < SMALL_SHARE * largest), key=_area)
    room = length - used
    if room <= 0 or not extras:
        return plate
    areas = np.cumsum([it.area for it in extras])
    low, high = len(small), int(np.searchsorted(areas, room * height, side="right"))
    tail = shortest_pack(extras[:low], room, height, seed, rotate) if low else Packing([], [])
    for _ in range(FILL_PROBES):
        if tail is None or low >= high:
            break
        middle = (low + high + 1) // 2
        packed = shortest_pack(extras[:middle], room, height, seed, rotate)
        if packed is None:
            high = middle - 1
        else:
            low, tail = middle, packed
    if tail is None or not tail.items:
        return plate
    shift = np.eye(3)
    shift[0, 2] = used
    filled = Packing(
        base.items + tail.items, base.transforms + [shift @ t for t in tail.transforms]
    )
    if sum(it.area for it in filled.items) <= sum(it.area for it in plate.items):
        return plate
    return filled
