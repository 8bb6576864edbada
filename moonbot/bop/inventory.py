"""What `moonbot generate` left in OUT/tasks, as merge sees it: the complete tasks grouped into
scenes, and what is missing, unusable or foreign.

A task directory `OUT/tasks/<task_id>/` is complete when its DONE.json (written last) parses
and every file it lists is there with its size; hidden entries (`.<task_id>.*.tmp`, `.old`:
an interrupted task's temporaries) are not tasks and are skipped silently. DONE.json's `files`
maps a path relative to the task directory to `{"bytes": int, "sha256": hex}` (moonbot.pipeline
.tasks) or to a bare sha256 hex string (accepted too; then sizes are not checked).

task.json must hold, with these types: task_id (str, the directory's name), split (str),
scene_id, task_in_scene, tasks_per_scene, obj_id, bags, stain_seeds, views_per_task, seed
(int), mesh, location (str), dust (bool), sun_azimuth_deg, sun_elevation_deg, camera_height_m
(number), views (list of int, views_per_task of them), config (object), config_hash (str).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from moonbot.config import Config, config_hash
from moonbot.sweep import task_config, tasks

DONE = "DONE.json"
TASK = "task.json"

_FIELDS: dict[str, type | tuple[type, ...]] = {
    "task_id": str, "split": str, "scene_id": int, "task_in_scene": int, "tasks_per_scene": int,
    "mesh": str, "obj_id": int, "location": str, "bags": int, "stain_seeds": int, "dust": bool,
    "sun_azimuth_deg": (int, float), "sun_elevation_deg": (int, float), "camera_height_m": (int, float),
    "views": list, "views_per_task": int, "seed": int, "config": dict, "config_hash": str,
}
# Fields every task of one scene shares.
SCENE_FIELDS = ("split", "scene_id", "mesh", "obj_id", "location", "bags", "stain_seeds", "dust",
                "tasks_per_scene", "views_per_task", "seed")


class MergeError(ValueError):
    """The task directories cannot be merged as they are (they contradict each other); the
    message names the file and the field."""


@dataclass(frozen=True)
class TaskDir:
    """One complete task: its directory, task.json (`record`) and DONE.json's listing (`files`:
    path relative to the directory → {"bytes": int or None, "sha256": hex})."""

    path: Path
    record: dict
    files: dict

    @property
    def task_id(self) -> str:
        return self.record["task_id"]


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
        return {k: self.tasks[0].record[k] for k in SCENE_FIELDS}


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


def read_done(directory: Path) -> dict | None:
    """DONE.json's files of a task directory, normalised to {path: {"bytes": int or None,
    "sha256": hex}}; None when the task is not complete (no or unreadable marker, a listed file
    missing or of another size)."""
    try:
        done = json.loads((directory / DONE).read_text(encoding="utf-8"))
        files = {}
        for name, entry in done["files"].items():
            if isinstance(entry, str):
                entry = {"bytes": None, "sha256": entry}
            size = (directory / name).stat().st_size
            if entry.get("bytes") is not None and size != entry["bytes"]:
                return None
            files[name] = {"bytes": entry.get("bytes"), "sha256": str(entry["sha256"])}
        return files
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def read_task_record(directory: Path, sha256: str | None = None) -> dict:
    """task.json of a task directory, checked against DONE.json's `sha256` (when given) and field
    by field. MergeError naming the file and field when one is missing or of the wrong type."""
    path = directory / TASK
    try:
        data = path.read_bytes()
    except OSError as e:
        raise MergeError(f"{path}: cannot read ({e.strerror or e})") from None
    if sha256 is not None and hashlib.sha256(data).hexdigest() != sha256:
        raise MergeError(f"{path}: sha256 differs from DONE.json's")
    try:
        record = json.loads(data.decode("utf-8"))
    except ValueError as e:
        raise MergeError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(record, dict):
        raise MergeError(f"{path}: must be a JSON object")
    for name, kind in _FIELDS.items():
        if name not in record:
            raise MergeError(f"{path}: field '{name}' is missing")
        value = record[name]
        ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
        if kind == (int, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not ok:
            raise MergeError(f"{path}: field '{name}' must be {_kind_name(kind)}, got {value!r}")
    if record["task_id"] != directory.name:
        raise MergeError(f"{path}: field 'task_id' is {record['task_id']!r}, but the directory is {directory.name!r}")
    for name in ("scene_id", "task_in_scene", "obj_id", "bags", "stain_seeds"):
        if record[name] < 0:
            raise MergeError(f"{path}: field '{name}' must be >= 0, got {record[name]}")
    if not 0 <= record["task_in_scene"] < record["tasks_per_scene"]:
        raise MergeError(f"{path}: field 'task_in_scene' must be in 0..tasks_per_scene-1 "
                         f"({record['tasks_per_scene'] - 1}), got {record['task_in_scene']}")
    views = record["views"]
    indices = all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in views)
    if not indices or len(set(views)) != len(views):
        raise MergeError(f"{path}: field 'views' must be distinct orbit indices (ints >= 0), got {views!r}")
    if len(views) != record["views_per_task"] or not views:
        raise MergeError(f"{path}: field 'views' has {len(views)} entries, "
                         f"views_per_task says {record['views_per_task']}")
    if not record["split"] or not all(c.isalnum() or c in "-_" for c in record["split"]):
        raise MergeError(f"{path}: field 'split' must be letters, digits, '-' or '_', got {record['split']!r}")
    for name in ("mesh", "location"):
        if not record[name] or "/" in record[name] or record[name].startswith("."):
            raise MergeError(f"{path}: field '{name}' must be a plain name, got {record[name]!r}")
    return record


def _kind_name(kind) -> str:
    names = {str: "a string", int: "an integer", bool: "true or false", list: "a list", dict: "an object"}
    return "a number" if kind == (int, float) else names[kind]


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
        files = read_done(directory)
        if files is None:
            inventory.invalid[directory.name] = (f"{directory / DONE}: missing, unreadable, or a listed file "
                                                 "is missing or truncated")
            continue
        try:
            record = read_task_record(directory, files.get(TASK, {}).get("sha256"))
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
            if task.record["config_hash"] != want:
                inventory.invalid[task.task_id] = (f"{task.path / TASK}: field 'config_hash' is "
                                                   f"{task.record['config_hash'][:12]}..., the sweep's config "
                                                   f"gives {want[:12]}... (rendered with another config)")
                inventory.missing.append(task.task_id)
                continue
            kept.append(task)
        complete = kept
        order = [s.name for s in config.sweep.splits] or ["default"]
        inventory.position = {task_id: k for k, task_id in enumerate(expected)}
        inventory.missing.sort(key=inventory.position.__getitem__)
    else:
        order = sorted({t.record["split"] for t in complete})

    _check_shared(complete, "config.camera", lambda r: r["config"].get("camera"))
    _check_shared(complete, "config.meshes", lambda r: r["config"].get("meshes"))
    scenes: dict[tuple[str, int], dict[int, TaskDir]] = {}
    for task in complete:
        r = task.record
        group = scenes.setdefault((r["split"], r["scene_id"]), {})
        if r["task_in_scene"] in group:
            other = group[r["task_in_scene"]]
            raise MergeError(f"{task.path / TASK}: split {r['split']!r}, scene_id {r['scene_id']} and task_in_scene "
                             f"{r['task_in_scene']} are also those of {other.path / TASK}")
        first = next(iter(group.values()), None)
        if first is not None:
            for name in SCENE_FIELDS:
                if r[name] != first.record[name]:
                    raise MergeError(f"{task.path / TASK}: field '{name}' is {r[name]!r}, but {first.path / TASK} "
                                     f"of the same scene has {first.record[name]!r}")
        group[r["task_in_scene"]] = task
    for (split, scene_id), group in sorted(scenes.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1])):
        ordered = tuple(group[k] for k in sorted(group))
        absent = tuple(k for k in range(ordered[0].record["tasks_per_scene"]) if k not in group)
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
    first = get(complete[0].record)
    for task in complete[1:]:
        if get(task.record) != first:
            raise MergeError(f"{task.path / TASK}: field '{name}' differs from {complete[0].path / TASK}'s "
                             "(one dataset has one camera and one set of object models)")
