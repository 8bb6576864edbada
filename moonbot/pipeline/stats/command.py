"""`moonbot stats OUT`: collect a generate run's task records, summarise them against an optional
reference and plot OUT/stats/throughput.svg; the CLI prints what this returns."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from moonbot.pipeline.stats.aggregate import Reference, Summary, reference_from_bench, reference_from_run, summarize
from moonbot.pipeline.stats.collect import StatsError, collect, load, load_placements
from moonbot.pipeline.stats.report import write_plot


def run_stats(
    out_dir: Path,
    reference_path: Path | None = None,
    reference_rate: float | None = None,
    on_skipped: Callable[[Path], None] | None = None,
) -> Summary:
    """Collects OUT's task records (or, its task directories gone, reads what collect wrote
    before), summarises them — with scaling efficiency against `reference_rate` (samples/s of one
    worker), or `reference_path` (a previous run's OUT, or a bench_generate record whose 1-worker
    run has the same render threads) — and writes OUT/stats/throughput.svg. `on_skipped(directory)`
    is told each task directory left out as incomplete. Returns the summary; raises StatsError (or
    OSError) naming what is wrong."""
    out_dir = Path(out_dir)
    if (out_dir / "tasks").is_dir():
        collected = collect(out_dir)
        records, placements = collected.records, collected.placements
        for directory in collected.incomplete if on_skipped is not None else ():
            on_skipped(directory)
    else:  # task directories gone: what collect wrote before
        records, placements = load(out_dir), load_placements(out_dir)
    if not records:
        raise StatsError(f"{out_dir / 'tasks'}: no finished tasks")
    reference = None
    if reference_rate is not None:
        reference = Reference(reference_rate, "--reference-rate")
    elif reference_path is not None and Path(reference_path).is_dir():
        reference = reference_from_run(reference_path)
    elif reference_path is not None:
        reference = reference_from_bench(reference_path, max(r.threads for r in records))
    summary = summarize(records, reference, placements)
    (out_dir / "stats").mkdir(parents=True, exist_ok=True)
    write_plot(summary, out_dir / "stats" / "throughput.svg", f"moonbot throughput: {out_dir.name}")
    return summary
