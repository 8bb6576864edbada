"""One COCO file per split of a merged BOP dataset, for detectron2 / mmdetection: its scenes'
scene_gt_coco.json content (moonbot.bop.coco, as bop_toolkit's calc_gt_coco writes it) gathered,
with `file_name` relative to the dataset root, image `id` = scene_id × 1 000 000 + im_id (BOP
im_ids have 6 digits) with `scene_id` and `im_id` fields beside it, and annotation ids from 1
over the split. Everything else is as in scene_gt_coco.json.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from moonbot.atomic_io import atomic_write
from moonbot.bop.coco import coco_categories, coco_info, image_info, rgb_name, scene_annotations
from moonbot.bop.reader import DatasetError, load_json
from moonbot.bop.toolkit_json import dumps_toolkit_json
from moonbot.export.scenes import SceneDir, dataset_scenes

# Split files' image ids: scene_id × this + im_id (BOP image ids are six-digit).
IMAGE_ID_STRIDE = 1_000_000


@dataclass(frozen=True)
class DatasetFacts:
    """What the COCO files take from the dataset root: its name (dataset_info.json), object ids
    (models/models_info.json) and image size (camera.json, pixels)."""

    name: str
    obj_ids: tuple[int, ...]
    width: int
    height: int


def dataset_facts(dataset: Path) -> DatasetFacts:
    """The dataset's name, object ids and image size. DatasetError naming the file and field."""
    dataset = Path(dataset)
    info, models, camera = (
        load_json(dataset / name) for name in ("dataset_info.json", "models/models_info.json", "camera.json")
    )
    try:
        name = info["name"]
        if not isinstance(name, str) or not name:
            raise TypeError(name)
    except (KeyError, TypeError):
        raise DatasetError(f"{dataset / 'dataset_info.json'}: field 'name' must be a non-empty string") from None
    try:
        obj_ids = tuple(sorted(int(k) for k in models))
    except (TypeError, ValueError):
        raise DatasetError(f"{dataset / 'models/models_info.json'}: keys must be obj_ids") from None
    size = []
    for field in ("width", "height"):
        value = camera.get(field) if isinstance(camera, dict) else None
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise DatasetError(f"{dataset / 'camera.json'}: field '{field}' must be a positive integer, got {value!r}")
        size.append(value)
    return DatasetFacts(name, obj_ids, *size)


def split_coco(
    dataset: Path, split: str, facts: DatasetFacts | None = None, scenes: Sequence[SceneDir] | None = None
) -> dict:
    """One COCO file's content for a split of `dataset`: its scenes' images and annotations with
    dataset-root-relative file names and split-unique ids (module docstring). `facts` and
    `scenes` (the dataset's, as dataset_facts and dataset_scenes find them) are read when not
    given. DatasetError when the split has no scene."""
    dataset = Path(dataset)
    facts = facts or dataset_facts(dataset)
    coco = {
        "info": coco_info(facts.name, split),
        "licenses": [],
        "categories": coco_categories(facts.name, facts.obj_ids),
        "images": [],
        "annotations": [],
    }
    found = [s for s in (scenes if scenes is not None else dataset_scenes(dataset)) if s.split == split]
    if not found:
        raise DatasetError(f"{dataset}: no scene of split {split!r}")
    for scene in found:
        prefix = scene.path.relative_to(dataset).as_posix()
        for im_id, image_annotations in scene_annotations(scene.path, facts.width, facts.height):
            if not 0 <= im_id < IMAGE_ID_STRIDE:
                raise DatasetError(
                    f"{scene.path / 'scene_gt.json'}: image id {im_id} is not a BOP image id "
                    f"(0 to {IMAGE_ID_STRIDE - 1})"
                )
            image_id = scene.scene_id * IMAGE_ID_STRIDE + im_id
            image = image_info(image_id, f"{prefix}/{rgb_name(scene.path, im_id)}", facts.width, facts.height)
            coco["images"].append({**image, "scene_id": scene.scene_id, "im_id": im_id})
            for annotation in image_annotations:
                coco["annotations"].append({"id": len(coco["annotations"]) + 1, "image_id": image_id, **annotation})
    return coco


def write_split_cocos(dataset: Path, out_dir: Path) -> dict[str, Path]:
    """Writes `out_dir`/instances_<split>.json for every split of `dataset` (each file replaced
    whole); returns split → path."""
    dataset, out_dir = Path(dataset), Path(out_dir)
    facts = dataset_facts(dataset)
    scenes = dataset_scenes(dataset)
    splits = list(dict.fromkeys(s.split for s in scenes))
    out_dir.mkdir(parents=True, exist_ok=True)
    written = {}
    for split in splits:
        data = dumps_toolkit_json(split_coco(dataset, split, facts, scenes))
        path = out_dir / f"instances_{split}.json"
        atomic_write(path, "wb", lambda f, data=data: f.write(data))
        written[split] = path
    return written
