"""A generate run's throughput, summarised from its tasks' stats records (moonbot.pipeline.stats
.collect) — samples/s overall, per host, per worker, per core and per render thread, where
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

import datetime
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from moonbot.pipeline.stats.collect import StatsError, load, load_placements, stage_names
from moonbot.records.stats import StatsRecord


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
    threads: int  # render threads per worker (the largest its tasks report)
    workers: int  # peak concurrent tasks on this host
    tasks: int
    samples: int
    wall_s: float  # Σ task wall seconds
    span_s: float  # this host's first task start to its last task end
    samples_per_s: float
    samples_per_s_per_core: float
    busy: float  # Σ wall / (workers × span)
    stages_s: dict  # stage -> Σ seconds


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
    placements: int = 0  # scene layouts placed (bags placed and settled), each once
    placement_wall_s: float = 0.0  # Σ their wall seconds


def ratio(a: float, b: float) -> float:
    """a / b, NaN where b is not positive (a rate over no time, a share of nothing)."""
    return a / b if b > 0 else math.nan


def _intervals(records: list[StatsRecord]) -> list[tuple[float, float]]:
    return [(s, s + r.wall_s) for r in records for s in (r.start_seconds(),)]


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


def _worker_id(r: StatsRecord) -> tuple:
    return (r.host, r.pid) if r.worker == "local" else (r.host, r.worker)


def _utc(seconds: float) -> str:
    return datetime.datetime.fromtimestamp(seconds, datetime.timezone.utc).isoformat(timespec="milliseconds")


def summarize(
    records: list[StatsRecord], reference: Reference | None = None, placements: Iterable[dict] = ()
) -> Summary:
    """Totals, rates and efficiencies of a run's task records (formulas in the module docstring).
    With a `reference`, also the scaling efficiency against it. `placements`: the run's placement
    timings (load_placements), their stages counted once each. Raises ValueError without records."""
    if not records:
        raise ValueError("no finished tasks to summarise")
    records = sorted(records, key=lambda r: r.task_id)
    intervals = _intervals(records)
    first = min(s for s, _ in intervals)
    last = max(e for _, e in intervals)
    span = last - first
    samples = sum(r.samples for r in records)
    wall = sum(r.wall_s for r in records)
    placements = list(placements)
    timed_stages = [r.stages_s for r in records] + [p["stages_s"] for p in placements]
    stages = stage_names(timed_stages)
    stage_totals = {k: sum(s.get(k, 0.0) for s in timed_stages) for k in stages}
    timed = sum(stage_totals.values())
    placement_wall = sum(p["wall_s"] for p in placements)

    hosts = []
    for host in sorted({r.host for r in records}):
        mine = [r for r in records if r.host == host]
        iv = _intervals(mine)
        h_span = max(e for _, e in iv) - min(s for s, _ in iv)
        h_workers = peak_concurrency(iv)
        h_samples = sum(r.samples for r in mine)
        h_wall = sum(r.wall_s for r in mine)
        cores = max(r.cores for r in mine)
        rate = ratio(h_samples, h_span)
        hosts.append(
            HostSummary(
                host=host,
                cpu_model=sorted({r.cpu_model for r in mine})[0],
                cores=cores,
                threads=max(r.threads for r in mine),
                workers=h_workers,
                tasks=len(mine),
                samples=h_samples,
                wall_s=h_wall,
                span_s=h_span,
                samples_per_s=rate,
                samples_per_s_per_core=ratio(rate, cores),
                busy=ratio(h_wall, h_workers * h_span),
                stages_s={k: sum(r.stages_s.get(k, 0.0) for r in mine) for k in stages},
            )
        )

    workers = peak_concurrency(intervals)
    rate = ratio(samples, span)
    cores = sum(h.cores for h in hosts)
    render_threads = sum(h.workers * h.threads for h in hosts)
    per_worker = ratio(rate, workers)
    return Summary(
        tasks=len(records),
        samples=samples,
        bytes_written=sum(r.bytes_written for r in records),
        wall_s=wall,
        cpu_s=sum(r.cpu_s for r in records),
        first_start_utc=_utc(first),
        last_end_utc=_utc(last),
        span_s=span,
        idle_s=max(0.0, span - busy_seconds(intervals)),
        workers=workers,
        worker_ids=len({_worker_id(r) for r in records}),
        cores=cores,
        render_threads=render_threads,
        samples_per_s=rate,
        per_worker=per_worker,
        per_core=ratio(rate, cores),
        per_thread=ratio(rate, render_threads),
        cpu_use=ratio(sum(r.cpu_s for r in records), sum(r.wall_s * r.threads for r in records)),
        parallel_efficiency=ratio(wall, workers * span),
        stage_share={k: ratio(v, timed) for k, v in stage_totals.items()},
        stage_seconds_per_sample={k: ratio(v, samples) for k, v in stage_totals.items()},
        stage_coverage=ratio(timed, wall + placement_wall),
        hosts=tuple(hosts),
        reference=reference,
        scaling_efficiency=None if reference is None else ratio(per_worker, reference.samples_per_s_per_worker),
        placements=len(placements),
        placement_wall_s=placement_wall,
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
        raise StatsError(
            f"{path}: not a bench_generate record (benchmark: generate, runs: "
            f"[{{workers, threads_per_worker, samples_per_s}}])"
        ) from None
    if threads not in rates:
        raise StatsError(
            f"{path}: runs: no run of 1 worker × {threads} render threads to compare with "
            f"(it has {', '.join(f'1 × {t}' for t in sorted(rates)) or 'none'})"
        )
    return Reference(rates[threads], f"{path}: 1 worker × {threads} threads, {rates[threads]:.4g} samples/s")


def reference_from_run(out_dir: Path) -> Reference:
    """A previous run's samples/s per worker (X_ref / n_ref), as the reference for scaling efficiency."""
    s = summarize(load(out_dir), placements=load_placements(out_dir))
    return Reference(
        s.per_worker, f"{out_dir}: {s.samples_per_s:.4g} samples/s on {s.workers} worker{'s' if s.workers != 1 else ''}"
    )
