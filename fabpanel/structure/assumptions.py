"""What the structural check assumes and leaves out, in one list for the checking engineer
(``report/summary.json`` -> ``structure.assumptions`` and the report's first structure table)."""

from __future__ import annotations

from .actions import TERRAIN, WindProfile


def assumptions(job, reference_height_m: float | None, sprung: int, band: float = 0.0) -> list[str]:
    """Sentences, each one assumption (national values, models, simplifications, omissions);
    ``band``: for ``supports = "lowest"``, the band used (mm, raised from ``support_band``
    where the lowest ribs alone did not surround the shell)."""
    loads, st = job.loads, job.structure
    out = []
    if loads.code == "thesis":
        out.append(
            f"loads of the thesis §7.3: snow {loads.snow * 1e3:g} kN/m2 on the plan, wind "
            f"{loads.wind * 1e3:g} kN/m2 projected along {list(loads.wind_direction)}; "
            f"combinations {loads.gamma_g:g} G + {loads.gamma_q:g} Q"
        )
    else:
        out.append(
            "national annex values as given in [loads] (recommended EN values where not): "
            f"s_k = {loads.snow_ground * 1e3:g} kN/m2, C_e = {loads.snow_exposure:g}, "
            f"C_t = {loads.snow_thermal:g}; v_b,0 = {loads.wind_speed:g} m/s, "
            f"c_dir c_season = {loads.wind_factor:g}, terrain category {loads.terrain}, "
            "c_0 = 1 (no orography)"
        )
        if reference_height_m is not None:
            q_p = WindProfile(loads.wind_speed, loads.terrain, c_dir=loads.wind_factor)
            z_min = TERRAIN[loads.terrain][1]
            out.append(
                f"wind reference height: the shell's top, {reference_height_m:.1f} m above the "
                f"ground (q_p = {q_p.peak_pressure(reference_height_m):.3g} kN/m2"
                + (
                    f", taken at terrain {loads.terrain}'s z_min = {z_min:g} m)"
                    if reference_height_m < z_min
                    else ")"
                )
            )
        out += [
            (
                "external wind pressure coefficients APPROXIMATE: c_pe,10 of a duopitch roof "
                "(EN 1991-1-4 Table 7.4a, zone H facing the wind, zone I away) at each element's "
                "pitch; no code figure covers a free-form shell, so a wind-tunnel or CFD study "
                "replaces them for a final design"
            ),
            (
                "the same rule for every wind direction, also along a vault's axis (Table 7.4a "
                "at theta = 0); c_pe,10 everywhere: the local checks of sheets and fixings, on "
                "loaded areas under 10 m2, would take c_pe,1 (not done)"
            ),
            f"internal pressure under the shell c_pi = {list(loads.internal_pressure)}, both",
            (
                "snow: mu_1 by pitch (Table 5.2), undrifted and four half-span cases; the drifted "
                "load of cylindrical roofs (§5.3.5) and drifts at obstructions are not applied"
            ),
            (
                f"combinations EN 1990 (6.10): gamma_G {loads.gamma_g_sup:g} / {loads.gamma_g_inf:g}, "
                f"gamma_Q {loads.gamma_q:g}, psi_0 snow {loads.psi0_snow:g}, wind "
                f"{loads.psi0_wind:g}; SLS characteristic"
            ),
        ]
    if st.joints == "bolted":
        out.append(
            "bolted joints: each panel's ribs and sheets are its own shells, the back-to-back "
            "ribs joined at the bolts by linear springs (EN 1993-1-8 Table 6.11: shear k_11 in "
            "series with bearing k_12 in both ribs, k_b = 1.25; the bolt's axial k_10 split "
            "between the two sheet levels, so the joint bends about the compressed sheet); "
            "clearance slip of the snug-tight bolts not modelled; contact in compression as "
            "stiff as the bolt (softer than it is); bolts checked for shear, bearing (from the "
            "pitch and the distance to the rib's end, the rib's welded edges not limiting; "
            "single lap cap) and tension, category A/D, with the tension of a bolt row N + |M| / (h/2)"
        )
    else:
        out.append(
            'bolted joints NOT modelled ([structure] joints = "rigid"): back-to-back ribs are '
            "one continuous shell of twice the rib thickness; bolts not checked"
        )
    out += [
        (
            "rib-to-sheet welds: one fillet weld per sheet edge, EN 1993-1-8 4.5.3.3 "
            "(simplified method) on the sheet edge's membrane traction plus its edge moment "
            "as a couple over the rib thickness, read at the edge nodes of the model (stresses "
            "extrapolated from the elements' integration points)"
        ),
        (
            "corner stiffeners: S8 plates between the sheets' mid-surfaces, their ends tied to "
            "the ribs' translations at stiffener_offset from the corner and their top and bottom "
            "edges to the sheets' (the weld lines as hinges); their welds all round (a fillet "
            "on both faces, throat up to 3 mm) checked as the sheet edges' from the plates' "
            "edge stresses (one element a stiffener: a coarse reading)"
            if st.stiffeners == "plates"
            else "corner stiffeners are mass only, lumped on the panel corner lines (no "
            'stiffness: [structure] stiffeners = "mass")'
        ),
        (
            f"supports: {_which_supports(st, band)} boundary ribs, {st.support_fixity} at their "
            "anchor-bolt nodes (mid-depth; every rib node when fixed); foundations rigid"
        ),
        "material linear elastic; von Mises at the shell faces against f_y with gamma_M0 = 1.0",
        _buckling(job),
        (
            f"{sprung} sheets sprung onto their ribs: their locked-in bending E t / (2 R) is "
            "added to their ULS stress; rolled sheets' residual stresses are not modelled"
            if sprung
            else "no sprung sheets checked (rolled sheets' residual stresses are not modelled)"
        ),
    ]
    return out


def _buckling(job) -> str:
    """What the buckling check does and leaves out."""
    st = job.structure
    text = f"buckling: linear (LBA) with a knock-down of {job.loads.buckling_knockdown:.3g}"
    text += (
        "; the first factor's mesh convergence checked at finer sizes"
        if st.buckling_convergence
        else "; no mesh-convergence study"
    )
    if not st.gnia:
        return text + "; no geometrically nonlinear analysis with imperfections (GNIA)"
    amplitude = (
        f"{st.imperfection_amplitude:g} mm as given"
        if st.imperfection_amplitude is not None
        else f"EN 1993-1-6 §8.7.2's dimple amplitude for tolerance class {st.tolerance_class} "
        "(Table 8.8 U_n1 = U_n2, n_i = 25, l_g = 4 sqrt(r t) capped at the panel size)"
    )
    return text + (
        f"; GNIA: the first LBA mode as the imperfection, {amplitude}, both signs, the "
        "governing combination ramped with NLGEOM to its limit point; elastic (no yielding: "
        f"not a GMNIA), the limit factor required to reach gamma_M1 = {st.gamma_m1:g}"
    )


def _which_supports(st, band: float) -> str:
    """The supports' choice in words: the band of ``"lowest"``, said raised where it was."""
    if st.supports != "lowest":
        return str(st.supports)
    if band > st.support_band:
        return (
            f"lowest (within {band:.0f} mm of the lowest boundary point: the "
            f"{st.support_band:g} mm band raised until they surround the shell's centre in plan)"
        )
    return f"lowest (within {st.support_band:g} mm of the lowest boundary point)"
