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
      yolo/         when the caller passes moonbot.yolo.export's exporter (the commands do)

Split directories, scene ids and the view: moonbot.bop.layout. Image ids follow the sweep:
IIIIII = task_in_scene × views_per_task + the view's index in the task's `views`; KKKKKK is the
instance's index in the image's scene_gt.json list (the scene's bags in instance-id order).

The parts: the scene folders (moonbot.bop.scene_build), the models (moonbot.bop.models),
dataset_info.json (moonbot.bop.dataset_info), files, canonical JSON and the manifest
(moonbot.bop.dataset_files). Exporters the caller passes (moonbot.yolo.export) read the merged
dataset in the staging tree and add their files before the manifest is written, so the manifest
lists them and they are renamed into place with the rest.

Bytes: the dataset is a pure function of the task directories (and the config): JSON with
sorted keys (image ids in numeric order), scenes in sweep order, PNGs encoded at the tasks'
`output.png_compression`. Merging again gives the same bytes (manifest.json lists every other
file's size and sha256, and every link's target). Files taken from the tasks are copied, their
sha256 checked against DONE.json on the way (a mismatch makes the task invalid, reported, and its
scene is merged without it); with `link=True` they are hard-linked instead (no copy, no read:
DONE.json's sha256 is trusted; across file systems they are copied). Task files are only ever
replaced by rename, never changed in place, so a link cannot change under the dataset.

bop_toolkit conventions throughout: mm, R row-major, OpenCV camera, pixel centres at +0.5;
scene_gt_info.json as moonbot.bop.gt_info documents.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from moonbot.atomic_io import staged_directory
from moonbot.bop.dataset_files import MANIFEST, dumps_json, put_bytes, write_manifest
from moonbot.bop.dataset_info import DATASET_INFO, dataset_info
from moonbot.bop.inventory import MergeError, scan_tasks
from moonbot.bop.layout import SCENE_INDEX_JSON, SCENE_INDEX_PARQUET, TEST_SPLIT, TEST_TARGETS, view_target
from moonbot.bop.models import write_models
from moonbot.bop.scene_build import SceneOutput, run_scenes
from moonbot.bop.scene_index import index_json, index_rows, parquet_bytes, test_targets
from moonbot.config import Config, config_hash
from moonbot.config.load import from_mapping
from moonbot.config.schema import MeshesConfig
from moonbot.scene.bag_mesh import dataset_meshes
from moonbot.writer.checksum import file_sha256

# `moonbot merge` exits with this when it merged what was complete but tasks are missing or invalid.
EXIT_INCOMPLETE = 3

# Adds files to a merged dataset before its manifest is written: called with the staging
# dataset's root (every scene, the models, the index and dataset_info.json written) and the
# manifest entries, dataset-relative path → (bytes, sha256), to which it adds each file it writes
# (a file it leaves out is hashed when the manifest is made).
Exporter = Callable[[Path, dict], None]


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


def _write_view(stage: Path, outputs: list[SceneOutput]) -> dict[str, str]:
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
    stale = sorted(
        p
        for pattern in (f".{dataset_dir.name}.*.tmp", f".{dataset_dir.name}.*.old")
        for p in parent.glob(pattern)
        if p.is_dir()
    )
    for p in stale:
        shutil.rmtree(p, ignore_errors=True)
    return stale


def merge_dataset(
    out_dir: Path,
    dataset_dir: Path | None = None,
    config: Config | None = None,
    *,
    link: bool = False,
    workers: int | None = None,
    progress=sys.stderr,
    exporters: Sequence[Exporter] = (),
) -> MergeReport:
    """Merges the complete tasks of `out_dir`/tasks into the BOP dataset `dataset_dir` (default
    `out_dir`/dataset), replacing a previous one whole. `config`: the sweep's config, which names
    the missing tasks and goes into dataset_info.json (None: `out_dir`/config.json when present,
    else the dataset has no config record and only missing tasks of present scenes are known).
    `link`: hard-link task files instead of copying them. `workers`: processes building scenes
    (default: one per core). Progress lines go to `progress` (None: silent). `exporters`: each
    called in turn with the complete staging dataset and its manifest entries (Exporter), to add
    its files before the manifest is written. Raises MergeError when nothing is complete or tasks
    contradict each other, OSError naming the file on I/O failure; in both cases the previous
    dataset is left as it was. Temporaries of interrupted merges beside the dataset are removed
    first (sweep_stale)."""
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
        raise MergeError(
            f"{out_dir / 'tasks'}: no complete task to merge"
            + (f" ({len(inventory.invalid)} unusable)" if inventory.invalid else "")
        )
    first = inventory.scenes[0].tasks[0]
    try:
        meshes = from_mapping(MeshesConfig, first.record["config"]["meshes"])
    except (KeyError, TypeError, ValueError) as e:
        raise MergeError(f"{first.path / 'task.json'}: field 'config.meshes' is not a meshes section ({e})") from None
    workers = max(1, workers or os.cpu_count() or 1)
    for p in sweep_stale(dataset_dir):
        say(f"removed {p} (left by an interrupted merge)")

    with staged_directory(dataset_dir) as stage:
        outputs = run_scenes(stage, inventory, link, workers, say, tuple(meshes.objects()))
        # Tasks found bad while building were appended in completion order: back to sweep order.
        last = len(inventory.position)
        inventory.missing = sorted(set(inventory.missing), key=lambda t: (inventory.position.get(t, last), t))
        if not outputs:
            raise MergeError(
                f"{out_dir / 'tasks'}: no task could be merged: "
                + "; ".join(f"{k}: {v}" for k, v in sorted(inventory.invalid.items()))
            )
        entries: dict = {}
        for output in outputs:
            entries.update(output.entries)
        camera = outputs[0].camera
        for output in outputs[1:]:
            if output.camera != camera:
                raise MergeError(f"{output.rel}: camera {output.camera} differs from {outputs[0].rel}'s {camera}")
        splits = [s for s in inventory.splits if any(o.split == s for o in outputs)]

        rows = index_rows([o.meta for o in outputs])
        put_bytes(stage, SCENE_INDEX_JSON, dumps_json(index_json(rows)), entries)
        put_bytes(stage, SCENE_INDEX_PARQUET, parquet_bytes(rows), entries)
        if TEST_SPLIT in splits:
            targets = test_targets({o.meta["scene_id"]: o.visible_counts for o in outputs if o.split == TEST_SPLIT})
            put_bytes(stage, TEST_TARGETS, dumps_json(targets), entries)
        links = _write_view(stage, outputs)

        models_reused = _models(stage, dataset_dir, meshes, entries)
        put_bytes(stage, "camera.json", dumps_json(camera), entries)

        info = dataset_info(outputs, splits, inventory, config, meshes)
        put_bytes(stage, DATASET_INFO, dumps_json(info), entries)
        for export in exporters:
            export(stage, entries)
        manifest, manifest_bytes = write_manifest(stage, entries, links)
    return MergeReport(
        dataset=dataset_dir,
        splits=tuple(splits),
        scenes=len(outputs),
        tasks=info["tasks_merged"],
        images=info["images"],
        instances=sum(o.instances for o in outputs),
        missing=tuple(inventory.missing),
        invalid=dict(sorted(inventory.invalid.items())),
        extra=tuple(inventory.extra),
        amodal_outside_px=info["amodal_outside_visible_px"],
        files=len(entries) + 1,
        bytes=manifest["total_bytes"] + len(manifest_bytes),
        seconds=time.perf_counter() - start,
        models_reused=models_reused,
    )
