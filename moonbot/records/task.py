"""task.json: a task's identity (moonbot.sweep.Task's fields), where its images go in the dataset
(`views`, the orbit indices it rendered), and the config it rendered (`config`, the resolved
moonbot.config.Config as JSON, and its `config_hash`). moonbot.pipeline.tasks writes it; merge
(moonbot.bop.inventory) reads it. Written with sorted keys, indent 2.

Version 1 (no schema_version) has the same fields."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from moonbot.records.base import SCHEMA_VERSION, add_schema_version, decode, read_json, to_json, write_json

TASK = "task.json"
_NON_NEGATIVE = {"lo": 0}


def _plain_name(name: str, value: str) -> None:
    if not value or "/" in value or value.startswith("."):
        raise ValueError(f"{name}: must be a plain name, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class TaskRecord:
    """task.json. Angles in degrees, heights in metres; `index` numbers the sweep's tasks from 0,
    `scene_id` its split's scenes, `task_in_scene` its scene's tasks (of `tasks_per_scene`);
    `views` are distinct orbit indices, `views_per_task` of them; `seed` is the task config's."""

    task_id: str
    index: int | None = dataclasses.field(default=None, metadata=_NON_NEGATIVE)
    split: str
    scene_id: int = dataclasses.field(metadata=_NON_NEGATIVE)
    task_in_scene: int = dataclasses.field(metadata=_NON_NEGATIVE)
    tasks_per_scene: int = dataclasses.field(metadata={"lo": 1})
    mesh: str
    obj_id: int = dataclasses.field(metadata=_NON_NEGATIVE)
    location: str
    bags: int = dataclasses.field(metadata=_NON_NEGATIVE)
    stain_seeds: int = dataclasses.field(metadata=_NON_NEGATIVE)
    dust: bool
    sun_elevation_deg: float
    sun_azimuth_deg: float
    camera_height_m: float
    views: tuple[int, ...] = dataclasses.field(metadata=_NON_NEGATIVE)
    views_per_task: int
    seed: int
    config: dict[str, Any]
    config_hash: str
    moonbot_version: str | None = None
    schema_version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        if not self.task_in_scene < self.tasks_per_scene:
            raise ValueError(
                f"task_in_scene: must be in 0..tasks_per_scene-1 ({self.tasks_per_scene - 1}), got {self.task_in_scene}"
            )
        if len(set(self.views)) != len(self.views) or not self.views:
            raise ValueError(f"views: must be distinct orbit indices, got {list(self.views)}")
        if len(self.views) != self.views_per_task:
            raise ValueError(f"views: has {len(self.views)} entries, views_per_task says {self.views_per_task}")
        if not self.split or not all(c.isalnum() or c in "-_" for c in self.split):
            raise ValueError(f"split: must be letters, digits, '-' or '_', got {self.split!r}")
        _plain_name("mesh", self.mesh)
        _plain_name("location", self.location)

    def as_json(self) -> dict:
        """The record as the JSON object task.json holds."""
        return to_json(self)


UPGRADES = {1: add_schema_version}


def read_task(path: Path, sha256: str | None = None) -> TaskRecord:
    """A task.json file; with `sha256`, its bytes must have that checksum (DONE.json's).
    RecordError naming the file and field."""
    return decode(TaskRecord, read_json(path, sha256), str(path), UPGRADES)


def write_task(path: Path, record: TaskRecord) -> None:
    """`record` to `path` atomically (keys sorted, indent 2)."""
    write_json(path, record, sort_keys=True)
