"""COCO instance annotations of a BOP scene: `scene_gt_coco.json`, as bop_toolkit's
`scripts/calc_gt_coco.py` writes it (merge writes it into every scene; moonbot.export.coco gathers
a split's scenes into one file for detectron2 / mmdetection).

scene_gt_coco.json holds what calc_gt_coco computes with `--use_all_gt` and the default
`--bbox_type amodal` (every image of the scene; moonbot's training data has no test targets):

- `images`: one per image of scene_gt.json, `id` = the BOP im_id, `file_name` the rgb file
  relative to the scene directory (`rgb/000000.png`), `width`/`height` the dataset's image size,
  `license` 1, empty `coco_url`/`flickr_url`.
- `annotations`: one per instance whose visible mask (mask_visib/) has a pixel and whose amodal
  mask (mask/) has one; `id` counts them from 1 within the scene in scene_gt.json order (an
  instance left out takes no id); `category_id` = obj_id; `iscrowd` 0; `area` = visible pixels;
  `bbox` = [x, y, w, h] of the amodal mask, w = max x - min x + 1 (calc_gt_coco's
  `bbox_from_binary_mask`, one wider than scene_gt_info's bbox); `segmentation` = the visible
  mask's uncompressed RLE (moonbot.bop.rle); `width`/`height` the mask's; `ignore` =
  visib_fract < 0.1.
- `categories`: {"id": obj_id, "name": str(obj_id), "supercategory": dataset name} for every
  object of the dataset (models/models_info.json).
- `info`: description "<dataset>_<split>" (the split without its type: `train` for train_pbr),
  url of the format's reference tool, version "0.1.0", empty contributor; `licenses` [].

Where calc_gt_coco writes the wall-clock time (`info.year`, `info.date_created`, each image's
`date_captured`), moonbot writes the Unix epoch in the same format: a dataset is a pure function
of its tasks, so its bytes carry no time of writing. The file is laid out as bop_toolkit's
save_json lays it out (moonbot.bop.toolkit_json); with those three fields set alike, it is
byte for byte calc_gt_coco's file.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.bop.reader import DatasetError, load_json
from moonbot.bop.rle import encode_rle
from moonbot.bop.toolkit_json import dumps_toolkit_json

SCENE_COCO = "scene_gt_coco.json"
# calc_gt_coco flags an instance `ignore` below this visible fraction (its "objects smaller than
# 10% visible"), so that evaluation neither rewards nor penalises detecting it.
IGNORE_BELOW_VISIB_FRACT = 0.1
_EPOCH = datetime.datetime.fromtimestamp(0, datetime.timezone.utc)


def toolkit_split(split: str) -> str:
    """The split as bop_toolkit's dataset_params takes it: the directory name without its split
    type (`train_pbr` → `train`; `test` stays)."""
    return split.split("_", 1)[0]


def coco_info(dataset_name: str, split: str) -> dict:
    """calc_gt_coco's `info`, with the epoch where it writes the time of writing."""
    return {
        "description": f"{dataset_name}_{toolkit_split(split)}",
        "url": "https://github.com/thodan/bop_toolkit",
        "version": "0.1.0",
        "year": _EPOCH.year,
        "contributor": "",
        "date_created": _EPOCH.isoformat(" "),
    }


def coco_categories(dataset_name: str, obj_ids: Iterable[int]) -> list[dict]:
    """One category per object, as calc_gt_coco lists them."""
    return [{"id": int(obj_id), "name": str(obj_id), "supercategory": dataset_name} for obj_id in obj_ids]


def image_info(image_id: int, file_name: str, width: int, height: int) -> dict:
    return {
        "id": image_id,
        "file_name": file_name,
        "width": width,
        "height": height,
        "date_captured": _EPOCH.replace(tzinfo=None).isoformat(" "),
        "license": 1,
        "coco_url": "",
        "flickr_url": "",
    }


def amodal_bbox(mask: np.ndarray) -> list[int]:
    """[x, y, w, h] of a non-empty (H, W) mask, pixels: w = max x - min x + 1 (calc_gt_coco's box,
    which covers the last column; scene_gt_info's `bbox_obj` is one narrower)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return [int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1)]


def read_mask(path: Path, height: int, width: int) -> np.ndarray:
    """A BOP mask PNG as (H, W) bool (nonzero = set). DatasetError naming the file when it is
    missing, unreadable or not H × W."""
    if not path.is_file():
        raise DatasetError(f"{path}: missing")
    try:
        pixels = _core.read_image(str(path))
    except (OSError, ValueError, RuntimeError) as e:
        raise DatasetError(f"{path}: unreadable ({e})") from None
    if pixels.size != height * width or pixels.shape[:2] != (height, width):
        raise DatasetError(f"{path}: {pixels.shape} pixels, the dataset's images are {height} x {width}")
    return pixels.reshape(height, width) != 0


def rgb_name(scene_dir: Path, im_id: int) -> str:
    """The image's rgb file relative to the scene directory (PNG, else JPEG as BOP's PBR splits).
    DatasetError when there is neither."""
    for suffix in (".png", ".jpg"):
        name = f"rgb/{im_id:06d}{suffix}"
        if (scene_dir / name).is_file():
            return name
    raise DatasetError(f"{scene_dir / 'rgb'}: no {im_id:06d}.png or .jpg (image {im_id} of scene_gt.json)")


def scene_annotations(scene_dir: Path, width: int, height: int):
    """Yields (im_id, [annotation without id or image_id, ...]) for each image of the scene, in
    scene_gt.json order; instances with an empty visible or amodal mask are left out."""
    gt = load_json(scene_dir / "scene_gt.json")
    gt_info = load_json(scene_dir / "scene_gt_info.json")
    if not isinstance(gt, dict) or not isinstance(gt_info, dict):
        raise DatasetError(f"{scene_dir}: scene_gt.json and scene_gt_info.json must be JSON objects")
    for im_key, instances in gt.items():
        try:
            im_id = int(im_key)
            infos = gt_info[im_key]
            pairs = [(int(inst["obj_id"]), float(infos[k]["visib_fract"])) for k, inst in enumerate(instances)]
        except (KeyError, IndexError, TypeError, ValueError) as e:
            raise DatasetError(
                f"{scene_dir / 'scene_gt.json'}: image {im_key!r} lacks obj_id, or "
                f"scene_gt_info.json its visib_fract ({e!r})"
            ) from None
        annotations = []
        for k, (obj_id, visib_fract) in enumerate(pairs):
            mask_name = f"{im_id:06d}_{k:06d}.png"
            visible = read_mask(scene_dir / "mask_visib" / mask_name, height, width)
            if not visible.any():
                continue
            amodal = read_mask(scene_dir / "mask" / mask_name, height, width)
            if not amodal.any():
                continue
            annotations.append(
                {
                    "category_id": obj_id,
                    "iscrowd": 0,
                    "area": int(np.count_nonzero(visible)),
                    "bbox": amodal_bbox(amodal),
                    "segmentation": encode_rle(visible),
                    "width": width,
                    "height": height,
                    "ignore": visib_fract < IGNORE_BELOW_VISIB_FRACT,
                }
            )
        yield im_id, annotations


def scene_coco(
    scene_dir: Path, dataset_name: str, split: str, obj_ids: Sequence[int], im_size: tuple[int, int]
) -> dict:
    """The content of `scene_dir`'s scene_gt_coco.json (see the module's docstring). `im_size`:
    (width, height) pixels. DatasetError naming the file when a scene file is missing or
    malformed."""
    scene_dir = Path(scene_dir)
    width, height = im_size
    coco = {
        "info": coco_info(dataset_name, split),
        "licenses": [],
        "categories": coco_categories(dataset_name, obj_ids),
        "images": [],
        "annotations": [],
    }
    for im_id, image_annotations in scene_annotations(scene_dir, width, height):
        coco["images"].append(image_info(im_id, rgb_name(scene_dir, im_id), width, height))
        for annotation in image_annotations:
            coco["annotations"].append({"id": len(coco["annotations"]) + 1, "image_id": im_id, **annotation})
    return coco


def scene_gt_coco_bytes(
    scene_dir: Path, dataset_name: str, split: str, obj_ids: Sequence[int], im_size: tuple[int, int]
) -> bytes:
    """scene_gt_coco.json's bytes for `scene_dir`, laid out as calc_gt_coco saves it."""
    return dumps_toolkit_json(scene_coco(scene_dir, dataset_name, split, obj_ids, im_size))
