"""The shop's schedules: rolling, fasteners, welds and panels (``docs/*.csv``).

Each schedule is a header and rows of strings, so the same table goes into a CSV file and into
the report. Lengths mm, masses kg, areas m2 (coating), angles degrees; positions in the design's
own frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..welds import PLATE_THROAT
from .bolts import NUT_CLASS, WASHER_CLASS, bolt_set, joint_bolts
from .source import DocSource, PartDoc

#: chord of the rolling template the shop checks a rolled sheet with, mm (a sheet narrower
#: than this is checked over its own chord)
TEMPLATE_CHORD = 1000.0
#: half the largest bent angle for which a chord and sagitta are given (a quarter turn)
MAX_HALF_ANGLE = math.pi / 4.0


@dataclass(frozen=True)
class Schedule:
    """A table: its file name in ``docs/``, title, header and rows (strings)."""

    name: str
    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


def _mm(value: float) -> str:
    return f"{value:.1f}"


def rolling_schedule(source: DocSource) -> Schedule:
    """One row per sheet mark: how it is formed, its radius at the unrolling fibre, the roll's
    axis on the flat part, the sagitta over the rolled chord and a template's chord and
    sagitta (module constant ``TEMPLATE_CHORD``)."""
    fibre = source.job.cutting.neutral_fibre
    rows = []
    for mark, parts in _by_mark(p for p in source.parts if p.kind.startswith("sheet")):
        first = parts[0]
        low, high = first.bend_radius
        method = _forming_method(first)
        chord = sagitta = template = template_sagitta = ""
        across = first.roll_extent[1]
        # half the bent angle, radians. A panel sheet bent through more than a quarter turn
        # at its smallest radius is one whose radius is local (a cone's apex end, a sheet that
        # opens out): the chord and sagitta of that radius over the whole width would be
        # meaningless (negative chords past a half turn), so they are left blank
        half = across / (2.0 * low) if low > 0 else 0.0
        if 0.0 < half <= MAX_HALF_ANGLE:
            chord = _mm(2.0 * low * math.sin(half))
            sagitta = _mm(low * (1.0 - math.cos(half)))
            t_chord = min(TEMPLATE_CHORD, 2.0 * low * math.sin(half))
            template = _mm(t_chord)
            template_sagitta = _mm(low - math.sqrt(max(low**2 - (t_chord / 2.0) ** 2, 0.0)))
        rows.append(
            (
                mark,
                str(len(parts)),
                first.kind,
                f"{first.thickness:g}",
                method,
                first.forming,
                fibre,
                _mm(low) if low > 0 else "",
                _mm(high) if low > 0 else "",
                f"{first.roll_axis_deg:.1f}" if low > 0 else "",
                _mm(first.roll_extent[0]) if low > 0 else "",
                _mm(first.roll_extent[1]) if low > 0 else "",
                chord,
                sagitta,
                template,
                template_sagitta,
                f"{first.spring_stress:.1f}" if first.spring_stress else "",
                " ".join(p.id for p in parts),
            )
        )
    return Schedule(
        "rolling.csv",
        "Rolling schedule",
        (
            "mark",
            "quantity",
            "kind",
            "thickness_mm",
            "method",
            "instruction",
            "fibre",
            "radius_min_mm",
            "radius_max_mm",
            "roll_axis_deg",
            "length_along_axis_mm",
            "width_across_axis_mm",
            "chord_mm",
            "sagitta_mm",
            "template_chord_mm",
            "template_sagitta_mm",
            "locked_in_stress_MPa",
            "parts",
        ),
        tuple(rows),
    )


def _forming_method(part: PartDoc) -> str:
    """rolled | sprung | flat | double-curved | unknown, from the etched instruction."""
    words = part.forming.split()
    if "ROLL" in words:
        return "rolled"
    if "SPRING" in words:
        return "sprung"
    if "FLAT" in words:
        return "flat"
    if "DOUBLE" in words:
        return "double-curved (press or wheel)"
    return "rolled" if part.bend_radius[0] > 0 else "unknown"


def _by_mark(parts) -> list[tuple[str, list[PartDoc]]]:
    groups: dict[str, list[PartDoc]] = {}
    for part in parts:
        groups.setdefault(part.mark, []).append(part)
    return sorted(groups.items())


def fastener_schedule(source: DocSource) -> Schedule:
    """Bolts, nuts and washers by size, class and grip, with the job's spares share; anchor
    holes on the boundary ribs counted apart (their bolts are the foundation's)."""
    spares = source.job.docs.spares
    bolts = joint_bolts(source)
    rows = []
    diameters, counts = np.unique(np.round(bolts.diameters, 3), return_counts=True)
    for hole, count in zip(diameters, counts):
        found = bolt_set(source, float(hole))
        if found is None:
            rows.append(
                (
                    "bolt", "-", f"no standard bolt for a {hole:g} mm hole", "", "", "",
                    str(count), "", "",
                )
            )  # fmt: skip
            continue
        order = math.ceil(count * (1.0 + spares))
        grade = found.grade
        for item, standard, size, grade_text, each in (
            ("bolt", "EN ISO 4017", found.screw, grade, 1),
            ("nut", "EN ISO 4032", found.bolt.name, NUT_CLASS[grade], 1),
            ("washer", "EN ISO 7089", f"{found.bolt.d:g}", WASHER_CLASS[grade], 2),
        ):
            rows.append(
                (
                    item,
                    standard,
                    size,
                    grade_text,
                    _mm(found.grip),
                    f"{hole:g}",
                    str(each * int(count)),
                    str(math.ceil(each * order)),
                    f"{spares:.0%}",
                )
            )
    if bolts.anchor_holes:
        rows.append(
            (
                "anchor bolt", "by the foundation design", "", "", "", "",
                str(bolts.anchor_holes), "", "",
            )
        )  # fmt: skip
    if bolts.unmatched:
        ribs = sorted(set(bolts.unmatched))
        named = ", ".join(ribs[:6]) + (f" and {len(ribs) - 6} more" if len(ribs) > 6 else "")
        rows.append(
            (
                "no bolt: hole without a partner", "fix the joint (build issues)", named,
                "", "", "", str(len(bolts.unmatched)), "", "",
            )
        )  # fmt: skip
    return Schedule(
        "fasteners.csv",
        "Fasteners",
        (
            "item",
            "standard",
            "size",
            "class",
            "grip_mm",
            "hole_mm",
            "count",
            "order",
            "spares",
        ),
        tuple(rows),
    )


def weld_lengths(
    source: DocSource, parts: list[PartDoc]
) -> list[tuple[str, str, float, int, float]]:
    """One panel's welds: (weld, joint, throat mm, sides, length mm).

    - sheet to rib: each sheet edge on its rib, one fillet (the other face of the rib is the
      contact face of the joint, kept clear), less a snipe at each end;
    - rib to rib: the four corners where ribs 1 and 3 butt against ribs 0 and 2, one fillet
      inside the panel, over the rib height less two snipes;
    - stiffener: all round each corner stiffener but its snipes, on both faces.
    """
    from ..buildup import Buildup

    buildup = Buildup.of(source.job)
    snipe, throat = buildup.welds.snipe, buildup.welds.throat
    sheets = [p for p in parts if p.kind.startswith("sheet")]
    ribs = [p for p in parts if p.kind == "rib"]
    stiffeners = [p for p in parts if p.kind == "stiffener"]
    welds = []
    if sheets and ribs:
        length = sum(float(np.sum(np.maximum(s.edge_lengths_3d - 2 * snipe, 0.0))) for s in sheets)
        welds.append(("W1", "sheet to rib", throat, 1, length))
    if len(ribs) >= 4:
        corner = max(buildup.rib_height - 2 * snipe, 0.0)
        welds.append(("W2", "rib to rib", PLATE_THROAT, 1, 4 * corner))
    if stiffeners:
        chamfer = 4 * snipe * math.sqrt(2.0)
        length = sum(max(s.cut_length - chamfer, 0.0) for s in stiffeners)
        welds.append(("W3", "stiffener to ribs and sheets", min(throat, PLATE_THROAT), 2, length))
    return welds


def weld_schedule(source: DocSource) -> Schedule:
    """Welds per panel type (panels with the same part marks) and in total, by weld."""
    types = panel_types(source)
    rows = []
    totals: dict[tuple[str, str, float, int], float] = {}
    for name, panels in types:
        parts = source.parts_of(panels[0])
        for weld, joint, throat, sides, length in weld_lengths(source, parts):
            each = length * sides
            rows.append(
                (
                    name, str(len(panels)), weld, joint, "fillet", f"{throat:.1f}", str(sides),
                    _mm(each), _mm(each * len(panels)),
                )
            )  # fmt: skip
            key = (weld, joint, throat, sides)
            totals[key] = totals.get(key, 0.0) + each * len(panels)
    for (weld, joint, throat, sides), total in sorted(totals.items()):
        rows.append(
            (
                "all", str(len(source.panels)), weld, joint, "fillet", f"{throat:.1f}", str(sides),
                "", _mm(total),
            )
        )  # fmt: skip
    return Schedule(
        "welds.csv",
        "Welds",
        (
            "panel_type",
            "panels",
            "weld",
            "joint",
            "type",
            "throat_mm",
            "sides",
            "length_per_panel_mm",
            "length_total_mm",
        ),
        tuple(rows),
    )


def panel_types(source: DocSource) -> list[tuple[str, list[str]]]:
    """Panels grouped by their parts' marks (equal parts, equal panel): (type name, panel ids),
    types named PT01... in order of their first panel."""
    signature: dict[tuple[str, ...], list[str]] = {}
    built = {p.panel for p in source.parts}
    for panel in source.panels:
        if panel.id in built:
            marks = tuple(sorted(p.mark for p in source.parts_of(panel.id)))
            signature.setdefault(marks, []).append(panel.id)
    return [(f"PT{i + 1:02d}", ids) for i, ids in enumerate(signature.values())]
