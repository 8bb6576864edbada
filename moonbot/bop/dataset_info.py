"""dataset_info.json of a merged dataset (moonbot.bop.merge): what it holds (splits and their
counts, the objects, the config and its hashes, the tasks missing or unusable) and the
conventions its files follow."""

from __future__ import annotations

import dataclasses

from moonbot import __version__
from moonbot.bop.inventory import Inventory
from moonbot.bop.layout import bop_split
from moonbot.bop.scene_build import SceneOutput
from moonbot.config import Config, config_hash
from moonbot.config.schema import MeshesConfig

DATASET_INFO = "dataset_info.json"


def dataset_info(
    outputs: list[SceneOutput], splits: list[str], inventory: Inventory, config: Config | None, meshes: MeshesConfig
) -> dict:
    """dataset_info.json's content for the scenes `outputs` (dataset order) in `splits`;
    `inventory`: the tasks found, missing, unusable and extra; `config`: the sweep's (None: not
    known); `meshes`: the tasks' meshes section."""
    per_split = {s: {"scenes": 0, "tasks": 0, "images": 0, "instances": 0} for s in splits}
    for output in outputs:
        counts = per_split[output.split]
        counts["scenes"] += 1
        counts["tasks"] += len(output.task_ids)
        counts["images"] += output.images
        counts["instances"] += output.instances
    merged_tasks = [task_id for o in outputs for task_id in o.task_ids]
    versions = sorted({v for o in outputs for v in o.task_versions})
    outside = sum(o.amodal_outside_px for o in outputs)
    info = {
        "name": "moonbot",
        "description": "Synthetic lunar sandbag scenes for 6-DoF pose estimation (BOP layout), by moonbot",
        "layout": "BOP: <bop split>/<scene_id:06d>/ (train_pbr, val_pbr, test); the paper's "
        "<split>/<mesh>/<location>/scene_NNNNNN as links under by_condition/",
        "bop_splits": {s: bop_split(s) for s in splits},
        "moonbot_version": __version__,
        "task_moonbot_versions": versions,
        "config": dataclasses.asdict(config) if config is not None else None,
        "config_hash": config_hash(config) if config is not None else None,
        "seed": config.seed if config is not None else None,
        "meshes_hash": config_hash(meshes),
        "objects": {str(obj_id): name for obj_id, name in meshes.objects().items()},
        "splits": [{"name": s, **per_split[s]} for s in splits],
        "tasks_merged": len(merged_tasks),
        "images": sum(o.images for o in outputs),
        "complete": not inventory.missing and not inventory.invalid,
        "missing_tasks": list(inventory.missing),
        "invalid_tasks": dict(sorted(inventory.invalid.items())),
        "extra_tasks": list(inventory.extra),
        "amodal_outside_visible_px": outside,
        "conventions": {
            "units": "millimetres (poses, models, depth × depth_scale); depth_npy in metres",
            "camera": "OpenCV: x right, y down, z forward; pixel (u, v) spans [u, u+1) x [v, v+1), rays "
            "through its centre (u + 0.5, v + 0.5)",
            "depth": "z-depth along the optical axis; 0 = no valid depth",
            "mask": "the instance rendered alone (amodal), 0/255",
            "mask_visib": "pixels whose centre ray meets this instance first (exact instance segmentation; "
            "bop_toolkit's depth-tolerance estimate would add pixels within delta behind "
            "another surface)",
            "px_count_all": "pixels of the instance alone on a 3W x 3H canvas (bop_toolkit calc_gt_info)",
            "bbox": "[x, y, w, h], w = max x - min x (bop_toolkit calc_2d_bbox); [-1, -1, -1, -1] when "
            "nothing is visible",
            "image_ids": "task_in_scene * views_per_task + index of the view in the task",
            "yolo": "class = obj_id - 1; rows from the visible masks; detect: boxes over pixel edges, "
            "segment: one polygon per instance",
        },
    }
    return info
