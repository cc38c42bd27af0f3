"""What the report says, as blocks (:mod:`fabpanel.report.blocks`): the verdicts first, then the
key plan, each stage's measures, the shop schedules, the plates, the structure and the issues.
"""

from __future__ import annotations

import io
from collections import Counter
from pathlib import Path

from ..raster import palette_png
from ..structure.convergence import buckling_text
from .blocks import (
    Block,
    Figure,
    Gallery,
    Heading,
    Table,
    Text,
    Vector,
    Verdict,
    Verdicts,
    cell,
    header_label,
    label,
    number,
    record_table,
)

#: plate thumbnails' width, px
THUMBNAIL_WIDTH = 220


def report_blocks(result, source=None) -> list[Block]:
    """Every block of the report of ``result`` (``source``: the documents' DocSource, when the
    run made them: key plan and schedules)."""
    summary = result.summary
    blocks: list[Block] = [
        Heading(f"fabpanel report: {result.surface.source.name}", 1),
        Text(
            f"Stages run: {', '.join(summary['stages_run'])}. Lengths in mm unless stated; "
            "positions in the design's own frame (model files) or the local frame (figures; "
            f"origin {cell(summary['input']['origin_mm'], 'origin_mm')})."
        ),
        Heading("Verdicts", 2, "verdicts"),
        verdicts(result),
    ]
    if source is not None:
        blocks += [Heading("Key plan", 2, "keyplan"), keyplan_vector(source)]
    blocks += layout_blocks(result)
    blocks += develop_blocks(result)
    blocks += parts_blocks(result)
    if source is not None:
        blocks += schedule_blocks(source)
    blocks += cutting_blocks(result)
    from .structure_figures import structure_blocks

    blocks += structure_blocks(result)
    blocks += issue_blocks(result)
    blocks += [
        Heading("Timings", 2, "timings"),
        Table(
            ("stage", "time"),
            tuple((k, f"{v:.1f} s") for k, v in summary["timings_s"].items()),
        ),
    ]
    return blocks


def _issues_coded(result, prefix: str) -> list:
    return [i for i in result.issues if i.code.startswith(prefix)]


def verdicts(result) -> Verdicts:
    """The first page: layout, stock, developability, build and structure, each pass or fail
    with its governing numbers, and what the structural model leaves out."""
    summary = result.summary
    items = []
    panels = summary.get("panels")
    if panels:
        g = panels.get("gates") or {}
        failed = _issues_coded(result, "layout-")
        items.append(
            Verdict(
                "Layout",
                "fail" if failed else "pass",
                (
                    (
                        f"{panels['count']} panels ({panels['method']}), "
                        f"{number(g.get('count_ratio', 0))} x the area's count"
                    ),
                    (
                        f"edges in 0.5-1.25 x size: {g.get('edges_in_band', 0):.0%}; corners in "
                        f"60-120°: {g.get('corners_in_60_120', 0):.0%}"
                    ),
                    (
                        f"shortest edge {cell(g.get('shortest_edge_mm'), 'x_mm')}; "
                        f"{len(failed)} layout issue(s)"
                    ),
                ),
            )
        )
    developed = summary.get("developability")
    if developed:
        classes = developed["classes"]
        bad = classes.get("not-developable", 0)
        total = sum(classes.values())
        # the cut stage's own check: sheets that unroll above the strain tolerance
        strained = len(_issues_coded(result, "unroll-strain"))
        items.append(
            Verdict(
                "Developable",
                "fail" if bad or strained else "pass",
                (
                    (
                        f"{total - bad} of {total} panels developable "
                        f"({', '.join(f'{v} {k}' for k, v in classes.items())})"
                    ),
                    (
                        f"largest unroll strain {number(developed['unroll_strain_max'])}; "
                        f"{strained} sheet(s) unroll above the strain tolerance"
                    ),
                    f"deviation from the design: {cell(developed['deviation_mm'], 'x_mm')}",
                    *_boundary_lines(developed),
                ),
            )
        )
    parts = summary.get("parts")
    if parts:
        checks = parts["checks"]
        clash = checks.get("clash", {})
        clashes = clash.get("clashes", 0) if isinstance(clash, dict) else 0
        unreachable = checks.get("bolts_unreachable") or 0
        not_built = checks.get("panels_not_built", 0)
        errors = len([i for i in result.issues if i.severity == "error"])
        ok = checks.get("all_valid", True) and not clashes and not unreachable and not not_built
        items.append(
            Verdict(
                "Buildable",
                "pass" if ok else "fail",
                (
                    (
                        f"{parts['count']} parts, {number(parts['mass_kg'])} kg "
                        f"({number(parts['mass_per_m2_kg'])} kg/m²); every solid valid: "
                        f"{cell(checks.get('all_valid'))}"
                    ),
                    (
                        f"clashes: {clashes}; bolts {checks.get('bolts_total', 0)}, unreachable "
                        f"{cell(checks.get('bolts_unreachable'))}; panels not built: {not_built}"
                    ),
                    (
                        f"{errors} error-level issue(s): panels with one are marked HOLD in "
                        "docs/panels.csv and on their drawing"
                    ),
                ),
            )
        )
    nests = summary.get("nests")
    if nests:
        left = nests.get("parts_left_out", 0)
        items.append(
            Verdict(
                "Fits the stock",
                "fail" if left else "pass",
                (
                    (
                        f"{nests.get('parts_placed', 0)} parts on {nests['plates']} plates, "
                        f"{nests.get('parts_left_out', 0)} left out"
                    ),
                    (
                        f"utilisation {nests.get('utilisation', 0):.0%}; bought "
                        f"{number(nests.get('bought_kg', 0))} kg for "
                        f"{number(nests.get('net_kg', 0))} kg net"
                    ),
                ),
            )
        )
    items.append(_structure_verdict(summary.get("structure", {})))
    errors, warnings = summary["issues"]["errors"], summary["issues"]["warnings"]
    items.append(
        Verdict(
            "Issues",
            "fail" if errors else "pass",
            (f"{errors} error(s), {warnings} warning(s): see Issues",),
        )
    )
    not_modelled = tuple(summary.get("structure", {}).get("assumptions", ()))
    return Verdicts(tuple(items), not_modelled)


def _structure_verdict(structure: dict) -> Verdict:
    if not structure.get("analysed"):
        return Verdict("Structure", "not checked", (str(structure.get("reason", "not run")),))
    d, s, b = structure["deflection"], structure["stress"], structure["buckling"]
    lines: tuple[str, ...] = (
        f"von Mises utilisation {number(s['utilisation'])} at {s['part']} ({s['combination']})",
        f"deflection {number(d['max_mm'])} mm = {d['ratio']} (limit {number(d['limit_mm'])} mm)",
        f"buckling factor {buckling_text(b)} (required {number(b['required'])})",
    )
    forming = structure.get("forming", {})
    if forming.get("sprung"):
        combined = (
            f"sprung sheets: ULS + locked-in stress utilisation "
            f"{number(forming['max_combined_utilisation'])} at {forming['part']} "
            f"({forming['uls_MPa']} + {forming['locked_in_MPa']} MPa)"
        )
        lines += (combined,)
    convergence = b.get("convergence", {})
    if convergence.get("table") and not convergence.get("converged"):
        lines += ("buckling mesh study NOT converged within 5 % (see Structure)",)
    gnia = b.get("gnia")
    if gnia:
        limit = "limit" if gnia["limit_reached"] else "no limit up to"
        amplitude = number(gnia["amplitude_mm"])
        text = f"GNIA {limit} {number(gnia['factor'])} (imperfection {amplitude} mm; "
        lines += (text + f"required {number(gnia['required'])})",)
    bolts = structure.get("bolts", {})
    if bolts.get("checked"):
        lines += (f"bolts: utilisation {number(bolts['utilisation'])}",)
    welds = structure.get("welds", {})
    if "utilisation" in welds:
        stiffeners = welds.get("stiffeners", {})
        lines += (
            f"welds: utilisation {number(welds['utilisation'])}"
            + (
                f" (stiffeners {number(stiffeners['utilisation'])})"
                if "utilisation" in stiffeners
                else ""
            ),
        )
    failed = [k for k, v in structure.get("checks", {}).items() if not v]
    if failed:
        lines += (f"fails: {', '.join(failed)}",)
    return Verdict("Structure", "pass" if structure.get("ok") else "fail", lines)


def keyplan_vector(source) -> Vector:
    from ..docs.keyplan import draw_keyplan

    svg, png = io.StringIO(), io.BytesIO()
    draw_keyplan(source, svg, "svg")
    draw_keyplan(source, png, "png")
    return Vector(svg.getvalue(), png.getvalue(), "Key plan: panel ids and erection sequence")


def layout_blocks(result) -> list[Block]:
    summary = result.summary.get("panels")
    if not summary or result.layout is None:
        return []
    from .figures import layout_figure

    gates = dict(summary.get("gates") or {})
    histogram = gates.pop("edge_histogram", None)
    blocks: list[Block] = [
        Heading("Panel layout", 2, "layout"),
        record_table({k: v for k, v in summary.items() if k != "gates"}),
        Heading("Layout gates", 3),
        record_table(gates),
    ]
    if histogram:
        bins = histogram["bins_vs_panel_size"]
        rows = tuple(
            (
                f"{number(lo)}-{number(hi) if hi is not None else '∞'} x size",
                str(count),
            )
            for lo, hi, count in zip(bins[:-1], bins[1:], histogram["counts"])
        )
        blocks.append(Table(("edge length", "edges"), rows, caption="Edge-length histogram"))
    blocks.append(Figure(layout_figure(result.layout, result.surface), "Panel layout, plan and 3D"))
    return blocks


def develop_blocks(result) -> list[Block]:
    summary = result.summary.get("developability")
    developed = result.developed
    if not summary or developed is None:
        return []
    from .develop_figures import curvature_figure, deviation_figure
    from .figures import panel_figure

    blocks: list[Block] = [
        Heading("Developability", 2, "develop"),
        record_table(summary),
        Figure(panel_figure(developed), "Panels coloured by class (blue planar, green "
               "single-curved, yellow conical, red not developable)"),
    ]  # fmt: skip
    for figure, caption in (
        (curvature_figure, "Gaussian curvature before and after"),
        (deviation_figure, "Deviation from the design surface"),
    ):
        png = figure(developed)
        if png is not None:
            blocks.append(Figure(png, caption))
    per_panel = developed.metrics.get("per_panel") or {}
    if per_panel:
        keys = list(next(iter(per_panel.values())).keys())
        rows = tuple(
            (pid, *(cell(record.get(k), k) for k in keys)) for pid, record in per_panel.items()
        )
        # the develop stage's forming is roll or press by radius; whether a sheet is rolled or
        # sprung is the cut stage's (rolling schedule)
        names = ["roll or press" if k == "forming" else label(k) for k in keys]
        blocks.append(Table(("panel", *names), rows, sortable=True, caption="Per panel"))
    return blocks


def parts_blocks(result) -> list[Block]:
    summary = result.summary.get("parts")
    if not summary:
        return []
    rows = tuple(
        (kind, str(count), cell(summary["mass_by_kind_kg"].get(kind), "x_kg"))
        for kind, count in summary["by_kind"].items()
    )
    checks = {k: v for k, v in summary["checks"].items() if k not in ("counts", "not_built")}
    return [
        Heading("Parts and build checks", 2, "parts"),
        Table(("kind", "parts", "mass"), rows),
        record_table(checks),
    ]


def schedule_blocks(source) -> list[Block]:
    from ..docs import schedules

    blocks: list[Block] = [
        Heading("Shop schedules", 2, "schedules"),
        Text("The same tables as docs/*.csv; the key plan as docs/keyplan.pdf (A3)."),
    ]
    for schedule in schedules(source):
        blocks += [
            Heading(f"{schedule.title} (docs/{schedule.name})", 3),
            Table(
                tuple(header_label(h) for h in schedule.header),
                schedule.rows,
                sortable=len(schedule.rows) > 12,
            ),
        ]
    return blocks


def cutting_blocks(result) -> list[Block]:
    flat, nests = result.summary.get("flat"), result.summary.get("nests")
    blocks: list[Block] = []
    if flat:
        blocks += [Heading("Flat parts", 2, "flat"), record_table(flat)]
    if nests:
        groups = nests.get("groups") or []
        suggestion = nests.get("stock_suggestion") or []
        blocks += [
            Heading("Nests", 2, "nests"),
            record_table(nests, skip=("groups", "stock_suggestion")),
        ]
        for title, records in (("Per material and thickness", groups),
                               ("Stock suggestion", suggestion)):  # fmt: skip
            if records:
                keys = list(records[0].keys())
                blocks += [
                    Heading(title, 3),
                    Table(
                        tuple(label(k) for k in keys),
                        tuple(tuple(cell(r.get(k), k) for k in keys) for r in records),
                    ),
                ]
    if result.nests is not None and result.out_dir is not None:
        items = []
        for plate in result.nests.plates:
            png = result.out_dir / "cut" / "nests" / f"{plate.name}.png"
            if png.exists():
                items.append(
                    (
                        thumbnail(png),
                        f"../cut/nests/{plate.name}.png",
                        f"{plate.name}: {_count(len(plate.placements), 'part')}, {plate.utilisation:.0%}",
                    )
                )
        if items:
            blocks += [
                Heading("Plates", 3),
                Text("Click a plate for the full image (cut/nests/*.png; DXF beside it)."),
                Gallery(tuple(items)),
            ]
    return blocks


def thumbnail(path: Path) -> bytes:
    """A small PNG of a plate image, ``THUMBNAIL_WIDTH`` px wide."""
    from PIL import Image

    with Image.open(path) as image:
        ratio = THUMBNAIL_WIDTH / max(image.width, 1)
        small = image.convert("RGB").resize(
            (THUMBNAIL_WIDTH, max(1, round(image.height * ratio))), Image.Resampling.LANCZOS
        )
    return palette_png(small)


def issue_blocks(result) -> list[Block]:
    if not result.issues:
        return [Heading("Issues", 2, "issues"), Text("None.")]
    counts = Counter((i.severity, i.code) for i in result.issues)
    summary_rows = tuple((severity, code, str(n)) for (severity, code), n in sorted(counts.items()))
    rows = tuple((i.severity, i.code, i.item or "", i.message) for i in result.issues)
    return [
        Heading("Issues", 2, "issues"),
        Table(("severity", "code", "count"), summary_rows),
        Table(("severity", "code", "item", "message"), rows, sortable=True),
    ]


def _boundary_lines(developed: dict) -> tuple[str, ...]:
    """The design boundary as the sheets follow it, and the sides that cut its chord."""
    deviation = developed.get("boundary_deviation_mm") or {}
    if not deviation:
        return ()
    chords = developed.get("boundary_chords") or {}
    followed = deviation.get("followed", deviation)
    worst = max(followed.get("design_to_panels", 0.0), followed.get("panels_to_design", 0.0))
    lines = [f"sheets within {number(worst)} mm of the design boundary"]
    if chords.get("sides"):
        lines[0] += " where they follow it"
        if chords.get("sides") == developed.get("boundary_sides"):
            lines[0] = "no boundary side follows the design boundary"
        lines.append(
            f"{chords['sides']} boundary side(s) cut the chord across it, up to "
            f"{number(chords['offset_mm_max'])} mm inside: a planar rib cannot follow a "
            f"boundary curving in the sheet's plane (boundary-chord)"
        )
    return tuple(lines)


def _count(n: int, noun: str) -> str:
    """``1 part``, ``2 parts``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"
