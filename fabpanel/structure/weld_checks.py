"""The sheet-to-rib fillet welds, and those all round the corner stiffener plates, checked under
every ULS combination (EN 1993-1-8 §4.5.3.3).

Every sheet edge of the shell model stands on a rib (the sandwich's junction lines) and is
joined to it by one fillet weld of throat ``a`` (``[sandwich.welds] throat``), so everything the
sheet edge carries passes through that weld. From the sheet elements along each junction the
force per unit length on the edge is read at the edge's three nodes:

* the membrane traction ``t (σ_m · m)``, with ``σ_m`` the mean of the two faces' stresses and
  ``m`` the edge's outward normal in the sheet: shear flow along the weld, the force across it
  in the sheet's plane, and out of it;
* the edge moment ``t² / 6 |σ_b · m|`` (``σ_b`` half the faces' difference), which the joint
  carries as a couple between the weld and the sheet bearing on the rib's top, its lever the
  rib thickness, so it adds ``|moment| / t_rib`` to the weld's force.

The weld force per unit length is the length of the traction plus the couple's force (an upper
bound of their vector sum), against the simplified method's ``F_w,Rd = a f_u / (√3 β_w
γ_M2)``, with ``β_w`` by the steel's grade (EN 1993-1-8 Table 4.1) and ``γ_M2 = 1.25``. The
directional method (§4.5.3.2) would allow more where the force runs along the weld; the
simplified one needs no weld geometry beyond the throat, and is on the safe side.

A corner stiffener plate (:mod:`.stiffeners`, one S8 element) is welded all round, on both
faces (W3 of the weld schedule, throat up to 3 mm): its four sides are read the same way, the
traction from the plate's own edge stresses, against twice a fillet's resistance. Its welds
are hinges in the model (its ties hold translations only), so the edge moment there is small.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import Issue
from .connectors import GAMMA_M2
from .mesh import ShellModel

#: utilisations above this are an error
LIMIT = 1.0
#: the three S8R nodes of each side: corner, mid-side node, corner
SIDE_NODES = np.array([[0, 4, 1], [1, 5, 2], [2, 6, 3], [3, 7, 0]])
#: EN 1993-1-8 Table 4.1: beta_w by yield strength (N/mm²) of the weaker part, up to
_BETA_W = ((235.0, 0.80), (275.0, 0.85), (355.0, 0.90), (math.inf, 1.00))


def beta_w(fy: float) -> float:
    """The correlation factor of a fillet weld in steel of yield strength ``fy`` (MPa):
    S235 0.80, S275 0.85, S355 0.90, S420 and S460 1.00."""
    return next(beta for limit, beta in _BETA_W if fy <= limit + 1e-9)


@dataclass(frozen=True)
class FilletWeld:
    """A welded joint: the throat ``a`` of its fillets and the lever an edge moment acts on as
    a couple (mm: the rib a sheet stands on; the plate welded on both faces), the steel's
    ``fu`` and ``fy`` (MPa), and its fillets (1: a sheet edge, 2: a plate on both faces)."""

    throat: float
    lever: float
    fu: float
    fy: float
    fillets: int = 1

    @classmethod
    def of(cls, job) -> FilletWeld:
        from ..buildup import Buildup

        bu = Buildup.of(job)
        return cls(
            throat=bu.welds.throat,
            lever=bu.t_rib,
            fu=float(job.material.fu),
            fy=float(job.material.fy),
        )

    @classmethod
    def stiffener_of(cls, job) -> FilletWeld:
        """The corner stiffeners' weld (W3 of the weld schedule): a fillet on both faces of
        the plate, of the job's throat up to :data:`~fabpanel.welds.PLATE_THROAT`; an edge
        moment is a couple across the plate's thickness."""
        from ..buildup import Buildup
        from ..welds import PLATE_THROAT

        bu = Buildup.of(job)
        return cls(
            throat=min(bu.welds.throat, PLATE_THROAT),
            lever=bu.t_stf,
            fu=float(job.material.fu),
            fy=float(job.material.fy),
            fillets=2,
        )

    @property
    def resistance(self) -> float:
        """``F_w,Rd`` per unit length of the joint, N/mm: ``a f_u / (√3 β_w γ_M2)``
        (§4.5.3.3) for each of its fillets."""
        one = self.throat * self.fu / (math.sqrt(3.0) * beta_w(self.fy) * GAMMA_M2)
        return self.fillets * one


def junction_edges(shell: ShellModel) -> tuple[np.ndarray, np.ndarray]:
    """The sheet elements' sides that lie on a rib: ``(element, side)`` (k,) each, the side
    numbered as :data:`SIDE_NODES`. A side lies on a rib where its three nodes all belong to
    rib elements (ribs meet sheets only along the junction lines)."""
    assert shell.side is not None
    quads = shell.quads
    rib = shell.side[: len(quads)] >= 0
    on_rib = np.zeros(len(shell.nodes), dtype=bool)
    on_rib[quads[rib].ravel()] = True
    sheets = np.flatnonzero(~rib)
    sides = on_rib[quads[sheets][:, SIDE_NODES]].all(axis=2)  # (s, 4)
    element, side = np.nonzero(sides)
    return sheets[element], side


def edge_frames(shell: ShellModel, element: np.ndarray, side: np.ndarray) -> np.ndarray:
    """(k, 2, 3): per junction side, the unit direction along it and its outward normal in
    the sheet's plane (away from the element's centre)."""
    quads = shell.quads[element]
    corners = shell.nodes[quads[:, :4]]
    ends = shell.nodes[quads[np.arange(len(side))[:, None], SIDE_NODES[side][:, [0, 2]]]]
    along = ends[:, 1] - ends[:, 0]
    along /= np.linalg.norm(along, axis=1, keepdims=True)
    normal = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    outward = np.cross(along, normal)
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    away = ends.mean(axis=1) - corners.mean(axis=1)
    outward *= np.sign(np.einsum("ki,ki->k", outward, away))[:, None]
    return np.stack([along, outward], axis=1)


def _tensor(stress: np.ndarray) -> np.ndarray:
    """(..., 3, 3) from (..., 6) components in .frd order (xx, yy, zz, xy, yz, zx)."""
    xx, yy, zz, xy, yz, zx = np.moveaxis(stress, -1, 0)
    return np.stack(
        [np.stack([xx, xy, zx], -1), np.stack([xy, yy, yz], -1), np.stack([zx, yz, zz], -1)], -2
    )


def edge_loads(
    shell: ShellModel,
    s_bot: np.ndarray,
    s_top: np.ndarray,
    element: np.ndarray,
    side: np.ndarray,
    frames: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Per static case, at the three nodes of every junction side: the membrane traction
    (C, k, 3, 3) N/mm, world, and the edge moment vector (C, k, 3, 3) N mm/mm, from the
    faces' stresses ``s_bot``, ``s_top`` (C, E, 8, 6)."""
    local = SIDE_NODES[side]  # (k, 3) local node numbers
    bottom = _tensor(s_bot[:, element[:, None], local])  # (C, k, 3, 3, 3)
    top = _tensor(s_top[:, element[:, None], local])
    t = shell.thickness[element][None, :, None, None]
    outward = frames[:, 1]  # (k, 3)
    membrane = np.einsum("ckaij,kj->ckai", 0.5 * (bottom + top), outward) * t
    bending = np.einsum("ckaij,kj->ckai", 0.5 * (top - bottom), outward) * t**2 / 6.0
    return membrane, bending


def weld_checks(
    shell: ShellModel,
    s_bot: np.ndarray,
    s_top: np.ndarray,
    factors: np.ndarray,
    names: list[str],
    weld: FilletWeld,
    panel_ids: tuple[str, ...],
    stiffener_weld: FilletWeld | None = None,
    origin: np.ndarray | None = None,
) -> tuple[dict, list[Issue]]:
    """Every junction's fillet weld under every ULS combination (``factors`` (K, C), named
    ``names``); the summary (resistance, the worst weld force and its parts, where and under
    which combination) and an error where a weld is overloaded. With ``stiffener_weld``, the
    welds all round the corner stiffener plates too (:func:`stiffener_edges`), in the
    summary's ``stiffeners``."""
    element, side = junction_edges(shell)
    summary, issues = _edge_check(
        shell, (s_bot, s_top), factors, names, weld, panel_ids, element, side, SHEET_EDGES
    )
    summary["method"] = "EN 1993-1-8 4.5.3.3 (simplified), one fillet weld per sheet edge"
    _in_design_frame(summary, origin)
    if stiffener_weld is not None:
        element, side = stiffener_edges(shell)
        if len(element):
            stiffeners, more = _edge_check(
                shell,
                (s_bot, s_top),
                factors,
                names,
                stiffener_weld,
                panel_ids,
                element,
                side,
                STIFFENER_SIDES,
            )
            _in_design_frame(stiffeners, origin)
            stiffeners["method"] = (
                "EN 1993-1-8 4.5.3.3 (simplified), a fillet weld on both faces all round"
            )
            summary["stiffeners"] = stiffeners
            summary["ok"] = bool(summary["ok"] and stiffeners["ok"])
            issues += more
    return summary, issues


@dataclass(frozen=True)
class _Wording:
    """How an overloaded weld of one kind is reported."""

    code: str
    what: str
    fix: str


SHEET_EDGES = _Wording(
    "weld-overloaded", "sheet edge(s)", "raise [sandwich.welds] throat or the sheet thickness"
)
STIFFENER_SIDES = _Wording(
    "stiffener-weld-overloaded",
    "corner stiffener side(s)",
    "raise [sandwich.welds] throat (up to 3 mm on a stiffener) or [sandwich] stiffener_thickness",
)


def stiffener_edges(shell: ShellModel) -> tuple[np.ndarray, np.ndarray]:
    """Every side of the corner stiffener plates (group ``STF``): ``(element, side)`` (k,)
    each. Each side is welded: its ends to the two ribs, its top and bottom to the sheets."""
    names = [g.name for g in shell.groups]
    if "STF" not in names:
        return np.zeros(0, int), np.zeros(0, int)
    plates = np.flatnonzero(shell.group[: len(shell.quads)] == names.index("STF"))
    return np.repeat(plates, 4), np.tile(np.arange(4), len(plates))


def _edge_check(
    shell: ShellModel,
    stresses: tuple[np.ndarray, np.ndarray],
    factors: np.ndarray,
    names: list[str],
    weld: FilletWeld,
    panel_ids: tuple[str, ...],
    element: np.ndarray,
    side: np.ndarray,
    wording: _Wording,
) -> tuple[dict, list[Issue]]:
    """The welds along the element sides ``(element, side)`` (see the module docstring; the
    edge moment a couple on the lever ``weld.lever``: with a fillet on both faces each takes
    half the traction and the whole couple's force, so the joint's force is the traction plus
    ``fillets x moment / lever`` against ``fillets x`` a fillet's resistance)."""
    resistance = weld.resistance
    summary: dict = {
        "throat_mm": round(weld.throat, 3),
        "fillets": weld.fillets,
        "beta_w": beta_w(weld.fy),
        "gamma_M2": GAMMA_M2,
        "resistance_N_per_mm": round(resistance, 1),
        "edges": len(element),
    }
    if not len(element) or not len(factors):
        return {**summary, "ok": True, "utilisation": 0.0}, []
    frames = edge_frames(shell, element, side)
    membrane, bending = edge_loads(shell, *stresses, element, side, frames)
    combined_m = np.einsum("kc,cnai->knai", factors, membrane)  # (K, k, 3, 3)
    combined_b = np.einsum("kc,cnai->knai", factors, bending)
    moment = np.linalg.norm(combined_b, axis=-1)
    force = np.linalg.norm(combined_m, axis=-1) + weld.fillets * moment / weld.lever
    worst = np.unravel_index(int(np.argmax(force)), force.shape)
    combo, edge, node = (int(i) for i in worst)
    utilisation = float(force[worst]) / resistance
    assert shell.panel is not None
    summary.update(
        utilisation=round(utilisation, 4),
        ok=bool(utilisation <= LIMIT),
        governing={
            "combination": names[combo],
            "force_N_per_mm": round(float(force[worst]), 1),
            **_parts(combined_m[worst], frames[edge]),
            "moment_Nmm_per_mm": round(float(moment[worst]), 1),
            "panel": panel_ids[int(shell.panel[element[edge], 0])],
            "at_mm": [
                round(float(v), 1) for v in shell.nodes[_node(shell, element, side, edge, node)]
            ],
        },
    )
    over = force.max(axis=(0, 2)) > LIMIT * resistance
    if not over.any():
        return summary, []
    panels = sorted({panel_ids[int(p)] for p in shell.panel[element[over], 0]})
    return summary, [
        Issue(
            wording.code,
            f"{int(over.sum())} {wording.what} of {len(panels)} panel(s) ({', '.join(panels[:6])}"
            f"{' ...' if len(panels) > 6 else ''}) need more than the weld's "
            f"{resistance:.0f} N/mm ({weld.fillets} x a = {weld.throat:g} mm): up to "
            f"{float(force[worst]):.0f} N/mm under {names[combo]}; {wording.fix}",
            severity="error",
        )
    ]


def _in_design_frame(summary: dict, origin: np.ndarray | None) -> None:
    """The governing weld's place moved from the model's local frame into the design's, as
    the issues and reactions are (``origin``: the layout's; None leaves it local)."""
    governing = summary.get("governing")
    if origin is not None and governing and "at_mm" in governing:
        governing["at_mm"] = [round(float(v), 1) for v in np.add(governing["at_mm"], origin)]


def _parts(traction: np.ndarray, frame: np.ndarray) -> dict:
    """The weld force's parts along the weld, across it in the sheet and out of the sheet."""
    along, across = float(traction @ frame[0]), float(traction @ frame[1])
    out = float(np.linalg.norm(traction - along * frame[0] - across * frame[1]))
    return {
        "along_N_per_mm": round(along, 1),
        "across_N_per_mm": round(across, 1),
        "out_of_plane_N_per_mm": round(out, 1),
    }


def _node(shell: ShellModel, element: np.ndarray, side: np.ndarray, edge: int, node: int) -> int:
    return int(shell.quads[element[edge], SIDE_NODES[side[edge], node]])
