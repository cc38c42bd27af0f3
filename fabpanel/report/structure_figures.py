"""Structural figures and the report section of the structure stage: deformed shape (SLS),
von Mises utilisation map (ULS), first buckling mode, and the per-panel table."""

from __future__ import annotations

import numpy as np

from ..structure.analysis import element_counts
from ..structure.convergence import last_step

#: S8R node order around the element outline (corner, mid-side, corner...)
_OUTLINE = [0, 4, 1, 5, 2, 6, 3, 7]


def _sheet(structure, name: str = "TOP"):
    shell = structure.shell
    names = [g.name for g in shell.groups]
    mask = shell.group[: len(shell.quads)] == names.index(name)
    return shell.quads[mask][:, _OUTLINE], np.nonzero(mask)[0]


def _shape_figure(structure, field: np.ndarray, title: str, label: str, cmap: str) -> bytes:
    """Top sheet moved by ``field (n, 3)`` scaled to 5 % of the model size, coloured by
    |field|, over the undeformed outline."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .figures import png_bytes, view_3d

    shell = structure.shell
    polys, _ = _sheet(structure)
    size = float(np.ptp(shell.nodes, axis=0).max())
    amplitude = np.linalg.norm(field, axis=1)
    scale = 0.05 * size / max(amplitude.max(), 1e-300)
    moved = (shell.nodes + scale * field) / 1000.0
    # each element coloured by its largest nodal value, so the colour bar ends at the largest
    # value drawn, which the title names
    values = amplitude[polys].max(axis=1)
    fig = plt.figure(figsize=(8, 5.2))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(
        Poly3DCollection(
            shell.nodes[polys] / 1000.0, facecolor="none", edgecolor="0.75", linewidth=0.3
        )
    )
    faces = Poly3DCollection(moved[polys], cmap=cmap, edgecolor="k", linewidth=0.1)
    faces.set_array(values)
    ax.add_collection3d(faces)
    view_3d(ax, np.r_[moved[polys].reshape(-1, 3), shell.nodes[polys].reshape(-1, 3) / 1e3])
    faces.set_clim(0.0, max(float(values.max()), 1e-300))
    ax.set_title(f"{title.format(top=values.max())} (shown x{scale:.3g})", fontsize=10)
    fig.colorbar(faces, ax=ax, shrink=0.7, label=label)
    data = png_bytes(fig)
    plt.close(fig)
    return data


def deformed_figure(structure) -> bytes:
    """PNG: the top sheet under the SLS combination with the largest displacement."""
    s = structure.summary["deflection"]
    return _shape_figure(
        structure,
        structure.displacement,
        f"deformed shape, {s['combination']}: top sheet max {{top:.3g}} mm\n(whole model "
        f"{s['max_mm']:.3g} mm, {s['ratio']})",
        "|u| [mm]",
        "viridis",
    )


def buckling_figure(structure) -> bytes | None:
    """PNG: the first positive buckling mode on the top sheet."""
    if structure.mode_shape is None:
        return None
    b = structure.summary["buckling"]
    return _shape_figure(
        structure,
        structure.mode_shape,
        f"buckling mode 1 under {b['combination']}: factor {b['first']:.3g} "
        f"(required {b['required']:.3g})",
        "relative amplitude",
        "magma",
    )


def utilisation_figure(structure) -> bytes:
    """PNG, in 3D (a plan squashes the steep sides, where the largest values often sit): ULS
    von Mises utilisation of every top-sheet element, and of every panel (its largest over
    sheets and ribs), on one colour scale ending at the largest value drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .figures import png_bytes, view_3d

    shell = structure.shell
    polys, elements = _sheet(structure)
    points = shell.nodes[polys] / 1000.0
    per_panel = np.array(
        [structure.summary["panels"][pid]["utilisation"] for pid in structure.panel_ids]
    )
    top = structure.utilisation[elements]
    panels = per_panel[shell.panel[elements, 0]]
    limit = max(float(top.max()), float(panels.max()), 1e-6)
    fig = plt.figure(figsize=(12, 5.0))
    for index, (values, title) in enumerate(
        (
            (top, "top sheet elements"),
            (panels, "panels (largest of sheets and ribs)"),
        ),
        start=1,
    ):
        ax = fig.add_subplot(1, 2, index, projection="3d")
        cells = Poly3DCollection(points, cmap="RdYlGn_r", edgecolor="none")
        cells.set_array(values)
        cells.set_clim(0.0, limit)
        ax.add_collection3d(cells)
        view_3d(ax, points.reshape(-1, 3))
        ax.set_title(f"von Mises / fy, ULS, {title}:\nmax {values.max():.3f}", fontsize=10)
    fig.colorbar(cells, ax=fig.axes, shrink=0.7, label="utilisation [-]")
    data = png_bytes(fig)
    plt.close(fig)
    return data


def _gnia_row(g: dict, ok) -> str:
    """The GNIA's limit factor beside the LBA, with the imperfection it assumed."""
    limit = "limit" if g["limit_reached"] else "no limit up to"
    where = f", r {g['radius_mm']} mm, t {g['thickness_mm']:g} mm" if g.get("radius_mm") else ""
    return (
        f"{limit} {g['factor']:.4g} (LBA {g['lba']:.4g}, ratio {g['ratio_to_lba']}; "
        f"first yield, linear, at {g['first_yield_linear']:.4g}); "
        f"imperfection {g['amplitude_mm']} mm ({g['amplitude_source']}{where}), both signs "
        f"({', '.join(p['sign'] + ' ' + format(p['limit'], '.4g') for p in g['paths'])}); "
        f"required {g['required']:g}: {ok(g['ok'])}"
    )


def _unsettled(buckling: dict) -> str:
    """ ", NOT converged (the factor fell by 40% ...)" where the mesh study stopped before the
    first factor settled: an OK that a finer mesh may overturn."""
    convergence = buckling.get("convergence", {})
    if len(convergence.get("table", ())) < 2 or convergence.get("converged", True):
        return ""
    return f" at the finest mesh allowed, NOT converged (the first factor {last_step(convergence)})"


def _bolts_row(bolts: dict, ok) -> str:
    """The joint bolts' check in one line (or why there is none)."""
    if not bolts.get("checked"):
        return str(bolts.get("why", "not checked"))
    g, r = bolts["governing"], bolts["resistance_kN"]
    return (
        f"{bolts['bolts']} bolts {bolts['bolt']}, largest shear {bolts['max_shear_kN']} kN "
        f"(F_v,Rd {r['shear']} kN, F_b,Rd from {r['bearing_min']} kN), tension "
        f"{bolts['max_tension_kN']} kN (F_t,Rd {r['tension']} kN); utilisation "
        f"{bolts['utilisation']} at {g['bolt']} ({g['check']}, {g['combination']}); every "
        f"bolt in structure/bolts.csv: {ok(bolts['ok'])}"
    )


def _welds_row(welds: dict, ok) -> str:
    """The sheet-to-rib welds' check in one line."""
    if "governing" not in welds:
        return f"{welds.get('edges', 0)} sheet edges on ribs: nothing to check"
    g = welds["governing"]
    return (
        f"{welds['edges']} sheet-edge segments, fillet a = {welds['throat_mm']:.2f} mm, "
        f"F_w,Rd {welds['resistance_N_per_mm']} N/mm (beta_w {welds['beta_w']}); largest "
        f"{g['force_N_per_mm']} N/mm (along {g['along_N_per_mm']}, across "
        f"{g['across_N_per_mm']}, out of plane {g['out_of_plane_N_per_mm']} N/mm, edge moment "
        f"{g['moment_Nmm_per_mm']} N mm/mm) at {g['panel']} ({g['combination']}); utilisation "
        f"{welds['utilisation']}"
        + _stiffener_welds(welds.get("stiffeners"))
        + f": {ok(welds['ok'])}"
    )


def _stiffener_welds(stiffeners: dict | None) -> str:
    """The corner stiffeners' welds, appended to the welds' line."""
    if not stiffeners or "governing" not in stiffeners:
        return ""
    g = stiffeners["governing"]
    return (
        f"; corner stiffeners all round: {stiffeners['edges']} plate sides, 2 fillets a = "
        f"{stiffeners['throat_mm']:.2f} mm, F_w,Rd {stiffeners['resistance_N_per_mm']} N/mm, "
        f"largest {g['force_N_per_mm']} N/mm at {g['panel']} ({g['combination']}), "
        f"utilisation {stiffeners['utilisation']}"
    )


def structure_blocks(result) -> list:
    """The structure section as report blocks: key checks, figures, load cases, reactions per
    support, buckling modes, the per-panel table."""
    from .blocks import Bullets, Figure, Heading, Table, Text, cell

    summary = result.summary.get("structure", {})
    structure = getattr(result, "structure", None)
    blocks: list = [Heading("Structure", 2, "structure")]
    if not summary.get("analysed"):
        blocks.append(Text(f"Not analysed: {summary.get('reason')}"))
        return blocks
    ok = lambda flag: "OK" if flag else "FAILS"
    m, d, s, b = (summary[k] for k in ("mass", "deflection", "stress", "buckling"))
    mesh = summary["mesh"]
    reactions = "; ".join(f"{k}: {v['error']:.4%}" for k, v in summary["load_cases"].items())
    rows = [
        (
            "model",
            (
                f"{element_counts(mesh)}, {mesh['nodes']} nodes, {mesh['elements_per_side']} per "
                f"panel side, {summary['supports']['nodes']} "
                f"{summary['supports'].get('fixity', 'pinned')} anchor nodes in "
                f"{len(summary['supports'].get('reactions', []))} supports "
                f"({summary['supports']['mode']})"
            ),
        ),
        (
            "mass",
            (
                f"{m['model_kg']} kg in the model, {m['parts_kg']} kg of parts ({m['error']:+.3%}): "
                f"{ok(m['ok'])}"
            ),
        ),
        ("reactions", f"{reactions}: {ok(summary['checks']['reactions'])}"),
        (
            "deflection (SLS)",
            (
                f"{d['max_mm']} mm = {d['ratio']} at {d['panel']} ({d['combination']}); limit "
                f"{d['limit_mm']} mm: {ok(d['ok'])}"
            ),
        ),
        (
            "von Mises (ULS)",
            (
                f"{s['max_von_mises_MPa']} MPa, utilisation {s['utilisation']} at {s['part']} "
                f"({s['combination']}): {ok(s['ok'])}"
            ),
        ),
        (
            "buckling",
            (
                f"factors {', '.join(f'{f:.3g}' for f in b['factors'])} under {b['combination']}; "
                f"required {b['required']:.3g}: {ok(b['ok'])}{_unsettled(b)}"
            ),
        ),
        ("stiffeners", str(mesh["stiffeners"])),
        ("joint bolts", _bolts_row(summary.get("bolts", {}), ok)),
        ("welds", _welds_row(summary.get("welds", {}), ok)),
    ]
    if b.get("note"):
        rows.append(("buckling note", b["note"]))
    if b.get("gnia"):
        rows.append(("GNIA (imperfect, nonlinear)", _gnia_row(b["gnia"], ok)))
    convergence = b.get("convergence", {})
    if convergence.get("table"):
        steps = ", ".join(
            f"{r['per_side']} per side: {r['first']:.4g}" for r in convergence["table"]
        )
        verdict = "converged" if convergence["converged"] else "NOT converged (budget)"
        rows.append(("buckling mesh study", f"{steps}: {verdict} within 5 %"))
    blocks.append(Table(("check", "result"), tuple(rows)))
    if summary.get("assumptions"):
        blocks += [
            Heading("What the check assumes and leaves out", 3),
            Bullets(tuple(summary["assumptions"])),
        ]
    if structure is not None and structure.shell is not None:
        for figure, caption in (
            (deformed_figure, "Deformed shape (SLS)"),
            (utilisation_figure, "Utilisation (ULS)"),
            (buckling_figure, "First buckling mode"),
        ):
            png = figure(structure)
            if png is not None:
                blocks.append(Figure(png, caption))
    blocks += [
        Heading("Load cases", 3),
        Table(
            ("case", "load", "applied [N]", "reaction [N]", "error"),
            tuple(
                (
                    k,
                    v["description"],
                    cell(v["applied_N"]),
                    cell(v["reaction_N"]),
                    f"{v['error']:.2e}",
                )
                for k, v in summary["load_cases"].items()
            ),
        ),
    ]
    supports = summary["supports"].get("reactions", [])
    if supports:
        blocks += [
            Heading("Reactions per support", 3),
            Text(
                "Every case and combination per support is in structure/reactions.csv, "
                "the supports' places (the moments' centres) in structure/supports.csv."
            ),
            Table(
                (
                    "support",
                    "centroid [mm]",
                    "G [kN]",
                    "combinations max [kN]",
                    "combinations min [kN]",
                    "|moment| max [kN m]",
                ),
                tuple(
                    (
                        r["support"],
                        cell(r["centroid_mm"]),
                        cell(r["cases_kN"].get("G", [])),
                        cell(r["max_kN"]),
                        cell(r["min_kN"]),
                        cell(r["max_moment_kNm"]),
                    )
                    for r in supports
                ),
            ),
            Table(
                ("support", "case", "Fx, Fy, Fz [kN]", "Mx, My, Mz [kN m]"),
                tuple(
                    (r["support"], case, cell(force), cell(r["cases_kNm"][case]))
                    for r in supports
                    for case, force in r["cases_kN"].items()
                ),
            ),
        ]
    blocks += [
        Heading("Buckling modes", 3),
        Table(
            ("mode", "factor", "panels involved"),
            tuple(
                (
                    str(mode["mode"]),
                    f"{mode['factor']:.4g}",
                    f"{mode['panel_count']}: {', '.join(mode['panels'])}",
                )
                for mode in b["modes"]
            ),
        ),
    ]
    panels = sorted(summary["panels"].items(), key=lambda kv: -kv[1]["utilisation"])
    blocks.append(
        Table(
            ("panel", "utilisation", "where", "max |u| SLS [mm]", "in buckling modes"),
            tuple(
                (
                    pid,
                    f"{rec['utilisation']:.3f}",
                    rec["part"],
                    f"{rec['displacement_mm']:.3g}",
                    ", ".join(map(str, rec["buckling_modes"])),
                )
                for pid, rec in panels
            ),
            sortable=True,
            caption="Per panel (largest utilisation first)",
        )
    )
    return blocks
