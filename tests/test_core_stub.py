"""moonbot/_core.pyi is pybind11-stubgen's output for the built core, committed as it comes out:
this test generates it again and compares, so the stub cannot drift from the bindings (their
docstrings carry the units, shapes and dtypes). After changing a binding, refresh it with
`.venv/bin/pybind11-stubgen moonbot._core -o .` from the repository root."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.unit

STUB = Path(__file__).resolve().parent.parent / "moonbot" / "_core.pyi"


def test_committed_stub_is_what_stubgen_writes(tmp_path):
    pytest.importorskip("pybind11_stubgen", reason="pybind11-stubgen is in the test extras (pyproject.toml)")
    subprocess.run(
        [sys.executable, "-m", "pybind11_stubgen", "moonbot._core", "-o", str(tmp_path), "--exit-code"],
        check=True,
        capture_output=True,
        timeout=120,
    )
    generated = (tmp_path / "moonbot" / "_core.pyi").read_text(encoding="utf-8")
    assert generated == STUB.read_text(encoding="utf-8"), (
        "moonbot/_core.pyi differs from the bindings: run `.venv/bin/pybind11-stubgen moonbot._core -o .`"
    )
