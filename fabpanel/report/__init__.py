"""Report: ``report/summary.json`` and a self-contained ``report/index.html`` (figures embedded).

The report renders what the stages measured; it computes nothing of its own but totals.
"""

from .html import write_report
from .summary import summarise

__all__ = ["summarise", "write_report"]
