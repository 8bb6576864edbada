"""Amodal masks (moonbot.render.amodal): each bag rendered alone over the window of bop_toolkit's
3W × 3H canvas it can cover gives exactly what rendering the whole canvas gives — also for bags
cut by the border, off the image, or reaching behind the camera — and contains the bag's visible
pixels in the full scene; run_views writes them and records them in gt.json."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from moonbot import _core
from moonbot.config import load_config
from moonbot.pipeline import run_views
from moonbot.render import build_amodal_scenes, build_scene, render_amodal_masks
from moonbot.render.amodal import canvas_window
from moonbot.scene import compose_scene, intrinsics, orbit_pose

pytestmark = pytest.mark.unit

W, H = 48, 36
SMALL = {
    "camera.width": W,
    "camera.height": H,
    "render.spp": 1,
    "render.bounces": 0,
    "render.light_samples": 1,
    "terrain.location": "plane",
    "bags.count": 4,
    "bags.layout": "scattered",
    "bags.scatter_radius_m": 0.6,
}


@pytest.fixture(scope="module")
def scene():
    config = load_config(None, SMALL)
    spec = compose_scene(config)
    return config, spec, build_scene(spec), build_amodal_scenes(spec)


def poses(spec):
    """Orbit cameras all round, near and far, low and high: bags whole, cut by the border, outside
    the image, and (at 0.15 m) reaching behind the camera."""
    rng = np.random.default_rng(5)
    for k in range(24):
        radius = (0.15, 0.5, 1.0, 2.0)[k % 4]
        yield orbit_pose(spec.target, radius, rng.uniform(0.05, 0.8), rng.uniform(0.0, 360.0))


def test_windows_equal_the_whole_canvas_and_contain_the_visible_part(scene):
    config, spec, full, amodal_scenes = scene
    K = intrinsics(config.camera)
    sun = _core.DirectionalLight(0.0, 90.0, 0.0)
    behind = truncated = occluded = 0
    for pose in poses(spec):
        masks = render_amodal_masks(amodal_scenes, K, pose, W, H)
        assert masks.rays == sum(m.rays for m in masks.masks) > 0
        canvas = _core.Camera(K[0, 0], K[1, 1], K[0, 2] + W, K[1, 2] + H, 3 * W, 3 * H, pose.R, pose.t)
        image = _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], W, H, pose.R, pose.t)
        labels = _core.render(full, image, sun, passes=["instance"])["instance"]
        for bag, m in zip(amodal_scenes.bags, masks.masks):
            alone = _core.render(bag.scene, canvas, sun, passes=["instance"])["instance"] == bag.instance_id
            assert m.px_count_all == alone.sum()
            ys, xs = np.nonzero(alone)
            want = (
                (-1, -1, -1, -1)
                if xs.size == 0
                else (int(xs.min()) - W, int(ys.min()) - H, int(xs.max() - xs.min()), int(ys.max() - ys.min()))
            )
            assert m.bbox_all == want
            np.testing.assert_array_equal(m.mask, alone[H : 2 * H, W : 2 * W])
            visible = labels == bag.instance_id
            assert not (visible & ~m.mask).any()
            window = canvas_window(K, pose, bag.world_from_model, bag.vertices, W, H)
            behind += window == (-W, -H, 2 * W, 2 * H)
            truncated += m.px_count_all > m.mask.sum() > 0
            occluded += m.mask.sum() > visible.sum() > 0
    assert behind and truncated and occluded  # every case was met


def test_run_views_writes_the_masks_and_records_them(tmp_path):
    config = load_config(None, {**SMALL, "bags.count": 2})
    [result] = run_views(config, [3], tmp_path)
    gt = json.loads((result.out_dir / "gt.json").read_text())
    labels = np.array(Image.open(result.out_dir / "mask.png"))
    assert "amodal" in gt["timings_s"] and gt["timings_s"]["amodal"] > 0
    for inst in gt["instances"]:
        assert inst["mask_amodal"] == f"amodal_{inst['instance_id']:03d}.png"
        mask = np.array(Image.open(result.out_dir / inst["mask_amodal"]))
        assert mask.dtype == np.uint8 and mask.shape == (H, W) and set(np.unique(mask)) <= {0, 255}
        visible = labels == inst["instance_id"]
        assert inst["px_count_all"] >= (mask > 0).sum() >= inst["px_count_visib"] == visible.sum()
        assert not ((labels == inst["instance_id"]) & (mask == 0)).any()
        assert isinstance(inst["bbox_all"], list) and len(inst["bbox_all"]) == 4
