"""The YOLO trees of a merged dataset (moonbot.bop.merge), read from the dataset itself: its
scene index, each scene's scene_meta.json and scene_gt.json, and the visible masks
(mask_visib/IIIIII_KKKKKK.png, 0/255), to

    yolo/detect/  data.yaml  images/<split>/<name>.png  labels/<split>/<name>.txt   (boxes)
    yolo/segment/ data.yaml  images/<split>/<name>.png  labels/<split>/<name>.txt   (polygons)

Names are `<mesh>_<location>_<scene_id:06d>_<im_id:06d>`; images are hard links to the dataset's
own rgb files (copies across file systems); label rows as moonbot.yolo.labels writes them, one
per instance with a visible pixel, in the instance order of scene_gt.json. `write_yolo` is a
merge exporter: it runs on the staging dataset before the manifest is written, which lists its
files.
"""

from __future__ import annotations

import json
from pathlib import Path

from moonbot import _core
from moonbot.bop.dataset_files import link_or_copy, put_bytes
from moonbot.bop.dataset_info import DATASET_INFO
from moonbot.bop.layout import SCENE_INDEX_JSON, SCENE_META
from moonbot.yolo.labels import data_yaml, detect_row, segment_row

YOLO_TASKS = ("detect", "segment")


def _read_json(path: Path):
    return json.loads(path.read_text(encoding="utf-8"))


def _scene_labels(dataset: Path, scene_dir: str) -> list[tuple[str, str, str, str, str]]:
    """(split, name, rgb relative path, detect text, segment text) of every image of the scene
    folder `scene_dir` (dataset-relative), in image-id order."""
    meta = _read_json(dataset / scene_dir / SCENE_META)
    scene_gt = _read_json(dataset / scene_dir / "scene_gt.json")
    labels = []
    for im in sorted(scene_gt, key=int):
        name = f"{int(im):06d}"
        detect_rows, segment_rows = [], []
        for k, instance in enumerate(scene_gt[im]):
            visible = _core.read_image(str(dataset / scene_dir / "mask_visib" / f"{name}_{k:06d}.png")) > 0
            for rows, make in ((detect_rows, detect_row), (segment_rows, segment_row)):
                row = make(instance["obj_id"], visible)
                if row is not None:
                    rows.append(row)
        labels.append(
            (
                meta["split"],
                f"{meta['mesh']}_{meta['location']}_{meta['scene_id']:06d}_{name}",
                f"{scene_dir}/rgb/{name}.png",
                "".join(row + "\n" for row in detect_rows),
                "".join(row + "\n" for row in segment_rows),
            )
        )
    return labels


def write_yolo(dataset: Path, entries: dict) -> None:
    """Writes dataset/yolo/ for the merged `dataset` (its splits and objects from
    dataset_info.json, its scenes in scene_index.json's order) and records each file in `entries`
    (dataset-relative path → (bytes, sha256), the rgb files' among them: a linked image's entry is
    its rgb file's)."""
    info = _read_json(dataset / DATASET_INFO)
    splits = [split["name"] for split in info["splits"]]
    objects = {int(obj_id): name for obj_id, name in info["objects"].items()}
    scene_dirs = dict.fromkeys(row["scene_dir"] for row in _read_json(dataset / SCENE_INDEX_JSON)["rows"])
    for scene_dir in scene_dirs:
        for split, name, rgb_rel, detect_text, segment_text in _scene_labels(dataset, scene_dir):
            for kind, text in (("detect", detect_text), ("segment", segment_text)):
                base = f"yolo/{kind}"
                image_rel, label_rel = f"{base}/images/{split}/{name}.png", f"{base}/labels/{split}/{name}.txt"
                (dataset / image_rel).parent.mkdir(parents=True, exist_ok=True)
                (dataset / label_rel).parent.mkdir(parents=True, exist_ok=True)
                link_or_copy(dataset / rgb_rel, dataset / image_rel)
                entries[image_rel] = entries[rgb_rel]
                put_bytes(dataset, label_rel, text.encode("ascii"), entries)
    for kind in YOLO_TASKS:
        put_bytes(dataset, f"yolo/{kind}/data.yaml", data_yaml(splits, kind, objects).encode("utf-8"), entries)
