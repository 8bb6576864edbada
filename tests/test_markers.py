"""Every test is `unit` or `integration` (pyproject.toml's markers), never both and never neither,
so that `pytest -m unit` and `pytest -m integration` between them run the whole suite, and a new
test module without its `pytestmark` fails here."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parents[1]
NO_TESTS_COLLECTED = 5  # pytest's exit status when the selection is empty


def test_every_test_is_unit_or_integration_and_not_both():
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "--collect-only",
            "-q",
            "-p",
            "no:cacheprovider",
            "-m",
            "(unit and integration) or not (unit or integration)",
            str(ROOT / "tests"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=240,
    )
    # Otherwise stdout lists the tests that carry both markers or neither (or a collection error).
    assert run.returncode == NO_TESTS_COLLECTED, run.stdout + run.stderr
