"""Throughput statistics of a generate run, in four steps: `collect` reads every finished task's
stats.json (moonbot.records.stats) into OUT/stats/tasks.jsonl and tasks.parquet; `aggregate`
summarises them (the formulas are its docstring); `report` formats the summary as a table and
an SVG chart; `command` is `moonbot stats`."""

from moonbot.pipeline.stats.aggregate import (
    HostSummary,
    Reference,
    Summary,
    busy_seconds,
    peak_concurrency,
    reference_from_bench,
    reference_from_run,
    summarize,
)
from moonbot.pipeline.stats.collect import (
    STAGE_ORDER,
    Collected,
    StatsError,
    collect,
    load,
    load_placements,
    read_tasks,
    task_directories,
    to_table,
)
from moonbot.pipeline.stats.command import run_stats
from moonbot.pipeline.stats.report import format_summary, throughput_svg, write_plot

__all__ = [
    "STAGE_ORDER",
    "Collected",
    "HostSummary",
    "Reference",
    "StatsError",
    "Summary",
    "busy_seconds",
    "collect",
    "format_summary",
    "load",
    "load_placements",
    "peak_concurrency",
    "read_tasks",
    "reference_from_bench",
    "reference_from_run",
    "run_stats",
    "summarize",
    "task_directories",
    "throughput_svg",
    "to_table",
    "write_plot",
]
