"""CI gates beside the tests: ruff's lint and format, and mypy on the package, all clean.

They run as tests so that the README's one test command (what ``.ci/run`` runs) checks them.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "command",
    [
        ["ruff", "check", "."],
        ["ruff", "format", "--check", "."],
        ["mypy"],  # files and settings from [tool.mypy] in pyproject
    ],
    ids=["ruff-check", "ruff-format", "mypy"],
)
def test_gate_is_clean(command):
    result = subprocess.run(
        [sys.executable, "-m", *command],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
