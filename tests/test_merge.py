"""`moonbot merge` end to end on real task directories: a tiny sweep rendered with
moonbot.pipeline.tasks.run_task (a train scene of two stacked bags in two tasks of two views — one
bag occludes the other, one is cut by the image border — and a test scene of one bag), merged into
a BOP dataset and read back with independent decoders (Pillow, PyYAML). Checks the tree, every
JSON field's type and unit, scene_gt_info against counts on the arrays and against the silhouette
rendered on bop_toolkit's whole 3W × 3H canvas, amodal ⊇ visible, YOLO labels, byte-identical
re-merges (copy or hard links, one or two processes), missing, corrupt and stray inputs, and an
interrupted merge."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from PIL import Image

from moonbot import _core
from moonbot.bop import EXIT_INCOMPLETE, MergeError, merge_dataset
from moonbot.cli import main
from moonbot.config import Config, load_config
from moonbot.config.load import from_mapping
from moonbot.pipeline.tasks import run_task
from moonbot.scene import compose_scene
from moonbot.sweep import tasks
from moonbot.yolo.export import write_yolo

from masks import raster

pytestmark = pytest.mark.integration

SWEEP = """
seed: 3
camera: {width: 64, height: 48}
orbit: {views: 2, step_deg: 180.0, radius_m: 0.8}
render: {spp: 1, bounces: 0, light_samples: 1}
terrain: {location: plane}
output: {exr: true}
dust: {cloud: {voxel_m: 0.1}}
meshes:   # coarse meshes: fast to render and to settle
  sandbag_01: {edge_length_m: 0.03, edge_steps: 2}
  sandbag_02: {edge_length_m: 0.03, edge_steps: 2, seam_height_m: 0.003}
  sandbag_03: {edge_length_m: 0.03, edge_steps: 2, size_m: [0.36, 0.2, 0.12], fold_length_m: 0.06}
sweep:
  many_bags_layout: stacked
  splits:
    - name: train
      meshes: [sandbag-01]
      bag_counts: [2]
      sun_elevations_deg: [12.0, 25.0]
    - name: test
      meshes: [sandbag-02]
      bag_counts: [1]
      dust: [true]
"""
TRAIN = "train_pbr/000000"
TEST = "test/000000"  # with dust
VIEWS = {
    TRAIN: "by_condition/train/sandbag-01/plane/scene_000000",
    TEST: "by_condition/test/sandbag-02/plane/scene_000000",
}
W, H = 64, 48


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> tuple[Path, Config]:
    """OUT with the sweep's three tasks rendered, and the sweep config (also as OUT/sweep.yaml)."""
    out = tmp_path_factory.mktemp("out")
    (out / "sweep.yaml").write_text(SWEEP)
    config = load_config(out / "sweep.yaml")
    for task in tasks(config):
        run_task(config, task, out, threads=2)
    return out, config


@pytest.fixture(scope="module")
def dataset(sweep) -> Path:
    out, config = sweep
    report = merge_dataset(out, config=config, workers=1, progress=None, exporters=(write_yolo,))
    assert report.complete and report.scenes == 2 and report.tasks == 3 and report.images == 6
    assert not report.models_reused
    return report.dataset


def task_ids(config: Config) -> list[str]:
    return [t.task_id for t in tasks(config)]


def copy_out(out: Path, dataset: Path, to: Path) -> Path:
    """A copy of OUT's tasks (and of the merged dataset, so models are reused and merges are quick)."""
    shutil.copytree(out / "tasks", to / "tasks")
    shutil.copytree(dataset, to / "dataset")
    return to


def rewrite(task: Path, rel: str, data: bytes) -> None:
    """Replaces a task file and its DONE.json entry: a task that is sound but says something else."""
    import hashlib

    (task / rel).write_bytes(data)
    done = load(task / "DONE.json")
    done["files"][rel] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (task / "DONE.json").write_text(json.dumps(done))


def png(path: Path) -> np.ndarray:
    with Image.open(path) as im:
        return np.array(im)


def load(path: Path):
    return json.loads(path.read_text())


def is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def manifest_files(dataset: Path) -> dict:
    return load(dataset / "manifest.json")["files"]


# --- the tree --------------------------------------------------------------------------------------


def test_tree_is_complete_and_nothing_else(dataset):
    files = sorted(p.relative_to(dataset).as_posix() for p in dataset.rglob("*") if p.is_file())
    assert not [f for f in files if "/." in f or f.startswith(".") or f.endswith(".tmp")]
    expected = {
        "camera.json",
        "dataset_info.json",
        "manifest.json",
        "yolo/detect/data.yaml",
        "yolo/segment/data.yaml",
        "models/models_info.json",
        "models_eval/models_info.json",
        "scene_index.json",
        "scene_index.parquet",
        "test_targets_bop19.json",
    }
    expected |= {f"{d}/obj_{k:06d}.ply" for d in ("models", "models_eval") for k in (1, 2, 3)}
    for scene, images, bags in ((TRAIN, 4, 2), (TEST, 2, 1)):
        expected |= {
            f"{scene}/{name}.json"
            for name in ("scene_gt", "scene_camera", "scene_gt_info", "scene_meta", "scene_gt_coco")
        }
        for im in range(images):
            expected |= {
                f"{scene}/rgb/{im:06d}.png",
                f"{scene}/rgb_exr/{im:06d}.exr",
                f"{scene}/depth/{im:06d}.png",
                f"{scene}/depth_npy/{im:06d}.npy",
                f"{scene}/depth_preview/{im:06d}.png",
                f"{scene}/mask_color/{im:06d}.png",
            }
            expected |= {f"{scene}/{kind}/{im:06d}_{k:06d}.png" for kind in ("mask", "mask_visib") for k in range(bags)}
            split, mesh, location, _ = VIEWS[scene].split("/")[1:]
            name = f"{mesh}_{location}_000000_{im:06d}"
            expected |= {
                f"yolo/{kind}/{sub}/{split}/{name}.{ext}"
                for kind in ("detect", "segment")
                for sub, ext in (("images", "png"), ("labels", "txt"))
            }
    assert set(files) == expected
    # The paper's hierarchy: relative links to the scenes, and nothing else under by_condition/.
    links = sorted(p.relative_to(dataset).as_posix() for p in dataset.rglob("*") if p.is_symlink())
    assert links == sorted(VIEWS.values())
    for scene, view in VIEWS.items():
        assert os.readlink(dataset / view) == "../../../../" + scene
        assert (dataset / view).resolve() == (dataset / scene).resolve()


def test_manifest_lists_every_file_with_its_sha256(dataset):
    import hashlib

    manifest = load(dataset / "manifest.json")
    on_disk = {p.relative_to(dataset).as_posix() for p in dataset.rglob("*") if p.is_file()} - {"manifest.json"}
    assert set(manifest["files"]) == on_disk and manifest["algorithm"] == "sha256"
    assert manifest["file_count"] == len(on_disk)
    for rel, entry in manifest["files"].items():
        data = (dataset / rel).read_bytes()
        assert entry == {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}, rel
    assert manifest["total_bytes"] == sum(e["bytes"] for e in manifest["files"].values())
    assert manifest["links"] == {view: "../../../../" + scene for scene, view in sorted(VIEWS.items())}


def test_images_are_the_task_files_in_sweep_order(sweep, dataset):
    """Image id = task_in_scene × views_per_task + the view's index: the train scene's images 2, 3
    are the second task's (Sun at 25°) views 0 and 1."""
    out, config = sweep
    ids = task_ids(config)
    for im, (task, view) in enumerate([(ids[0], 0), (ids[0], 1), (ids[1], 0), (ids[1], 1)]):
        src = out / "tasks" / task / f"view_{view:03d}"
        dst = dataset / TRAIN
        assert (dst / "rgb" / f"{im:06d}.png").read_bytes() == (src / "rgb.png").read_bytes()
        assert (dst / "depth" / f"{im:06d}.png").read_bytes() == (src / "depth.png").read_bytes()
        assert (dst / "depth_npy" / f"{im:06d}.npy").read_bytes() == (src / "depth.npy").read_bytes()
        assert (dst / "depth_preview" / f"{im:06d}.png").read_bytes() == (src / "depth_preview.png").read_bytes()
        assert (dst / "rgb_exr" / f"{im:06d}.exr").read_bytes() == (src / "rgb.exr").read_bytes()
        for k in range(2):
            amodal = (src / f"amodal_{k + 1:03d}.png").read_bytes()
            assert (dst / "mask" / f"{im:06d}_{k:06d}.png").read_bytes() == amodal
        gt = load(src / "gt.json")
        meta = load(dst / "scene_meta.json")["images"][str(im)]
        assert meta["task_in_scene"] == im // 2 and meta["view"] == view
        assert meta["sun"]["elevation_deg"] == (12.0, 25.0)[im // 2]
        assert meta["camera_azimuth_deg"] == gt["camera_azimuth_deg"] and meta["render_seed"] == gt["render_seed"]


# --- JSON fields: types and units ------------------------------------------------------------------


def test_scene_gt_and_camera_fields(dataset):
    for scene, bags in ((TRAIN, 2), (TEST, 1)):
        gt = load(dataset / scene / "scene_gt.json")
        cam = load(dataset / scene / "scene_camera.json")
        assert list(gt) == list(cam) == [str(i) for i in range(len(gt))]
        for im, instances in gt.items():
            c = cam[im]
            assert set(c) == {"cam_K", "depth_scale", "cam_R_w2c", "cam_t_w2c"}
            K = np.array(c["cam_K"]).reshape(3, 3)
            assert all(is_number(v) for v in c["cam_K"]) and K[0, 2] == W / 2 and K[1, 2] == H / 2 and K[2, 2] == 1
            assert c["depth_scale"] == 1.0
            R_w2c = np.array(c["cam_R_w2c"]).reshape(3, 3)
            np.testing.assert_allclose(R_w2c @ R_w2c.T, np.eye(3), atol=1e-9)
            centre_mm = -R_w2c.T @ np.array(c["cam_t_w2c"])
            # The orbit: 0.8 m from the target horizontally, 0.5 m above it (millimetres).
            assert 700 < np.hypot(*centre_mm[:2]) < 900 and 400 < centre_mm[2] < 900
            assert len(instances) == bags
            for inst in instances:
                assert set(inst) == {"obj_id", "cam_R_m2c", "cam_t_m2c"}
                assert inst["obj_id"] == (1 if scene == TRAIN else 2) and isinstance(inst["obj_id"], int)
                R = np.array(inst["cam_R_m2c"]).reshape(3, 3)
                np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
                assert np.linalg.det(R) > 0
                t = np.array(inst["cam_t_m2c"])
                assert 500 < t[2] < 1500 and np.linalg.norm(t) < 1500  # mm, in front of the camera


def test_poses_project_into_the_boxes(dataset):
    """The model origin (bag centre) projected with cam_K and cam_t_m2c (mm) falls inside the
    instance's bbox_obj: the units of K, t and the boxes agree."""
    for scene in (TRAIN, TEST):
        gt = load(dataset / scene / "scene_gt.json")
        cam = load(dataset / scene / "scene_camera.json")
        info = load(dataset / scene / "scene_gt_info.json")
        for im in gt:
            K = np.array(cam[im]["cam_K"]).reshape(3, 3)
            for inst, entry in zip(gt[im], info[im]):
                u, v, w = K @ np.array(inst["cam_t_m2c"])
                x, y, bw, bh = entry["bbox_obj"]
                assert x <= u / w <= x + bw + 1 and y <= v / w <= y + bh + 1


def test_gt_info_fields_and_scene_meta(dataset):
    for scene in (TRAIN, TEST):
        info = load(dataset / scene / "scene_gt_info.json")
        for entries in info.values():
            for e in entries:
                assert set(e) == {
                    "bbox_obj",
                    "bbox_visib",
                    "px_count_all",
                    "px_count_valid",
                    "px_count_visib",
                    "visib_fract",
                }
                counts = [e[k] for k in ("px_count_all", "px_count_valid", "px_count_visib")]
                assert all(isinstance(c, int) and c >= 0 for c in counts)
                assert isinstance(e["visib_fract"], float) and 0.0 <= e["visib_fract"] <= 1.0
                assert all(isinstance(v, int) for v in e["bbox_obj"] + e["bbox_visib"])
                assert len(e["bbox_obj"]) == len(e["bbox_visib"]) == 4
    meta = load(dataset / TRAIN / "scene_meta.json")
    expected = {
        "split": "train",
        "scene_id": 0,
        "mesh": "sandbag-01",
        "obj_id": 1,
        "location": "plane",
        "bags": 2,
        "stain_seeds": 0,
        "dust": False,
        "tasks_per_scene": 2,
        "views_per_task": 2,
        "bop_split": "train_pbr",
        "scene_dir": TRAIN,
        "view": VIEWS[TRAIN],
    }
    assert {k: meta[k] for k in expected} == expected
    assert isinstance(meta["seed"], int)
    assert meta["instances"] == [{"instance_id": 1, "obj_id": 1}, {"instance_id": 2, "obj_id": 1}]
    assert [
        (t["task_in_scene"], t["sun_elevation_deg"], t["sun_azimuth_deg"], t["camera_height_m"], t["image_ids"])
        for t in meta["tasks"]
    ] == [(0, 12.0, 120.0, 0.5, [0, 1]), (1, 25.0, 120.0, 0.5, [2, 3])]
    assert meta["missing_tasks_in_scene"] == []
    for image in meta["images"].values():
        assert is_number(image["camera_height_m"]) and is_number(image["ev100"])
        assert set(image["sun"]) == {"azimuth_deg", "elevation_deg", "irradiance_w_m2"}
        assert "dust" not in image
    dusty = load(dataset / TEST / "scene_meta.json")
    assert dusty["dust"] is True
    for image in dusty["images"].values():  # each view's dust record: capture time in seconds, ...
        assert is_number(image["dust"]["capture_time_s"]) and isinstance(image["dust"]["note"], str)


def test_dataset_level_files(sweep, dataset):
    out, config = sweep
    camera = load(dataset / "camera.json")
    assert camera == {
        "cx": 32.0,
        "cy": 24.0,
        "depth_scale": 1.0,
        "fx": camera["fx"],
        "fy": camera["fx"],
        "height": H,
        "width": W,
    }
    assert camera["fx"] == pytest.approx((W / 2) / np.tan(np.radians(60.0) / 2))
    info = load(dataset / "dataset_info.json")
    from moonbot.config import config_hash

    assert info["config_hash"] == config_hash(config) and info["seed"] == 3
    assert from_mapping(Config, info["config"]) == config  # the config round-trips
    assert info["complete"] is True and info["missing_tasks"] == [] and info["invalid_tasks"] == {}
    assert info["splits"] == [
        {"name": "train", "scenes": 1, "tasks": 2, "images": 4, "instances": 8},
        {"name": "test", "scenes": 1, "tasks": 1, "images": 2, "instances": 2},
    ]
    assert info["objects"] == {"1": "sandbag-01", "2": "sandbag-02", "3": "sandbag-03"}
    assert info["amodal_outside_visible_px"] == 0 and isinstance(info["moonbot_version"], str)
    models = load(dataset / "models" / "models_info.json")
    assert set(models) == {"1", "2", "3"} and models == load(dataset / "models_eval" / "models_info.json")
    assert 350 < models["1"]["diameter"] < 450  # mm: a 0.32 × 0.20 × 0.12 m bag


# --- gt_info against the arrays ---------------------------------------------------------------------


def box(mask: np.ndarray) -> list[int]:
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return [-1, -1, -1, -1]
    return [int(xs.min()), int(ys.min()), int(xs.max() - xs.min()), int(ys.max() - ys.min())]


def test_gt_info_matches_hand_counts(dataset):
    occluded = truncated = 0
    for scene in (TRAIN, TEST):
        info = load(dataset / scene / "scene_gt_info.json")
        for im, entries in info.items():
            depth = png(dataset / scene / "depth" / f"{int(im):06d}.png")
            npy = np.load(dataset / scene / "depth_npy" / f"{int(im):06d}.npy")
            assert depth.dtype == np.uint16 and npy.dtype == np.float32
            np.testing.assert_array_equal(depth, np.rint(npy.astype(np.float64) * 1000).astype(np.uint16))  # mm
            for k, e in enumerate(entries):
                amodal = png(dataset / scene / "mask" / f"{int(im):06d}_{k:06d}.png")
                visib = png(dataset / scene / "mask_visib" / f"{int(im):06d}_{k:06d}.png")
                assert amodal.dtype == visib.dtype == np.uint8 and amodal.shape == visib.shape == (H, W)
                assert set(np.unique(amodal)) <= {0, 255} and set(np.unique(visib)) <= {0, 255}
                amodal, visib = amodal > 0, visib > 0
                assert not (visib & ~amodal).any()  # amodal ⊇ visible
                assert e["px_count_visib"] == visib.sum()
                assert e["px_count_valid"] == (amodal & (depth > 0)).sum()
                assert e["bbox_visib"] == box(visib)
                assert e["visib_fract"] == pytest.approx(visib.sum() / e["px_count_all"], abs=0)
                assert e["px_count_all"] >= amodal.sum()
                if (
                    e["bbox_obj"][0] >= 0
                    and e["bbox_obj"][0] + e["bbox_obj"][2] < W
                    and e["bbox_obj"][1] >= 0
                    and e["bbox_obj"][1] + e["bbox_obj"][3] < H
                ):
                    assert e["px_count_all"] == amodal.sum() and e["bbox_obj"] == box(amodal)
                else:
                    truncated += 1
                    assert e["px_count_all"] > amodal.sum()
                occluded += int(amodal.sum() > visib.sum())
                # The visible mask is the instance's label in the rendered id mask, shown in mask_color.
                colours = png(dataset / scene / "mask_color" / f"{int(im):06d}.png")
                assert colours.shape == (H, W, 3) and (colours[visib] > 0).any(axis=1).all()
    assert occluded >= 1 and truncated >= 1  # the sweep exercises both


def test_px_count_all_matches_the_whole_canvas(sweep, dataset):
    """Each bag rendered alone over bop_toolkit's entire 3W × 3H canvas (principal point shifted
    by (W, H)) gives exactly px_count_all and bbox_obj — the windows moonbot renders lose nothing."""
    out, config = sweep
    task = out / "tasks" / task_ids(config)[0]
    spec = compose_scene(from_mapping(Config, load(task / "task.json")["config"]))
    info = load(dataset / TRAIN / "scene_gt_info.json")
    cam = load(dataset / TRAIN / "scene_camera.json")
    sun = _core.DirectionalLight(0.0, 90.0, 0.0)
    for im in ("0", "1"):
        K = np.array(cam[im]["cam_K"]).reshape(3, 3)
        R = np.array(cam[im]["cam_R_w2c"]).reshape(3, 3)
        t = np.array(cam[im]["cam_t_w2c"]) / 1000.0
        camera = _core.Camera(K[0, 0], K[1, 1], K[0, 2] + W, K[1, 2] + H, 3 * W, 3 * H, R, t)
        for k, bag in enumerate(spec.bags):
            scene = _core.Scene()
            scene.add_instance(
                scene.add_mesh(*spec.meshes[bag.obj_id]), bag.world_from_model, bag.instance_id, (1.0, 1.0, 1.0)
            )
            scene.commit()
            silhouette = _core.render(scene, camera, sun, passes=["instance"])["instance"] > 0
            e = info[im][k]
            assert e["px_count_all"] == silhouette.sum()
            x, y, bw, bh = box(silhouette)
            if e["px_count_visib"] > 0:
                assert e["bbox_obj"] == [x - W, y - H, bw, bh]
            # ... and its middle third is the amodal mask in the image.
            amodal = png(dataset / TRAIN / "mask" / f"{int(im):06d}_{k:06d}.png") > 0
            np.testing.assert_array_equal(silhouette[H : 2 * H, W : 2 * W], amodal)


# --- YOLO ---------------------------------------------------------------------------------------------


def test_yolo_labels_parse_and_match_the_visible_masks(dataset):
    for kind in ("detect", "segment"):
        data = yaml.safe_load((dataset / "yolo" / kind / "data.yaml").read_text())
        assert "path" not in data  # root = the YAML's directory
        # No val split in this sweep: val is the training images, never the test images.
        assert data["train"] == "images/train" and data["val"] == "images/train" and data["test"] == "images/test"
        assert data["nc"] == len(data["names"]) == 3 and data["names"] == {
            0: "sandbag-01",
            1: "sandbag-02",
            2: "sandbag-03",
        }
        for split in ("train", "test"):
            assert (dataset / "yolo" / kind / data["train" if split == "train" else "test"]).is_dir()
    for scene in (TRAIN, TEST):
        split, mesh, location, _ = VIEWS[scene].split("/")[1:]
        info = load(dataset / scene / "scene_gt_info.json")
        gt = load(dataset / scene / "scene_gt.json")
        for im, entries in info.items():
            name = f"{mesh}_{location}_000000_{int(im):06d}"
            image = dataset / "yolo/detect/images" / split / f"{name}.png"
            assert image.read_bytes() == (dataset / scene / "rgb" / f"{int(im):06d}.png").read_bytes()
            assert os.path.samefile(image, dataset / "yolo/segment/images" / split / f"{name}.png")
            detect = (dataset / "yolo/detect/labels" / split / f"{name}.txt").read_text().splitlines()
            segment = (dataset / "yolo/segment/labels" / split / f"{name}.txt").read_text().splitlines()
            visible = [k for k, e in enumerate(entries) if e["px_count_visib"] > 0]
            assert len(detect) == len(segment) == len(visible)
            for k, d_row, s_row in zip(visible, detect, segment):
                e = entries[k]
                d, s = d_row.split(), s_row.split()
                assert int(d[0]) == int(s[0]) == gt[im][k]["obj_id"] - 1
                assert len(d) == 5 and len(s) >= 7 and len(s) % 2 == 1
                values = [float(v) for v in d[1:] + s[1:]]
                assert all(0.0 <= v <= 1.0 for v in values)
                cx, cy, bw, bh = (float(v) for v in d[1:])
                x, y, w, h = e["bbox_visib"]  # bop_toolkit: w = max - min; YOLO spans pixel edges: w + 1
                assert (cx - bw / 2) * W == pytest.approx(x, abs=1e-4) and bw * W == pytest.approx(w + 1, abs=1e-4)
                assert (cy - bh / 2) * H == pytest.approx(y, abs=1e-4) and bh * H == pytest.approx(h + 1, abs=1e-4)
                ring = np.array([float(v) for v in s[1:]]).reshape(-1, 2) * (W, H)
                assert len(np.unique(ring.round(3), axis=0)) >= 3
                lo, hi = ring.min(axis=0), ring.max(axis=0)
                np.testing.assert_allclose([lo[0], lo[1], hi[0], hi[1]], [x, y, x + w + 1, y + h + 1], atol=1e-4)
                visib = png(dataset / scene / "mask_visib" / f"{int(im):06d}_{k:06d}.png") > 0
                filled = raster(ring, H, W)
                assert (filled & visib).sum() / (filled | visib).sum() > 0.8  # tiny masks, 1 px tolerance


# --- determinism ------------------------------------------------------------------------------------


def test_merge_again_gives_the_same_bytes(sweep, dataset, tmp_path):
    out, config = sweep
    before = (dataset / "manifest.json").read_bytes()
    # In place: models reused.
    report = merge_dataset(out, config=config, workers=1, progress=None, exporters=(write_yolo,))
    assert report.models_reused and (dataset / "manifest.json").read_bytes() == before
    # Elsewhere, hard-linked, two processes: the same bytes.
    other = tmp_path / "linked"
    shutil.copytree(dataset, other)  # as the previous dataset there, so its models are reused
    report = merge_dataset(out, other, config=config, link=True, workers=2, progress=None, exporters=(write_yolo,))
    assert (other / "manifest.json").read_bytes() == before
    rgb = other / TRAIN / "rgb" / "000000.png"
    task_rgb = out / "tasks" / task_ids(config)[0] / "view_000" / "rgb.png"
    assert os.path.samefile(rgb, task_rgb)  # linked, not copied
    for rel in manifest_files(dataset):
        assert (other / rel).read_bytes() == (dataset / rel).read_bytes(), rel


def test_cli_without_config_reads_out_config_json(sweep, dataset, tmp_path):
    """`moonbot merge OUT` takes the sweep's config from OUT/config.json when present: the same
    dataset as with --config."""
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    import dataclasses

    (copy / "config.json").write_text(json.dumps(dataclasses.asdict(config)))
    result = CliRunner().invoke(main, ["merge", str(copy), "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert "merged 3 tasks: 2 scenes, 6 images" in result.output
    assert (copy / "dataset" / "manifest.json").read_bytes() == (dataset / "manifest.json").read_bytes()


# --- incomplete and bad input --------------------------------------------------------------------------


def test_missing_task_is_reported_and_the_rest_merged(sweep, dataset, tmp_path):
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    gone = task_ids(config)[1]
    shutil.rmtree(copy / "tasks" / gone)
    (copy / "tasks" / f".{gone}.abc123.tmp").mkdir()  # an interrupted task's temporary: not a task
    (copy / "tasks" / f".{gone}.abc123.tmp" / "junk").write_text("x")
    result = CliRunner().invoke(main, ["merge", str(copy), "--config", str(out / "sweep.yaml"), "--workers", "1"])
    assert result.exit_code == EXIT_INCOMPLETE, result.output
    assert f"missing: {gone}" in result.output and "incomplete: 1 tasks missing, 0 unusable" in result.output
    merged = copy / "dataset"
    info = load(merged / "dataset_info.json")
    assert info["complete"] is False and info["missing_tasks"] == [gone] and info["invalid_tasks"] == {}
    assert load(merged / TRAIN / "scene_meta.json")["missing_tasks_in_scene"] == [1]
    assert list(load(merged / TRAIN / "scene_gt.json")) == ["0", "1"]  # the first task's images, ids unchanged
    assert (merged / TRAIN / "rgb" / "000001.png").read_bytes() == (dataset / TRAIN / "rgb" / "000001.png").read_bytes()
    assert not (merged / TRAIN / "rgb" / "000002.png").exists()
    assert not any(p.name.startswith(".") for p in merged.rglob("*"))


def test_missing_task_without_config_is_found_from_its_scene(sweep, dataset, tmp_path):
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    shutil.rmtree(copy / "tasks" / task_ids(config)[0])
    (copy / "tasks" / "not-a-task").mkdir()  # no DONE.json: reported, not merged
    report = merge_dataset(copy, workers=1, progress=None, exporters=(write_yolo,))
    assert not report.complete and report.missing == ("train scene 000000 task 0",)
    assert "not-a-task" in report.invalid and "DONE.json" in report.invalid["not-a-task"]
    assert list(load(copy / "dataset" / TRAIN / "scene_gt.json")) == ["2", "3"]
    assert load(copy / "dataset" / "dataset_info.json")["config"] is None


def test_corrupt_task_is_left_out_naming_the_file(sweep, dataset, tmp_path):
    """A task file whose bytes no longer match DONE.json (same size): the task is reported unusable
    with the file named, and its scene is merged from the other task."""
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    bad = task_ids(config)[0]
    path = copy / "tasks" / bad / "view_001" / "rgb.png"
    data = bytearray(path.read_bytes())
    data[-20] ^= 0xFF
    path.write_bytes(bytes(data))
    report = merge_dataset(copy, config=config, workers=1, progress=None, exporters=(write_yolo,))
    assert list(report.invalid) == [bad] and str(path) in report.invalid[bad] and "sha256" in report.invalid[bad]
    assert report.missing == (bad,) and report.images == 4
    assert list(load(copy / "dataset" / TRAIN / "scene_gt.json")) == ["2", "3"]
    assert not (copy / "dataset" / TRAIN / "rgb" / "000000.png").exists()
    assert not (copy / "dataset" / "yolo/detect/labels/train/sandbag-01_plane_000000_000000.txt").exists()


def test_without_exporters_the_dataset_is_the_same_but_for_yolo(sweep, dataset, tmp_path):
    """The BOP dataset does not depend on the YOLO export: merged without it, every other file
    has the same bytes and there is no yolo/; the export reads the merged dataset, so running it
    gives the dataset its yolo/ tree as the merge with it wrote."""
    out, config = sweep
    bare = tmp_path / "bare"
    merge_dataset(out, bare, config=config, workers=1, progress=None)
    assert not (bare / "yolo").exists()
    with_yolo = manifest_files(dataset)
    assert manifest_files(bare) == {rel: entry for rel, entry in with_yolo.items() if not rel.startswith("yolo/")}
    entries = {rel: (entry["bytes"], entry["sha256"]) for rel, entry in manifest_files(bare).items()}
    write_yolo(bare, entries)
    assert {rel: {"bytes": size, "sha256": sha} for rel, (size, sha) in entries.items()} == with_yolo
    for rel in with_yolo:
        assert (bare / rel).read_bytes() == (dataset / rel).read_bytes(), rel


def test_malformed_task_json_names_the_field(sweep, dataset, tmp_path):
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    bad = task_ids(config)[2]
    record = load(copy / "tasks" / bad / "task.json")
    record["scene_id"] = "zero"
    rewrite(copy / "tasks" / bad, "task.json", json.dumps(record).encode())
    report = merge_dataset(copy, workers=1, progress=None, exporters=(write_yolo,))
    assert "task.json: scene_id: must be an integer, got 'zero'" in report.invalid[bad]


def test_contradicting_tasks_stop_the_merge_and_keep_the_dataset(sweep, dataset, tmp_path):
    """Two tasks of one scene that disagree on the scene's bag count are not one dataset: MergeError
    naming both task.json files and the field; the previous dataset is untouched."""
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    bad = task_ids(config)[1]
    record = load(copy / "tasks" / bad / "task.json")
    record["bags"] = 3
    rewrite(copy / "tasks" / bad, "task.json", json.dumps(record).encode())
    with pytest.raises(MergeError, match=r"task\.json: bags: is 3, but .*task\.json of the same scene has 2"):
        merge_dataset(copy, workers=1, progress=None, exporters=(write_yolo,))
    assert (copy / "dataset" / "manifest.json").read_bytes() == (dataset / "manifest.json").read_bytes()


def test_nothing_mergeable_keeps_the_previous_dataset(sweep, dataset, tmp_path):
    """Every task corrupt: the merge fails inside its staging directory, which is removed; the
    previous dataset is left as it was, and the CLI exits 1 naming the files."""
    out, config = sweep
    copy = copy_out(out, dataset, tmp_path / "out")
    for task in (copy / "tasks").iterdir():
        path = task / "view_000" / "gt.json"
        path.write_text(path.read_text().replace('"depth_scale": 1.0', '"depth_scale": 2.0'))
    result = CliRunner().invoke(main, ["merge", str(copy), "--workers", "1"])
    assert result.exit_code == 1 and "no task could be merged" in result.output and "gt.json" in result.output
    assert sorted(p.name for p in copy.iterdir()) == ["dataset", "tasks"]  # no temporaries
    for rel in manifest_files(dataset):
        assert (copy / "dataset" / rel).read_bytes() == (dataset / rel).read_bytes()


def test_no_tasks_is_an_error(tmp_path):
    (tmp_path / "tasks").mkdir()
    result = CliRunner().invoke(main, ["merge", str(tmp_path)])
    assert result.exit_code == 1 and "no complete task to merge" in result.output
    assert not (tmp_path / "dataset").exists()


def test_killed_merge_leaves_no_dataset_and_a_rerun_recovers(sweep, dataset, tmp_path):
    """SIGKILL while the dataset is being staged: no dataset appears (only a hidden temporary);
    the next merge removes the temporary and writes the same bytes as an uninterrupted one."""
    out, config = sweep
    copy = tmp_path / "out"
    shutil.copytree(out / "tasks", copy / "tasks")
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from moonbot.cli import main; main()",
            "merge",
            str(copy),
            "--config",
            str(out / "sweep.yaml"),
            "--workers",
            "1",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60
        while not list(copy.glob(".dataset.*.tmp")) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.005)
        assert proc.poll() is None, "merge finished before it could be interrupted"
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert not (copy / "dataset").exists() and list(copy.glob(".dataset.*.tmp"))
    shutil.copytree(dataset, copy / "dataset")  # a previous dataset, so the rerun reuses its models
    report = merge_dataset(copy, config=config, workers=1, progress=None, exporters=(write_yolo,))
    assert report.complete and not list(copy.glob(".dataset.*"))
    assert (copy / "dataset" / "manifest.json").read_bytes() == (dataset / "manifest.json").read_bytes()
