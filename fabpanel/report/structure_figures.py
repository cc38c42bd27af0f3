"""Structural figures and the report section of the structure stage: deformed shape (SLS),
von Mises utilisation map (ULS), first buckling mode, and the per-panel table."""

from __future__ import annotations

import html

import numpy as np

#: S8R node order around the element outline (corner, mid-side, corner...)
_OUTLINE = [0, 4, 1, 5, 2, 6, 3, 7]


def _sheet(structure, name: str = "TOP"):
    shell = structure.shell
    names = [g.name for g in shell.groups]
    mask = shell.group[: len(shell.quads)] == names.index(name)
    return shell.quads[mask][:, _OUTLINE], np.nonzero(mask)[0]


def _view_3d(ax, points):
    lo, hi = points.min(0), points.max(0)
    ax.set_xlim(lo[0], hi[0]), ax.set_ylim(lo[1], hi[1]), ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3))
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.view_init(elev=28, azim=-60)


def _shape_figure(structure, field: np.ndarray, title: str, label: str, cmap: str) -> str:
    """Top sheet moved by ``field (n, 3)`` scaled to 5 % of the model size, coloured by
    |field|, over the undeformed outline."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .html import _png

    shell = structure.shell
    polys, _ = _sheet(structure)
    size = float(np.ptp(shell.nodes, axis=0).max())
    amplitude = np.linalg.norm(field, axis=1)
    scale = 0.05 * size / max(amplitude.max(), 1e-300)
    moved = (shell.nodes + scale * field) / 1000.0
    values = amplitude[polys].mean(axis=1)
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
    _view_3d(ax, np.r_[moved[polys].reshape(-1, 3), shell.nodes[polys].reshape(-1, 3) / 1e3])
    ax.set_title(f"{title} (shown x{scale:.3g})", fontsize=10)
    fig.colorbar(faces, ax=ax, shrink=0.7, label=label)
    data = _png(fig)
    plt.close(fig)
    return data


def deformed_figure(structure) -> str:
    """Base64 PNG: the top sheet under the SLS combination with the largest displacement."""
    s = structure.summary["deflection"]
    return _shape_figure(
        structure,
        structure.displacement,
        f"deformed shape, {s['combination']}: max {s['max_mm']:.3g} mm ({s['ratio']})",
        "|u| [mm]",
        "viridis",
    )


def buckling_figure(structure) -> str | None:
    """Base64 PNG: the first positive buckling mode on the top sheet."""
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


def utilisation_figure(structure) -> str:
    """Base64 PNG, in plan: ULS von Mises utilisation of every top-sheet element, and of every
    panel (its largest over sheets and ribs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    from .html import _png

    shell = structure.shell
    polys, elements = _sheet(structure)
    plan = shell.nodes[polys][..., :2] / 1000.0
    per_panel = np.array(
        [structure.summary["panels"][pid]["utilisation"] for pid in structure.panel_ids]
    )
    top = structure.utilisation[elements]
    limit = max(float(structure.utilisation.max()), 1e-6)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    for ax, values, title in (
        (axes[0], top, "top sheet elements"),
        (axes[1], per_panel[shell.panel[elements, 0]], "panels (largest of sheets and ribs)"),
    ):
        cells = PolyCollection(
            plan, array=values, cmap="RdYlGn_r", clim=(0, limit), edgecolors="none"
        )
        ax.add_collection(cells)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]")
        ax.set_title(f"von Mises / fy, ULS, {title}: max {values.max():.3f}", fontsize=10)
    fig.colorbar(cells, ax=axes, shrink=0.8, label="utilisation [-]")
    data = _png(fig)
    plt.close(fig)
    return data


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
        f"{welds['utilisation']}: {ok(welds['ok'])}"
    )


def structure_section(result) -> str:
    """HTML of the structure section: key checks, figures, load cases, per-panel table."""
    from .html import _fmt, _table

    summary = result.summary.get("structure", {})
    structure = getattr(result, "structure", None)
    parts = ["<h2>Structure</h2>"]
    if not summary.get("analysed"):
        parts.append(f"<p><b>Not analysed:</b> {html.escape(str(summary.get('reason')))}</p>")
        return "".join(parts)
    ok = lambda flag: "OK" if flag else "FAILS"
    m, d, s, b = (summary[k] for k in ("mass", "deflection", "stress", "buckling"))
    mesh = summary["mesh"]
    reactions = "; ".join(f"{k}: {v['error']:.4%}" for k, v in summary["load_cases"].items())
    rows = [
        (
            "model",
            (
                f"{mesh['elements']} S8R, {mesh['nodes']} nodes, "
                f"{mesh['elements_per_side']} per panel side, "
                f"{summary['supports']['nodes']} {summary['supports'].get('fixity', 'pinned')} "
                f"anchor nodes in {len(summary['supports'].get('reactions', []))} supports "
                f"({summary['supports']['mode']})"
            ),
        ),
        (
            "mass",
            (
                f"{m['model_kg']} kg in the model, {m['parts_kg']} kg of parts "
                f"({m['error']:+.3%}): {ok(m['ok'])}"
            ),
        ),
        ("reactions", f"{reactions}: {ok(summary['checks']['reactions'])}"),
        (
            "deflection (SLS)",
            (
                f"{d['max_mm']} mm = {d['ratio']} at {d['panel']} "
                f"({d['combination']}); limit {d['limit_mm']} mm: {ok(d['ok'])}"
            ),
        ),
        (
            "von Mises (ULS)",
            (
                f"{s['max_von_mises_MPa']} MPa, utilisation {s['utilisation']} at "
                f"{s['part']} ({s['combination']}): {ok(s['ok'])}"
            ),
        ),
        (
            "buckling",
            (
                f"factors {', '.join(f'{f:.3g}' for f in b['factors'])} under "
                f"{b['combination']}; required {b['required']:.3g}: {ok(b['ok'])}"
            ),
        ),
        ("stiffeners", mesh["stiffeners"]),
        ("joint bolts", _bolts_row(summary.get("bolts", {}), ok)),
        ("sheet-to-rib welds", _welds_row(summary.get("welds", {}), ok)),
    ]
    if b.get("note"):
        rows.append(("buckling note", b["note"]))
    convergence = b.get("convergence", {})
    if convergence.get("table"):
        steps = ", ".join(
            f"{r['per_side']} per side: {r['first']:.4g}" for r in convergence["table"]
        )
        verdict = "converged" if convergence["converged"] else "NOT converged (budget)"
        rows.append(("buckling mesh study", f"{steps}: {verdict} within 5 %"))
    parts.append(_table(rows))
    if summary.get("assumptions"):
        items = "".join(f"<li>{html.escape(a)}</li>" for a in summary["assumptions"])
        parts.append(f"<h3>What the check assumes and leaves out</h3><ul>{items}</ul>")
    if structure is not None and structure.shell is not None:
        for figure, alt in (
            (deformed_figure, "deformed shape"),
            (utilisation_figure, "utilisation map"),
            (buckling_figure, "first buckling mode"),
        ):
            data = figure(structure)
            if data is not None:
                parts.append(f'<img alt="{alt}" src="data:image/png;base64,{data}">')
    cases = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{html.escape(v['description'])}</td>"
        f"<td>{_fmt(v['applied_N'])}</td><td>{_fmt(v['reaction_N'])}</td>"
        f"<td>{v['error']:.2e}</td></tr>"
        for k, v in summary["load_cases"].items()
    )
    parts.append(
        "<h3>Load cases</h3><table><tr><th>case</th><th>load</th><th>applied [N]</th>"
        f"<th>reaction [N]</th><th>error</th></tr>{cases}</table>"
    )
    supports = "".join(
        f"<tr><td>{html.escape(r['support'])}</td><td>{_fmt(r['centroid_mm'])}</td>"
        + "".join(f"<td>{_fmt(r['cases_kN'].get(c, []))}</td>" for c in ("G",))
        + f"<td>{_fmt(r['max_kN'])}</td><td>{_fmt(r['min_kN'])}</td>"
        f"<td>{_fmt(r['max_moment_kNm'])}</td></tr>"
        for r in summary["supports"].get("reactions", [])
    )
    if supports:
        parts.append(
            "<h3>Reactions per support</h3><p>Every case and combination per support is in "
            "<code>structure/reactions.csv</code>.</p><table><tr><th>support</th>"
            "<th>centroid [mm]</th><th>G [kN]</th><th>combinations max [kN]</th>"
            f"<th>combinations min [kN]</th><th>|moment| max [kN m]</th></tr>{supports}</table>"
        )
    modes = "".join(
        f"<tr><td>{mode['mode']}</td><td>{mode['factor']:.4g}</td>"
        f"<td>{mode['panel_count']}: {html.escape(', '.join(mode['panels']))}</td>"
        f"</tr>"
        for mode in b["modes"]
    )
    parts.append(
        "<h3>Buckling modes</h3><table><tr><th>mode</th><th>factor</th>"
        f"<th>panels involved</th></tr>{modes}</table>"
    )
    panels = sorted(summary["panels"].items(), key=lambda kv: -kv[1]["utilisation"])
    body = "".join(
        f"<tr><td>{pid}</td><td>{rec['utilisation']:.3f}</td>"
        f"<td>{html.escape(rec['part'])}</td><td>{rec['displacement_mm']:.3g}</td>"
        f"<td>{', '.join(map(str, rec['buckling_modes']))}</td></tr>"
        for pid, rec in panels
    )
    parts.append(
        "<details><summary>Per panel (largest utilisation first)</summary><table><tr>"
        "<th>panel</th><th>utilisation</th><th>where</th><th>max |u| SLS [mm]</th>"
        f"<th>in buckling modes</th></tr>{body}</table></details>"
    )
    return "".join(parts)
