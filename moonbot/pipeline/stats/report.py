"""A generate run's throughput summary (moonbot.pipeline.stats.aggregate) as a terminal table and an
SVG chart."""

from __future__ import annotations

import math
from pathlib import Path

from moonbot.atomic_io import atomic_write
from moonbot.charts import COLOURS, bar_panels_svg
from moonbot.pipeline.stats.aggregate import Summary, ratio
from moonbot.pipeline.stats.collect import STAGE_ORDER


def _num(x: float, digits: int = 3) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def _frac(x: float) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.3f}"


def _bytes(n: int) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.2f} {unit}"
    return f"{n} B"


def format_summary(s: Summary) -> str:
    """The summary as a table for a terminal (rates in samples/s, times in seconds)."""
    lines = [
        f"tasks       {s.tasks}, {s.samples} samples, {_bytes(s.bytes_written)} written",
        f"span        {s.first_start_utc} to {s.last_end_utc}: {s.span_s:.1f} s"
        + (f" ({s.idle_s:.1f} s with no task running)" if s.idle_s >= 0.05 else ""),
        f"throughput  {_num(s.samples_per_s, 4)} samples/s; per worker {_num(s.per_worker)} ({s.workers} "
        f"worker{'s' if s.workers != 1 else ''} at peak, {s.worker_ids} distinct), per core {_num(s.per_core)} "
        f"({s.cores} cores), per render thread {_num(s.per_thread)} ({s.render_threads} threads)",
        f"task time   {s.wall_s:.1f} s wall, {s.cpu_s:.1f} s CPU (CPU use {_frac(s.cpu_use)} of the render "
        f"threads' time)",
        f"efficiency  parallel {_frac(s.parallel_efficiency)} (task wall / workers × span)",
    ]
    if s.placements:
        layouts = f"{s.placements} scene layout{'s' if s.placements != 1 else ''}"
        lines.append(
            f"placement   {layouts} placed and settled once each, {s.placement_wall_s:.1f} s wall "
            f"(in the stage shares below)"
        )
    if s.reference is not None:
        lines.append(
            f"            scaling {_frac(s.scaling_efficiency)} (per-worker samples/s / "
            f"{_num(s.reference.samples_per_s_per_worker, 4)} of the reference, {s.reference.source})"
        )
    lines += [
        "",
        f"{'host':<20} {'cpu':<28} {'cores':>5} {'workers':>7} {'thr':>3} {'tasks':>6} "
        f"{'samples':>8} {'span s':>8} {'samples/s':>9} {'/core':>7} {'busy':>5}",
    ]
    for h in s.hosts:
        lines.append(
            f"{h.host[:20]:<20} {h.cpu_model[:28]:<28} {h.cores:>5} {h.workers:>7} {h.threads:>3} "
            f"{h.tasks:>6} {h.samples:>8} {h.span_s:>8.1f} {_num(h.samples_per_s, 4):>9} "
            f"{_num(h.samples_per_s_per_core):>7} {_frac(h.busy):>5}"
        )
    lines += ["", f"{'stage':<14} {'share':>6} {'s/sample':>9}"]
    for k, share in s.stage_share.items():
        lines.append(f"{k:<14} {100 * share:>5.1f}% {s.stage_seconds_per_sample[k]:>9.4f}")
    lines.append(
        f"(the stages cover {_num(100 * s.stage_coverage, 3)} % of the tasks' "
        + ("and placements' " if s.placements else "")
        + "wall time)"
    )
    notes = [
        f"host {h.host}: {h.workers} workers × {h.threads} threads > {h.cores} cores (oversubscribed)"
        for h in s.hosts
        if h.workers * h.threads > h.cores
    ]
    return "\n".join(lines + ([""] + notes if notes else []))


def throughput_svg(s: Summary, title: str) -> str:
    """An SVG of samples/s per host (labelled with samples/s per core) and, per host, the seconds a
    sample spends in each stage, stacked in pipeline order."""
    stages = list(s.stage_share)
    colours = [
        COLOURS[(STAGE_ORDER.index(k) if k in STAGE_ORDER else len(STAGE_ORDER) + stages.index(k)) % len(COLOURS)]
        for k in stages
    ]
    rate_rows = [
        (h.host, [h.samples_per_s], f"{_num(h.samples_per_s)} ({_num(h.samples_per_s_per_core)}/core)") for h in s.hosts
    ]
    rate_rows.append(("all hosts", [s.samples_per_s], f"{_num(s.samples_per_s)} ({_num(s.per_core)}/core)"))
    stage_rows = [
        (
            h.host,
            [ratio(h.stages_s[k], h.samples) for k in stages],
            f"{_num(ratio(sum(h.stages_s.values()), h.samples))} s",
        )
        for h in s.hosts
    ]
    return bar_panels_svg(
        title,
        [
            {"title": "throughput per host", "axis_label": "samples/s", "rows": rate_rows, "colours": [COLOURS[0]]},
            {
                "title": "stage time per sample, per host",
                "axis_label": "seconds per sample",
                "rows": stage_rows,
                "series": stages,
                "colours": colours,
            },
        ],
    ).decode("utf-8")


def write_plot(s: Summary, path: Path, title: str) -> None:
    """Writes `throughput_svg` to `path` atomically (its folder must exist)."""
    text = throughput_svg(s, title)
    atomic_write(Path(path), "w", lambda f: f.write(text))
