"""Tasks of a sweep (paper 4.2; DESIGN.md "The SynBag-1.0 sweep"). A task is one scene lit by
one Sun (azimuth, elevation) and seen from one camera height: the orbit's views, rendered by one
worker in one go. Scenes of a split are every combination of its meshes × locations × bag counts
× stain seeds × dust, nested in that order; the tasks of a scene every Sun elevation × Sun
azimuth × camera height, nested in that order. That order numbers the scenes, the tasks and the
images of the dataset, whatever order the tasks are run in."""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
from dataclasses import dataclass

from moonbot.config import Config
from moonbot.config.load import from_mapping
from moonbot.config.schema import SplitConfig, SweepConfig


@dataclass(frozen=True)
class Task:
    """One task's identity: where it sits in the sweep and what it varies. `index` numbers the
    tasks of the whole sweep from 0; `scene_id` the scenes of its split; `task_in_scene` the
    tasks of its scene (of `tasks_per_scene`); `obj_id` is the BOP id of its `mesh`
    (MeshesConfig.objects). Angles in degrees, heights in metres."""

    index: int
    split: str
    scene_id: int
    task_in_scene: int
    tasks_per_scene: int
    mesh: str
    obj_id: int
    location: str
    bags: int
    stain_seeds: int
    dust: bool
    sun_elevation_deg: float
    sun_azimuth_deg: float
    camera_height_m: float

    @property
    def task_id(self) -> str:
        """A readable, file-name-safe name, unique in the sweep: split, scene and task numbers,
        then what they vary (e.g. train-s000041-t07-sandbag-02-hilly-b05-st30-dust-el8-az210-h0.5)."""
        return (f"{self.split}-s{self.scene_id:06d}-t{self.task_in_scene:02d}-{self.mesh}-{self.location}"
                f"-b{self.bags:02d}-st{self.stain_seeds:02d}-{'dust' if self.dust else 'clear'}"
                f"-el{self.sun_elevation_deg:g}-az{self.sun_azimuth_deg:g}-h{self.camera_height_m:g}")


def tasks(config: Config) -> list[Task]:
    """Every task of the config's sweep, in sweep order. A config without splits is one split,
    "default", of one scene and one task: the config itself."""
    splits = config.sweep.splits or (SplitConfig(name="default"),)
    out: list[Task] = []
    for split in splits:
        def axis(values: tuple, base):
            return values if values else (base,)
        scenes = list(itertools.product(
            axis(split.meshes, config.bags.mesh), axis(split.locations, config.terrain.location),
            axis(split.bag_counts, config.bags.count), axis(split.stain_seeds, config.bags.stain.seeds),
            axis(split.dust, config.dust.enabled)))
        shots = list(itertools.product(
            axis(split.sun_elevations_deg, config.sun.elevation_deg),
            axis(split.sun_azimuths_deg, config.sun.azimuth_deg),
            axis(split.camera_heights_m, config.orbit.height_m)))
        for scene_id, (mesh, location, bags, stain, dust) in enumerate(scenes):
            for k, (elevation, azimuth, height) in enumerate(shots):
                out.append(Task(len(out), split.name, scene_id, k, len(shots), mesh, config.meshes.obj_id(mesh),
                                location, bags, stain, dust,
                                float(elevation), float(azimuth), float(height)))
    return out


def scene_seed(dataset_seed: int, split: str, mesh: str, location: str, bags: int) -> int:
    """The seed a scene is composed with (bag placement, stains, dust): a 63-bit hash of the
    dataset seed and the scene's physical layout. The stain and dust variants of one layout
    share it, so they show the same bags in the same places (the paper renders each stain level
    with and without dust); every split, mesh, location and bag count gets its own."""
    key = f"moonbot.scene:{dataset_seed}:{split}:{mesh}:{location}:{bags}".encode()
    return int.from_bytes(hashlib.blake2b(key, digest_size=8).digest(), "little") >> 1


def task_config(config: Config, task: Task) -> Config:
    """The single-scene config a task renders: the base config with the task's mesh, location,
    bags (one bag: layout single; more: the sweep's many_bags_layout), stain, dust, Sun and
    camera height, its scene's seed (a config without splits keeps its own, so `generate` on it
    renders what `render-one` does), and no sweep of its own (so its hash depends on the task
    alone, not on the rest of the sweep)."""
    data = dataclasses.asdict(config)
    if config.sweep.splits:  # a config without a sweep renders as itself, seed and all
        data["seed"] = scene_seed(config.seed, task.split, task.mesh, task.location, task.bags)
    data["bags"].update(mesh=task.mesh, count=task.bags,
                        layout="single" if task.bags == 1 else config.sweep.many_bags_layout)
    data["bags"]["stain"]["seeds"] = task.stain_seeds
    data["terrain"]["location"] = task.location
    data["dust"]["enabled"] = task.dust
    data["sun"].update(elevation_deg=task.sun_elevation_deg, azimuth_deg=task.sun_azimuth_deg)
    data["orbit"]["height_m"] = task.camera_height_m
    data["sweep"] = dataclasses.asdict(SweepConfig())
    return from_mapping(Config, data)
