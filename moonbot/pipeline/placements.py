"""The scene-level step of a sweep: the bags of each layout placed, settled and checked once, for
every task that shows them.

A layout is what fixes where the bags lie: a split's mesh, location and bag count. Its seed
(moonbot.sweep.scene_seed) is the same for the stain and dust variants of those bags, and so is
every other input of the placement, so all the tasks of all those scenes — each Sun, camera
height, stain and dust — show the same poses. `moonbot generate` runs one placement task per
layout with pending tasks and hands its record to them as a Dask dependency; the record is also
kept as OUT/placements/<layout_id>.json, so a resumed run reads it back instead of settling again.

A record's poses are JSON numbers: Python writes a float64 as the shortest decimal that reads back
as the same float64, so a pose read from the file is bit for bit the pose settled, and the images
do not depend on whether the placement was computed in this run or an earlier one.

Its timings (placing and checking, settling, the whole task) are counted once per layout, here,
and never in the tasks' stats.json: moonbot.pipeline.stats adds them to a run's stage totals.
"""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import os
import socket
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from moonbot.atomic_io import atomic_write
from moonbot.config import Config
from moonbot.scene.compose import place_bags
from moonbot.scene.placement import Placement
from moonbot.sweep import Task, task_config
from moonbot.terrain import get_terrain

PLACEMENTS_DIR = "placements"
# The heartbeat name of a layout's placement task (OUT/running/<name>.json) and its Dask key.
TASK_PREFIX = "place-"


class PlacementError(RuntimeError):
    """A layout's bags could not be placed, settled or checked; the message names the layout."""


def layout_id(task: Task) -> str:
    """The name of the layout whose placement `task` shows: split, mesh, location and bag count
    (e.g. train-sandbag-02-hilly-b05); file-name safe, unique in the sweep."""
    return f"{task.split}-{task.mesh}-{task.location}-b{task.bags:02d}"


def placement_path(out_dir: Path, layout: str) -> Path:
    """Where a layout's placement record is kept: OUT/placements/<layout>.json."""
    return Path(out_dir) / PLACEMENTS_DIR / f"{layout}.json"


def placement_inputs(config: Config) -> str:
    """SHA-256 (hex) of everything a placement depends on in a task's config: its seed, meshes,
    terrain and bags (their stain aside, which only paints them). Tasks with the same digest
    have the same poses; a task handed a record of another digest refuses it."""
    bags = dataclasses.asdict(config.bags)
    bags.pop("stain")
    inputs = {
        "seed": config.seed,
        "meshes": dataclasses.asdict(config.meshes),
        "bags": bags,
        "terrain": dataclasses.asdict(config.terrain),
    }
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def place_layout(
    config: Config, task: Task, out_dir: Path, worker: str = "local", on_stage: Callable[[str], None] | None = None
) -> dict:
    """The placement record of `task`'s layout: read from OUT/placements/<layout>.json when a
    sound one for the same inputs is there, else computed (placed, settled when bags.settle is on,
    checked against the ground's mesh: moonbot.scene.placement.arrange_bags) and written there
    atomically. Returns {"record": the record, "placed": whether this call computed it}. Raises
    PlacementError naming the layout when the bags cannot be placed or settled."""
    stage = on_stage or (lambda name: None)
    layout = layout_id(task)
    tconfig = task_config(config, task)
    digest = placement_inputs(tconfig)
    path = placement_path(out_dir, layout)
    kept = read_record(path)
    if kept is not None and kept["inputs_sha256"] == digest:
        return {"record": kept, "placed": False}
    started = datetime.datetime.now(datetime.timezone.utc)
    wall, cpu = time.perf_counter(), time.process_time()
    stage("place bags")
    try:
        terrain, _ = get_terrain(tconfig.terrain)  # built already on a warmed worker
        placement = place_bags(tconfig, terrain.ground)
    except Exception as e:  # a bad field, MuJoCo, the terrain: every dependent task is told which layout
        raise PlacementError(f"scene layout {layout} (seed {tconfig.seed}): {e}") from e
    wall_s = time.perf_counter() - wall
    settle_s = placement.settle_seconds or 0.0
    record = {
        "layout_id": layout,
        "inputs_sha256": digest,
        "seed": tconfig.seed,
        "poses": [pose.ravel().tolist() for pose in placement.poses],
        "settle": None
        if placement.settle_seconds is None
        else {"simulated_s": placement.settle_simulated_s, "steps": placement.settle_steps},
        # Seconds: settling (MuJoCo) and the rest (placing, the exact overlap checks) of wall_s.
        "stages_s": {
            "place": wall_s - settle_s,
            **({"settle": settle_s} if placement.settle_seconds is not None else {}),
        },
        "wall_s": wall_s,
        "cpu_s": time.process_time() - cpu,
        "started_utc": started.isoformat(),
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "worker": worker,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, "w", lambda f: f.write(json.dumps(record, indent=2, sort_keys=True) + "\n"))
    return {"record": record, "placed": True}


def read_record(path: Path) -> dict | None:
    """A placement record from `path`, or None when there is none or it is not sound (a record
    that does not parse is computed again, never trusted)."""
    try:
        record = json.loads(path.read_text())
        poses = record["poses"]
        if not (
            isinstance(record["inputs_sha256"], str)
            and isinstance(poses, list)
            and poses
            and all(isinstance(p, list) and len(p) == 16 for p in poses)
        ):
            return None
        return record
    except (OSError, ValueError, KeyError, TypeError):
        return None


def placement_for(config: Config, record: dict) -> Placement:
    """The Placement a task of `config` (a task's config) renders with, from its layout's record.
    Raises PlacementError when the record was made for other inputs (another seed, mesh, bag
    count or ground): such poses would not be the ones this task's scene settles to."""
    if record["inputs_sha256"] != placement_inputs(config):
        raise PlacementError(
            f"scene layout {record['layout_id']}: its placement was made for other inputs "
            f"than this task's (seed {config.seed}, {config.bags.count} × {config.bags.mesh} "
            f"on {config.terrain.location})"
        )
    poses = [np.array(p, dtype=np.float64).reshape(4, 4) for p in record["poses"]]
    settle = record["settle"]
    return Placement(
        poses=poses,
        settle_simulated_s=None if settle is None else settle["simulated_s"],
        settle_steps=None if settle is None else settle["steps"],
        settle_seconds=None if settle is None else record["stages_s"]["settle"],
    )


def read_placements(out_dir: Path) -> list[dict]:
    """Every sound placement record in OUT/placements, sorted by layout_id."""
    root = Path(out_dir) / PLACEMENTS_DIR
    records = [read_record(p) for p in sorted(root.glob("*.json"))] if root.is_dir() else []
    return sorted((r for r in records if r is not None), key=lambda r: r["layout_id"])
