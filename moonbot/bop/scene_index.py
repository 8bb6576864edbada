"""The dataset-level index of a merged dataset (scene_index.json and scene_index.parquet) and its
bop_toolkit evaluation targets (test_targets_bop19.json).

The index has one row per merged task — a scene seen under one Sun and from one camera height —
so a row maps a BOP scene and a range of its image ids to every condition of the paper's sweep:

    bop_split (str: train_pbr, val_pbr, test), split (str: the sweep's name), scene_id (int),
    im_id_first, im_id_last (int: the task's images are im_id_first..im_id_last), scene_dir,
    view (str: paths relative to the dataset), mesh (str), obj_id (int), location (str),
    bags (int), stain_seeds (int: 0 = clean), dust (bool), sun_elevation_deg,
    sun_azimuth_deg (float, degrees; azimuth clockwise from North), camera_height_m (float,
    metres above the target bag), task_in_scene (int), task_id (str)

Rows in dataset order (splits as the sweep orders them, scene ids, then task_in_scene). The JSON
file is {"columns": [...], "rows": [{column: value}, ...]}; the parquet file holds the same rows
with those column types (string, int64, bool, float64), zstd-compressed. Every value also sits in
the scene's scene_meta.json (its scene fields and its `tasks` list).
"""

from __future__ import annotations

import io

import pyarrow as pa
import pyarrow.parquet as pq

COLUMNS: dict[str, pa.DataType] = {
    "bop_split": pa.string(),
    "split": pa.string(),
    "scene_id": pa.int64(),
    "im_id_first": pa.int64(),
    "im_id_last": pa.int64(),
    "scene_dir": pa.string(),
    "view": pa.string(),
    "mesh": pa.string(),
    "obj_id": pa.int64(),
    "location": pa.string(),
    "bags": pa.int64(),
    "stain_seeds": pa.int64(),
    "dust": pa.bool_(),
    "sun_elevation_deg": pa.float64(),
    "sun_azimuth_deg": pa.float64(),
    "camera_height_m": pa.float64(),
    "task_in_scene": pa.int64(),
    "task_id": pa.string(),
}
# Each task's columns come from its entry in scene_meta.json's `tasks`, the image id range from
# that entry's image_ids, and the rest from the scene's own fields.
_TASK_COLUMNS = ("sun_elevation_deg", "sun_azimuth_deg", "camera_height_m", "task_in_scene", "task_id")
_IMAGE_RANGE_COLUMNS = ("im_id_first", "im_id_last")
_SCENE_COLUMNS = tuple(name for name in COLUMNS if name not in _TASK_COLUMNS + _IMAGE_RANGE_COLUMNS)


def index_rows(scene_metas: list[dict]) -> list[dict]:
    """The index rows of scenes given by their scene_meta.json contents (in dataset order)."""
    rows = []
    for meta in scene_metas:
        scene = {name: meta[name] for name in _SCENE_COLUMNS}
        for task in sorted(meta["tasks"], key=lambda t: t["task_in_scene"]):
            first, last = task["image_ids"]
            row = {**scene, "im_id_first": first, "im_id_last": last, **{name: task[name] for name in _TASK_COLUMNS}}
            rows.append({name: row[name] for name in COLUMNS})
    return rows


def index_json(rows: list[dict]) -> dict:
    """scene_index.json's content."""
    return {"columns": list(COLUMNS), "rows": rows}


def index_table(rows: list[dict]) -> pa.Table:
    """The rows as an Arrow table with COLUMNS' types."""
    return pa.table({name: pa.array([row[name] for row in rows], kind) for name, kind in COLUMNS.items()})


def parquet_bytes(rows: list[dict]) -> bytes:
    """scene_index.parquet's bytes: the same for the same rows (and pyarrow version)."""
    sink = io.BytesIO()
    pq.write_table(index_table(rows), sink, compression="zstd")
    return sink.getvalue()


def test_targets(visible_counts: dict[int, dict[int, dict[int, int]]]) -> list[dict]:
    """test_targets_bop19.json's entries, {im_id, obj_id, inst_count, scene_id}, sorted by scene,
    image and object, from `visible_counts` (scene_id → im_id → obj_id → instances of the object
    with at least one visible pixel). These are the instances `moonbot eval` evaluates by default,
    so bop_toolkit's eval_bop19_pose (whose default takes the inst_count most visible ground-truth
    instances of an object in an image) counts the same ones."""
    return [
        {"im_id": im_id, "inst_count": count, "obj_id": obj_id, "scene_id": scene_id}
        for scene_id in sorted(visible_counts)
        for im_id in sorted(visible_counts[scene_id])
        for obj_id, count in sorted(visible_counts[scene_id][im_id].items())
        if count > 0
    ]
