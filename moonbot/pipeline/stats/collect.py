"""Reading a generate run's throughput records: every complete task's stats.json (moonbot.records
.stats) and the scene layouts' placement timings (OUT/placements), and writing them as
OUT/stats/tasks.jsonl, tasks.parquet and placements.jsonl, which `load` reads back when the task
directories are gone."""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from moonbot.atomic_io import atomic_write
from moonbot.pipeline.placements import read_placements
from moonbot.records.base import RecordError
from moonbot.records.done import complete_files
from moonbot.records.stats import STATS, StatsRecord, decode_stats, read_stats

# tasks.parquet's first columns: stats.json's contract, in this order (stages_s becomes one
# column per stage); any further field follows as a column of its own, sorted by name.
CONTRACT_COLUMNS: dict[str, pa.DataType | None] = {
    "task_id": pa.string(),
    "host": pa.string(),
    "pid": pa.int64(),
    "cpu_model": pa.string(),
    "cores": pa.int64(),
    "threads": pa.int64(),
    "worker": pa.string(),
    "started_utc": pa.timestamp("us", tz="UTC"),
    "wall_s": pa.float64(),
    "cpu_s": pa.float64(),
    "stages_s": None,
    "samples": pa.int64(),
    "bytes_written": pa.int64(),
    "samples_per_s": pa.float64(),
}
# The stages a task times (moonbot.pipeline.views, moonbot.writer.sample), in pipeline order;
# other stage names a worker reports follow these, sorted.
STAGE_ORDER = ("terrain", "compose", "place", "settle", "build_bvh", "dust", "render", "tonemap", "encode_write")


class StatsError(ValueError):
    """A stats record that breaks the contract; the message names the file (and line) and field."""


@dataclass(frozen=True)
class Collected:
    """What `collect` read: the task records, sorted by task_id, and the task directories it left
    out because they are not complete (no DONE.json, or files that do not match it); the scene
    layouts' placement records (OUT/placements), sorted by layout_id."""

    records: list[StatsRecord]
    incomplete: list[Path]
    placements: list[dict] = dataclasses.field(default_factory=list)


def task_directories(out_dir: Path) -> tuple[list[Path], list[Path]]:
    """(complete, incomplete) directories in OUT/tasks, each sorted by name. Hidden entries — a
    worker's temporaries — are neither."""
    root = Path(out_dir) / "tasks"
    if not root.is_dir():
        raise StatsError(f"{root}: no such directory (is {out_dir} a `moonbot generate --out` directory?)")
    complete, incomplete = [], []
    for d in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        (complete if complete_files(d) is not None else incomplete).append(d)
    return complete, incomplete


def read_task_stats(directory: Path) -> StatsRecord:
    """A task directory's stats.json, whose task_id must be the directory's name. StatsError
    naming the file and the field."""
    path = Path(directory) / STATS
    try:
        record = read_stats(path)
    except RecordError as e:
        raise StatsError(str(e)) from None
    if record.task_id != path.parent.name:
        raise StatsError(f"{path}: task_id: {record.task_id!r} is not its directory's name {path.parent.name!r}")
    return record


def read_tasks(out_dir: Path) -> Collected:
    """Every complete task's checked stats.json in OUT/tasks, sorted by task_id."""
    complete, incomplete = task_directories(out_dir)
    records = [read_task_stats(d) for d in complete]
    return Collected(sorted(records, key=lambda r: r.task_id), incomplete)


def _jsonl(records: list[dict]) -> str:
    """One record a line, keys sorted, compact."""
    return "".join(json.dumps(r, sort_keys=True, separators=(",", ":")) + "\n" for r in records)


def collect(out_dir: Path) -> Collected:
    """Reads every complete task's stats.json (`read_tasks`) and writes OUT/stats/tasks.jsonl (one
    record a line, keys sorted, lines in task_id order) and OUT/stats/tasks.parquet (`to_table`),
    each atomically; the same tasks give the same bytes. The placement records (OUT/placements),
    if any, go into OUT/stats/placements.jsonl, without their poses."""
    collected = dataclasses.replace(
        read_tasks(out_dir), placements=[placement_timing(r) for r in read_placements(out_dir)]
    )
    stats_dir = Path(out_dir) / "stats"
    stats_dir.mkdir(parents=True, exist_ok=True)
    lines = _jsonl([r.as_json() for r in collected.records])
    atomic_write(stats_dir / "tasks.jsonl", "w", lambda f: f.write(lines))
    table = to_table(collected.records)
    atomic_write(stats_dir / "tasks.parquet", "wb", lambda f: pq.write_table(table, f, compression="zstd"))
    if collected.placements:  # a run of `moonbot generate` (one of run_task alone has none)
        placed = _jsonl(collected.placements)
        atomic_write(stats_dir / "placements.jsonl", "w", lambda f: f.write(placed))
    return collected


def check_stages(stages: object, where: str) -> None:
    """StatsError unless `stages` maps stage names to finite, non-negative seconds."""
    if not isinstance(stages, dict):
        raise StatsError(f"{where}: stages_s: expected an object of stage: seconds, got {type(stages).__name__}")
    for stage, seconds in stages.items():
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)):
            raise StatsError(
                f"{where}: stages_s.{stage}: expected a number of seconds, got {seconds!r} ({type(seconds).__name__})"
            )
        if not math.isfinite(seconds) or seconds < 0:
            raise StatsError(f"{where}: stages_s.{stage}: must be finite and non-negative, got {seconds!r}")


def placement_timing(record: dict) -> dict:
    """A placement record's timing fields (layout_id, stages_s, wall_s, cpu_s, started_utc, host,
    pid, worker), checked like a task's."""
    where = f"placement {record.get('layout_id')!r}"
    for name in ("wall_s", "cpu_s"):
        if not isinstance(record.get(name), (int, float)) or not math.isfinite(record[name]) or record[name] < 0:
            raise StatsError(f"{where}: {name}: expected non-negative seconds, got {record.get(name)!r}")
    check_stages(record.get("stages_s"), where)
    return {
        k: record.get(k) for k in ("layout_id", "stages_s", "wall_s", "cpu_s", "started_utc", "host", "pid", "worker")
    }


def _read_jsonl(path: Path) -> list[tuple[str, object]]:
    """(\"file:line\", parsed value) for every line of `path`; StatsError naming the line."""
    parsed = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        try:
            parsed.append((f"{path}:{number}", json.loads(line)))
        except ValueError as e:
            raise StatsError(f"{path}:{number}: not JSON ({e})") from None
    return parsed


def load_placements(out_dir: Path) -> list[dict]:
    """A run's placement timings: from OUT/placements when it exists, else from
    OUT/stats/placements.jsonl (empty when neither: a run from before placements had tasks)."""
    out_dir = Path(out_dir)
    if (out_dir / "placements").is_dir():
        return [placement_timing(r) for r in read_placements(out_dir)]
    path = out_dir / "stats" / "placements.jsonl"
    if not path.is_file():
        return []
    return [placement_timing(record) for _, record in _read_jsonl(path)]


def load(out_dir: Path) -> list[StatsRecord]:
    """A run's records without writing anything: from OUT/tasks when it exists, else from
    OUT/stats/tasks.jsonl (a run whose task directories are gone). Raises StatsError."""
    out_dir = Path(out_dir)
    if (out_dir / "tasks").is_dir():
        return read_tasks(out_dir).records
    path = out_dir / "stats" / "tasks.jsonl"
    if not path.is_file():
        raise StatsError(f"{out_dir}: neither tasks/ nor stats/tasks.jsonl")
    try:
        records = [decode_stats(value, where) for where, value in _read_jsonl(path)]
    except RecordError as e:
        raise StatsError(str(e)) from None
    return sorted(records, key=lambda r: r.task_id)


def stage_names(stages: list[dict]) -> list[str]:
    """The stages present in any of `stages` (stage → seconds mappings): STAGE_ORDER's first, then
    the others sorted."""
    present = {k for s in stages for k in s}
    return [s for s in STAGE_ORDER if s in present] + sorted(present - set(STAGE_ORDER))


def to_table(records: list[StatsRecord]) -> pa.Table:
    """The records as one flat table: the contract's fields in CONTRACT_COLUMNS order (started_utc
    as a UTC timestamp in microseconds), a float64 column stage_<name>_s per stage (null where the
    task did not run it), then any further top-level fields, sorted: booleans, integers, floats
    and strings as such, anything else as its JSON text."""
    rows = [r.as_json() for r in records]
    columns: dict[str, pa.Array] = {}
    for name, kind in CONTRACT_COLUMNS.items():
        if name == "stages_s":
            for stage in stage_names([r.stages_s for r in records]):
                columns[f"stage_{stage}_s"] = pa.array([r.stages_s.get(stage) for r in records], pa.float64())
        elif name == "started_utc":
            columns[name] = pa.array([r.start_time() for r in records], kind)
        else:
            columns[name] = pa.array([row[name] for row in rows], kind)
    for name in sorted({k for row in rows for k in row} - set(CONTRACT_COLUMNS)):
        columns[name] = _extra_column([row.get(name) for row in rows])
    return pa.table(columns)


def _extra_column(values: list) -> pa.Array:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return pa.array(values, pa.bool_())
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return pa.array(values, pa.int64())
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return pa.array([None if v is None else float(v) for v in values], pa.float64())
    if all(isinstance(v, str) for v in present):
        return pa.array(values, pa.string())
    return pa.array([None if v is None else json.dumps(v, sort_keys=True) for v in values], pa.string())
