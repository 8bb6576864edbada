"""Reading `moonbot bench throughput` results back, and setting several side by side
(`moonbot bench compare A.json B.json …`): a table and an SVG plot.

The result's contract — its fields and their types, its schema_version and how an older version
is read — is moonbot.records.bench; every problem is reported as "<file>: <field>: <what is
wrong>"."""

from __future__ import annotations

import json
import math
from pathlib import Path

from moonbot.atomic_io import atomic_write
from moonbot.benchmark.throughput import STAGE_GROUPS
from moonbot.charts import COLOURS, bar_panels_svg
from moonbot.records.base import RecordError
from moonbot.records.bench import decode_bench_result, read_bench_result


class ResultError(ValueError):
    """A result file that cannot be read or breaks the schema; the message names the file and field."""


def validate(record: object, path: str = "<record>") -> dict:
    """`record` (a parsed result of `path`) upgraded to this schema version and checked, as the
    JSON object the current version writes; raises ResultError."""
    try:
        return decode_bench_result(record, path).as_json()
    except RecordError as e:
        raise ResultError(str(e)) from None


def load_result(path: Path) -> dict:
    """A result file, read and checked (moonbot.records.bench), as the JSON object the current
    version writes; raises ResultError."""
    try:
        return read_bench_result(Path(path)).as_json()
    except RecordError as e:
        raise ResultError(str(e)) from None


# --- presentation -----------------------------------------------------------------------------


def _g(x: float, digits: int = 3) -> str:
    return f"{x:.{digits}g}" if isinstance(x, (int, float)) and math.isfinite(x) else "n/a"


def _commit(m: dict) -> str:
    c = m["git_commit"]
    return c[:12] + ("-dirty" if c.endswith("-dirty") else "")


TABLE_HEADER = (
    f"{'result':<34} {'level':<8} {'W×T':>5} {'samples/s':>9} {'s/sample':>8} {'build':>6} "
    f"{'dust':>6} {'render':>6} {'enc/wr':>6} {'Mrays/s':>7} {'MB/smp':>6} {'RSS MiB':>7} "
    f"{'÷limit':>6} {'r+e÷lim':>7} {'load':>9}"
)


def table_rows(name: str, record: dict) -> list[str]:
    """One line per run of `record`: rates, seconds a sample per stage group (worker-seconds),
    Mrays/s, MB a sample, the largest worker's peak RSS, the ratios to the limit (whole pipeline;
    render + encode) and the 1-minute load before → after."""
    rows = []
    for r in record["runs"]:
        g = r["stage_groups_s_per_sample"]
        rows.append(
            f"{name[:34]:<34} {r['level']:<8} {r['workers']}×{r['threads_per_worker']:<3} "
            f"{_g(r['samples_per_s'], 4):>9} {_g(r['seconds_per_sample']):>8} {_g(g['scene_build']):>6} "
            f"{_g(g['dust']):>6} {_g(g['render']):>6} {_g(g['encode_write']):>6} {_g(r['mrays_per_s']):>7} "
            f"{r['bytes_per_sample'] / 1e6:>6.2f} {r['peak_rss_mib']['max_worker']:>7.0f} "
            f"{_g(r['ratio']['pipeline']):>6} {_g(r['ratio']['render_encode']):>7} "
            f"{r['load_before'][0]:>4.1f}→{r['load_after'][0]:<4.1f}"
        )
    return rows


def _cpu(m: dict) -> str:
    """The machine's CPU as a result records it: model, id, and the ISA Embree traced in out of
    those the CPU offered (results before these were recorded say so)."""
    if "embree_isa" not in m:
        return f"{m['cpu']} (CPU id, SIMD flags and Embree ISA not recorded)"
    return (
        f"{m['cpu']} ({m.get('cpu_id') or 'id unknown'}; Embree traced in {m['embree_isa']} of "
        f"{', '.join(m.get('embree_isas', []))}; SIMD {' '.join(m.get('simd_flags', []))})"
    )


def format_record(record: dict, name: str = "this run") -> str:
    """One result as text: machine, the runs table, the limit, scaling and the projection."""
    m = record["machine"]
    lines = [
        f"machine   {_cpu(m)}, {m['cores']} cores, {m['memory_gib']} GiB, {m['os']}, {m['compiler']}, "
        f"Embree {m['embree']}, OIIO {m['openimageio']}, commit {_commit(m)}",
        f"config    {record['config']['file']} (v{record['config']['version']}) at "
        f"{record['image']['width']}×{record['image']['height']}, {len(record['tasks'])} tasks"
        + (f", overrides {record['overrides']}" if record["overrides"] else ""),
        "",
        TABLE_HEADER,
        *table_rows(name, record),
        "",
        "stage columns: worker-seconds a sample (build = terrain + compose + settle + BVH; render includes "
        "amodal masks and tone map); ÷limit = (span / samples) over the limit's seconds a sample (Embree on the "
        "same rays + the encoders on the same files); r+e÷lim = render + tone map + encode/write over the same "
        "limit",
        "",
    ]
    lines.append("Embree alone on view 0 of each scene (64-ray streams, Mrays/s):")
    for row in record["embree_limit"]:
        bounce = ", ".join(f"{x:.1f}" for x in row.get("bounce_mrays_per_s", []))
        bounce_shadow = ", ".join(f"{x:.1f}" for x in row.get("bounce_shadow_mrays_per_s", []))
        lines.append(
            f"  {row['task_id'][:48]:<48} {row['threads']} thr: primary {row['primary_mrays_per_s']:.1f}, "
            f"shadow {row['shadow_mrays_per_s']:.1f}, "
            + (f"bounce by generation {bounce} (their shadow rays {bounce_shadow})" if bounce else "bounce not probed")
        )
    costs = sorted({r["limit"]["bounce_cost"] for r in record["runs"]})
    if costs != ["measured"]:
        lines.append(f"bounce rays in the limit: {'; '.join(costs)}")
    for level, e in record["encode_limit"].items():
        lines.append(
            f"encoders alone, {level}: {e['raw_mb_per_s']:.0f} MB/s of raw pixels "
            f"({e['serial_s'] / max(len(e['views']), 1) * 1e3:.1f} ms a view on one thread)"
        )
    for r in record["runs"]:
        lines.append(
            f"ratio to the limit, {r['level']} {r['workers']}×{r['threads_per_worker']}: render "
            f"{_g(r['ratio']['render'])}, encode {_g(r['ratio']['encode'])}, render + encode "
            f"{_g(r['ratio']['render_encode'])}, whole pipeline {_g(r['ratio']['pipeline'])}"
        )
    if len({s["workers"] for s in record["scaling"]}) > 1:
        lines.append(
            "scaling efficiency: "
            + ", ".join(
                f"{s['level']} {s['workers']} workers {s['efficiency']:.2f}"
                for s in record["scaling"]
                if s["workers"] != s.get("reference_workers")
            )
        )
    p = record["projection"]
    lines.append(
        f"\nfull {p['sweep']} sweep ({p['samples']} samples, {p['views_per_task']} views a task)"
        + ("" if p["image_matches_sweep"] else " — NOT at the sweep's image size")
        + ":"
    )
    for lv in p["levels"]:
        hours = ", ".join(f"{h['nodes']} node{'s' if h['nodes'] > 1 else ''} {h['hours']:.1f} h" for h in lv["hours"])
        lines.append(
            f"  {lv['level']:<8} {lv['seconds_per_sample']:.2f} s a sample "
            f"({_g(lv.get('ratio_pipeline', 0.0))}× the limit): {hours}; {lv['bytes'] / 1e9:.0f} GB"
        )
    if p.get("note"):
        lines.append(f"  ({p['note']})")
    return "\n".join(lines)


def format_comparison(named: list[tuple[str, dict]]) -> str:
    """Several results as one table (one line per run), then each one's machine."""
    lines = [TABLE_HEADER]
    for name, record in named:
        lines += table_rows(name, record)
    lines.append("")
    for name, record in named:
        m = record["machine"]
        versions = ", ".join(f"{k} {v}" for k, v in record.get("libraries", {}).items() if v)
        lines.append(
            f"{name}: {_cpu(m)}, {m['cores']} cores, {m['memory_gib']} GiB, {m['os']}, "
            f"{m['compiler']}, Embree {m['embree']}, OIIO {m['openimageio']}, TBB {m['tbb']}, "
            f"commit {_commit(m)}, {m['date']}; {record['config']['file']} at "
            f"{record['image']['width']}×{record['image']['height']}"
            + (f", overrides {record['overrides']}" if record["overrides"] else "")
            + (f"; {versions}" if versions else "")
        )
    isas = {r["machine"].get("embree_isa", "not recorded") for _, r in named}
    if len(isas) > 1:
        lines.append(
            "warning: Embree traced in different ISAs (" + ", ".join(sorted(isas)) + "): machines differ "
            "in more than their speed"
        )
    configs = {(r["config"]["name"], r["config"]["sha256"]) for _, r in named}
    if len(configs) > 1:
        lines.append(
            "warning: the results ran different benchmark configs: "
            + ", ".join(sorted(f"{n} ({s[:12]})" for n, s in configs))
        )
    if len({json.dumps(r["overrides"], sort_keys=True) for _, r in named}) > 1:
        lines.append("warning: the results ran with different --set overrides: compare their rows with care")
    return "\n".join(lines)


def comparison_svg(named: list[tuple[str, dict]], title: str = "moonbot bench throughput") -> str:
    """Three panels, one bar per run of every result: samples/s; worker-seconds a sample per
    stage group, stacked; the whole pipeline's time over the limit."""
    runs = [
        (f"{name}: {r['level']} {r['workers']}×{r['threads_per_worker']}", r)
        for name, rec in named
        for r in rec["runs"]
    ]
    groups = list(STAGE_GROUPS)
    return bar_panels_svg(
        title,
        [
            {
                "title": "throughput",
                "axis_label": "samples/s",
                "rows": [(label, [r["samples_per_s"]], _g(r["samples_per_s"])) for label, r in runs],
                "colours": [COLOURS[0]],
            },
            {
                "title": "where a sample's time goes (worker-seconds)",
                "axis_label": "seconds a sample",
                "rows": [
                    (
                        label,
                        [r["stage_groups_s_per_sample"][g] for g in groups],
                        f"{_g(sum(r['stage_groups_s_per_sample'].values()))} s",
                    )
                    for label, r in runs
                ],
                "series": groups,
                "colours": [COLOURS[k] for k in range(len(groups))],
            },
            {
                "title": "time over the limit (Embree + encoders on the same work)",
                "axis_label": "ratio",
                "rows": [
                    (
                        label,
                        [r["ratio"]["render_encode"], max(0.0, r["ratio"]["pipeline"] - r["ratio"]["render_encode"])],
                        f"{_g(r['ratio']['render_encode'])} / {_g(r['ratio']['pipeline'])}",
                    )
                    for label, r in runs
                ],
                "series": ["render + encode", "rest of the pipeline"],
                "colours": [COLOURS[2], COLOURS[7]],
            },
        ],
        width_in=10.0,
    ).decode("utf-8")


def write_svg(named: list[tuple[str, dict]], path: Path, title: str = "moonbot bench throughput") -> None:
    text = comparison_svg(named, title)
    atomic_write(Path(path), "w", lambda f: f.write(text))


def names_for(paths: list[Path]) -> list[str]:
    """Short names for result files: their stems, made unique with their folder when needed."""
    stems = [Path(p).stem for p in paths]
    return [f"{Path(p).parent.name}/{s}" if stems.count(s) > 1 else s for p, s in zip(paths, stems)]
