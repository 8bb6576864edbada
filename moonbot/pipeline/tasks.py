"""One task of a sweep, run to completion or not at all. A task renders its scene's orbit views
into a temporary directory beside its final place, writes its identity (task.json) and its
throughput (stats.json), then DONE.json — the checksum of every file, written last — and only
then renames the directory into place. A task directory with a sound DONE.json is complete and
is never rendered again; anything else (a killed worker's temporary, a directory without its
marker) is not a task and is swept or replaced."""

from __future__ import annotations

import dataclasses
import datetime
import os
import shutil
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from moonbot import __version__
from moonbot.atomic_io import staged_directory
from moonbot.config import Config, config_hash
from moonbot.host import host_record
from moonbot.pipeline.views import run_views
from moonbot.records.done import DONE, DoneRecord, FileEntry, complete_files, read_done, write_done
from moonbot.records.stats import STATS, StatsRecord, write_stats
from moonbot.records.task import TASK, TaskRecord, write_task
from moonbot.scene.placement import Placement
from moonbot.sweep import Task, task_config
from moonbot.writer.checksum import file_sha256


@dataclass(frozen=True)
class TaskOutcome:
    """What running a task did: `skipped` if it was complete already; `samples` written (0 if
    skipped) and its stats.json record (None if skipped)."""

    task_id: str
    skipped: bool
    samples: int
    stats: StatsRecord | None


def task_dir(out_dir: Path, task: Task) -> Path:
    """Where a task's complete output lives."""
    return Path(out_dir) / "tasks" / task.task_id


def is_complete(directory: Path) -> bool:
    """Whether `directory` holds a complete task: DONE.json parses and every file it lists is
    there with its size (checksums are checked by `verify_task`, which reads every byte)."""
    return complete_files(directory) is not None


def verify_task(directory: Path) -> list[str]:
    """The files of a complete task whose bytes no longer match DONE.json (empty: sound)."""
    done = read_done(directory / DONE)
    return [name for name, entry in sorted(done.files.items()) if file_sha256(directory / name)[1] != entry.sha256]


def sweep_temporaries(out_dir: Path) -> list[Path]:
    """Removes what interrupted tasks left in OUT/tasks (hidden `.name.*.tmp` / `.name.*.old`
    directories) and returns them. Only while no other driver writes into `out_dir`."""
    root = Path(out_dir) / "tasks"
    stray = sorted(p for p in root.glob(".*") if p.is_dir() and (p.name.endswith(".tmp") or p.name.endswith(".old")))
    for p in stray:
        shutil.rmtree(p, ignore_errors=True)
    return stray


def generate_folder_dataset(path: Path) -> Path | None:
    """When `path` is the folder of a `moonbot generate --out` run (its config.json and tasks/, and
    no manifest.json of a dataset of its own): where merge puts its dataset by default,
    path/dataset, merged or not yet. None for any other folder."""
    path = Path(path)
    if (path / "config.json").is_file() and (path / "tasks").is_dir() and not (path / "manifest.json").exists():
        return path / "dataset"
    return None


def task_record(config: Config, task: Task, views: list[int]) -> TaskRecord:
    """task.json: the task's identity, where its images go in the dataset, and the config it renders."""
    tconfig = task_config(config, task)
    return TaskRecord(
        **{f.name: getattr(task, f.name) for f in dataclasses.fields(task)},
        task_id=task.task_id,
        views=tuple(views),
        views_per_task=len(views),
        seed=tconfig.seed,
        config=dataclasses.asdict(tconfig),
        config_hash=config_hash(tconfig),
        moonbot_version=__version__,
    )


def run_task(
    config: Config,
    task: Task,
    out_dir: Path,
    threads: int | None = None,
    worker: str = "local",
    on_stage: Callable[[str], None] | None = None,
    placement: Placement | None = None,
) -> TaskOutcome:
    """Renders `task` of `config`'s sweep into OUT/tasks/<task_id>/ unless it is complete there
    already. `threads` overrides render.threads (the images do not depend on it); `on_stage(name)`
    is told each stage as it starts (run_views's, then "finish task": task.json, stats.json, the
    checksums and the rename). `placement`: the task's scene's bags placed and settled already
    (moonbot.pipeline.placements; None: the task places them itself). Raises on failure (a full
    disk, an unwritable directory), leaving no partial task behind."""
    final = task_dir(out_dir, task)
    if is_complete(final):
        return TaskOutcome(task.task_id, True, 0, None)
    started = datetime.datetime.now(datetime.timezone.utc)
    wall, cpu = time.perf_counter(), time.process_time()
    tconfig = task_config(config, task)
    views = list(range(tconfig.orbit.views))
    with staged_directory(final) as staging:
        results = run_views(tconfig, views, staging, threads=threads, on_stage=on_stage, placement=placement)
        if on_stage is not None:
            on_stage("finish task")
        write_task(staging / TASK, task_record(config, task, views))
        stages: dict[str, float] = {}
        rays: dict[str, int] = {}
        for r in results:
            for stage, seconds in r.timings.items():
                stages[stage] = stages.get(stage, 0.0) + seconds
            for kind, count in r.rays.items():
                rays[kind] = rays.get(kind, 0) + int(count)
        wall_s = time.perf_counter() - wall
        # CPU model, id and SIMD flags, and the ISA Embree traced this task's rays in.
        machine = host_record(tconfig.render.embree_isa)
        stats = StatsRecord(
            task_id=task.task_id,
            host=socket.gethostname(),
            pid=os.getpid(),
            cpu_model=machine.pop("cpu_model"),
            cores=os.cpu_count() or 1,
            threads=threads or tconfig.render.threads or render_threads_default(),
            worker=worker,
            started_utc=started.isoformat(),
            wall_s=wall_s,
            cpu_s=time.process_time() - cpu,
            stages_s=stages,
            samples=len(results),
            # Rays traced, summed over the views (moonbot.pipeline.views.ViewResult.rays).
            rays=rays,
            # Everything but stats.json and DONE.json themselves (a few hundred bytes).
            bytes_written=sum(p.stat().st_size for p in staging.rglob("*") if p.is_file()),
            samples_per_s=len(results) / wall_s if wall_s > 0 else 0.0,
            other=machine,
        )
        write_stats(staging / STATS, stats)
        # The marker last: its checksums cover every other file, so a task is whole or absent.
        listing = {}
        for p in sorted(staging.rglob("*")):
            if p.is_file():
                size, sha256 = file_sha256(p)
                listing[str(p.relative_to(staging))] = FileEntry(sha256=sha256, bytes=size)
        write_done(staging / DONE, DoneRecord(task_id=task.task_id, samples=len(results), files=listing))
    return TaskOutcome(task.task_id, False, len(results), stats)


def render_threads_default() -> int:
    """The threads render.threads = 0 gives: TBB's default, the CPUs this process may run on
    (its affinity: a SLURM cpuset or a pinned worker has fewer than the host's cores)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1
