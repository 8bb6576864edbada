"""moonbot.export on a merged smoke dataset (test_merge's sweep: a train scene of two stacked bags
in two tasks of two views, one bag occluding the other and one cut by the image border, and a
test scene of one bag), read back with independent tools: pycocotools loads every COCO file and
decodes its masks to the mask_visib pixels exactly, with boxes from the amodal masks; the
`webdataset` package reads the shards back to the BOP files' bytes and values. Where bop_toolkit
is importable, its own calc_gt_coco functions rebuild scene_gt_coco.json byte for byte."""

from __future__ import annotations

import gc
import hashlib
import json
import shutil
import subprocess
import sys
import tarfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO

from moonbot.bop import merge_dataset
from moonbot.bop.coco import SCENE_COCO, scene_coco
from moonbot.bop.reader import DatasetError
from moonbot.bop.rle import encode_rle
from moonbot.bop.toolkit_json import dumps_toolkit_json
from moonbot.cli import main
from moonbot.config import load_config
from moonbot.export import dataset_scenes, write_shards, write_split_cocos
from moonbot.export.coco import IMAGE_ID_STRIDE
from moonbot.pipeline.tasks import run_task
from moonbot.sweep import tasks

from test_merge import SWEEP

# pycocotools' compiled decoder (2.0.11) calls a NumPy-1 style __array__ that NumPy 2 warns about.
pytestmark = [
    pytest.mark.integration,
    pytest.mark.filterwarnings("ignore:__array__ implementation doesn't accept a copy keyword:DeprecationWarning"),
]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("out")
    (out / "sweep.yaml").write_text(SWEEP)
    config = load_config(out / "sweep.yaml")
    for task in tasks(config):
        run_task(config, task, out, threads=2)
    report = merge_dataset(out, config=config, workers=1, progress=None)
    assert report.complete and report.images == 6
    return report.dataset


def load(path: Path):
    return json.loads(path.read_text())


def png(path: Path) -> np.ndarray:
    with Image.open(path) as im:
        return np.array(im)


def decode(rle: dict) -> np.ndarray:
    """pycocotools' decoding of an uncompressed RLE, (H, W) bool."""
    height, width = rle["size"]
    return mask_utils.decode(mask_utils.frPyObjects(rle, height, width)).astype(bool)


def box_of(mask: np.ndarray) -> list[int]:
    """[x, y, w, h] spanning the set pixels, both ends included (the oracle for COCO's bbox)."""
    ys, xs = np.nonzero(mask)
    return [int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)]


def instances(scene: Path):
    """(im_id, k, obj_id, visib_fract, visible mask, amodal mask) of every instance of a scene, from
    its BOP files through Pillow."""
    gt, info = load(scene / "scene_gt.json"), load(scene / "scene_gt_info.json")
    for im, entries in gt.items():
        for k, entry in enumerate(entries):
            name = f"{int(im):06d}_{k:06d}.png"
            yield (
                int(im),
                k,
                entry["obj_id"],
                info[im][k]["visib_fract"],
                png(scene / "mask_visib" / name) > 0,
                png(scene / "mask" / name) > 0,
            )


# ---------------------------------------------------------------------------------------------
# RLE and the toolkit's JSON layout


def test_the_package_imports_first_or_after_moonbot_bop():
    for first in ("moonbot.export", "moonbot.bop"):
        run = subprocess.run(
            [sys.executable, "-c", f"import {first}, moonbot.export, moonbot.bop"], capture_output=True, text=True
        )
        assert run.returncode == 0, run.stderr


def test_rle_of_a_small_mask_by_hand():
    # Column-major: column 0 is (1, 1), column 1 is (0, 1) -> 1 1 0 1: no 0s, two 1s, one 0, one 1.
    assert encode_rle(np.array([[1, 0], [1, 1]], np.uint8)) == {"counts": [0, 2, 1, 1], "size": [2, 2]}
    assert encode_rle(np.zeros((3, 5), bool)) == {"counts": [15], "size": [3, 5]}
    assert encode_rle(np.full((3, 5), 255, np.uint8)) == {"counts": [0, 15], "size": [3, 5]}
    with pytest.raises(ValueError, match="shape"):
        encode_rle(np.zeros((2, 2, 2)))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 9), st.integers(1, 9), st.data())
def test_rle_decodes_with_pycocotools(height, width, data):
    mask = np.array(data.draw(st.lists(st.booleans(), min_size=height * width, max_size=height * width)), bool).reshape(
        height, width
    )
    rle = encode_rle(mask)
    assert sum(rle["counts"]) == height * width
    assert all(c > 0 for c in rle["counts"][1:])
    assert np.array_equal(decode(rle), mask)
    # pycocotools' own encoder, decoded, agrees.
    assert np.array_equal(decode(rle), mask_utils.decode(mask_utils.encode(np.asfortranarray(mask, np.uint8))) > 0)


def test_toolkit_json_layout():
    assert (
        dumps_toolkit_json({"b": [1, 2], "a": {"y": 1, "x": 0.5}}) == b'{\n  "a": {"x": 0.5, "y": 1},\n  "b": [1, 2]\n}'
    )
    assert dumps_toolkit_json([{"b": 1, "a": 2}, []]) == b'[\n  {"a": 2, "b": 1},\n  []\n]'
    assert dumps_toolkit_json({10: 0, 2: 1}) == b'{\n  "2": 1,\n  "10": 0\n}'  # int keys: numeric order
    assert dumps_toolkit_json({}) == b"{\n}"


# ---------------------------------------------------------------------------------------------
# scene_gt_coco.json, written by merge


def test_scene_gt_coco_is_in_every_scene_and_the_manifest(dataset):
    manifest = load(dataset / "manifest.json")["files"]
    found = dataset_scenes(dataset)
    assert {s.split for s in found} == {"train", "test"}
    for scene in found:
        path = scene.path / SCENE_COCO
        rel = path.relative_to(dataset).as_posix()
        assert manifest[rel]["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
        text = path.read_text()
        assert text.startswith('{\n  "annotations": [') and text.endswith("\n}")  # bop_toolkit's save_json


def test_scene_gt_coco_loads_in_pycocotools_and_matches_the_masks(dataset):
    occluded = cut = 0
    for scene in dataset_scenes(dataset):
        coco = COCO(str(scene.path / SCENE_COCO))
        data = load(scene.path / SCENE_COCO)
        assert data["categories"] == [{"id": i, "name": str(i), "supercategory": "moonbot"} for i in (1, 2, 3)]
        assert data["info"]["description"] == f"moonbot_{scene.split}" and data["licenses"] == []
        assert sorted(coco.getImgIds()) == sorted(int(im) for im in load(scene.path / "scene_gt.json"))
        for image in data["images"]:
            assert (scene.path / image["file_name"]).is_file() and image["file_name"].startswith("rgb/")
            assert (image["width"], image["height"]) == (64, 48)
        annotations = iter(data["annotations"])
        expected_id = 1
        for im, _, obj_id, visib_fract, visible, amodal in instances(scene.path):
            if not visible.any():
                continue
            ann = next(annotations)
            assert (ann["id"], ann["image_id"], ann["category_id"]) == (expected_id, im, obj_id)
            expected_id += 1
            assert np.array_equal(coco.annToMask(coco.anns[ann["id"]]) > 0, visible)
            assert ann["area"] == int(visible.sum()) and ann["iscrowd"] == 0
            assert ann["bbox"] == box_of(amodal)
            assert ann["ignore"] == (visib_fract < 0.1)
            occluded += int(visible.sum() < amodal.sum())
            cut += int(amodal[:, 0].any() or amodal[:, -1].any() or amodal[0].any() or amodal[-1].any())
        assert next(annotations, None) is None
    assert occluded and cut  # the smoke scenes exercise occlusion and the image border


def test_scene_coco_on_a_hand_made_scene(tmp_path):
    """calc_gt_coco's rules where the smoke scenes do not reach them: an instance under 10 %
    visible is `ignore`, one with no visible pixel has no annotation and takes no id, a mask with
    its first pixel set starts its RLE with a 0 run, a JPEG rgb is named as it is."""

    scene = tmp_path / "000007"
    for sub in ("rgb", "mask", "mask_visib"):
        (scene / sub).mkdir(parents=True)
    visible = np.zeros((4, 5), np.uint8)
    visible[0:2, 0] = 255  # column 0, rows 0-1: RLE 0, 2, 18
    amodal = visible.copy()
    amodal[0:3, 0:4] = 255  # x 0-3, y 0-2: bbox [0, 0, 4, 3]
    Image.fromarray(visible).save(scene / "mask_visib" / "000000_000000.png")
    Image.fromarray(amodal).save(scene / "mask" / "000000_000000.png")
    Image.fromarray(np.zeros((4, 5), np.uint8)).save(scene / "mask_visib" / "000000_000001.png")
    Image.fromarray(amodal).save(scene / "mask" / "000000_000001.png")
    Image.fromarray(amodal).save(scene / "mask_visib" / "000003_000000.png")
    Image.fromarray(amodal).save(scene / "mask" / "000003_000000.png")
    (scene / "rgb" / "000000.png").write_bytes(b"")
    (scene / "rgb" / "000003.jpg").write_bytes(b"")
    pose = {"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 500]}
    (scene / "scene_gt.json").write_text(
        json.dumps({"0": [{"obj_id": 2, **pose}, {"obj_id": 1, **pose}], "3": [{"obj_id": 1, **pose}]})
    )
    (scene / "scene_gt_info.json").write_text(
        json.dumps({"0": [{"visib_fract": 0.05}, {"visib_fract": 0.0}], "3": [{"visib_fract": 1.0}]})
    )
    coco = scene_coco(scene, "lunar", "train_pbr", [1, 2], (5, 4))
    assert coco["info"]["description"] == "lunar_train" and coco["categories"][1]["supercategory"] == "lunar"
    assert [(i["id"], i["file_name"]) for i in coco["images"]] == [(0, "rgb/000000.png"), (3, "rgb/000003.jpg")]
    first, second = coco["annotations"]
    assert first == {
        "id": 1,
        "image_id": 0,
        "category_id": 2,
        "iscrowd": 0,
        "area": 2,
        "bbox": [0, 0, 4, 3],
        "segmentation": {"counts": [0, 2, 18], "size": [4, 5]},
        "width": 5,
        "height": 4,
        "ignore": True,
    }
    assert (second["id"], second["image_id"], second["category_id"], second["area"], second["ignore"]) == (
        2,
        3,
        1,
        12,
        False,
    )
    (scene / "mask" / "000003_000000.png").unlink()
    with pytest.raises(DatasetError, match="000003_000000.png: missing"):
        scene_coco(scene, "lunar", "train_pbr", [1, 2], (5, 4))
    with pytest.raises(DatasetError, match="4, 5"):
        scene_coco(scene, "lunar", "train_pbr", [1, 2], (6, 4))


# ---------------------------------------------------------------------------------------------
# One COCO file per split


def test_split_coco_files_load_and_decode_to_mask_visib(dataset, tmp_path):
    result = CliRunner().invoke(main, ["export", "coco", str(dataset), "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["instances_test.json", "instances_train.json"]
    for split in ("train", "test"):
        coco = COCO(str(tmp_path / f"instances_{split}.json"))
        scenes = [s for s in dataset_scenes(dataset) if s.split == split]
        scene_anns = sum(len(load(s.path / SCENE_COCO)["annotations"]) for s in scenes)
        assert len(coco.anns) == scene_anns and sorted(coco.anns) == list(range(1, scene_anns + 1))
        checked = 0
        for scene in scenes:
            for im, _, obj_id, _, visible, amodal in instances(scene.path):
                image_id = scene.scene_id * IMAGE_ID_STRIDE + im
                image = coco.imgs[image_id]
                assert (image["scene_id"], image["im_id"]) == (scene.scene_id, im)
                assert (dataset / image["file_name"]).samefile(scene.path / "rgb" / f"{im:06d}.png")
                if not visible.any():
                    continue
                anns = coco.loadAnns(coco.getAnnIds(imgIds=[image_id]))
                matches = [a for a in anns if np.array_equal(coco.annToMask(a) > 0, visible)]
                assert len(matches) == 1 and matches[0]["category_id"] == obj_id
                assert matches[0]["bbox"] == box_of(amodal)
                checked += 1
        assert checked == scene_anns


# ---------------------------------------------------------------------------------------------
# Webdataset shards


def read_shards(folder: Path) -> list[tuple[str, dict]]:
    """(shard file name, sample) in reading order, through the webdataset package."""
    import webdataset as wds

    urls = sorted(str(p) for p in folder.glob("shard-*.tar"))
    with warnings.catch_warnings():
        # webdataset leaves the local shard files it opened to the garbage collector to close.
        warnings.simplefilter("ignore", ResourceWarning)
        samples = [(Path(s["__url__"]).name, s) for s in wds.WebDataset(urls, shardshuffle=False, empty_check=False)]
        gc.collect()
    return samples


def test_shards_read_back_with_webdataset_match_the_bop_files(dataset, tmp_path):
    result = CliRunner().invoke(main, ["export", "shards", str(dataset), "--out", str(tmp_path), "--shard-size", "3"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["test_web", "train_web"]
    expected_shards = {"train_web": ["shard-000000.tar", "shard-000001.tar"], "test_web": ["shard-000000.tar"]}
    for split, folder in (("train", tmp_path / "train_web"), ("test", tmp_path / "test_web")):
        assert sorted(p.name for p in folder.iterdir()) == sorted(expected_shards[folder.name] + ["key_to_shard.json"])
        samples = read_shards(folder)
        key_to_shard = load(folder / "key_to_shard.json")
        scenes = {s.scene_id: s for s in dataset_scenes(dataset) if s.split == split}
        expected_keys = [
            f"{sid:06d}_{int(im):06d}" for sid, s in sorted(scenes.items()) for im in load(s.path / "scene_gt.json")
        ]
        assert [s["__key__"] for _, s in samples] == expected_keys  # dataset order, 3 to a shard
        assert sorted(key_to_shard) == sorted(expected_keys)
        for position, (shard, sample) in enumerate(samples):
            assert shard == f"shard-{position // 3:06d}.tar" and key_to_shard[sample["__key__"]] == position // 3
            assert set(sample) - {"__key__", "__url__", "__local_path__"} == {
                "camera.json",
                "depth.png",
                "gt.json",
                "gt_info.json",
                "mask.json",
                "mask_visib.json",
                "rgb.png",
            }
            scene_id, im = (int(x) for x in sample["__key__"].split("_"))
            scene = scenes[scene_id].path
            assert sample["rgb.png"] == (scene / "rgb" / f"{im:06d}.png").read_bytes()
            assert sample["depth.png"] == (scene / "depth" / f"{im:06d}.png").read_bytes()
            assert json.loads(sample["gt.json"]) == load(scene / "scene_gt.json")[str(im)]
            assert json.loads(sample["gt_info.json"]) == load(scene / "scene_gt_info.json")[str(im)]
            assert json.loads(sample["camera.json"]) == load(scene / "scene_camera.json")[str(im)]
            n = len(load(scene / "scene_gt.json")[str(im)])
            for field, folder_name in (("mask.json", "mask"), ("mask_visib.json", "mask_visib")):
                masks = json.loads(sample[field])
                assert sorted(masks, key=int) == [str(k) for k in range(n)]
                for k in range(n):
                    truth = png(scene / folder_name / f"{im:06d}_{k:06d}.png") > 0
                    assert np.array_equal(decode(masks[str(k)]), truth)


def test_shards_are_deterministic_bytes(dataset, tmp_path):
    a = write_shards(dataset, tmp_path / "a", shard_size=2)
    write_shards(dataset, tmp_path / "b", shard_size=2)
    assert [(s.split, s.images, s.shards) for s in a] == [("test", 2, 1), ("train", 4, 2)]
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*") if p.is_file())
    for rel in files:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    with tarfile.open(tmp_path / "a" / "train_web" / "shard-000000.tar") as tar:
        members = tar.getmembers()
    assert [m.name for m in members[:7]] == [
        f"000000_000000.{f}"
        for f in ("camera.json", "depth.png", "gt.json", "gt_info.json", "mask.json", "mask_visib.json", "rgb.png")
    ]
    assert all(
        (m.mtime, m.uid, m.gid, m.uname, m.gname, m.mode, m.isreg()) == (0, 0, 0, "", "", 0o444, True) for m in members
    )


def test_shuffled_shards_hold_the_same_images_in_a_seeded_order(dataset, tmp_path):
    write_shards(dataset, tmp_path / "plain", shard_size=3)
    write_shards(dataset, tmp_path / "s1", shard_size=3, shuffle_seed=1)
    write_shards(dataset, tmp_path / "s1again", shard_size=3, shuffle_seed=1)
    plain = [s["__key__"] for _, s in read_shards(tmp_path / "plain" / "train_web")]
    shuffled = [s["__key__"] for _, s in read_shards(tmp_path / "s1" / "train_web")]
    assert sorted(shuffled) == plain
    assert shuffled == [plain[k] for k in np.random.RandomState(1).permutation(len(plain))]
    assert (tmp_path / "s1" / "train_web" / "shard-000000.tar").read_bytes() == (
        tmp_path / "s1again" / "train_web" / "shard-000000.tar"
    ).read_bytes()


# ---------------------------------------------------------------------------------------------
# Bad input


def test_a_missing_mask_is_named_and_nothing_half_written(dataset, tmp_path):
    copy = tmp_path / "dataset"
    shutil.copytree(dataset, copy)
    write_shards(copy, tmp_path / "shards", shard_size=3)
    before = (tmp_path / "shards" / "train_web" / "shard-000000.tar").read_bytes()
    scene = next(s for s in dataset_scenes(copy) if s.split == "train")
    missing = scene.path / "mask_visib" / "000001_000000.png"
    missing.unlink()
    with pytest.raises(DatasetError, match=str(missing)):
        write_split_cocos(copy, tmp_path / "coco")
    assert not (tmp_path / "coco" / "instances_train.json").exists()
    result = CliRunner().invoke(main, ["export", "shards", str(copy), "--out", str(tmp_path / "shards")])
    assert result.exit_code == 1 and str(missing) in result.output
    assert (tmp_path / "shards" / "train_web" / "shard-000000.tar").read_bytes() == before  # the previous shards
    assert sorted(p.name for p in (tmp_path / "shards").iterdir()) == ["test_web", "train_web"]  # no temporaries


def test_bad_arguments_are_refused(dataset, tmp_path):
    result = CliRunner().invoke(main, ["export", "shards", str(dataset), "--out", str(tmp_path), "--shard-size", "0"])
    assert result.exit_code == 2 and "--shard-size" in result.output
    (tmp_path / "empty").mkdir()
    result = CliRunner().invoke(main, ["export", "coco", str(tmp_path / "empty"), "--out", str(tmp_path / "c")])
    assert result.exit_code == 1 and str(tmp_path / "empty") in result.output


# ---------------------------------------------------------------------------------------------
# bop_toolkit's own calc_gt_coco functions, where bop_toolkit is installed


def test_scene_gt_coco_is_what_bop_toolkit_computes(dataset, tmp_path):
    pycoco_utils = pytest.importorskip("bop_toolkit_lib.pycoco_utils")
    inout = pytest.importorskip("bop_toolkit_lib.inout")
    for scene in dataset_scenes(dataset):
        ours = load(scene.path / SCENE_COCO)
        # calc_gt_coco's loop (--use_all_gt, amodal boxes), on bop_toolkit's loaders.
        scene_gt = inout.load_scene_gt(str(scene.path / "scene_gt.json"))
        scene_gt_info = inout.load_json(str(scene.path / "scene_gt_info.json"), keys_to_int=True)
        output = {
            "info": ours["info"],
            "licenses": [],
            "categories": ours["categories"],
            "images": [],
            "annotations": [],
        }
        segmentation_id = 1
        for im_id, inst_list in scene_gt.items():
            image = pycoco_utils.create_image_info(im_id, f"rgb/{im_id:06d}.png", (64, 48))
            image["date_captured"] = "1970-01-01 00:00:00"  # calc_gt_coco writes the time of writing here
            output["images"].append(image)
            for idx, inst in enumerate(inst_list):
                name = f"{im_id:06d}_{idx:06d}.png"
                visible = inout.load_depth(str(scene.path / "mask_visib" / name)).astype(bool)
                if visible.sum() < 1:
                    continue
                full = inout.load_depth(str(scene.path / "mask" / name)).astype(bool)
                if full.sum() < 1:
                    continue
                annotation = pycoco_utils.create_annotation_info(
                    segmentation_id,
                    im_id,
                    inst["obj_id"],
                    visible,
                    pycoco_utils.bbox_from_binary_mask(full),
                    tolerance=2,
                    ignore=scene_gt_info[im_id][idx]["visib_fract"] < 0.1,
                )
                output["annotations"].append(annotation)
                segmentation_id += 1
        path = tmp_path / f"{scene.split}_{scene.scene_id}.json"
        inout.save_json(str(path), output)
        assert path.read_bytes() == (scene.path / SCENE_COCO).read_bytes()


def test_shards_load_with_bop_toolkits_reader(dataset, tmp_path):
    bop_webdataset = pytest.importorskip("bop_toolkit_lib.dataset.bop_webdataset")
    write_shards(dataset, tmp_path, shard_size=4)
    for scene in dataset_scenes(dataset):
        folder = tmp_path / f"{scene.split}_web"
        key_to_shard = load(folder / "key_to_shard.json")
        for im, k, obj_id, _, visible, amodal in instances(scene.path):
            key = f"{scene.scene_id:06d}_{im:06d}"
            data = bop_webdataset.load_image_data(
                folder / f"shard-{key_to_shard[key]:06d}.tar",
                key,
                load_mask=True,
                load_gt=True,
                load_gt_info=True,
                rgb_suffix=".png",
            )
            assert np.array_equal(data["im_rgb"], png(scene.path / "rgb" / f"{im:06d}.png"))
            assert data["gt"][k]["obj_id"] == obj_id
            assert np.array_equal(data["mask_visib"][k].astype(bool), visible)
            assert np.array_equal(data["mask"][k].astype(bool), amodal)
