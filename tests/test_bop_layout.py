"""The tree `moonbot merge` writes is BOP's own (moonbot/bop/layout.py): the smoke sweep generated
and merged, then its paths, names and ids checked against the rules bop_toolkit's dataset_params
builds its paths with; the dataset-level index against every scene's scene_meta.json; the
by_condition/ view's links; the evaluation targets; and the val split the sweep draws from train.
A second test loads the same dataset with bop_toolkit itself where it is importable (it is not
on PyPI; docs/dataset-format.md says how to install and register a dataset with it)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from moonbot import _core
from moonbot.bop.layout import MAX_ID, bop_split, check_id, scene_dirs, scene_rel, view_rel, view_target
from moonbot.bop.reader import read_models, scenes
from moonbot.bop.scene_index import COLUMNS, index_rows
from moonbot.config import ConfigError, load_config
from moonbot.pipeline.generate import generate
from moonbot.sweep import tasks
from moonbot.sweep.tasks import draw, scene_seed

pytestmark = pytest.mark.integration

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
SPLITS = {"train": "train_pbr", "val": "val_pbr", "test": "test"}


@pytest.fixture(scope="module")
def smoke(tmp_path_factory) -> Path:
    """configs/smoke.yaml generated and merged: train, val drawn from train, and test."""
    out = tmp_path_factory.mktemp("smoke")
    result = generate(load_config(CONFIGS / "smoke.yaml"), out, workers=1, progress=None)
    assert not result.failed and result.merge.complete
    return out / "dataset"


def load(path: Path):
    return json.loads(path.read_text())


# --- the rules themselves ---------------------------------------------------------------------------


def test_split_directories_are_bops_and_one_to_one():
    assert [bop_split(s) for s in ("train", "val", "test", "default")] == [
        "train_pbr",
        "val_pbr",
        "test",
        "default_pbr",
    ]
    names = ["train", "train_pbr", "test", "test_pbr", "val", "pbr", "t"]
    assert len({bop_split(n) for n in names}) == len(names)


def test_ids_are_six_digits_zero_padded_within_range():
    assert scene_rel("train", 7) == "train_pbr/000007" and scene_rel("test", MAX_ID) == "test/999999"
    assert view_rel("val", "sandbag-02", "hilly", 41) == "by_condition/val/sandbag-02/hilly/scene_000041"
    assert view_target("val", 41) == "../../../../val_pbr/000041"
    for bad in (-1, MAX_ID + 1, 1.0, True, "3"):
        with pytest.raises(ValueError, match="scene_id: must be an integer in 0..999999"):
            scene_rel("train", bad)
    assert check_id(0, "x") == 0


def test_a_sweep_past_six_digit_ids_is_refused_naming_the_field(tmp_path):
    path = tmp_path / "big.yaml"
    # 3 meshes × 255 bag counts × 1308 stain seeds > 10^6 scenes
    path.write_text(
        "sweep:\n  splits:\n    - name: train\n      meshes: [sandbag-01, sandbag-02, sandbag-03]\n"
        f"      bag_counts: {list(range(1, 256))}\n      stain_seeds: {list(range(1308))}\n"
    )
    with pytest.raises(ConfigError, match=r"sweep.splits\[0\].meshes: 1000620 scenes .* six-digit scene ids"):
        load_config(path)
    path.write_text(
        "orbit: {views: 3600}\nsweep:\n  splits:\n    - name: train\n"
        f"      sun_elevations_deg: {[float(e) for e in range(0, 90)]}\n"
        f"      sun_azimuths_deg: [0.0, 90.0, 180.0, 270.0]\n"
    )
    with pytest.raises(ConfigError, match=r"sweep.splits\[0\]: 360 tasks × 3600 views a scene exceed"):
        load_config(path)


# --- the val split --------------------------------------------------------------------------------


def test_val_is_drawn_from_train_balanced_deterministic_and_in_new_layouts():
    config = load_config(CONFIGS / "smoke.yaml")
    ts = tasks(config)
    assert [s for s in dict.fromkeys(t.split for t in ts)] == ["train", "val", "test"]
    val = [t for t in ts if t.split == "val"]
    train = {(t.mesh, t.location, t.bags, t.stain_seeds, t.dust) for t in ts if t.split == "train"}
    assert [t.scene_id for t in val] == [0, 1, 2] and sorted(t.mesh for t in val) == [
        "sandbag-01",
        "sandbag-02",
        "sandbag-03",
    ]
    assert all((t.mesh, t.location, t.bags, t.stain_seeds, t.dust) in train for t in val)
    assert tasks(config) == ts  # the same draw every time
    assert all(
        scene_seed(config.seed, "val", t.mesh, t.location, t.bags)
        != scene_seed(config.seed, "train", t.mesh, t.location, t.bags)
        for t in val
    )
    # Balanced over meshes whatever the count: k of each per k × 3 drawn, in the grid's order.
    scenes = [(m, "plane", b, s, d) for m in ("a", "b", "c") for b in (1, 3) for s in (0, 15) for d in (False, True)]
    shots = [(e, 120.0, h) for e in (5.0, 12.0) for h in (0.2, 0.5, 0.9)]
    chosen = draw(7, "val", scenes, shots, 7, 2)
    assert [c[0][0] for c in chosen].count("a") == 3 and [c[0][0] for c in chosen].count("b") == 2
    assert [scenes.index(c[0]) for c in chosen] == sorted(scenes.index(c[0]) for c in chosen)
    assert all(len(c[1]) == 2 and c[1] == sorted(c[1], key=shots.index) for c in chosen)
    assert draw(8, "val", scenes, shots, 7, 2) != chosen  # another seed, another draw
    assert [c[1] for c in draw(7, "val", scenes, shots, 3, 0)] == [shots] * 3


@pytest.mark.parametrize(
    "split, message",
    [
        ({"name": "val", "draw_from": "nope", "scenes": 1}, r"sweep.splits\[1\].draw_from: 'nope' is not a split"),
        ({"name": "val", "draw_from": "train", "scenes": 0}, r"sweep.splits\[1\].scenes: .* needs scenes >= 1"),
        ({"name": "val", "draw_from": "train", "scenes": 25}, r"sweep.splits\[1\].scenes: 25 is more than the 24"),
        ({"name": "val", "draw_from": "train", "scenes": 1, "tasks_per_scene": 2}, r"tasks_per_scene: 2 is more"),
        (
            {"name": "val", "draw_from": "train", "scenes": 1, "dust": [True]},
            r"sweep.splits\[1\].dust: a split that draws",
        ),
        ({"name": "val", "scenes": 3}, r"sweep.splits\[1\].scenes: only for a split with draw_from"),
    ],
)
def test_a_bad_draw_names_the_field(split, message):
    data = yaml.safe_load((CONFIGS / "smoke.yaml").read_text())
    with pytest.raises(ConfigError, match=message):
        load_config(CONFIGS / "smoke.yaml", {"sweep.splits": [data["sweep"]["splits"][0], split]})


# --- the generated tree -----------------------------------------------------------------------------


def test_every_scene_sits_where_bop_looks_for_it(smoke):
    info = load(smoke / "dataset_info.json")
    assert info["bop_splits"] == SPLITS
    # Each split directory holds scene directories only, named by six digits (bop_toolkit's
    # get_present_scene_ids reads every directory there as an int), numbered 0.. in sweep order.
    counts = {"train": 24, "val": 3, "test": 6}
    for split, directory in SPLITS.items():
        names = sorted(p.name for p in (smoke / directory).iterdir())
        assert names == [f"{k:06d}" for k in range(counts[split])]
    top = {p.name for p in smoke.iterdir()}
    assert top == {
        "camera.json",
        "dataset_info.json",
        "manifest.json",
        "scene_index.json",
        "scene_index.parquet",
        "test_targets_bop19.json",
        "models",
        "models_eval",
        "by_condition",
        "yolo",
        *SPLITS.values(),
    }
    assert [p.relative_to(smoke).as_posix() for p in scene_dirs(smoke)] == sorted(
        f"{d}/{k:06d}" for s, d in SPLITS.items() for k in range(counts[s])
    )
    for scene in scene_dirs(smoke):
        meta = load(scene / "scene_meta.json")
        assert (
            scene.relative_to(smoke).as_posix()
            == meta["scene_dir"]
            == f"{SPLITS[meta['split']]}/{meta['scene_id']:06d}"
        )
        assert 0 <= meta["scene_id"] <= MAX_ID and meta["bop_split"] == SPLITS[meta["split"]]
        gt, camera, gt_info = (load(scene / f"{n}.json") for n in ("scene_gt", "scene_camera", "scene_gt_info"))
        assert list(gt) == list(camera) == list(gt_info) and all(re.fullmatch(r"0|[1-9][0-9]{0,5}", im) for im in gt)
        for im, instances in gt.items():
            # bop_toolkit's path templates: rgb/{im_id:06d}.png, depth/..., mask(_visib)/{im_id:06d}_{gt_id:06d}.png
            for template in ("rgb/{im:06d}.png", "depth/{im:06d}.png"):
                assert (scene / template.format(im=int(im))).is_file()
            for k in range(len(instances)):
                for kind in ("mask", "mask_visib"):
                    assert (scene / kind / f"{int(im):06d}_{k:06d}.png").is_file()
        assert sorted(p.name for p in (scene / "rgb").iterdir()) == [f"{int(im):06d}.png" for im in gt]
        # The paper's hierarchy: a relative link that resolves to the scene.
        link = smoke / meta["view"]
        assert link.is_symlink() and not os.path.isabs(os.readlink(link))
        assert link.resolve() == scene.resolve()
        assert (
            meta["view"]
            == f"by_condition/{meta['split']}/{meta['mesh']}/{meta['location']}/scene_{meta['scene_id']:06d}"
        )
    views = sorted(p for p in (smoke / "by_condition").rglob("*") if p.is_symlink())
    assert len(views) == sum(counts.values())


def test_the_index_is_every_tasks_scene_meta(smoke):
    metas = [load(scene / "scene_meta.json") for scene in scene_dirs(smoke)]
    order = {s: k for k, s in enumerate(SPLITS.values())}
    metas.sort(key=lambda m: (order[m["bop_split"]], m["scene_id"]))
    want = index_rows(metas)
    index = load(smoke / "scene_index.json")
    assert index["columns"] == list(COLUMNS) and index["rows"] == want
    table = pq.read_table(smoke / "scene_index.parquet")
    assert table.column_names == list(COLUMNS) and table.to_pylist() == want
    assert len(want) == 33  # one row a task
    for row in want:
        meta = next(m for m in metas if (m["bop_split"], m["scene_id"]) == (row["bop_split"], row["scene_id"]))
        task = meta["tasks"][row["task_in_scene"]]
        assert (row["sun_elevation_deg"], row["sun_azimuth_deg"], row["camera_height_m"], row["task_id"]) == (
            task["sun_elevation_deg"],
            task["sun_azimuth_deg"],
            task["camera_height_m"],
            task["task_id"],
        )
        assert [row["im_id_first"], row["im_id_last"]] == task["image_ids"]
        for name in ("mesh", "obj_id", "location", "bags", "stain_seeds", "dust", "split"):
            assert row[name] == meta[name]
        assert (row["sun_elevation_deg"], row["camera_height_m"]) == (
            (30.0, 1.0) if row["split"] == "test" else (12.0, 0.5)
        )


def test_the_targets_are_the_visible_instances_of_the_test_split(smoke):
    targets = load(smoke / "test_targets_bop19.json")
    want = []
    for scene in scenes(smoke, "test"):
        for im, instances in sorted(scene.images.items()):
            for obj in sorted({i.obj_id for i in instances}):
                count = sum(1 for i in instances if i.obj_id == obj and i.px_visib > 0)
                if count:
                    want.append({"im_id": im, "inst_count": count, "obj_id": obj, "scene_id": scene.scene_id})
    assert targets == want and len(targets) >= 12


def test_readers_and_yolo_see_the_three_splits(smoke):
    assert {s.split for s in scenes(smoke)} == set(SPLITS)
    assert [s.scene_id for s in scenes(smoke, "val")] == [0, 1, 2] == [s.scene_id for s in scenes(smoke, "val_pbr")]
    for kind in ("detect", "segment"):
        data = yaml.safe_load((smoke / "yolo" / kind / "data.yaml").read_text())
        assert (data["train"], data["val"], data["test"]) == ("images/train", "images/val", "images/test")
        val_images = sorted((smoke / "yolo" / kind / "images" / "val").iterdir())
        assert len(val_images) == 3 * 2  # 3 scenes × 1 task × 2 views


# --- bop_toolkit itself -----------------------------------------------------------------------------


def test_bop_toolkit_loads_the_dataset(smoke):
    """bop_toolkit's dataset_params and loaders on the dataset, given its path and name (the
    dataset folder is named `moonbot`, registered as docs/dataset-format.md shows)."""
    dataset_params = pytest.importorskip("bop_toolkit_lib.dataset_params")
    inout = pytest.importorskip("bop_toolkit_lib.inout")
    root = smoke.parent / "bop"
    root.mkdir(exist_ok=True)
    if not (root / "moonbot").exists():
        (root / "moonbot").symlink_to(smoke, target_is_directory=True)
    try:
        model_params = dataset_params.get_model_params(str(root), "moonbot", "eval")
    except (ValueError, KeyError):
        pytest.skip("bop_toolkit does not know the dataset 'moonbot': register it as docs/dataset-format.md shows")
    assert model_params["obj_ids"] == sorted(read_models(smoke, "models_eval"))
    for kind in ("models", "models_eval"):  # the meshes, and the surface samples the error scripts use
        template = dataset_params.get_model_params(str(root), "moonbot", kind.partition("_")[2] or None)["model_tpath"]
        for obj_id, model in read_models(smoke, kind).items():
            ply = inout.load_ply(template.format(obj_id=obj_id))
            assert np.array_equal(ply["pts"], model.vertices)
            assert np.array_equal(ply.get("faces", np.zeros((0, 3))), model.triangles)
    camera = dataset_params.get_camera_params(str(root), "moonbot")
    assert camera["im_size"] == (64, 48)
    for split, split_type in (("train", "pbr"), ("val", "pbr"), ("test", None)):
        params = dataset_params.get_split_params(str(root), "moonbot", split, split_type)
        ours = scenes(smoke, split)
        assert params["scene_ids"] == dataset_params.get_present_scene_ids(params) == [s.scene_id for s in ours]
        assert params["im_size"] == (64, 48)
        for scene in ours:
            gt = inout.load_scene_gt(params["scene_gt_tpath"].format(scene_id=scene.scene_id))
            cameras = inout.load_scene_camera(params["scene_camera_tpath"].format(scene_id=scene.scene_id))
            assert sorted(gt) == sorted(cameras) == sorted(scene.images)
            for im_id, instances in scene.images.items():
                assert np.array_equal(cameras[im_id]["cam_K"], scene.cameras[im_id])
                for inst, entry in zip(instances, gt[im_id], strict=True):
                    assert entry["obj_id"] == inst.obj_id
                    assert np.array_equal(entry["cam_R_m2c"], inst.R) and np.array_equal(
                        entry["cam_t_m2c"].ravel(), inst.t
                    )
                depth = inout.load_depth(params["depth_tpath"].format(scene_id=scene.scene_id, im_id=im_id))
                depth_mm, metric_mm = depth * cameras[im_id]["depth_scale"], scene.depth_m(im_id) * 1000.0
                kept = (metric_mm > 0) & (metric_mm <= 65535)  # what the 16-bit PNG holds; the rest is 0
                assert np.abs(depth_mm - metric_mm)[kept].max() <= 0.5 + 1e-3 and not depth_mm[~kept].any()
                rgb = inout.load_im(params["rgb_tpath"].format(scene_id=scene.scene_id, im_id=im_id))
                assert rgb.shape == (48, 64, 3)
                assert np.array_equal(rgb, _core.read_image(str(scene.path / "rgb" / f"{im_id:06d}.png")))
