"""How the driver of `moonbot generate` tells a hung task from a slow one.

A task reports each stage it enters (compose scene, build BVH, render view k, encode view k, ...)
by rewriting a small JSON file, OUT/running/<task_id>.json: its heartbeat. Progress is a new
stage; nothing else counts, so a thread that beats on its own cannot hide a hang. The driver
reads the files of the tasks it is waiting for every few seconds and times each beat with its
own clock, from when it first read it: workers' clocks never enter, and the files need only the
shared filesystem the tasks already write to. A task whose beat has not changed for longer than
the stall limit is hung; the driver then restarts its worker process through the worker's nanny
(which kills it even when the hung code holds the GIL) and the task runs again.

Why a file: the worker itself cannot be asked (`client.run` needs its event loop, which stops
when hung code holds the GIL); scheduler metadata set by the task would do, but costs each task a
client of its own and a round trip at every stage, where the file needs only the filesystem the
task and the driver already share.

A debug setting makes one task hang for real, to test all of this on a real cluster: the
environment variable MOONBOT_DEBUG_HANG_TASK=<task_id> (or <task_id>@<stage>, e.g.
`train-000003@render view 1`) set where the workers start makes that task block forever at the
start of its first stage (or of the stage named), after reporting it, in a C call that holds the
GIL: the worst kind of hang, which only a signal from outside ends. Its gentle sibling,
MOONBOT_DEBUG_HOLD_TASK (the same syntax), holds that task there until the file
OUT/running/<task_id>.release exists, so that a test can act at a known point of a run (kill the
task's worker or the driver) and then let the task go on; each later run of the task waits too
until then.
"""

from __future__ import annotations

import ctypes
import json
import os
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from moonbot.atomic_io import atomic_write
from moonbot.config import Config

HEARTBEAT_DIR = "running"
DEBUG_HANG_ENV = "MOONBOT_DEBUG_HANG_TASK"
DEBUG_HOLD_ENV = "MOONBOT_DEBUG_HOLD_TASK"
# How often a held task looks for its release file, seconds.
HOLD_POLL_S = 0.05

# The stall limit when --task-timeout is not given: a stage may last STALL_FLOOR_S, or
# RENDER_BUDGET_S_PER_MEGASAMPLE for each million pixel samples a view renders (a view's render is
# the longest stage a task has; bench/results/generate-amd-epyc-2c.json has about 1.3 s a million
# on one thread, so the budget is some 50 times that), or STALL_FACTOR times the
# longest stage of the tasks finished so far in the run, whichever is largest. The floor keeps
# small configs from being judged on stages of milliseconds, and the factor covers scenes heavier
# than the ones finished first (more bags, dust) and a loaded machine.
STALL_FLOOR_S = 300.0
RENDER_BUDGET_S_PER_MEGASAMPLE = 60.0
STALL_FACTOR = 10.0


def heartbeat_dir(out_dir: Path) -> Path:
    """Where the heartbeats of a run into `out_dir` are: one file per running task."""
    return Path(out_dir) / HEARTBEAT_DIR


def release_path(out_dir: Path, task_id: str) -> Path:
    """The file whose existence lets a task held by MOONBOT_DEBUG_HOLD_TASK go on."""
    return heartbeat_dir(out_dir) / f"{task_id}.release"


class Heartbeat:
    """The worker's side: `stage(name)` records that the task entered stage `name` (and how long
    the previous one lasted); `close()` removes the file when the task ends, whichever way."""

    def __init__(self, out_dir: Path, task_id: str, worker: str) -> None:
        self.path = heartbeat_dir(out_dir) / f"{task_id}.json"
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.task_id = task_id
        self.worker = worker
        self.attempt = os.urandom(8).hex()  # tells this run of the task from an earlier, killed one
        self.beats = 0
        self.longest_stage_s = 0.0  # seconds, over the stages that ended
        self._started = self._stage_started = time.monotonic()
        self._hang_stage = debug_hang_stage(task_id)
        self._hold_stage = debug_hold_stage(task_id)
        self._release = release_path(out_dir, task_id)

    def stage(self, name: str) -> None:
        now = time.monotonic()
        if self.beats:
            self.longest_stage_s = max(self.longest_stage_s, now - self._stage_started)
        self._stage_started = now
        self.beats += 1
        record = {
            "task_id": self.task_id,
            "attempt": self.attempt,
            "beat": self.beats,
            "stage": name,
            "worker": self.worker,
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "elapsed_s": now - self._started,
        }
        atomic_write(self.path, "w", lambda f: f.write(json.dumps(record) + "\n"))
        if self._hang_stage is not None and self._hang_stage in ("", name):
            hang_holding_the_gil()
        if self._hold_stage is not None and self._hold_stage in ("", name):
            while not self._release.exists():
                time.sleep(HOLD_POLL_S)

    def close(self) -> None:
        if self.beats:
            self.longest_stage_s = max(self.longest_stage_s, time.monotonic() - self._stage_started)
        self.path.unlink(missing_ok=True)


def hang_holding_the_gil() -> None:
    """Blocks the calling thread for good inside a C call that keeps the GIL (libc's pause()
    through ctypes.PyDLL): the worst hang, as of an extension that deadlocks before releasing the
    GIL. No Python code of the process runs again, the worker's event loop included, so only a
    signal from outside ends it."""
    libc = ctypes.PyDLL(None)
    while True:
        libc.pause()  # returns after a handled signal; the handler itself waits for the GIL


def debug_hang_stage(task_id: str) -> str | None:
    """The stage at which MOONBOT_DEBUG_HANG_TASK makes `task_id` hang ("" = its first stage), or
    None when it names another task or is unset."""
    return _debug_stage(DEBUG_HANG_ENV, task_id)


def debug_hold_stage(task_id: str) -> str | None:
    """The stage at which MOONBOT_DEBUG_HOLD_TASK holds `task_id` until its release file exists
    ("" = its first stage), or None when it names another task or is unset."""
    return _debug_stage(DEBUG_HOLD_ENV, task_id)


def _debug_stage(variable: str, task_id: str) -> str | None:
    """The stage named by the environment variable `variable` (<task_id>[@<stage>]) for `task_id`."""
    setting = os.environ.get(variable, "")
    target, _, stage = setting.partition("@")
    return stage.strip() if setting and target.strip() == task_id else None


@dataclass(frozen=True)
class Beat:
    """A task's last heartbeat as the driver read it; `seen_at` is the driver's time.monotonic()
    when it first read this beat."""

    task_id: str
    attempt: str
    beat: int
    stage: str
    worker: str
    host: str
    pid: int
    elapsed_s: float  # seconds since the task started, on the worker, at this beat
    seen_at: float

    def stalled_s(self, now: float) -> float:
        """Seconds without progress: since this beat was first read."""
        return now - self.seen_at

    def task_s(self, now: float) -> float:
        """Seconds since the task started (as far as the driver can tell)."""
        return self.elapsed_s + self.stalled_s(now)

    def where(self) -> str:
        return f"stage {self.stage!r} on worker {self.worker} (host {self.host}, pid {self.pid})"


class StallLimit:
    """The seconds a task may go without progress: `fixed_s` when given (0: never judged hung),
    else the larger of the config's floor (see STALL_FLOOR_S) and STALL_FACTOR times the longest
    stage of the tasks finished so far (`finished`)."""

    def __init__(self, config: Config, fixed_s: float | None = None) -> None:
        self.fixed_s = fixed_s
        self.floor_s = default_floor_s(config)
        self.longest_stage_s = 0.0

    def finished(self, longest_stage_s: float) -> None:
        self.longest_stage_s = max(self.longest_stage_s, longest_stage_s)

    @property
    def seconds(self) -> float | None:
        """The limit now; None when no task is ever judged hung."""
        if self.fixed_s is not None:
            return self.fixed_s or None
        return max(self.floor_s, STALL_FACTOR * self.longest_stage_s)

    def describe(self) -> str:
        if self.fixed_s is not None:
            return "off (--task-timeout 0)" if not self.fixed_s else f"{self.fixed_s:g} s (--task-timeout)"
        return (
            f"{self.seconds:.0f} s without progress (the larger of {self.floor_s:.0f} s and "
            f"{STALL_FACTOR:g}x the longest stage of the tasks finished; --task-timeout sets it)"
        )


def default_floor_s(config: Config) -> float:
    """The stall limit before any task has finished, seconds: STALL_FLOOR_S, or the render budget
    of one view of `config`, whichever is larger. The sweep's splits keep the base camera and
    render settings, so one view of the base config stands for every task's."""
    megasamples = config.camera.width * config.camera.height * config.render.spp / 1e6
    return max(STALL_FLOOR_S, RENDER_BUDGET_S_PER_MEGASAMPLE * megasamples)


class Watchdog:
    """The driver's side: `poll(task_ids)` reads the heartbeats of the tasks it waits for and
    returns those stalled beyond the limit; `dismiss(beat)` stops judging a run of a task whose
    worker was restarted (its next run beats afresh); `forget(task_id)` drops a task that ended."""

    def __init__(self, out_dir: Path, limit: StallLimit) -> None:
        self.directory = heartbeat_dir(out_dir)
        self.limit = limit
        self.beats: dict[str, Beat] = {}
        # Runs whose worker was restarted. Their last heartbeat stays until the task's next run
        # overwrites it: deleting it could delete that next run's first beats instead (the
        # scheduler may start it elsewhere while the restart is still under way).
        self.dismissed: set[str] = set()

    def poll(self, waiting: set[str], now: float) -> list[Beat]:
        try:
            entries = list(os.scandir(self.directory))
        except FileNotFoundError:
            entries = []
        for entry in entries:
            task_id = entry.name.removesuffix(".json")
            if not entry.name.endswith(".json") or task_id not in waiting:
                continue
            try:
                record = json.loads(Path(entry.path).read_text())
                key = (record["attempt"], record["beat"])
            except (OSError, ValueError, KeyError, TypeError):
                continue  # removed meanwhile, or not a heartbeat
            if record["attempt"] in self.dismissed:
                continue
            known = self.beats.get(task_id)
            if known is None or (known.attempt, known.beat) != key:
                self.beats[task_id] = Beat(
                    task_id,
                    record["attempt"],
                    record["beat"],
                    str(record["stage"]),
                    str(record["worker"]),
                    str(record["host"]),
                    int(record["pid"]),
                    float(record["elapsed_s"]),
                    now,
                )
        limit = self.limit.seconds
        if limit is None:
            return []
        return [b for b in self.beats.values() if b.task_id in waiting and b.stalled_s(now) > limit]

    def dismiss(self, beat: Beat) -> None:
        self.dismissed.add(beat.attempt)
        if self.beats.get(beat.task_id) == beat:
            del self.beats[beat.task_id]

    def forget(self, task_id: str) -> None:
        self.beats.pop(task_id, None)
        (self.directory / f"{task_id}.json").unlink(missing_ok=True)
