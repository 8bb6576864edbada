"""Where and how the scripts in bench/ write a result: indented JSON in bench/results/, named by
the benchmark and the machine it was measured on."""

from __future__ import annotations

import json
from pathlib import Path

from moonbot.charts import time_error_plot

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


def write_result_and_chart(
    result: dict, name: str, title: str, detail: str, curves: dict, x_label: str, y_label: str
) -> Path:
    """write_result(result, name), then beside it (.svg) the time-against-error chart of `curves`
    (moonbot.charts.time_error_plot's), titled "<title> (<commit>, <detail>)" with the commit
    measured (7 hex digits; no detail: "<title> (<commit>)"); prints both paths and returns the
    result's."""
    out = write_result(result, name)
    commit = result["machine"]["git_commit"][:7]
    full_title = f"{title} ({commit}, {detail})" if detail else f"{title} ({commit})"
    time_error_plot(out.with_suffix(".svg"), full_title, curves, x_label, y_label)
    print(f"\nwritten {out} and {out.with_suffix('.svg').name}")
    return out
