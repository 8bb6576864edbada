"""Tasks of a sweep (paper 4.2; docs/scaling.md "The SynBag-1.0 sweep"). A task is one scene lit by
one Sun (azimuth, elevation) and seen from one camera height: the orbit's views, rendered by one
worker in one go. Scenes of a split are every combination of its meshes × locations × bag counts
× stain seeds × dust, nested in that order; the tasks of a scene every Sun elevation × Sun
azimuth × camera height, nested in that order. That order numbers the scenes, the tasks and the
images of the dataset, whatever order the tasks are run in.

A split with `draw_from` (a validation split, typically: `val` drawing from `train`) has no grid
of its own: it draws `scenes` scenes from the named split's grid and, for each, `tasks_per_scene`
of its Sun × camera-height tasks (0: all), by `draw`. Its scenes are rendered under its own
name, so their scene seeds, and with them the bags' layouts, stains and dust, are not the source
split's: the validation images show the training conditions in scenes no training image shows."""

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
        return (
            f"{self.split}-s{self.scene_id:06d}-t{self.task_in_scene:02d}-{self.mesh}-{self.location}"
            f"-b{self.bags:02d}-st{self.stain_seeds:02d}-{'dust' if self.dust else 'clear'}"
            f"-el{self.sun_elevation_deg:g}-az{self.sun_azimuth_deg:g}-h{self.camera_height_m:g}"
        )


def tasks(config: Config) -> list[Task]:
    """Every task of the config's sweep, in sweep order. A config without splits is one split,
    "default", of one scene and one task: the config itself."""
    splits = config.sweep.splits or (SplitConfig(name="default"),)
    by_name = {split.name: split for split in splits}
    out: list[Task] = []
    for split in splits:
        grid = by_name[split.draw_from] if split.draw_from else split

        def axis(values: tuple, base):
            return values if values else (base,)

        scenes = list(
            itertools.product(
                axis(grid.meshes, config.bags.mesh),
                axis(grid.locations, config.terrain.location),
                axis(grid.bag_counts, config.bags.count),
                axis(grid.stain_seeds, config.bags.stain.seeds),
                axis(grid.dust, config.dust.enabled),
            )
        )
        shots = list(
            itertools.product(
                axis(grid.sun_elevations_deg, config.sun.elevation_deg),
                axis(grid.sun_azimuths_deg, config.sun.azimuth_deg),
                axis(grid.camera_heights_m, config.orbit.height_m),
            )
        )
        if split.draw_from:
            chosen = draw(config.seed, split.name, scenes, shots, split.scenes, split.tasks_per_scene)
        else:
            chosen = [(scene, shots) for scene in scenes]
        for scene_id, ((mesh, location, bags, stain, dust), scene_shots) in enumerate(chosen):
            for k, (elevation, azimuth, height) in enumerate(scene_shots):
                out.append(
                    Task(
                        len(out),
                        split.name,
                        scene_id,
                        k,
                        len(scene_shots),
                        mesh,
                        config.meshes.obj_id(mesh),
                        location,
                        bags,
                        stain,
                        dust,
                        float(elevation),
                        float(azimuth),
                        float(height),
                    )
                )
    return out


def _rank(seed: int, split: str, item: tuple) -> bytes:
    """A scene's or task's place in a draw: a hash of the dataset seed, the drawing split's name
    and the item's values, so a draw changes with neither the worker count nor the library."""
    return hashlib.blake2b(f"moonbot.draw:{seed}:{split}:{item!r}".encode(), digest_size=16).digest()


def draw(
    seed: int, split: str, scenes: list[tuple], shots: list[tuple], count: int, tasks_per_scene: int
) -> list[tuple[tuple, list[tuple]]]:
    """The scenes (mesh, location, bags, stain, dust) and, for each, the shots (elevation,
    azimuth, height) that split `split` draws from another split's grid (`scenes` and `shots`
    in that split's sweep order). Balanced over meshes: each mesh's scenes are ranked by `_rank`,
    and the first `count` are taken in turns — the best-ranked of every mesh (in the grid's mesh
    order), then the second, and so on — so a draw of k × (meshes) scenes holds k of each.
    Each drawn scene's shots are ranked likewise (the scene's values joined to the shot's) and
    the first `tasks_per_scene` taken (0: all). Both are returned in the grid's own order."""
    if not 1 <= count <= len(scenes):
        raise ValueError(f"{split}: scenes must be in 1..{len(scenes)}, got {count}")
    if not 0 <= tasks_per_scene <= len(shots):
        raise ValueError(f"{split}: tasks_per_scene must be in 0..{len(shots)}, got {tasks_per_scene}")
    by_mesh: dict[str, list[int]] = {}
    for k, scene in enumerate(scenes):
        by_mesh.setdefault(scene[0], []).append(k)
    ranked = [sorted(ks, key=lambda k: _rank(seed, split, scenes[k])) for ks in by_mesh.values()]
    turns = [ks[turn] for turn in range(max(map(len, ranked))) for ks in ranked if turn < len(ks)]
    chosen = []
    for k in sorted(turns[:count]):
        order = sorted(range(len(shots)), key=lambda j: _rank(seed, split, scenes[k] + shots[j]))
        keep = sorted(order[: tasks_per_scene or len(shots)])
        chosen.append((scenes[k], [shots[j] for j in keep]))
    return chosen


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
    data["bags"].update(
        mesh=task.mesh, count=task.bags, layout="single" if task.bags == 1 else config.sweep.many_bags_layout
    )
    data["bags"]["stain"]["seeds"] = task.stain_seeds
    data["terrain"]["location"] = task.location
    data["dust"]["enabled"] = task.dust
    data["sun"].update(elevation_deg=task.sun_elevation_deg, azimuth_deg=task.sun_azimuth_deg)
    data["orbit"]["height_m"] = task.camera_height_m
    data["sweep"] = dataclasses.asdict(SweepConfig())
    return from_mapping(Config, data)
