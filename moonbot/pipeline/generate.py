"""`moonbot generate`: the sweep's tasks sharded over a Dask cluster (../shared/reference/
dask-distribution.md). Each task runs on a worker process with one Dask thread while the C++
core uses the cores; the filesystem is the record of what is done, so a rerun (or --resume)
submits only the tasks without a complete directory, and the dataset's bytes never depend on
which worker ran what, in which order, or how often a task was retried."""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import dask
from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker

from moonbot.bop.merge import merge_dataset
from moonbot.config import Config, ConfigError, config_hash, load_config
from moonbot.pipeline.stats import collect
from moonbot.pipeline.tasks import is_complete, run_task, sweep_temporaries, task_dir
from moonbot.writer.staging import atomic_write
from moonbot.sweep import Task, task_config, tasks

# A worker's death counts against the tasks it held; a few deaths of one task are the cluster's
# fault (preemption, the out-of-memory killer), more are the task's (dask-distribution.md §1.4).
ALLOWED_FAILURES = 5
# A task that raises (a transient I/O error) is tried this many more times before it is reported.
RETRIES = 2


class TerrainWarmup(WorkerPlugin):
    """Builds the terrain of every location of the sweep once per worker process, when the worker
    starts (and again if the nanny restarts it), and keeps them all in its cache: no task then
    builds a terrain, however the scheduler interleaves locations on that worker."""

    name = "moonbot-terrain"

    def __init__(self, terrains: list) -> None:
        self.terrains = terrains

    def setup(self, worker) -> None:
        from moonbot.terrain import warm

        warm(self.terrains)


def _run_on_worker(config: Config, task: Task, out_dir: str, threads: int | None) -> dict:
    """The function a worker runs: one task, reported as a small dict (the images stay on disk)."""
    try:
        worker = get_worker().address
    except ValueError:
        worker = "local"
    outcome = run_task(config, task, Path(out_dir), threads=threads, worker=worker)
    return {"task_id": outcome.task_id, "skipped": outcome.skipped, "samples": outcome.samples,
            "seconds": outcome.stats["wall_s"] if outcome.stats else 0.0}


@dataclass
class GenerateResult:
    """What a run did: tasks in the sweep, already complete before it, rendered by it, and failed
    (task_id → error text)."""

    tasks: int = 0
    complete_before: int = 0
    rendered: int = 0
    samples: int = 0
    failed: dict = field(default_factory=dict)
    seconds: float = 0.0
    merge: object = None  # the MergeReport of the merge that ended the run (None: not merged)


def pending_tasks(config: Config, out_dir: Path) -> tuple[list[Task], int]:
    """(the sweep's tasks without a complete directory in `out_dir`, in sweep order; how many are
    complete)."""
    all_tasks = tasks(config)
    pending = [t for t in all_tasks if not is_complete(task_dir(out_dir, t))]
    return pending, len(all_tasks) - len(pending)


def generate(config: Config | str | Path | None, out_dir: Path, *, client: Client | None = None,
             workers: int | None = None, threads: int | None = None, scheduler: str | None = None,
             scheduler_file: str | None = None, merge: bool = True, progress=sys.stderr) -> GenerateResult:
    """Renders every task of the config's sweep missing from `out_dir` (OUT/tasks/<task_id>/).
    The cluster: `client` if given; else the scheduler at `scheduler` (an address) or in
    `scheduler_file`; else a LocalCluster of `workers` processes (default: one per core, at most
    the tasks) with one Dask thread each. `threads` sets each task's render threads (default: the
    config's render.threads on a given cluster, cores / workers on the local one; the images do
    not depend on it). Prints progress to
    `progress` (None: silent). A task that fails is reported in the result and the others go on.
    The resolved config is kept as OUT/config.json (a later run into the same OUT must have the
    same config); at the end the tasks' stats are collected (OUT/stats/) and, with `merge`, the
    complete tasks are merged into the BOP dataset OUT/dataset (missing ones reported)."""
    if not isinstance(config, Config):
        config = load_config(config)
    out_dir = Path(out_dir)
    try:
        (out_dir / "tasks").mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OSError(f"{out_dir}: cannot hold the dataset ({e.strerror or e})") from e
    start = time.perf_counter()
    keep_config(config, out_dir)
    sweep_temporaries(out_dir)
    pending, complete = pending_tasks(config, out_dir)
    result = GenerateResult(tasks=complete + len(pending), complete_before=complete)
    say = (lambda text: print(text, file=progress, flush=True)) if progress else (lambda text: None)
    say(f"{result.tasks} tasks, {complete} complete, {len(pending)} to render into {out_dir}")
    if pending:
        render_pending(config, out_dir, pending, result, client, workers, threads, scheduler, scheduler_file,
                       start, say)
    sweep_temporaries(out_dir)
    if result.rendered or result.complete_before:
        collect(out_dir)
        if merge:
            result.merge = merge_dataset(out_dir, config=config, progress=progress)
    result.seconds = time.perf_counter() - start
    return result


def keep_config(config: Config, out_dir: Path) -> None:
    """Writes the resolved config to OUT/config.json, or checks that the one there is the same:
    tasks of two configs never share a dataset directory."""
    path = out_dir / "config.json"
    text = json.dumps(dataclasses.asdict(config), indent=2, sort_keys=True) + "\n"
    if path.exists():
        try:
            kept = load_config(path)
        except ConfigError as e:
            raise OSError(f"{path}: not a moonbot config ({e})") from None
        if config_hash(kept) != config_hash(config):
            raise OSError(f"{path}: {out_dir} holds a sweep of another config (hash {config_hash(kept)[:12]}, "
                          f"this one {config_hash(config)[:12]}); render it into another --out")
        return
    atomic_write(path, "w", lambda f: f.write(text))


def render_pending(config: Config, out_dir: Path, pending: list[Task], result: GenerateResult, client, workers,
                   threads, scheduler, scheduler_file, start: float, say) -> None:
    """Runs `pending` on the cluster (see generate) and records outcomes in `result`."""
    own_cluster = own_client = None
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                          "distributed.scheduler.worker-saturation": 1.0}):
        if client is None:
            if scheduler or scheduler_file:
                own_client = client = (Client(scheduler) if scheduler else Client(scheduler_file=scheduler_file))
            else:
                cores = os.cpu_count() or 1
                n = max(1, min(workers or cores, len(pending)))
                threads = threads or max(1, cores // n)
                own_cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=40)
                own_client = client = Client(own_cluster)
        try:
            say(f"dashboard: {client.dashboard_link}")
            # One task per location stands for its terrain (task_config costs ~10 ms; a sweep has thousands).
            by_location = {t.location: t for t in reversed(pending)}
            terrains = list({task_config(config, t).terrain: None for t in by_location.values()})
            client.register_plugin(TerrainWarmup(terrains))
            futures = client.map(_run_on_worker, [config] * len(pending), pending, [str(out_dir)] * len(pending),
                                 [threads] * len(pending), key=[f"render-{t.task_id}" for t in pending],
                                 pure=False, retries=RETRIES)
            names = {f.key: t.task_id for f, t in zip(futures, pending)}
            done = 0
            for future in as_completed(futures):
                task_id = names[future.key]
                if future.status == "finished":
                    outcome = future.result()
                    result.samples += outcome["samples"]
                    result.rendered += 0 if outcome["skipped"] else 1
                else:
                    result.failed[task_id] = repr(future.exception())
                # Release at once: a held result pins its task to the worker that ran it, and
                # that worker's death would make the scheduler run the finished task again.
                future.release()
                done += 1
                elapsed = time.perf_counter() - start
                rate = result.samples / elapsed if elapsed > 0 else 0.0
                eta = elapsed / done * (len(pending) - done)
                say(f"[{done}/{len(pending)}] {task_id}: {'failed' if task_id in result.failed else 'done'}; "
                    f"{result.samples} samples, {rate:.2f} samples/s, ETA {eta:.0f} s")
            del futures
        finally:
            if own_client is not None:
                own_client.close()
            if own_cluster is not None:
                own_cluster.close()
