"""What `moonbot generate` left in OUT/tasks, as merge sees it: the complete tasks grouped into
scenes, and what is missing, unusable or foreign.

A task directory `OUT/tasks/<task_id>/` is complete when its DONE.json (written last) reads
and every file it lists is there with its size (moonbot.records.done); hidden entries
(`.<task_id>.*.tmp`, `.old`: an interrupted task's temporaries) are not tasks and are skipped
silently. Its task.json (moonbot.records.task) must match DONE.json's checksum and name the
directory as its task_id.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

from moonbot.config import Config, config_hash
from moonbot.records.base import RecordError
from moonbot.records.done import DONE, FileEntry, complete_files
from moonbot.records.task import TASK, TaskRecord, read_task
from moonbot.sweep import task_config, tasks

# Fields every task of one scene shares.
SCENE_FIELDS = (
    "split",
    "scene_id",
    "mesh",
    "obj_id",
    "location",
    "bags",
    "stain_seeds",
    "dust",
    "tasks_per_scene",
    "views_per_task",
    "seed",
)


class MergeError(ValueError):
    """The task directories cannot be merged as they are (they contradict each other); the
    message names the file and the field."""


@dataclass(frozen=True)
class TaskDir:
    """One complete task: its directory, task.json (`task`) and DONE.json's listing (`files`:
    path relative to the directory → its size and sha256)."""

    path: Path
    task: TaskRecord
    files: dict[str, FileEntry]

    @property
    def task_id(self) -> str:
        return self.task.task_id

    @functools.cached_property
    def record(self) -> dict:
        """task.json as the JSON object it holds: the values merge copies into the scene files."""
        return self.task.as_json()


@dataclass(frozen=True)
class SceneTasks:
    """The complete tasks of one scene, by task_in_scene, and the task_in_scene values missing."""

    split: str
    scene_id: int
    tasks: tuple[TaskDir, ...]
    missing: tuple[int, ...]

    @property
    def record(self) -> dict:
        """The scene's shared fields (SCENE_FIELDS), from its first task."""
        return {k: getattr(self.tasks[0].task, k) for k in SCENE_FIELDS}


@dataclass
class Inventory:
    """Scenes to merge (split order, then scene_id), and what will not be merged: `missing`
    (tasks the sweep has but OUT/tasks does not; without a config, only the missing tasks of
    scenes that have at least one), `invalid` (directory name → why it cannot be used),
    `extra` (complete tasks that are not in the config's sweep), `splits` in dataset order,
    `position` (task_id → index in the config's sweep; empty without a config)."""

    scenes: list[SceneTasks] = field(default_factory=list)
    splits: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    invalid: dict[str, str] = field(default_factory=dict)
    extra: list[str] = field(default_factory=list)
    position: dict[str, int] = field(default_factory=dict)


def read_task_record(directory: Path, sha256: str | None = None) -> TaskRecord:
    """task.json of a task directory, checked against DONE.json's `sha256` (when given), field by
    field, and against the directory's name. MergeError naming the file and field."""
    path = directory / TASK
    try:
        record = read_task(path, sha256)
    except RecordError as e:
        raise MergeError(str(e)) from None
    if record.task_id != directory.name:
        raise MergeError(f"{path}: task_id: is {record.task_id!r}, but the directory is {directory.name!r}")
    return record


def scan_tasks(tasks_dir: Path, config: Config | None = None) -> Inventory:
    """Reads every task directory under `tasks_dir` (OUT/tasks) and groups the complete ones into
    scenes. With the sweep's `config`, the expected tasks are its sweep's (missing ones named by
    task_id, splits in its order) and a task rendered with another config (its config_hash differs
    from the sweep's for that task) is invalid; without, splits are sorted by name. A directory
    that is not complete, or whose task.json is unreadable or malformed, is reported in `invalid`
    and skipped. MergeError when complete tasks contradict each other (two claim one image range,
    or tasks of one scene disagree on a SCENE_FIELDS value, or the camera or meshes differ)."""
    inventory = Inventory()
    complete: list[TaskDir] = []
    entries = sorted(p for p in tasks_dir.iterdir() if not p.name.startswith(".")) if tasks_dir.is_dir() else []
    for directory in entries:
        if not directory.is_dir():
            continue
        files = complete_files(directory)
        if files is None:
            inventory.invalid[directory.name] = (
                f"{directory / DONE}: missing, unreadable, or a listed file is missing or truncated"
            )
            continue
        try:
            record = read_task_record(directory, files[TASK].sha256 if TASK in files else None)
        except MergeError as e:
            inventory.invalid[directory.name] = str(e)
            continue
        complete.append(TaskDir(directory, record, files))

    if config is not None:
        expected = {t.task_id: t for t in tasks(config)}
        by_id = {t.task_id: t for t in complete}
        inventory.missing = [task_id for task_id in expected if task_id not in by_id]
        inventory.extra = sorted(task_id for task_id in by_id if task_id not in expected)
        kept = []
        for task in complete:
            sweep_task = expected.get(task.task_id)
            if sweep_task is None:
                continue
            want = config_hash(task_config(config, sweep_task))
            if task.task.config_hash != want:
                inventory.invalid[task.task_id] = (
                    f"{task.path / TASK}: config_hash: is "
                    f"{task.task.config_hash[:12]}..., the sweep's config "
                    f"gives {want[:12]}... (rendered with another config)"
                )
                inventory.missing.append(task.task_id)
                continue
            kept.append(task)
        complete = kept
        order = [s.name for s in config.sweep.splits] or ["default"]
        inventory.position = {task_id: k for k, task_id in enumerate(expected)}
        inventory.missing.sort(key=inventory.position.__getitem__)
    else:
        order = sorted({t.task.split for t in complete})

    _check_shared(complete, "config.camera", lambda r: r.config.get("camera"))
    _check_shared(complete, "config.meshes", lambda r: r.config.get("meshes"))
    scenes: dict[tuple[str, int], dict[int, TaskDir]] = {}
    for task in complete:
        r = task.task
        group = scenes.setdefault((r.split, r.scene_id), {})
        if r.task_in_scene in group:
            other = group[r.task_in_scene]
            raise MergeError(
                f"{task.path / TASK}: split {r.split!r}, scene_id {r.scene_id} and task_in_scene "
                f"{r.task_in_scene} are also those of {other.path / TASK}"
            )
        first = next(iter(group.values()), None)
        if first is not None:
            for name in SCENE_FIELDS:
                mine, theirs = getattr(r, name), getattr(first.task, name)
                if mine != theirs:
                    raise MergeError(
                        f"{task.path / TASK}: {name}: is {mine!r}, but {first.path / TASK} "
                        f"of the same scene has {theirs!r}"
                    )
        group[r.task_in_scene] = task
    for (split, scene_id), group in sorted(scenes.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1])):
        ordered = tuple(group[k] for k in sorted(group))
        absent = tuple(k for k in range(ordered[0].task.tasks_per_scene) if k not in group)
        inventory.scenes.append(SceneTasks(split, scene_id, ordered, absent))
        if config is None:
            inventory.missing += [f"{split} scene {scene_id:06d} task {k}" for k in absent]
    inventory.splits = [s for s in order if any(sc.split == s for sc in inventory.scenes)]
    return inventory


def _check_shared(complete: list[TaskDir], name: str, get) -> None:
    """MergeError unless every task has the same value of `name` (the dataset has one camera and
    one set of object models)."""
    if not complete:
        return
    first = get(complete[0].task)
    for task in complete[1:]:
        if get(task.task) != first:
            raise MergeError(
                f"{task.path / TASK}: {name}: differs from {complete[0].path / TASK}'s "
                "(one dataset has one camera and one set of object models)"
            )
