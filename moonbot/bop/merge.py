"""`moonbot merge`: the complete task directories of OUT/tasks (moonbot.bop.inventory) into one BOP
dataset, built in a temporary directory beside DATASET and renamed into place whole, so an
interrupted merge leaves the previous dataset (or nothing) and never half of one.

    DATASET/
      camera.json  dataset_info.json  manifest.json
      scene_index.json  scene_index.parquet   one row per merged task: scene ids → conditions
      test_targets_bop19.json                 when there is a test split (bop_toolkit's eval)
      models/       obj_NNNNNN.ply (mm) + models_info.json     (moonbot.bop.models)
      models_eval/  obj_NNNNNN.ply (surface samples) + models_info.json
      <bop split>/NNNNNN/                     train_pbr, val_pbr, test; NNNNNN = scene_id in its split
        rgb/IIIIII.png  depth/IIIIII.png (uint16, mm × depth_scale)  depth_npy/IIIIII.npy (float32 m)
        depth_preview/IIIIII.png  mask_color/IIIIII.png  [rgb_exr/IIIIII.exr when rendered]
        mask/IIIIII_KKKKKK.png        the instance alone (amodal), 0/255
        mask_visib/IIIIII_KKKKKK.png  its visible part, 0/255
        scene_gt.json  scene_camera.json  scene_gt_info.json  scene_meta.json
        scene_gt_coco.json            bop_toolkit calc_gt_coco's COCO annotations (moonbot.bop.coco)
      by_condition/<split>/<mesh>/<location>/scene_NNNNNN → ../../../../<bop split>/NNNNNN  (links)
      yolo/detect/  data.yaml  images/<split>/<name>.png  labels/<split>/<name>.txt   (boxes)
      yolo/segment/ data.yaml  images/<split>/<name>.png  labels/<split>/<name>.txt   (polygons)

Split directories, scene ids and the view: moonbot.bop.layout. Image ids follow the sweep:
IIIIII = task_in_scene × views_per_task + the view's index in the task's `views`; KKKKKK is the
instance's index in the image's scene_gt.json list (the scene's bags in instance-id order). YOLO
names are `<mesh>_<location>_<scene_id:06d>_<im_id:06d>`.

Bytes: the dataset is a pure function of the task directories (and the config): JSON with
sorted keys (image ids in numeric order), scenes in sweep order, PNGs encoded at the tasks'
`output.png_compression`. Merging again gives the same bytes (manifest.json lists every other
file's size and sha256, and every link's target). Files taken from the tasks are copied, their
sha256 checked against DONE.json on the way (a mismatch makes the task invalid, reported, and its
scene is merged without it); with `link=True` they are hard-linked instead (no copy, no read:
DONE.json's sha256 is trusted; across file systems they are copied). Task files are only ever
replaced by rename, never changed in place, so a link cannot change under the dataset. YOLO
images are hard links to the dataset's own rgb files.

bop_toolkit conventions throughout: mm, R row-major, OpenCV camera, pixel centres at +0.5;
scene_gt_info.json as moonbot.bop.gt_info documents.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import multiprocessing
import os
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from moonbot import __version__, _core
from moonbot.atomic_io import staged_directory
from moonbot.bop.gt_info import gt_info_entry
from moonbot.bop.inventory import Inventory, MergeError, SceneTasks, TaskDir, scan_tasks
from moonbot.bop.layout import (SCENE_INDEX_JSON, SCENE_INDEX_PARQUET, SCENE_META, TEST_SPLIT, TEST_TARGETS,
                                bop_split, check_id, scene_rel, view_rel, view_target)
from moonbot.bop.scene_index import index_json, index_rows, parquet_bytes, test_targets
from moonbot.bop.models import write_models
from moonbot.config import Config, config_hash
from moonbot.config.load import from_mapping
from moonbot.config.schema import MeshesConfig
from moonbot.bop.coco import SCENE_COCO, scene_gt_coco_bytes
from moonbot.records.base import RecordError
from moonbot.records.done import FileEntry
from moonbot.records.gt import GT, read_gt
from moonbot.records.task import TASK as TASK_RECORD
from moonbot.scene.bag_mesh import dataset_meshes
from moonbot.writer.checksum import file_sha256
from moonbot.writer.sheet import colour_mask
from moonbot.yolo.labels import data_yaml, detect_row, segment_row

YOLO_TASKS = ("detect", "segment")
MANIFEST = "manifest.json"
DATASET_INFO = "dataset_info.json"
# `moonbot merge` exits with this when it merged what was complete but tasks are missing or invalid.
EXIT_INCOMPLETE = 3
# What the per-scene folders hold, in the order a listing shows them.
SCENE_SUBDIRS = ("rgb", "depth", "depth_npy", "depth_preview", "mask", "mask_visib", "mask_color")


@dataclass(frozen=True)
class MergeReport:
    """What a merge did. `missing`: tasks not merged because they are not there (task ids with a
    config; "split scene N task K" without); `invalid`: task directory → why it was not merged;
    `extra`: complete tasks outside the config's sweep (ignored); `amodal_outside_px`: visible
    pixels that the amodal mask of the same instance lacks (0 for sound renders); `files` and
    `bytes`: the dataset's, manifest included; `seconds`: wall time."""

    dataset: Path
    splits: tuple[str, ...]
    scenes: int
    tasks: int
    images: int
    instances: int
    missing: tuple[str, ...]
    invalid: dict
    extra: tuple[str, ...]
    amodal_outside_px: int
    files: int
    bytes: int
    seconds: float
    models_reused: bool

    @property
    def complete(self) -> bool:
        """Every task the sweep asks for is merged (as far as merge can tell without a config)."""
        return not self.missing and not self.invalid


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
class _SceneOutput:
    rel: str
    entries: dict  # dataset-relative path → (bytes, sha256)
    yolo: list  # (split, name, rgb relative path, detect text, segment text)
    images: int
    instances: int
    amodal_outside_px: int
    camera: dict  # fx, fy, cx, cy, width, height, depth_scale of the scene's first image
    split: str
    task_ids: list  # the tasks merged into the scene
    task_versions: list  # their moonbot_version
    meta: dict  # scene_meta.json without its per-image records
    visible_counts: dict  # im_id → {obj_id: instances with a visible pixel}


# ---------------------------------------------------------------------------------------------
# Files


def _put_bytes(root: Path, rel: str, data: bytes, entries: dict) -> None:
    """Writes `data` to root/rel (inside the staging tree: no per-file atomicity needed) and
    records its size and sha256."""
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    entries[rel] = (len(data), hashlib.sha256(data).hexdigest())


def _put_png(root: Path, rel: str, pixels: np.ndarray, level: int, entries: dict) -> None:
    path = root / rel
    _core.write_image(str(path), pixels, level)
    entries[rel] = file_sha256(path)


def _link_or_copy(src: Path, dst: Path) -> bool:
    """Hard-links `src` at `dst`; copies when the file system cannot (another device, no links).
    Returns whether it linked."""
    try:
        os.link(src, dst)
        return True
    except OSError:
        shutil.copyfile(src, dst)
        return False


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


def _canonical(value):
    """`value` with every dict's keys in a stable order: integer keys numerically, before the
    others, which are sorted as strings."""
    if isinstance(value, dict):
        keys = sorted(value, key=lambda k: (0, int(k), "") if str(k).lstrip("-").isdigit() else (1, 0, str(k)))
        return {str(k): _canonical(value[k]) for k in keys}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    return value


def dumps_json(value) -> bytes:
    """Canonical JSON bytes (UTF-8, indent 2, stable key order, trailing newline)."""
    return (json.dumps(_canonical(value), indent=2, ensure_ascii=False) + "\n").encode("utf-8")


def dumps_scene_json(per_image: dict) -> bytes:
    """A BOP per-scene file: {"im_id": value}, one image a line (bop_toolkit's own layout), image
    ids in numeric order, each value compact with sorted keys."""
    lines = [f'  "{im}": {json.dumps(_canonical(per_image[im]), separators=(", ", ": "))}'
             for im in sorted(per_image, key=int)]
    return ("{\n" + ",\n".join(lines) + "\n}\n").encode("utf-8")


# ---------------------------------------------------------------------------------------------
# One scene


def _build_scene(job: _SceneJob) -> _SceneOutput:
    """Writes one scene folder of the staging dataset and returns its manifest entries and YOLO
    labels (the driver writes those, so a scene left out leaves nothing in yolo/)."""
    root = Path(job.stage)
    scene_root = root / job.rel
    for sub in SCENE_SUBDIRS:
        (scene_root / sub).mkdir(parents=True, exist_ok=True)
    entries: dict = {}
    yolo: list = []
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
            raise _BadTask(task.task_id, f"{task.path / 'task.json'}: field 'config.output.png_compression' "
                           "is missing or not an integer") from None
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
                    raise _BadTask(task.task_id, f"{gt_path}: instances[{k}].mask_amodal: missing (rendered "
                                   "before amodal masks were written: render the task again)")
                ids.append((inst["instance_id"], inst["obj_id"]))
            if reference_instances is None:
                reference_instances = ids
            elif ids != reference_instances:
                raise _BadTask(task.task_id, f"{gt_path}: field 'instances' holds (instance_id, obj_id) {ids}, "
                               f"other images of the scene {reference_instances}")
            if camera is None:
                camera = {"fx": K[0], "fy": K[4], "cx": K[2], "cy": K[5], "width": width, "height": height,
                          "depth_scale": depth_scale}

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
                raise _BadTask(task.task_id, f"{task.path / view}: mask.png {labels.shape} or depth.png {depth.shape} "
                               f"is not {height} x {width} as gt.json says")
            depth_valid = depth > 0
            _put_png(root, f"{job.rel}/mask_color/{name}.png", colour_mask(labels), level, entries)

            image_gt, image_info, detect_rows, segment_rows = [], [], [], []
            for k, inst in enumerate(instances):
                amodal = files.image(f"{view}/{inst['mask_amodal']}")
                if amodal.shape != (height, width):
                    raise _BadTask(task.task_id, f"{task.path / view / inst['mask_amodal']}: {amodal.shape} is not "
                                   f"{height} x {width}")
                amodal = amodal > 0
                visible = labels == inst["instance_id"]
                outside_total += int(np.count_nonzero(visible & ~amodal))
                mask_name = f"{name}_{k:06d}.png"
                files.put(f"{view}/{inst['mask_amodal']}", root, f"{job.rel}/mask/{mask_name}", entries)
                _put_png(root, f"{job.rel}/mask_visib/{mask_name}", visible.astype(np.uint8) * np.uint8(255),
                         level, entries)
                image_gt.append({"obj_id": inst["obj_id"], "cam_R_m2c": inst["cam_R_m2c"],
                                 "cam_t_m2c": inst["cam_t_m2c"]})
                image_info.append(gt_info_entry(amodal, visible, depth_valid, inst["px_count_all"], inst["bbox_all"]))
                for rows, make in ((detect_rows, detect_row), (segment_rows, segment_row)):
                    row = make(inst["obj_id"], visible)
                    if row is not None:
                        rows.append(row)
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
                "task_in_scene": r["task_in_scene"], "view": v,
                **{key: gt[key] for key in ("camera_azimuth_deg", "camera_height_m", "sun", "render_seed", "dust",
                                            "site") if key in gt},
                **({"ev100": gt["exposure"].get("ev100")} if isinstance(gt.get("exposure"), dict) else {}),
            }
            yolo_name = f"{shared['mesh']}_{shared['location']}_{shared['scene_id']:06d}_{name}"
            yolo.append((shared["split"], yolo_name, f"{job.rel}/rgb/{name}.png",
                         "".join(row + "\n" for row in detect_rows), "".join(row + "\n" for row in segment_rows)))
        tasks_meta.append({
            "task_in_scene": r["task_in_scene"], "task_id": r["task_id"], "config_hash": r["config_hash"],
            "sun_azimuth_deg": r["sun_azimuth_deg"], "sun_elevation_deg": r["sun_elevation_deg"],
            "camera_height_m": r["camera_height_m"], "views": r["views"],
            "image_ids": [first_image, first_image + len(r["views"]) - 1],
        })
    meta = {
        **shared,
        "bop_split": bop_split(shared["split"]),
        "scene_dir": job.rel,
        "view": view_rel(shared["split"], shared["mesh"], shared["location"], shared["scene_id"]),
        "instances": [{"instance_id": i, "obj_id": o} for i, o in reference_instances or []],
        "tasks": tasks_meta,
        "missing_tasks_in_scene": list(job.scene.missing),
    }
    _put_bytes(root, f"{job.rel}/scene_gt.json", dumps_scene_json(scene_gt), entries)
    _put_bytes(root, f"{job.rel}/scene_gt_info.json", dumps_scene_json(scene_gt_info), entries)
    _put_bytes(root, f"{job.rel}/scene_camera.json", dumps_scene_json(scene_camera), entries)
    _put_bytes(root, f"{job.rel}/{SCENE_META}", dumps_json({**meta, "images": images_meta}), entries)
    coco = scene_gt_coco_bytes(scene_root, "moonbot", bop_split(shared["split"]), job.obj_ids,
                               (camera["width"], camera["height"]))
    _put_bytes(root, f"{job.rel}/{SCENE_COCO}", coco, entries)
    return _SceneOutput(job.rel, entries, yolo, len(scene_gt), instances_total, outside_total, camera or {},
                        shared["split"], [t.task_id for t in job.scene.tasks],
                        [str(t.record.get("moonbot_version", "unknown")) for t in job.scene.tasks],
                        meta, visible_counts)


# ---------------------------------------------------------------------------------------------
# The dataset


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


def _run_scenes(stage: Path, inventory: Inventory, link: bool, workers: int, say,
                obj_ids: tuple[int, ...]) -> list[_SceneOutput]:
    """Builds every scene folder, `workers` processes at a time (1: in this process). A scene whose
    task turns out bad is rebuilt without it; the task goes to inventory.invalid / missing.
    `obj_ids`: the dataset's objects, the scenes' COCO categories."""
    jobs = {k: _SceneJob(str(stage), _scene_rel(s), s, link, obj_ids) for k, s in enumerate(inventory.scenes)}
    outputs: dict[int, _SceneOutput] = {}
    pool = None
    if workers > 1 and len(jobs) > 1:
        # spawn: the core's thread pool does not survive a fork.
        pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)),
                                   mp_context=multiprocessing.get_context("spawn"))

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


def _models(stage: Path, previous: Path, meshes: MeshesConfig, entries: dict) -> bool:
    """models/ and models_eval/ (each with models_info.json) for the three variants of `meshes`:
    copied from the `previous` dataset when its dataset_info.json has the same meshes_hash and its
    files still match its manifest (they are a pure function of the meshes, and take seconds to
    build), else built. Returns whether they were reused."""
    want = config_hash(meshes)
    try:
        info = json.loads((previous / DATASET_INFO).read_text(encoding="utf-8"))
        manifest = json.loads((previous / MANIFEST).read_text(encoding="utf-8"))["files"]
        if info.get("meshes_hash") == want:
            names = sorted(n for n in manifest if n.startswith(("models/", "models_eval/")))
            copied = {}
            for rel in names:
                dst = stage / rel
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(previous / rel, dst)
                copied[rel] = file_sha256(dst)
                if copied[rel] != (manifest[rel]["bytes"], manifest[rel]["sha256"]):
                    raise ValueError(rel)
            if names:
                entries.update(copied)
                return True
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass
    for sub in ("models", "models_eval"):
        shutil.rmtree(stage / sub, ignore_errors=True)
    write_models(stage, dataset_meshes(meshes))
    return False


def _write_view(stage: Path, outputs: list[_SceneOutput]) -> dict[str, str]:
    """The paper's split/mesh/location/scene hierarchy as relative links to the BOP scene
    directories (moonbot.bop.layout); returns link path → target, both dataset-relative."""
    links = {}
    for output in outputs:
        meta = output.meta
        link = stage / meta["view"]
        link.parent.mkdir(parents=True, exist_ok=True)
        target = view_target(meta["split"], meta["scene_id"])
        os.symlink(target, link, target_is_directory=True)
        links[meta["view"]] = target
    return links


def sweep_stale(dataset_dir: Path) -> list[Path]:
    """Removes what interrupted merges left beside `dataset_dir` (staged_directory's hidden
    `.<name>.*.tmp` and `.<name>.*.old` directories) and returns them. One merge at a time per
    dataset: a concurrent merge's staging directory would be removed too."""
    parent = dataset_dir.parent
    if not parent.is_dir():
        return []
    stale = sorted(p for pattern in (f".{dataset_dir.name}.*.tmp", f".{dataset_dir.name}.*.old")
                   for p in parent.glob(pattern) if p.is_dir())
    for p in stale:
        shutil.rmtree(p, ignore_errors=True)
    return stale


def merge_dataset(out_dir: Path, dataset_dir: Path | None = None, config: Config | None = None, *,
                  link: bool = False, workers: int | None = None, progress=sys.stderr) -> MergeReport:
    """Merges the complete tasks of `out_dir`/tasks into the BOP dataset `dataset_dir` (default
    `out_dir`/dataset), replacing a previous one whole. `config`: the sweep's config, which names
    the missing tasks and goes into dataset_info.json (None: `out_dir`/config.json when present,
    else the dataset has no config record and only missing tasks of present scenes are known).
    `link`: hard-link task files instead of copying them. `workers`: processes building scenes
    (default: one per core). Progress lines go to `progress` (None: silent). Raises MergeError
    when nothing is complete or tasks contradict each other, OSError naming the file on I/O
    failure; in both cases the previous dataset is left as it was. Temporaries of interrupted
    merges beside the dataset are removed first (sweep_stale)."""
    start = time.perf_counter()
    out_dir = Path(out_dir)
    dataset_dir = Path(dataset_dir) if dataset_dir is not None else out_dir / "dataset"
    say = (lambda text: print(text, file=progress, flush=True)) if progress else (lambda text: None)
    if config is None and (out_dir / "config.json").is_file():
        from moonbot.config import ConfigError, load_config

        try:
            config = load_config(out_dir / "config.json")
        except ConfigError as e:
            raise MergeError(str(e)) from None
    inventory = scan_tasks(out_dir / "tasks", config)
    if not inventory.scenes:
        raise MergeError(f"{out_dir / 'tasks'}: no complete task to merge"
                         + (f" ({len(inventory.invalid)} unusable)" if inventory.invalid else ""))
    first = inventory.scenes[0].tasks[0]
    try:
        meshes = from_mapping(MeshesConfig, first.record["config"]["meshes"])
    except (KeyError, TypeError, ValueError) as e:
        raise MergeError(f"{first.path / 'task.json'}: field 'config.meshes' is not a meshes section ({e})") from None
    workers = max(1, workers or os.cpu_count() or 1)
    for p in sweep_stale(dataset_dir):
        say(f"removed {p} (left by an interrupted merge)")

    with staged_directory(dataset_dir) as stage:
        outputs = _run_scenes(stage, inventory, link, workers, say, tuple(meshes.objects()))
        # Tasks found bad while building were appended in completion order: back to sweep order.
        last = len(inventory.position)
        inventory.missing = sorted(set(inventory.missing), key=lambda t: (inventory.position.get(t, last), t))
        if not outputs:
            raise MergeError(f"{out_dir / 'tasks'}: no task could be merged: "
                             + "; ".join(f"{k}: {v}" for k, v in sorted(inventory.invalid.items())))
        entries: dict = {}
        for output in outputs:
            entries.update(output.entries)
        camera = outputs[0].camera
        for output in outputs[1:]:
            if output.camera != camera:
                raise MergeError(f"{output.rel}: camera {output.camera} differs from {outputs[0].rel}'s {camera}")
        splits = [s for s in inventory.splits if any(o.split == s for o in outputs)]

        for output in outputs:
            for split, name, rgb_rel, detect_text, segment_text in output.yolo:
                for kind, text in (("detect", detect_text), ("segment", segment_text)):
                    base = f"yolo/{kind}"
                    image_rel, label_rel = f"{base}/images/{split}/{name}.png", f"{base}/labels/{split}/{name}.txt"
                    (stage / image_rel).parent.mkdir(parents=True, exist_ok=True)
                    (stage / label_rel).parent.mkdir(parents=True, exist_ok=True)
                    _link_or_copy(stage / rgb_rel, stage / image_rel)
                    entries[image_rel] = entries[rgb_rel]
                    _put_bytes(stage, label_rel, text.encode("ascii"), entries)
        for kind in YOLO_TASKS:
            _put_bytes(stage, f"yolo/{kind}/data.yaml", data_yaml(splits, kind, meshes.objects()).encode("utf-8"), entries)

        rows = index_rows([o.meta for o in outputs])
        _put_bytes(stage, SCENE_INDEX_JSON, dumps_json(index_json(rows)), entries)
        _put_bytes(stage, SCENE_INDEX_PARQUET, parquet_bytes(rows), entries)
        if TEST_SPLIT in splits:
            targets = test_targets({o.meta["scene_id"]: o.visible_counts for o in outputs if o.split == TEST_SPLIT})
            _put_bytes(stage, TEST_TARGETS, dumps_json(targets), entries)
        links = _write_view(stage, outputs)

        models_reused = _models(stage, dataset_dir, meshes, entries)
        _put_bytes(stage, "camera.json", dumps_json(camera), entries)

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
        _put_bytes(stage, DATASET_INFO, dumps_json(info), entries)

        # Everything on disk must be in the manifest (models are hashed here when built).
        for path in sorted(p for p in stage.rglob("*") if p.is_file()):
            rel = path.relative_to(stage).as_posix()
            if rel not in entries:
                entries[rel] = file_sha256(path)
        manifest = {"algorithm": "sha256", "file_count": len(entries),
                    "total_bytes": sum(size for size, _ in entries.values()),
                    "files": {rel: {"bytes": size, "sha256": sha} for rel, (size, sha) in sorted(entries.items())},
                    "links": dict(sorted(links.items()))}
        manifest_bytes = dumps_json(manifest)
        (stage / MANIFEST).write_bytes(manifest_bytes)

    return MergeReport(
        dataset=dataset_dir, splits=tuple(splits), scenes=len(outputs), tasks=len(merged_tasks),
        images=info["images"], instances=sum(o.instances for o in outputs), missing=tuple(inventory.missing),
        invalid=dict(sorted(inventory.invalid.items())), extra=tuple(inventory.extra), amodal_outside_px=outside,
        files=len(entries) + 1, bytes=manifest["total_bytes"] + len(manifest_bytes),
        seconds=time.perf_counter() - start, models_reused=models_reused)
