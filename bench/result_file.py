"""Where and how the scripts in bench/ write a result: indented JSON in bench/results/, named by
the benchmark and the machine it was measured on."""

from __future__ import annotations

import json
from pathlib import Path

from fingerprint import machine_slug  # bench/ is on sys.path when run as a script

RESULTS = Path(__file__).resolve().parent / "results"


def write_result(result: dict, name: str, out: Path | None = None) -> Path:
    """Writes `result` (a JSON-able dict whose "machine" is fingerprint.machine()'s) to `out`, by
    default RESULTS/<name>-<machine slug>.json, as JSON indented 2 spaces with a trailing newline,
    making its folder; returns the path written."""
    out = out or RESULTS / f"{name}-{machine_slug(result['machine'])}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    return out
