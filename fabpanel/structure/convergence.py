"""Is the first buckling factor converged in the element size?

A linear buckling factor falls as the mesh is refined until the mode's half-waves are
resolved (a sheet buckling between its ribs needs about four elements per panel side). After
the main run at ``n`` elements per side the check runs the same buckling case at ``n - 1`` (when
``n > 1``) and, while the factor still changes by ``TOLERANCE`` or more, at ``n + 1`` and ``n + 2``
(``MAX_REFINEMENTS``) as far as the element budget (``[structure] max_elements``) allows. The table goes to the
summary and the report; a factor that has not settled is a ``buckling-not-converged`` warning,
and the buckling check uses the smallest factor found.
"""

from __future__ import annotations

from collections.abc import Callable

from ..errors import Issue
from .buckling import significant

#: the first factor counts as converged when it changes by less than this between two sizes
TOLERANCE = 0.05
#: at most this many sizes finer than the chosen one are tried (each is a CalculiX run)
MAX_REFINEMENTS = 2


def _change(a: float, b: float) -> float:
    return abs(b - a) / max(abs(b), 1e-12)


def buckling_convergence(
    first_at: Callable[[int], float],
    n: int,
    first: float,
    allowed: Callable[[int], bool],
) -> tuple[dict, list[Issue]]:
    """The convergence table ``[(elements per side, first factor)]`` from ``n`` (factor
    ``first``) with ``first_at(k)`` running the buckling case at ``k`` per side and
    ``allowed(k)`` the budget, whether it converged, and the warning when it did not."""
    table = [(n, first)]
    if n > 1:
        table.insert(0, (n - 1, first_at(n - 1)))
    k = n
    while len(table) < 2 or _change(table[-2][1], table[-1][1]) >= TOLERANCE:
        if not allowed(k + 1):
            break
        k += 1
        table.append((k, first_at(k)))
    converged = len(table) >= 2 and _change(table[-2][1], table[-1][1]) < TOLERANCE
    summary = {
        "table": [{"per_side": per_side, "first": significant(f, 4)} for per_side, f in table],
        "converged": converged,
        "tolerance": TOLERANCE,
        "smallest": significant(min(f for _, f in table), 4),
    }
    issues = []
    if not converged:
        last = table[-2:]
        falling = len(last) == 2 and last[1][1] < last[0][1]
        detail = (
            last_step(summary)
            if len(last) == 2
            else "could not be compared with another element size"
        )
        issues.append(
            Issue(
                "buckling-not-converged",
                (
                    f"the first buckling factor {detail}; the element budget stops a finer "
                    "mesh, and the check uses the smallest factor found"
                    + (", which a finer mesh may lower further" if falling else "")
                    + ": raise [structure] max_elements or set element_size to check it"
                ),
                severity="warning",
            )
        )
    return summary, issues


def last_step(convergence: dict) -> str:
    """How the first factor moved at the study's last refinement, against the coarser mesh's
    value: "fell by 81% from 90.9 at 2 to 16.8 at 3 elements per panel side"."""
    (n0, f0), (n1, f1) = ((r["per_side"], r["first"]) for r in convergence["table"][-2:])
    way = "fell" if f1 < f0 else "rose"
    return (
        f"{way} by {abs(f1 - f0) / max(abs(f0), 1e-12):.0%} from {f0:.3g} at {n0} to {f1:.3g} "
        f"at {n1} elements per panel side"
    )


def checked_factor(first: float, convergence: dict) -> float:
    """The first buckling factor the check uses: the main run's, or the study's smallest where
    a finer size found a lower one (a factor not yet converged falls as the mesh is refined)."""
    return min(first, convergence.get("smallest", first))


def buckling_text(buckling: dict) -> str:
    """The first buckling factor the check uses, and the main run's where the mesh study found
    a lower one at a finer mesh: "19.30 (finer mesh of the study; 21.75 at 4 per side)"."""
    first, checked = buckling["first"], buckling.get("checked", buckling["first"])
    if checked >= first:
        return f"{first:.2f}"
    table = buckling.get("convergence", {}).get("table", [])
    main = next((r["per_side"] for r in table if r["first"] == first), None)
    at = f" at {main} per side" if main is not None else ""
    return f"{checked:.2f} (finer mesh of the study; {first:.2f}{at})"
