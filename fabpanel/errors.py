"""Typed errors of fabpanel.

Only what stops the pipeline raises; recoverable findings (a panel that misses a tolerance, a part
that does not fit a plate) are collected as :class:`Issue` records in the stage outputs.

Each error also subclasses the matching built-in so that callers can catch either
(``except ValueError`` catches an :class:`InputError`), as ezdxf does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


class FabpanelError(Exception):
    """Base class of every error fabpanel raises on purpose."""

    #: process exit code the CLI uses for this kind of error
    exit_code = 1


class InputError(FabpanelError, ValueError):
    """The input file, the job file or a command-line option is wrong.

    The message is one line: what is wrong, where, and how to fix it. The CLI prints it and exits 2.
    """

    exit_code = 2


class GeometryError(FabpanelError, ValueError):
    """The geometry cannot be processed as asked (e.g. a boundary that is not four-sided for `grid`).

    Counts as bad input for the CLI (exit 2): the user can change the input or the job.
    """

    exit_code = 2


class KernelError(FabpanelError, RuntimeError):
    """The geometry kernel (OCCT) failed on an operation that should have worked."""


class SolverError(FabpanelError, RuntimeError):
    """A numerical solver or an external engine (CalculiX, spyrrow) failed."""


class WorkerError(FabpanelError, RuntimeError):
    """A worker process stopped before its task was done (see :mod:`fabpanel.parallel`)."""


class Stopped(KeyboardInterrupt):
    """The run was stopped by a signal (SIGINT or SIGTERM).

    A :class:`KeyboardInterrupt`, so everything that lets Ctrl-C through lets it through and
    every ``finally`` and cleanup runs; the CLI exits ``128 + signum`` (130, 143).
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


Severity = Literal["info", "warning", "error"]
#: what a worker found, as plain data: ``(code, item, message)`` or, with a severity other than
#: the default, ``(code, item, message, severity)`` (the arguments of an :class:`Issue`)
Finding = tuple[str, str, str] | tuple[str, str, str, str]


@dataclass(frozen=True)
class Issue:
    """A recoverable finding, kept as data and shown in the manifest and the report.

    code : short stable identifier, e.g. ``"panel-too-large"``
    message : one sentence for a person
    item : id of the panel or part concerned (``"P012"``, ``"P012-TOP"``), empty for global findings
    severity : ``"info"``, ``"warning"`` or ``"error"``
    """

    code: str
    message: str
    item: str = ""
    severity: Severity = "warning"

    def to_dict(self) -> dict:
        return {
            "code": self.code,
            "message": self.message,
            "item": self.item,
            "severity": self.severity,
        }
