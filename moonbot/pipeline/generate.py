"""`moonbot generate`: the sweep's tasks sharded over a Dask cluster (why it is built
this way: docs/scaling.md). Each task runs on a worker process with one Dask thread while the C++
core uses the cores; the filesystem is the record of what is done, so a rerun (or --resume)
submits only the tasks without a complete directory, and the dataset's bytes never depend on
which worker ran what, in which order, or how often a task was retried. The bags of a scene are
placed and settled once, by a placement task per layout (moonbot.pipeline.placements) that the
scene's tasks depend on; a placement that fails fails them, naming the layout. A task that stops making
progress (moonbot.pipeline.heartbeat) has its worker restarted and runs again; one that hangs
RETRIES + 1 times is reported failed, and the others go on. Interrupted (Ctrl-C, SIGTERM), a run
closes its cluster, removes the local cluster's scratch space and the unfinished tasks'
temporaries, and returns what is complete, unmerged (GenerateResult.interrupted)."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import dask
from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker

from moonbot.atomic_io import atomic_write
from moonbot.bop.merge import merge_dataset
from moonbot.config import Config, ConfigError, config_hash, load_config
from moonbot.pipeline.heartbeat import Beat, Heartbeat, StallLimit, Watchdog, heartbeat_dir
from moonbot.pipeline.placements import TASK_PREFIX, layout_id, place_layout, placement_for, placement_path, read_record
from moonbot.pipeline.stats import collect
from moonbot.pipeline.tasks import is_complete, run_task, sweep_temporaries, task_dir
from moonbot.records.done import DONE, read_done
from moonbot.sweep import Task, task_config, tasks
from moonbot.yolo.export import write_yolo

# A worker's death counts against the tasks it held; a few deaths of one task are the cluster's
# fault (preemption, the out-of-memory killer), more are the task's (docs/scaling.md).
ALLOWED_FAILURES = 5
# A task that raises (a transient I/O error), or hangs, is tried this many more times before it
# is reported.
RETRIES = 2
# With no task finishing, the progress line is repeated this often (seconds), with the running
# task longest without progress: a run never looks frozen.
STATUS_EVERY_S = 30.0
# The progress line names this many running tasks, the oldest first, with their ages.
RUNNING_SHOWN = 3
# A finished task's small result is read from the worker that ran it, which may meanwhile be stuck
# in a hung task holding the GIL: after this many seconds the driver reads the task's directory
# (or placement record) instead, so that it goes on watching and can restart that worker.
RESULT_WAIT_S = 5.0


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


def _worker_address() -> str:
    try:
        return get_worker().address
    except ValueError:
        return "local"


def _place_on_worker(config: Config, task: Task, out_dir: str) -> dict:
    """The function a worker runs for a layout (that of `task`): its bags placed and settled, or
    read back from an earlier run, with a heartbeat of its own (OUT/running/place-<layout>.json);
    place_layout's dict plus the longest stage's seconds. Its result feeds the layout's tasks."""
    worker = _worker_address()
    heartbeat = Heartbeat(Path(out_dir), TASK_PREFIX + layout_id(task), worker)
    try:
        heartbeat.stage("start")
        outcome = place_layout(config, task, Path(out_dir), worker=worker, on_stage=heartbeat.stage)
    finally:
        heartbeat.close()
    return {**outcome, "longest_stage_s": heartbeat.longest_stage_s}


def _run_on_worker(config: Config, task: Task, out_dir: str, threads: int | None, placed: dict | None = None) -> dict:
    """The function a worker runs: one task, with its heartbeat, reported as a small dict (the
    images stay on disk). `placed`: its layout's placement (_place_on_worker's result; None: the
    task places its bags itself)."""
    worker = _worker_address()
    heartbeat = Heartbeat(Path(out_dir), task.task_id, worker)
    try:
        heartbeat.stage("start")
        placement = None if placed is None else placement_for(task_config(config, task), placed["record"])
        outcome = run_task(
            config, task, Path(out_dir), threads=threads, worker=worker, on_stage=heartbeat.stage, placement=placement
        )
    finally:
        heartbeat.close()
    return {
        "task_id": outcome.task_id,
        "skipped": outcome.skipped,
        "samples": outcome.samples,
        "seconds": outcome.stats.wall_s if outcome.stats else 0.0,
        "longest_stage_s": heartbeat.longest_stage_s,
    }


@dataclass
class GenerateResult:
    """What a run did: tasks in the sweep, already complete before it, rendered by it, and failed
    (task_id → error text); layouts placed (bags placed and settled) by it, or read back from an
    earlier run's OUT/placements; `hangs`: every hang detected (a Hang: the task's stage, worker,
    host and times), retried or not."""

    tasks: int = 0
    complete_before: int = 0
    rendered: int = 0
    samples: int = 0
    placed: int = 0  # layouts whose bags this run placed and settled (each once)
    placed_before: int = 0  # layouts whose placement an earlier run had kept
    failed: dict = field(default_factory=dict)
    hangs: list = field(default_factory=list)
    seconds: float = 0.0
    merge: object = None  # the MergeReport of the merge that ended the run (None: not merged)
    interrupted: str | None = None  # the signal that stopped the run ("SIGINT", "SIGTERM"), None if none did
    complete: int = 0  # tasks complete in OUT/tasks when the run ended


class Interrupted(KeyboardInterrupt):
    """A run stopped by a signal other than SIGINT (which raises KeyboardInterrupt itself)."""

    def __init__(self, signal_name: str) -> None:
        super().__init__(signal_name)
        self.signal_name = signal_name


@contextmanager
def sigterm_interrupts():
    """While it is open, SIGTERM (`kill`, a batch system's stop) interrupts the main thread as
    Ctrl-C does, so the run's clean-up runs instead of the process just ending. (Signal handlers
    belong to the main thread: elsewhere this does nothing.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise Interrupted(signal.Signals(signum).name)

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def pending_tasks(config: Config, out_dir: Path) -> tuple[list[Task], int]:
    """(the sweep's tasks without a complete directory in `out_dir`, in sweep order; how many are
    complete)."""
    all_tasks = tasks(config)
    pending = [t for t in all_tasks if not is_complete(task_dir(out_dir, t))]
    return pending, len(all_tasks) - len(pending)


def generate(
    config: Config | str | Path | None,
    out_dir: Path,
    *,
    client: Client | None = None,
    workers: int | None = None,
    threads: int | None = None,
    scheduler: str | None = None,
    scheduler_file: str | None = None,
    merge: bool = True,
    task_timeout: float | None = None,
    progress=sys.stderr,
) -> GenerateResult:
    """Renders every task of the config's sweep missing from `out_dir` (OUT/tasks/<task_id>/).
    The cluster: `client` if given; else the scheduler at `scheduler` (an address) or in
    `scheduler_file`; else a LocalCluster of `workers` processes (default: one per core, at most
    the tasks) with one Dask thread each. `threads` sets each task's render threads (default: the
    config's render.threads on a given cluster, cores / workers on the local one; the images do
    not depend on it). Prints progress to
    `progress` (None: silent). A task that fails is reported in the result and the others go on;
    so is one that hangs (no new stage for `task_timeout` seconds, default: StallLimit's; 0:
    never judged hung) RETRIES + 1 times, its worker restarted after each.
    The resolved config is kept as OUT/config.json (a later run into the same OUT must have the
    same config); at the end the tasks' stats are collected (OUT/stats/) and, with `merge`, the
    complete tasks are merged into the BOP dataset OUT/dataset (missing ones reported).
    Interrupted by Ctrl-C or SIGTERM, it closes the cluster, removes the temporaries (the local
    cluster's scratch space, unfinished tasks' staging folders, heartbeats) and returns at once
    with `interrupted` set and nothing merged: `moonbot merge OUT` merges what is complete."""
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
    try:
        with sigterm_interrupts():
            if pending:
                render_pending(
                    config,
                    out_dir,
                    pending,
                    result,
                    client,
                    workers,
                    threads,
                    scheduler,
                    scheduler_file,
                    start,
                    say,
                    StallLimit(config, task_timeout),
                )
    except KeyboardInterrupt as e:  # Ctrl-C, or SIGTERM as Interrupted; the cluster is closed by now
        result.interrupted = e.signal_name if isinstance(e, Interrupted) else "SIGINT"
    sweep_temporaries(out_dir)
    result.complete = result.tasks - len(pending_tasks(config, out_dir)[0])
    if result.interrupted:
        result.seconds = time.perf_counter() - start
        return result
    if result.rendered or result.complete_before:
        collect(out_dir)
        if merge:
            result.merge = merge_dataset(out_dir, config=config, progress=progress, exporters=(write_yolo,))
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
            raise OSError(
                f"{path}: {out_dir} holds a sweep of another config (hash {config_hash(kept)[:12]}, "
                f"this one {config_hash(config)[:12]}); render it into another --out"
            )
        return
    atomic_write(path, "w", lambda f: f.write(text))


def render_pending(
    config: Config,
    out_dir: Path,
    pending: list[Task],
    result: GenerateResult,
    client,
    workers,
    threads,
    scheduler,
    scheduler_file,
    start: float,
    say,
    limit: StallLimit,
) -> None:
    """Runs `pending` on the cluster (see generate) and records outcomes in `result`. A local
    cluster keeps its scratch space (worker folders, lock files) in a folder of its own under the
    system's temporary folder, removed when it closes, however the run ends."""
    own_cluster = own_client = scratch = None
    settings = {
        "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
        "distributed.scheduler.worker-saturation": 1.0,
    }
    if client is None and not (scheduler or scheduler_file):
        scratch = tempfile.mkdtemp(prefix="moonbot-dask-")
        settings["temporary-directory"] = scratch
    with dask.config.set(settings):
        try:
            if client is None:
                if scheduler or scheduler_file:
                    own_client = client = Client(scheduler) if scheduler else Client(scheduler_file=scheduler_file)
                else:
                    cores = os.cpu_count() or 1
                    n = max(1, min(workers or cores, len(pending)))
                    threads = threads or max(1, cores // n)
                    own_cluster = LocalCluster(
                        n_workers=n,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",
                        silence_logs=40,
                        local_directory=scratch,
                    )
                    own_client = client = Client(own_cluster)
            watch_pending(config, out_dir, pending, result, client, threads, start, say, limit)
        finally:
            if own_client is not None:
                own_client.close()
            if own_cluster is not None:
                own_cluster.close()
            shutil.rmtree(heartbeat_dir(out_dir), ignore_errors=True)
            if scratch is not None:
                shutil.rmtree(scratch, ignore_errors=True)


def watch_pending(
    config: Config,
    out_dir: Path,
    pending: list[Task],
    result: GenerateResult,
    client: Client,
    threads,
    start: float,
    say,
    limit: StallLimit,
) -> None:
    """Submits `pending` (and their layouts' placements) to `client` and watches them to the end."""
    # Heartbeats of an earlier, interrupted run are not this run's tasks'.
    shutil.rmtree(heartbeat_dir(out_dir), ignore_errors=True)
    say(f"dashboard: {client.dashboard_link}")
    say(f"a task is hung after {limit.describe()}")
    # One task per location stands for its terrain (task_config costs ~10 ms; a sweep has thousands).
    by_location = {t.location: t for t in reversed(pending)}
    terrains = list({task_config(config, t).terrain: None for t in by_location.values()})
    client.register_plugin(TerrainWarmup(terrains))
    # One placement per layout with pending tasks, submitted first (so run first); each
    # task waits for its own layout's only.
    layouts = {layout_id(t): t for t in reversed(pending)}
    kept = {layout for layout in layouts if read_record(placement_path(out_dir, layout)) is not None}
    placements = {
        layout: client.submit(
            _place_on_worker, config, t, str(out_dir), key=TASK_PREFIX + layout, pure=False, retries=RETRIES
        )
        for layout, t in sorted(layouts.items(), key=lambda item: item[1].index)
    }
    futures = client.map(
        _run_on_worker,
        [config] * len(pending),
        pending,
        [str(out_dir)] * len(pending),
        [threads] * len(pending),
        [placements[layout_id(t)] for t in pending],
        key=[f"render-{t.task_id}" for t in pending],
        pure=False,
        retries=RETRIES,
    )
    SweepWatch(client, futures, pending, result, Watchdog(out_dir, limit), start, say, out_dir, placements, kept).run()


@dataclass(frozen=True)
class Hang:
    """One hang of a task as the driver saw it: the task's last heartbeat (its stage, worker,
    host and pid), the seconds it had gone without progress and since the task started when it
    was judged hung, and how the restart of its worker went."""

    beat: Beat
    stalled_s: float
    task_s: float
    restart: str

    def describe(self) -> str:
        return (
            f"no progress for {self.stalled_s:.0f} s in {self.beat.where()}, {self.task_s:.0f} s into "
            f"the task; worker {self.restart}"
        )


class SweepWatch:
    """Waits for a sweep's futures: records each outcome in `result` as it comes, and every few
    seconds reads the running tasks' heartbeats, restarting the worker of a task hung beyond the
    limit (RETRIES + 1 hangs: the task is cancelled and reported failed). Prints a progress line
    per finished task, and a status line when none finished for STATUS_EVERY_S. The layouts'
    placement futures (`placements`: layout_id → future) are watched the same way, under their
    heartbeat names place-<layout>; one that fails or hangs for good fails the tasks of its layout
    (a failure reaches them through Dask, as the placement's error; a hang is reported to them here)."""

    def __init__(
        self,
        client: Client,
        futures: list,
        tasks: list[Task],
        result: GenerateResult,
        watchdog: Watchdog,
        start: float,
        say,
        out_dir: Path,
        placements: dict | None = None,
        kept_before: set[str] = frozenset(),
    ) -> None:
        self.client = client
        self.out_dir = Path(out_dir)
        self.tasks = {t.task_id: t for t in tasks}
        self.waiting = {t.task_id: f for f, t in zip(futures, tasks)}  # task_id → its future, until reported
        self.names = {f.key: t.task_id for f, t in zip(futures, tasks)}
        self.layout_of = {t.task_id: layout_id(t) for t in tasks}
        # Layouts whose placement an earlier run kept (read before any placement task ran).
        self.kept_before = set(kept_before)
        self.placements = {TASK_PREFIX + layout: future for layout, future in (placements or {}).items()}
        self.waiting.update(self.placements)
        self.names.update({f.key: name for name, f in self.placements.items()})
        self.result = result
        self.watchdog = watchdog
        self.hangs: dict[str, list[Hang]] = {}
        self.start = start
        self.say = say
        self.total = len(tasks)
        self.done = 0
        self.last_line = time.monotonic()

    def run(self) -> None:
        ready = as_completed(list(self.waiting.values()))
        next_poll = 0.0
        while self.waiting:
            if ready.has_ready():
                for future in ready.next_batch(block=False):
                    self.finished(future)
                continue
            now = time.monotonic()
            if now >= next_poll:
                for beat in self.watchdog.poll(set(self.waiting), now):
                    self.hung(beat)
                if now - self.last_line >= STATUS_EVERY_S:
                    count = len(self.waiting)
                    self.line(f"waiting for {count} task{'s' if count > 1 else ''}{self.running(now)}")
                limit = self.watchdog.limit.seconds
                next_poll = now + (5.0 if limit is None else min(5.0, max(0.5, limit / 20)))
            time.sleep(0.05)

    def finished(self, future) -> None:
        task_id = self.names[future.key]
        if self.waiting.get(task_id) is not future:
            return  # cancelled after hanging, and reported then
        if task_id in self.placements:
            self.placement_finished(task_id, future)
            return
        directory = task_dir(self.out_dir, self.tasks[task_id])
        outcome = fetch(future)
        if outcome is not None:
            self.result.samples += outcome["samples"]
            self.result.rendered += 0 if outcome["skipped"] else 1
            self.watchdog.limit.finished(outcome["longest_stage_s"])
        elif future.status != "error" and is_complete(directory):
            # It finished, but its small result went with a worker that died before the driver
            # read it (the future is "lost"), or is held by a worker that does not answer: the
            # task's directory is the record of what it did.
            self.result.samples += read_done(directory / DONE).samples
            self.result.rendered += 1
        elif future.status != "error":
            self.result.failed[task_id] = f"its future ended {future.status!r} without an error or a finished task"
        else:
            earlier = self.hangs.get(task_id)
            self.result.failed[task_id] = repr(future.exception()) + (
                f"; it had hung {len(earlier)} times before: {hang_history(earlier)}" if earlier else ""
            )
        self.report(task_id, future)

    def hung(self, beat: Beat) -> None:
        """Restarts the worker of a task hung at `beat`, so that the scheduler runs the task again.
        At its RETRIES + 1st hang, or when the worker cannot be restarted (and so the task cannot
        run again), the task is cancelled (before the restart: the scheduler must not run it again)
        and reported failed."""
        now = time.monotonic()
        tries = self.hangs.setdefault(beat.task_id, [])
        future = self.waiting[beat.task_id]
        final = len(tries) == RETRIES
        if final:
            future.cancel()
        stalled_s, task_s = beat.stalled_s(now), beat.task_s(now)
        restarted, how = self.restart(beat.worker)
        if not restarted and not final:
            future.cancel()
            final = True
        hang = Hang(beat, stalled_s, task_s, how)
        tries.append(hang)
        self.result.hangs.append(hang)
        self.watchdog.dismiss(beat)  # its next run beats afresh
        limit = self.watchdog.limit.seconds or 0.0
        what = f"{beat.task_id}: hung (limit {limit:.0f} s): {hang.describe()}"
        if not final:
            self.say(f"{what}; trying it again ({len(tries) + 1} of {RETRIES + 1})")
            return
        self.say(f"{what}; giving up after {len(tries)} tries")
        reason = f"hung {len(tries)} times (limit {limit:.0f} s without progress): {hang_history(tries)}"
        if beat.task_id in self.placements:
            self.placement_lost(beat.task_id, future, reason)
            return
        self.result.failed[beat.task_id] = reason
        self.report(beat.task_id, future)

    def placement_finished(self, name: str, future) -> None:
        """A layout's placement ended: counted when it finished (its tasks go on), said when it
        failed (its tasks then fail with its error, which names the layout)."""
        layout = name.removeprefix(TASK_PREFIX)
        outcome = fetch(future)
        if outcome is not None:
            self.watchdog.limit.finished(outcome["longest_stage_s"])
        elif future.status != "error" and read_record(placement_path(self.out_dir, layout)) is not None:
            outcome = {"placed": layout not in self.kept_before}  # its result unreadable (see RESULT_WAIT_S)
        if outcome is not None:
            if outcome["placed"]:
                self.result.placed += 1
            else:
                self.result.placed_before += 1
            self.say(f"{name}: " + ("placed" if outcome["placed"] else "placement kept from an earlier run"))
        else:
            error = repr(future.exception()) if future.status == "error" else f"its future ended {future.status!r}"
            self.say(f"{name}: failed: {error}; the tasks of this layout fail with it")
        self.forget_placement(name, future)

    def placement_lost(self, name: str, future, reason: str) -> None:
        """A layout's placement given up (cancelled after hanging): its waiting tasks can never
        run, so they are cancelled and reported failed, naming the layout and why."""
        self.forget_placement(name, future)
        layout = name.removeprefix(TASK_PREFIX)
        for task_id in [t for t in self.waiting if self.layout_of.get(t) == layout]:
            dependent = self.waiting[task_id]
            dependent.cancel()
            self.result.failed[task_id] = f"the placement of its scene layout {layout} {reason}"
            self.report(task_id, dependent)

    def forget_placement(self, name: str, future) -> None:
        # Released here, its result stays on the cluster for as long as a task of its layout waits for it.
        future.release()
        del self.waiting[name]
        self.watchdog.forget(name)

    def restart(self, worker: str) -> tuple[bool, str]:
        """Has the nanny of `worker` kill its process and start a new one (a worker already gone
        needs nothing: the scheduler reruns its task). (whether the worker is free of the hung
        task, how it went). A restart that fails (no nanny, a nanny that does not answer) is
        reported, never stops the sweep."""
        try:
            if worker not in self.client.scheduler_info(n_workers=-1)["workers"]:
                return True, "gone already"
            status = self.client.restart_workers([worker], timeout=60, raise_for_error=False)[worker]
        except Exception as e:  # noqa: BLE001 — see docstring
            return False, f"not restarted ({e!r})"
        outcomes = {"OK": "restarted", "removed": "removed (it had no nanny to restart it)"}
        return status in outcomes, outcomes.get(status, f"not restarted ({status})")

    def report(self, task_id: str, future) -> None:
        # Release at once: a held result pins its task to the worker that ran it, and
        # that worker's death would make the scheduler run the finished task again.
        future.release()
        del self.waiting[task_id]
        self.watchdog.forget(task_id)
        self.done += 1
        elapsed = time.perf_counter() - self.start
        rate = self.result.samples / elapsed if elapsed > 0 else 0.0
        eta = elapsed / self.done * (self.total - self.done)
        self.line(
            f"{task_id}: {'failed' if task_id in self.result.failed else 'done'}; {self.result.samples} "
            f"samples, {rate:.2f} samples/s, ETA {eta:.0f} s{self.running(time.monotonic())}"
        )

    def running(self, now: float) -> str:
        """The running tasks as running_tasks() says them, after "; " (empty: none known)."""
        text = running_tasks([b for b in self.watchdog.beats.values() if b.task_id in self.waiting], now)
        return f"; {text}" if text else ""

    def line(self, text: str) -> None:
        self.say(f"[{self.done}/{self.total}] {text}")
        self.last_line = time.monotonic()


def running_tasks(beats: list[Beat], now: float) -> str:
    """ "N running: <task> for A s (in <stage> for S s), ..." for the RUNNING_SHOWN oldest of the
    tasks whose last heartbeats are `beats`, then "and K more": each task's age (seconds since
    it started) and its stage's (seconds without progress), on the driver's clock at `now`
    (time.monotonic()). Oldest first by the whole seconds shown, ties by task id: a worker's
    sub-second timing must not reorder tasks whose ages read the same. Empty when `beats` is."""
    if not beats:
        return ""
    oldest = sorted(beats, key=lambda b: (-round(b.task_s(now)), b.task_id))
    shown = ", ".join(
        f"{b.task_id} for {b.task_s(now):.0f} s (in {b.stage!r} for {b.stalled_s(now):.0f} s)"
        for b in oldest[:RUNNING_SHOWN]
    )
    more = len(oldest) - RUNNING_SHOWN
    return f"{len(oldest)} running: {shown}" + (f", and {more} more" if more > 0 else "")


def fetch(future) -> dict | None:
    """A finished future's result, or None when it did not finish or its result could not be
    read within RESULT_WAIT_S (its worker hung or gone)."""
    if future.status != "finished":
        return None
    try:
        return future.result(timeout=RESULT_WAIT_S)
    except Exception:  # noqa: BLE001 — a timeout, or the worker lost meanwhile: the caller reads the files
        return None


def hang_history(hangs: list[Hang]) -> str:
    """Each hang of one task, numbered: where it was and for how long."""
    return " ".join(f"{i}) {h.describe()}." for i, h in enumerate(hangs, 1))
