"""Throughput statistics of a generate run: every finished task's stats.json (written by its
worker, moonbot.pipeline.tasks) collected into OUT/stats/tasks.jsonl and OUT/stats/tasks.parquet,
and summarised — samples/s overall, per host, per worker, per core and per render thread, where
the time went by stage, and how well the workers were used.

Definitions (task i: start s_i = started_utc in seconds, wall w_i, end e_i = s_i + w_i, n_i samples,
CPU c_i, t_i render threads; all times in seconds, rates in samples per second):

- span T = max e_i − min s_i: first task start to last task end. It leaves out what a run does
  outside tasks (cluster start-up, terrain warm-up before the first task, merge); a resumed run's
  gap between drivers is inside it, reported as `idle_s` (time within T when no task ran).
- throughput X = Σ n_i / T.
- workers n = the most tasks that ran at the same instant (the peak of the task intervals'
  overlap). A worker restarted by its nanny, or recycled by --lifetime, fills the same slot and is
  not counted twice; distinct worker addresses are reported as `worker_ids`.
- per worker X / n; per core X / Σ_h cores_h (each host's os.cpu_count once; on Kubernetes that is
  the node's, not the pod's share); per render thread X / Σ_h n_h·t_h (t_h the host's threads).
- per host h: X_h = Σ_{i on h} n_i / T_h with T_h the host's own span (its first start to its last
  end), X_h / cores_h per core; busy_h = Σ_{i on h} w_i / (n_h·T_h).
- parallel efficiency E_busy = Σ w_i / (n·T): the fraction of the workers' time inside a task.
  The rest is scheduling, the DONE.json checksums after wall_s was taken, and waiting for work.
- scaling efficiency against a reference (a previous run's stats, or a single-worker rate from a
  benchmark: bench/bench_generate.py's 1-worker run with the same render threads, or a number):
  X1 = X_ref / n_ref, the reference's samples/s per worker, and E = X / (n·X1). With a
  one-worker reference this is the usual E(n) = X(n) / (n·X(1)); it compares like with like only
  when both runs have the same worker shape (threads per worker) on the same hardware.
- stage share_k = Σ_i stage_ik / Σ_i Σ_j stage_ij: the time-weighted mean share of stage k in the
  timed stages (the shares sum to 1); `stage_coverage` = Σ_ij stage_ij / Σ_i w_i is the fraction of
  task wall time the stages account for (the remainder: writing task.json and stats.json).
- CPU use = Σ c_i / Σ w_i·t_i: process CPU seconds per second of the render threads' wall time.
- placements: a scene layout's bags are placed and settled once, by a task of their own, for all
  the tasks that show them (moonbot.pipeline.placements); OUT/placements/<layout>.json records
  its `place` and `settle` seconds, so each layout's are counted once. They join the stage
  totals (and so the shares and seconds per sample), and their wall time joins the coverage's
  denominator; the rates, spans and concurrency are the tasks' alone.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from moonbot.atomic_io import atomic_write
from moonbot.charts import COLOURS, bar_panels_svg
from moonbot.pipeline.placements import read_placements
from moonbot.pipeline.tasks import is_complete

# The stages a task times (moonbot.pipeline.views, moonbot.writer.sample), in pipeline order;
# other stage names a worker reports follow these, sorted.
STAGE_ORDER = ("terrain", "compose", "place", "settle", "build_bvh", "dust", "render", "tonemap", "encode_write")

_STR, _INT, _NUM = "a string", "an integer", "a number"
# stats.json's fields: (kind, lower bound or None, unit for messages). stages_s is checked apart.
FIELDS: dict[str, tuple[str, float | None, str]] = {
    "task_id": (_STR, None, ""),
    "host": (_STR, None, ""),
    "pid": (_INT, 0, ""),
    "cpu_model": (_STR, None, ""),
    "cores": (_INT, 1, "logical CPUs"),
    "threads": (_INT, 1, "render threads"),
    "worker": (_STR, None, ""),
    "started_utc": (_STR, None, "ISO-8601 time"),
    "wall_s": (_NUM, 0.0, "seconds"),
    "cpu_s": (_NUM, 0.0, "seconds"),
    "stages_s": ("an object of stage: seconds", None, ""),
    "samples": (_INT, 0, ""),
    "bytes_written": (_INT, 0, "bytes"),
    "samples_per_s": (_NUM, 0.0, "samples per second"),
}
_ARROW_TYPES = {_STR: pa.string(), _INT: pa.int64(), _NUM: pa.float64()}


class StatsError(ValueError):
    """A stats record that breaks the contract; the message names the file (and line) and field."""


@dataclass(frozen=True)
class Collected:
    """What `collect` read: the task records, sorted by task_id, and the task directories it left
    out because they are not complete (no DONE.json, or files that do not match it); the scene
    layouts' placement records (OUT/placements), sorted by layout_id."""

    records: list[dict]
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
        (complete if is_complete(d) else incomplete).append(d)
    return complete, incomplete


def read_stats(path: Path, task_dir_name: str | None = None) -> dict:
    """One stats.json, checked against the contract (the fields in FIELDS, their types and ranges,
    started_utc an ISO-8601 time, stages_s seconds per stage). `task_dir_name`, when given, must be
    its task_id. Raises StatsError naming the file and the field."""
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as e:
        raise StatsError(f"{path}: cannot read ({e.strerror or e})") from None
    except ValueError as e:
        raise StatsError(f"{path}: not JSON ({e})") from None
    check_record(record, str(path))
    if task_dir_name is not None and record["task_id"] != task_dir_name:
        raise StatsError(f"{path}: task_id: {record['task_id']!r} is not its directory's name {task_dir_name!r}")
    return record


def check_record(record: object, where: str) -> None:
    """Raises StatsError ("<where>: <field>: <problem>") unless `record` is a sound stats record."""
    if not isinstance(record, dict):
        raise StatsError(f"{where}: expected a JSON object, got {type(record).__name__}")
    for name, (kind, lo, unit) in FIELDS.items():
        if name not in record:
            raise StatsError(f"{where}: {name}: missing")
        value = record[name]
        if name == "stages_s":
            _check_stages(value, where)
            continue
        ok = {_STR: isinstance(value, str),
              _INT: isinstance(value, int) and not isinstance(value, bool),
              _NUM: isinstance(value, (int, float)) and not isinstance(value, bool)}[kind]
        if not ok:
            raise StatsError(f"{where}: {name}: expected {kind}{f' ({unit})' if unit else ''}, "
                             f"got {value!r} ({type(value).__name__})")
        if kind == _NUM and not math.isfinite(value):
            raise StatsError(f"{where}: {name}: must be finite, got {value!r}")
        if lo is not None and value < lo:
            raise StatsError(f"{where}: {name}: must be at least {lo:g}, got {value!r}")
        if kind == _STR and not value:
            raise StatsError(f"{where}: {name}: must not be empty")
    try:
        start_seconds(record)
    except ValueError:
        raise StatsError(f"{where}: started_utc: not an ISO-8601 time: {record['started_utc']!r}") from None


def _check_stages(stages: object, where: str) -> None:
    if not isinstance(stages, dict):
        raise StatsError(f"{where}: stages_s: expected an object of stage: seconds, got {type(stages).__name__}")
    for stage, seconds in stages.items():
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float)):
            raise StatsError(f"{where}: stages_s.{stage}: expected a number of seconds, "
                             f"got {seconds!r} ({type(seconds).__name__})")
        if not math.isfinite(seconds) or seconds < 0:
            raise StatsError(f"{where}: stages_s.{stage}: must be finite and non-negative, got {seconds!r}")


def start_time(record: dict) -> datetime.datetime:
    """started_utc as an aware UTC datetime (a time without an offset is read as UTC)."""
    t = datetime.datetime.fromisoformat(record["started_utc"])
    if t.tzinfo is None:
        return t.replace(tzinfo=datetime.timezone.utc)
    return t.astimezone(datetime.timezone.utc)


def start_seconds(record: dict) -> float:
    """started_utc in seconds since the Unix epoch."""
    return start_time(record).timestamp()


def read_tasks(out_dir: Path) -> Collected:
    """Every complete task's checked stats.json in OUT/tasks, sorted by task_id."""
    complete, incomplete = task_directories(out_dir)
    records = [read_stats(d / "stats.json", d.name) for d in complete]
    return Collected(sorted(records, key=lambda r: r["task_id"]), incomplete)


def collect(out_dir: Path) -> Collected:
    """Reads every complete task's stats.json (`read_tasks`) and writes OUT/stats/tasks.jsonl (one
    record a line, keys sorted, lines in task_id order) and OUT/stats/tasks.parquet (`to_table`),
    each atomically; the same tasks give the same bytes. The placement records (OUT/placements),
    if any, go into OUT/stats/placements.jsonl, without their poses."""
    collected = dataclasses.replace(read_tasks(out_dir),
                                    placements=[placement_timing(r) for r in read_placements(out_dir)])
    stats_dir = Path(out_dir) / "stats"
    stats_dir.mkdir(parents=True, exist_ok=True)
    lines = "".join(json.dumps(r, sort_keys=True, separators=(",", ":")) + "\n" for r in collected.records)
    atomic_write(stats_dir / "tasks.jsonl", "w", lambda f: f.write(lines))
    table = to_table(collected.records)
    atomic_write(stats_dir / "tasks.parquet", "wb", lambda f: pq.write_table(table, f, compression="zstd"))
    if collected.placements:  # a run of `moonbot generate` (one of run_task alone has none)
        placed = "".join(json.dumps(r, sort_keys=True, separators=(",", ":")) + "\n" for r in collected.placements)
        atomic_write(stats_dir / "placements.jsonl", "w", lambda f: f.write(placed))
    return collected


def placement_timing(record: dict) -> dict:
    """A placement record's timing fields (layout_id, stages_s, wall_s, cpu_s, started_utc, host,
    pid, worker), checked like a task's."""
    where = f"placement {record.get('layout_id')!r}"
    for name in ("wall_s", "cpu_s"):
        if not isinstance(record.get(name), (int, float)) or not math.isfinite(record[name]) or record[name] < 0:
            raise StatsError(f"{where}: {name}: expected non-negative seconds, got {record.get(name)!r}")
    _check_stages(record.get("stages_s"), where)
    return {k: record.get(k) for k in ("layout_id", "stages_s", "wall_s", "cpu_s", "started_utc", "host", "pid",
                                       "worker")}


def load_placements(out_dir: Path) -> list[dict]:
    """A run's placement timings: from OUT/placements when it exists, else from
    OUT/stats/placements.jsonl (empty when neither: a run from before placements had tasks)."""
    out_dir = Path(out_dir)
    if (out_dir / "placements").is_dir():
        return [placement_timing(r) for r in read_placements(out_dir)]
    path = out_dir / "stats" / "placements.jsonl"
    if not path.is_file():
        return []
    records = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        try:
            record = json.loads(line)
        except ValueError as e:
            raise StatsError(f"{path}:{number}: not JSON ({e})") from None
        records.append(placement_timing(record))
    return records


def load(out_dir: Path) -> list[dict]:
    """A run's records without writing anything: from OUT/tasks when it exists, else from
    OUT/stats/tasks.jsonl (a run whose task directories are gone). Raises StatsError."""
    out_dir = Path(out_dir)
    if (out_dir / "tasks").is_dir():
        return read_tasks(out_dir).records
    path = out_dir / "stats" / "tasks.jsonl"
    if not path.is_file():
        raise StatsError(f"{out_dir}: neither tasks/ nor stats/tasks.jsonl")
    records = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        try:
            record = json.loads(line)
        except ValueError as e:
            raise StatsError(f"{path}:{number}: not JSON ({e})") from None
        check_record(record, f"{path}:{number}")
        records.append(record)
    return sorted(records, key=lambda r: r["task_id"])


def stage_names(records: Iterable[dict]) -> list[str]:
    """The stages present in any record: STAGE_ORDER's first, then the others sorted."""
    present = {k for r in records for k in r["stages_s"]}
    return [s for s in STAGE_ORDER if s in present] + sorted(present - set(STAGE_ORDER))


def to_table(records: list[dict]) -> pa.Table:
    """The records as one flat table: the contract's fields in FIELDS order (started_utc as a UTC
    timestamp in microseconds), a float64 column stage_<name>_s per stage (null where the task did
    not run it), then any further top-level fields, sorted: booleans, integers, floats and strings
    as such, anything else as its JSON text."""
    columns: dict[str, pa.Array] = {}
    for name, (kind, _, _) in FIELDS.items():
        values = [r[name] for r in records]
        if name == "stages_s":
            for stage in stage_names(records):
                columns[f"stage_{stage}_s"] = pa.array([s.get(stage) for s in values], pa.float64())
        elif name == "started_utc":
            columns[name] = pa.array([start_time(r) for r in records], pa.timestamp("us", tz="UTC"))
        else:
            columns[name] = pa.array(values, _ARROW_TYPES[kind])
    for name in sorted({k for r in records for k in r} - set(FIELDS)):
        columns[name] = _extra_column([r.get(name) for r in records])
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


# --- the summary ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Reference:
    """What scaling efficiency compares with: the samples/s of one worker, and where it came from."""

    samples_per_s_per_worker: float
    source: str


@dataclass(frozen=True)
class HostSummary:
    """One host's share of a run (see the module docstring for the formulas)."""

    host: str
    cpu_model: str
    cores: int
    threads: int          # render threads per worker (the largest its tasks report)
    workers: int          # peak concurrent tasks on this host
    tasks: int
    samples: int
    wall_s: float         # Σ task wall seconds
    span_s: float         # this host's first task start to its last task end
    samples_per_s: float
    samples_per_s_per_core: float
    busy: float           # Σ wall / (workers × span)
    stages_s: dict        # stage -> Σ seconds


@dataclass(frozen=True)
class Summary:
    """A run's totals and rates (see the module docstring for the formulas); times in seconds,
    rates in samples per second, shares and efficiencies as fractions."""

    tasks: int
    samples: int
    bytes_written: int
    wall_s: float
    cpu_s: float
    first_start_utc: str
    last_end_utc: str
    span_s: float
    idle_s: float
    workers: int
    worker_ids: int
    cores: int
    render_threads: int
    samples_per_s: float
    per_worker: float
    per_core: float
    per_thread: float
    cpu_use: float
    parallel_efficiency: float
    stage_share: dict
    stage_seconds_per_sample: dict
    stage_coverage: float
    hosts: tuple
    reference: Reference | None = None
    scaling_efficiency: float | None = None
    placements: int = 0             # scene layouts placed (bags placed and settled), each once
    placement_wall_s: float = 0.0   # Σ their wall seconds


def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 else math.nan


def _intervals(records: list[dict]) -> list[tuple[float, float]]:
    return [(s, s + r["wall_s"]) for r in records for s in (start_seconds(r),)]


def peak_concurrency(intervals: list[tuple[float, float]]) -> int:
    """The most intervals [start, end) that contain one instant (an end and a start at the same
    instant do not overlap)."""
    events = sorted([(s, 1) for s, _ in intervals] + [(e, -1) for _, e in intervals])
    peak = running = 0
    for _, step in events:
        running += step
        peak = max(peak, running)
    return peak


def busy_seconds(intervals: list[tuple[float, float]]) -> float:
    """The length of the union of the intervals: time during which at least one task ran."""
    total, end = 0.0, -math.inf
    for s, e in sorted(intervals):
        if e > end:
            total += e - max(s, end)
            end = e
    return total


def _worker_id(r: dict) -> tuple:
    return (r["host"], r["pid"]) if r["worker"] == "local" else (r["host"], r["worker"])


def _utc(seconds: float) -> str:
    return datetime.datetime.fromtimestamp(seconds, datetime.timezone.utc).isoformat(timespec="milliseconds")


def summarize(records: list[dict], reference: Reference | None = None, placements: Iterable[dict] = ()) -> Summary:
    """Totals, rates and efficiencies of a run's task records (formulas in the module docstring).
    With a `reference`, also the scaling efficiency against it. `placements`: the run's placement
    timings (load_placements), their stages counted once each. Raises ValueError without records."""
    if not records:
        raise ValueError("no finished tasks to summarise")
    records = sorted(records, key=lambda r: r["task_id"])
    intervals = _intervals(records)
    first = min(s for s, _ in intervals)
    last = max(e for _, e in intervals)
    span = last - first
    samples = sum(r["samples"] for r in records)
    wall = sum(r["wall_s"] for r in records)
    placements = list(placements)
    stages = stage_names([*records, *placements])
    stage_totals = {k: sum(r["stages_s"].get(k, 0.0) for r in [*records, *placements]) for k in stages}
    timed = sum(stage_totals.values())
    placement_wall = sum(p["wall_s"] for p in placements)

    hosts = []
    for host in sorted({r["host"] for r in records}):
        mine = [r for r in records if r["host"] == host]
        iv = _intervals(mine)
        h_span = max(e for _, e in iv) - min(s for s, _ in iv)
        h_workers = peak_concurrency(iv)
        h_samples = sum(r["samples"] for r in mine)
        h_wall = sum(r["wall_s"] for r in mine)
        cores = max(r["cores"] for r in mine)
        rate = _ratio(h_samples, h_span)
        hosts.append(HostSummary(
            host=host, cpu_model=sorted({r["cpu_model"] for r in mine})[0], cores=cores,
            threads=max(r["threads"] for r in mine), workers=h_workers, tasks=len(mine),
            samples=h_samples, wall_s=h_wall, span_s=h_span, samples_per_s=rate,
            samples_per_s_per_core=_ratio(rate, cores), busy=_ratio(h_wall, h_workers * h_span),
            stages_s={k: sum(r["stages_s"].get(k, 0.0) for r in mine) for k in stages}))

    workers = peak_concurrency(intervals)
    rate = _ratio(samples, span)
    cores = sum(h.cores for h in hosts)
    render_threads = sum(h.workers * h.threads for h in hosts)
    per_worker = _ratio(rate, workers)
    return Summary(
        tasks=len(records), samples=samples, bytes_written=sum(r["bytes_written"] for r in records),
        wall_s=wall, cpu_s=sum(r["cpu_s"] for r in records),
        first_start_utc=_utc(first), last_end_utc=_utc(last), span_s=span,
        idle_s=max(0.0, span - busy_seconds(intervals)),
        workers=workers, worker_ids=len({_worker_id(r) for r in records}), cores=cores,
        render_threads=render_threads, samples_per_s=rate, per_worker=per_worker,
        per_core=_ratio(rate, cores), per_thread=_ratio(rate, render_threads),
        cpu_use=_ratio(sum(r["cpu_s"] for r in records), sum(r["wall_s"] * r["threads"] for r in records)),
        parallel_efficiency=_ratio(wall, workers * span),
        stage_share={k: _ratio(v, timed) for k, v in stage_totals.items()},
        stage_seconds_per_sample={k: _ratio(v, samples) for k, v in stage_totals.items()},
        stage_coverage=_ratio(timed, wall + placement_wall), hosts=tuple(hosts), reference=reference,
        scaling_efficiency=None if reference is None else _ratio(per_worker, reference.samples_per_s_per_worker),
        placements=len(placements), placement_wall_s=placement_wall,
    )


def reference_from_bench(path: Path, threads: int) -> Reference:
    """The samples/s of one worker with `threads` render threads from a bench/bench_generate.py
    record (its `runs`: workers, threads_per_worker, samples_per_s). Raises StatsError naming the
    file when it is not such a record or has no one-worker run of that shape."""
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
        runs = record["runs"] if record.get("benchmark") == "generate" else None
        rates = {r["threads_per_worker"]: r["samples_per_s"] for r in runs if r["workers"] == 1}
    except OSError as e:
        raise StatsError(f"{path}: cannot read ({e.strerror or e})") from None
    except (ValueError, KeyError, TypeError, AttributeError):
        raise StatsError(f"{path}: not a bench_generate record (benchmark: generate, runs: "
                         f"[{{workers, threads_per_worker, samples_per_s}}])") from None
    if threads not in rates:
        raise StatsError(f"{path}: runs: no run of 1 worker × {threads} render threads to compare with "
                         f"(it has {', '.join(f'1 × {t}' for t in sorted(rates)) or 'none'})")
    return Reference(rates[threads], f"{path}: 1 worker × {threads} threads, {rates[threads]:.4g} samples/s")


def reference_from_run(out_dir: Path) -> Reference:
    """A previous run's samples/s per worker (X_ref / n_ref), as the reference for scaling efficiency."""
    s = summarize(load(out_dir), placements=load_placements(out_dir))
    return Reference(s.per_worker, f"{out_dir}: {s.samples_per_s:.4g} samples/s on {s.workers} "
                                   f"worker{'s' if s.workers != 1 else ''}")


# --- presentation -----------------------------------------------------------------------------

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
        lines.append(f"placement   {layouts} placed and settled once each, {s.placement_wall_s:.1f} s wall "
                     f"(in the stage shares below)")
    if s.reference is not None:
        lines.append(f"            scaling {_frac(s.scaling_efficiency)} (per-worker samples/s / "
                     f"{_num(s.reference.samples_per_s_per_worker, 4)} of the reference, {s.reference.source})")
    lines += ["", f"{'host':<20} {'cpu':<28} {'cores':>5} {'workers':>7} {'thr':>3} {'tasks':>6} "
                  f"{'samples':>8} {'span s':>8} {'samples/s':>9} {'/core':>7} {'busy':>5}"]
    for h in s.hosts:
        lines.append(f"{h.host[:20]:<20} {h.cpu_model[:28]:<28} {h.cores:>5} {h.workers:>7} {h.threads:>3} "
                     f"{h.tasks:>6} {h.samples:>8} {h.span_s:>8.1f} {_num(h.samples_per_s, 4):>9} "
                     f"{_num(h.samples_per_s_per_core):>7} {_frac(h.busy):>5}")
    lines += ["", f"{'stage':<14} {'share':>6} {'s/sample':>9}"]
    for k, share in s.stage_share.items():
        lines.append(f"{k:<14} {100 * share:>5.1f}% {s.stage_seconds_per_sample[k]:>9.4f}")
    lines.append(f"(the stages cover {_num(100 * s.stage_coverage, 3)} % of the tasks' "
                 + ("and placements' " if s.placements else "") + "wall time)")
    notes = [f"host {h.host}: {h.workers} workers × {h.threads} threads > {h.cores} cores (oversubscribed)"
             for h in s.hosts if h.workers * h.threads > h.cores]
    return "\n".join(lines + ([""] + notes if notes else []))


def throughput_svg(s: Summary, title: str) -> str:
    """An SVG of samples/s per host (labelled with samples/s per core) and, per host, the seconds a
    sample spends in each stage, stacked in pipeline order."""
    stages = list(s.stage_share)
    colours = [COLOURS[(STAGE_ORDER.index(k) if k in STAGE_ORDER else len(STAGE_ORDER) + stages.index(k))
                       % len(COLOURS)] for k in stages]
    rate_rows = [(h.host, [h.samples_per_s], f"{_num(h.samples_per_s)} ({_num(h.samples_per_s_per_core)}/core)")
                 for h in s.hosts]
    rate_rows.append(("all hosts", [s.samples_per_s], f"{_num(s.samples_per_s)} ({_num(s.per_core)}/core)"))
    stage_rows = [(h.host, [_ratio(h.stages_s[k], h.samples) for k in stages],
                   f"{_num(_ratio(sum(h.stages_s.values()), h.samples))} s") for h in s.hosts]
    return bar_panels_svg(title, [
        {"title": "throughput per host", "axis_label": "samples/s", "rows": rate_rows, "colours": [COLOURS[0]]},
        {"title": "stage time per sample, per host", "axis_label": "seconds per sample", "rows": stage_rows,
         "series": stages, "colours": colours}]).decode("utf-8")


def write_plot(s: Summary, path: Path, title: str) -> None:
    """Writes `throughput_svg` to `path` atomically (its folder must exist)."""
    text = throughput_svg(s, title)
    atomic_write(Path(path), "w", lambda f: f.write(text))
