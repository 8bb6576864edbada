"""The scene build of `moonbot merge` (moonbot.bop.merge): one scene's complete tasks into its
BOP scene folder of the staging dataset,

    <bop split>/NNNNNN/  rgb/ depth/ depth_npy/ depth_preview/ mask/ mask_visib/ mask_color/ [rgb_exr/]
                         scene_gt.json  scene_camera.json  scene_gt_info.json  scene_meta.json
                         scene_gt_coco.json

each task file copied (or hard-linked) with its sha256 checked against DONE.json, each view's
gt.json checked field by field, and the visible masks and scene files derived. A task that breaks
the contract is left out and its scene built again without it; scenes are built in worker
processes, each scene's bytes independent of the others and of the worker count.
"""

from __future__ import annotations

import dataclasses
import hashlib
import multiprocessing
import os
import shutil
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.bop.coco import SCENE_COCO, scene_gt_coco_bytes
from moonbot.bop.dataset_files import dumps_json, dumps_scene_json, put_bytes, put_png
from moonbot.bop.gt_info import gt_info_entry
from moonbot.bop.inventory import Inventory, MergeError, SceneTasks, TaskDir
from moonbot.bop.layout import SCENE_META, bop_split, check_id, scene_rel, view_rel
from moonbot.records.base import RecordError
from moonbot.records.done import FileEntry
from moonbot.records.gt import GT, read_gt
from moonbot.records.task import TASK as TASK_RECORD
from moonbot.writer.sheet import colour_mask

# What the per-scene folders hold, in the order a listing shows them.
SCENE_SUBDIRS = ("rgb", "depth", "depth_npy", "depth_preview", "mask", "mask_visib", "mask_color")


class _BadTask(Exception):
    """A task whose files do not match DONE.json or break the view contract: it is left out."""

    def __init__(self, task_id: str, message: str) -> None:
        super().__init__(task_id, message)
        self.task_id, self.message = task_id, message


@dataclass(frozen=True)
class _SceneJob:
    stage: str
    rel: str
    scene: SceneTasks
    link: bool
    obj_ids: tuple[int, ...]  # the dataset's objects (MeshesConfig.objects): the COCO categories


@dataclass
class SceneOutput:
    """One scene folder as built: its manifest entries and what the dataset-level files need."""

    rel: str
    entries: dict  # dataset-relative path → (bytes, sha256)
    images: int
    instances: int
    amodal_outside_px: int
    camera: dict  # fx, fy, cx, cy, width, height, depth_scale of the scene's first image
    split: str
    task_ids: list  # the tasks merged into the scene
    task_versions: list  # their moonbot_version
    meta: dict  # scene_meta.json without its per-image records
    visible_counts: dict  # im_id → {obj_id: instances with a visible pixel}


class _TaskFiles:
    """The files of one complete task, read or copied with their sha256 checked against DONE.json
    (`_BadTask` on a mismatch or a file DONE.json does not list)."""

    def __init__(self, task: TaskDir, link: bool) -> None:
        self.task, self.link = task, link

    def _entry(self, rel: str) -> FileEntry:
        entry = self.task.files.get(rel)
        if entry is None:
            raise _BadTask(self.task.task_id, f"{self.task.path / rel}: not listed in DONE.json")
        return entry

    def has(self, rel: str) -> bool:
        return rel in self.task.files

    def read(self, rel: str) -> bytes:
        entry = self._entry(rel)
        data = (self.task.path / rel).read_bytes()
        if hashlib.sha256(data).hexdigest() != entry.sha256:
            raise _BadTask(self.task.task_id, f"{self.task.path / rel}: sha256 differs from DONE.json's")
        return data

    def image(self, rel: str) -> np.ndarray:
        self.read(rel)  # checks the bytes; the decoder reads them again from the page cache
        return _core.read_image(str(self.task.path / rel))

    def gt(self, rel: str) -> dict:
        """The view's gt.json `rel`, read and checked by its reader (moonbot.records.gt), as the
        JSON object it holds."""
        try:
            return read_gt(self.task.path / rel, self._entry(rel).sha256).as_json()
        except RecordError as e:
            raise _BadTask(self.task.task_id, str(e)) from None

    def put(self, rel: str, root: Path, dst_rel: str, entries: dict) -> None:
        """The task's `rel` at root/dst_rel: copied with its sha256 checked, or hard-linked."""
        entry = self._entry(rel)
        src, dst = self.task.path / rel, root / dst_rel
        if self.link:
            try:
                os.link(src, dst)
                size = entry.bytes if entry.bytes is not None else src.stat().st_size
                entries[dst_rel] = (size, entry.sha256)
                return
            except OSError:
                pass  # another file system, or no hard links there: copied (and checked) below
        digest, size = hashlib.sha256(), 0
        with open(src, "rb") as fin, open(dst, "wb") as fout:
            for chunk in iter(lambda: fin.read(1 << 20), b""):
                digest.update(chunk)
                fout.write(chunk)
                size += len(chunk)
        if digest.hexdigest() != entry.sha256:
            raise _BadTask(self.task.task_id, f"{src}: sha256 differs from DONE.json's")
        entries[dst_rel] = (size, entry.sha256)


def _build_scene(job: _SceneJob) -> SceneOutput:
    """Writes one scene folder of the staging dataset and returns its manifest entries and what
    the dataset-level files need (_BadTask when a task breaks the contract: the caller removes the
    folder and builds the scene again without that task)."""
    root = Path(job.stage)
    scene_root = root / job.rel
    for sub in SCENE_SUBDIRS:
        (scene_root / sub).mkdir(parents=True, exist_ok=True)
    entries: dict = {}
    scene_gt, scene_camera, scene_gt_info, images_meta = {}, {}, {}, {}
    reference_instances = None
    camera = None
    instances_total = outside_total = 0
    shared = job.scene.record
    tasks_meta = []
    visible_counts: dict = {}
    for task in job.scene.tasks:
        r = task.record
        files = _TaskFiles(task, job.link)
        try:
            level = int(r["config"]["output"]["png_compression"])
        except (KeyError, TypeError, ValueError):
            raise _BadTask(
                task.task_id,
                f"{task.path / 'task.json'}: field 'config.output.png_compression' is missing or not an integer",
            ) from None
        first_image = r["task_in_scene"] * r["views_per_task"]
        for i, v in enumerate(r["views"]):
            im = first_image + i
            try:
                check_id(im, "image id")
            except ValueError as e:
                raise _BadTask(task.task_id, f"{task.path / TASK_RECORD}: {e}") from None
            view = f"view_{v:03d}"
            gt_path = task.path / view / GT
            gt = files.gt(f"{view}/{GT}")
            K, R_w2c, t_w2c = gt["cam_K"], gt["cam_R_w2c"], gt["cam_t_w2c"]
            depth_scale, width, height, instances = gt["depth_scale"], gt["width"], gt["height"], gt["instances"]
            ids = []
            for k, inst in enumerate(instances):
                if "mask_amodal" not in inst:
                    raise _BadTask(
                        task.task_id,
                        f"{gt_path}: instances[{k}].mask_amodal: missing (rendered "
                        "before amodal masks were written: render the task again)",
                    )
                ids.append((inst["instance_id"], inst["obj_id"]))
            if reference_instances is None:
                reference_instances = ids
            elif ids != reference_instances:
                raise _BadTask(
                    task.task_id,
                    f"{gt_path}: field 'instances' holds (instance_id, obj_id) {ids}, "
                    f"other images of the scene {reference_instances}",
                )
            if camera is None:
                camera = {
                    "fx": K[0],
                    "fy": K[4],
                    "cx": K[2],
                    "cy": K[5],
                    "width": width,
                    "height": height,
                    "depth_scale": depth_scale,
                }

            name = f"{im:06d}"
            files.put(f"{view}/rgb.png", root, f"{job.rel}/rgb/{name}.png", entries)
            files.put(f"{view}/depth.png", root, f"{job.rel}/depth/{name}.png", entries)
            files.put(f"{view}/depth.npy", root, f"{job.rel}/depth_npy/{name}.npy", entries)
            files.put(f"{view}/depth_preview.png", root, f"{job.rel}/depth_preview/{name}.png", entries)
            if "rgb_exr" in gt:
                (scene_root / "rgb_exr").mkdir(exist_ok=True)
                files.put(f"{view}/rgb.exr", root, f"{job.rel}/rgb_exr/{name}.exr", entries)
            labels = files.image(f"{view}/mask.png")
            depth = files.image(f"{view}/depth.png")
            if labels.shape != (height, width) or depth.shape != (height, width):
                raise _BadTask(
                    task.task_id,
                    f"{task.path / view}: mask.png {labels.shape} or depth.png {depth.shape} "
                    f"is not {height} x {width} as gt.json says",
                )
            depth_valid = depth > 0
            put_png(root, f"{job.rel}/mask_color/{name}.png", colour_mask(labels), level, entries)

            image_gt, image_info = [], []
            for k, inst in enumerate(instances):
                amodal = files.image(f"{view}/{inst['mask_amodal']}")
                if amodal.shape != (height, width):
                    raise _BadTask(
                        task.task_id,
                        f"{task.path / view / inst['mask_amodal']}: {amodal.shape} is not {height} x {width}",
                    )
                amodal = amodal > 0
                visible = labels == inst["instance_id"]
                outside_total += int(np.count_nonzero(visible & ~amodal))
                mask_name = f"{name}_{k:06d}.png"
                files.put(f"{view}/{inst['mask_amodal']}", root, f"{job.rel}/mask/{mask_name}", entries)
                put_png(
                    root, f"{job.rel}/mask_visib/{mask_name}", visible.astype(np.uint8) * np.uint8(255), level, entries
                )
                image_gt.append(
                    {"obj_id": inst["obj_id"], "cam_R_m2c": inst["cam_R_m2c"], "cam_t_m2c": inst["cam_t_m2c"]}
                )
                image_info.append(gt_info_entry(amodal, visible, depth_valid, inst["px_count_all"], inst["bbox_all"]))
            instances_total += len(instances)
            visible_counts[im] = {}
            for entry, info_entry in zip(image_gt, image_info):
                if info_entry["px_count_visib"] > 0:
                    visible_counts[im][entry["obj_id"]] = visible_counts[im].get(entry["obj_id"], 0) + 1
            scene_gt[im] = image_gt
            scene_gt_info[im] = image_info
            scene_camera[im] = {"cam_K": K, "depth_scale": depth_scale, "cam_R_w2c": R_w2c, "cam_t_w2c": t_w2c}
            if "site" in gt:  # a dem location: the world frame (cam_R_w2c's) is the site's East-North-Up
                scene_camera[im]["site"] = gt["site"]
            images_meta[im] = {
                "task_in_scene": r["task_in_scene"],
                "view": v,
                **{
                    key: gt[key]
                    for key in ("camera_azimuth_deg", "camera_height_m", "sun", "render_seed", "dust", "site")
                    if key in gt
                },
                **({"ev100": gt["exposure"].get("ev100")} if isinstance(gt.get("exposure"), dict) else {}),
            }
        tasks_meta.append(
            {
                "task_in_scene": r["task_in_scene"],
                "task_id": r["task_id"],
                "config_hash": r["config_hash"],
                "sun_azimuth_deg": r["sun_azimuth_deg"],
                "sun_elevation_deg": r["sun_elevation_deg"],
                "camera_height_m": r["camera_height_m"],
                "views": r["views"],
                "image_ids": [first_image, first_image + len(r["views"]) - 1],
            }
        )
    meta = {
        **shared,
        "bop_split": bop_split(shared["split"]),
        "scene_dir": job.rel,
        "view": view_rel(shared["split"], shared["mesh"], shared["location"], shared["scene_id"]),
        "instances": [{"instance_id": i, "obj_id": o} for i, o in reference_instances or []],
        "tasks": tasks_meta,
        "missing_tasks_in_scene": list(job.scene.missing),
    }
    put_bytes(root, f"{job.rel}/scene_gt.json", dumps_scene_json(scene_gt), entries)
    put_bytes(root, f"{job.rel}/scene_gt_info.json", dumps_scene_json(scene_gt_info), entries)
    put_bytes(root, f"{job.rel}/scene_camera.json", dumps_scene_json(scene_camera), entries)
    put_bytes(root, f"{job.rel}/{SCENE_META}", dumps_json({**meta, "images": images_meta}), entries)
    coco = scene_gt_coco_bytes(
        scene_root, "moonbot", bop_split(shared["split"]), job.obj_ids, (camera["width"], camera["height"])
    )
    put_bytes(root, f"{job.rel}/{SCENE_COCO}", coco, entries)
    return SceneOutput(
        job.rel,
        entries,
        len(scene_gt),
        instances_total,
        outside_total,
        camera or {},
        shared["split"],
        [t.task_id for t in job.scene.tasks],
        [str(t.record.get("moonbot_version", "unknown")) for t in job.scene.tasks],
        meta,
        visible_counts,
    )


def _scene_rel(scene: SceneTasks) -> str:
    r = scene.record
    try:
        return scene_rel(r["split"], r["scene_id"])
    except ValueError as e:
        raise MergeError(f"{scene.tasks[0].path / TASK_RECORD}: {e}") from None


def _without(scene: SceneTasks, task_id: str) -> SceneTasks | None:
    kept = tuple(t for t in scene.tasks if t.task_id != task_id)
    if not kept:
        return None
    gone = {t.record["task_in_scene"] for t in scene.tasks if t.task_id == task_id}
    return dataclasses.replace(scene, tasks=kept, missing=tuple(sorted(set(scene.missing) | gone)))


def run_scenes(
    stage: Path, inventory: Inventory, link: bool, workers: int, say, obj_ids: tuple[int, ...]
) -> list[SceneOutput]:
    """Builds every scene folder, `workers` processes at a time (1: in this process). A scene whose
    task turns out bad is rebuilt without it; the task goes to inventory.invalid / missing.
    `obj_ids`: the dataset's objects, the scenes' COCO categories."""
    jobs = {k: _SceneJob(str(stage), _scene_rel(s), s, link, obj_ids) for k, s in enumerate(inventory.scenes)}
    outputs: dict[int, SceneOutput] = {}
    pool = None
    if workers > 1 and len(jobs) > 1:
        # spawn: the core's thread pool does not survive a fork.
        pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=multiprocessing.get_context("spawn"))

    def finished(k: int, result) -> None:
        if isinstance(result, _BadTask):
            shutil.rmtree(stage / jobs[k].rel, ignore_errors=True)
            inventory.invalid[result.task_id] = result.message
            inventory.missing.append(result.task_id)
            say(f"left out {result.task_id}: {result.message}")
            scene = _without(jobs[k].scene, result.task_id)
            if scene is not None:
                retry[k] = dataclasses.replace(jobs[k], scene=scene)
        else:
            outputs[k] = result
            say(f"[{len(outputs)}/{len(inventory.scenes)}] {result.rel}: {result.images} images")

    try:
        while jobs:
            retry: dict[int, _SceneJob] = {}
            if pool is None:
                for k, job in jobs.items():
                    try:
                        finished(k, _build_scene(job))
                    except _BadTask as e:
                        finished(k, e)
            else:
                futures = {pool.submit(_build_scene, job): k for k, job in jobs.items()}
                for future in as_completed(futures):
                    try:
                        finished(futures[future], future.result())
                    except _BadTask as e:
                        finished(futures[future], e)
            jobs = retry
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)  # before the staging directory is removed
    return [outputs[k] for k in sorted(outputs)]
