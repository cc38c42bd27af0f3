"""Report: ``report/summary.json``, the page ``report/index.html`` (figures embedded) and the
same content as ``report/report.pdf``.

The report renders what the stages measured; it computes nothing of its own but totals.
"""

from __future__ import annotations

import json
from pathlib import Path

from .summary import summarise

__all__ = ["summarise", "write_report"]


def write_report(result, folder: Path, source=None) -> list[Path]:
    """Write ``summary.json``, ``index.html`` and ``report.pdf`` into ``folder``; ``source``
    (:class:`fabpanel.docs.DocSource`) adds the key plan and the shop schedules."""
    from .content import report_blocks
    from .html import render
    from .pdf import render_pdf

    folder = Path(folder)
    (folder / "summary.json").write_text(json.dumps(result.summary, indent=1))
    blocks = report_blocks(result, source)
    (folder / "index.html").write_text(render(blocks), encoding="utf-8")
    render_pdf(blocks, folder / "report.pdf")
    return [folder / n for n in ("summary.json", "index.html", "report.pdf")]
