"""Writes one rendered view as files: rgb.png, depth.npy, depth.png, depth_preview.png, mask.png
and gt.json (intrinsics, per-instance model-to-camera poses in the BOP convention)."""

from __future__ import annotations

import json
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.render.view import RenderedView
from moonbot.scene.compose import BagInstance
from moonbot.scene.orbit import CameraPose
from moonbot.writer.staging import atomic_write

# BOP depth_scale: depth_mm = png_value × DEPTH_SCALE_MM. 1 mm steps, 65.535 m at most.
DEPTH_SCALE_MM = 1.0


def depth_to_png16(depth_m: np.ndarray) -> np.ndarray:
    """z-depth (H, W) float32 metres → (H, W) uint16 in units of DEPTH_SCALE_MM. 0 stays invalid;
    depths that do not fit (beyond 65.535 m at 1 mm) and non-finite values become 0, never wrap."""
    steps = np.rint(np.asarray(depth_m, dtype=np.float64) * (1000.0 / DEPTH_SCALE_MM))
    valid = np.isfinite(steps) & (steps > 0) & (steps <= np.iinfo(np.uint16).max)
    return np.where(valid, steps, 0).astype(np.uint16)


def depth_preview(depth_m: np.ndarray) -> np.ndarray:
    """8-bit picture of depth for people: inverse depth stretched between the 1st and 99th
    percentile of valid pixels, near = bright; 0 where depth is invalid. (H, W) uint8."""
    valid = np.isfinite(depth_m) & (depth_m > 0)
    out = np.zeros(depth_m.shape, dtype=np.uint8)
    if not valid.any():
        return out
    inv = 1.0 / depth_m[valid].astype(np.float64)
    lo, hi = np.percentile(inv, [1.0, 99.0])
    scale = 254.0 / (hi - lo) if hi > lo else 0.0
    out[valid] = (1.0 + np.clip((inv - lo) * scale, 0.0, 254.0)).astype(np.uint8)
    return out


def pose_m2c(camera: CameraPose, world_from_model: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Model-to-camera pose: (R (3, 3), t (3,) millimetres), x_cam = R x_model + t (BOP)."""
    R = camera.R @ world_from_model[:3, :3]
    t_m = camera.R @ world_from_model[:3, 3] + camera.t
    return R, t_m * 1000.0


def write_sample(out_dir: Path, view: RenderedView, exposure: float, K: np.ndarray,
                 camera: CameraPose, bags: tuple[BagInstance, ...], png_compression: int,
                 meta: dict, timings: dict) -> dict:
    """Encodes and writes one view into `out_dir` (which must exist). Every file is written to a
    temporary name and renamed into place; gt.json comes last, so its presence marks a complete
    sample. `timings` (seconds per stage so far) is extended with this stage's and recorded in
    gt.json as `timings_s`. Returns the gt.json content."""
    timings = dict(timings)
    start = time.perf_counter()
    rgb8 = _core.tonemap_reinhard(view.rgb, exposure)
    timings["tonemap"] = time.perf_counter() - start

    start = time.perf_counter()
    # The encoders release the GIL, so the files are written side by side; gt.json waits for all
    # of them and the first failure (a full disk, say) is raised here.
    jobs = [
        lambda: _core.write_image(str(out_dir / "rgb.png"), rgb8, png_compression),
        lambda: _core.write_image(str(out_dir / "depth.png"), depth_to_png16(view.depth), png_compression),
        lambda: _core.write_image(str(out_dir / "depth_preview.png"), depth_preview(view.depth), png_compression),
        lambda: _core.write_image(str(out_dir / "mask.png"), view.instance, png_compression),
        lambda: _save_npy_atomic(out_dir / "depth.npy", view.depth),
    ]
    with ThreadPoolExecutor(max_workers=min(len(jobs), os.cpu_count() or 1)) as pool:
        for future in [pool.submit(job) for job in jobs]:
            future.result()
    timings["encode_write"] = time.perf_counter() - start

    instances = []
    for bag in bags:
        R, t = pose_m2c(camera, bag.world_from_model)
        instances.append({
            "instance_id": bag.instance_id,
            "obj_id": bag.obj_id,
            "cam_R_m2c": R.reshape(-1).tolist(),
            "cam_t_m2c": t.tolist(),
            "px_count_visib": int(np.count_nonzero(view.instance == bag.instance_id)),
        })
    gt = {
        "cam_K": K.reshape(-1).tolist(),
        "width": int(view.depth.shape[1]),
        "height": int(view.depth.shape[0]),
        "depth_scale": DEPTH_SCALE_MM,
        "cam_R_w2c": camera.R.reshape(-1).tolist(),
        "cam_t_w2c": (camera.t * 1000.0).tolist(),
        "instances": instances,
        **meta,
        "timings_s": timings,
    }
    _write_text_atomic(out_dir / "gt.json", json.dumps(gt, indent=2) + "\n")
    return gt


def _save_npy_atomic(path: Path, array: np.ndarray) -> None:
    atomic_write(path, "wb", lambda f: np.save(f, array))


def _write_text_atomic(path: Path, text: str) -> None:
    atomic_write(path, "w", lambda f: f.write(text))
