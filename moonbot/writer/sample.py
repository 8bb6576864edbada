"""Writes one rendered view as files: rgb.png, depth.npy, depth.png, depth_preview.png, mask.png,
optionally rgb.exr (the linear radiance) and each bag's amodal mask (amodal_NNN.png), and gt.json
(intrinsics, per-instance model-to-camera poses in the BOP convention, the exposure)."""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.atomic_io import atomic_write
from moonbot.records.gt import GT, GtRecord, InstanceRecord, write_gt
from moonbot.render.amodal import AmodalMasks
from moonbot.render.exposure import LUMINOUS_EFFICACY_LM_W, Exposure, tonemap
from moonbot.render.view import RenderedView
from moonbot.scene.compose import BagInstance
from moonbot.scene.orbit import CameraPose

# BOP depth_scale: depth_mm = png_value × DEPTH_SCALE_MM. 1 mm steps, 65.535 m at most.
DEPTH_SCALE_MM = 1.0
# rgb.exr holds the renderer's float32 radiance unchanged: bit-exact, and no ceiling (half floats
# overflow at 65504, below the Sun's disk at 2e7 W/(m²·sr)).
RADIANCE_UNIT = "W/(m^2*sr)"
FLOAT32_MAX = float(np.finfo(np.float32).max)
# Amodal masks: one uint8 PNG per instance, 255 where the bag alone covers the pixel centre, else
# 0 (the BOP mask/ convention, so merge copies the bytes as they are).
AMODAL_FILE = "amodal_{instance_id:03d}.png"


def finite_radiance(rgb: np.ndarray) -> np.ndarray:
    """Radiance (H, W, 3) float32 with every sample finite and >= 0, as rgb.exr stores it: NaN,
    -Inf and negatives become 0, +Inf the largest float32 (the tone map's policy: NaN is no
    light, +Inf the brightest). A new array; the input is not changed."""
    out = np.nan_to_num(rgb, nan=0.0, posinf=FLOAT32_MAX, neginf=0.0)
    np.maximum(out, 0.0, out=out)  # also turns -0.0 into +0.0
    return out


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


def write_sample(
    out_dir: Path,
    view: RenderedView,
    exposure: Exposure,
    K: np.ndarray,
    camera: CameraPose,
    bags: tuple[BagInstance, ...],
    png_compression: int,
    meta: dict,
    timings: dict,
    exr: bool = False,
    amodal: AmodalMasks | None = None,
) -> GtRecord:
    """Encodes and writes one view into `out_dir` (which must exist): rgb.png tone-mapped at
    `exposure`, and with `exr` also rgb.exr (linear float32 radiance, W/(m²·sr), zip at
    `png_compression`'s level; its header has `whiteLuminance` = cd/m² of RGB 1.0,
    moonbot:radianceUnit and moonbot:ev100). Every file is written to a temporary name and renamed into place; gt.json comes last, so its presence marks
    a complete sample. `timings` (seconds per stage so far) is extended with this stage's and
    recorded in gt.json as `timings_s`. gt.json also records the exposure and
    `rgb_invalid_pixels`, the pixels with a NaN, ±Inf or negative channel (0 for a sound render;
    both outputs replace such samples, see finite_radiance). With `amodal` (the bags' masks rendered
    alone, moonbot.render.amodal) each instance also gets AMODAL_FILE (uint8 0/255, image size)
    and, in gt.json, `mask_amodal` (that file's name), `px_count_all` (its silhouette's pixels on
    bop_toolkit's 3W × 3H canvas) and `bbox_all` ([x, y, w, h] of that silhouette, image pixels,
    w = max − min; [-1, -1, -1, -1] when empty). `meta`: the rest of gt.json's fields (moonbot.records.gt),
    from `view` to `site`. Returns the gt.json record."""
    timings = dict(timings)
    start = time.perf_counter()
    rgb8, invalid_pixels = tonemap(view.rgb, exposure)
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
    amodal_by_id = {m.instance_id: m for m in amodal.masks} if amodal is not None else {}
    for m in amodal_by_id.values():
        png = m.mask.astype(np.uint8) * np.uint8(255)
        path = out_dir / AMODAL_FILE.format(instance_id=m.instance_id)
        jobs.append(lambda path=path, png=png: _core.write_image(str(path), png, png_compression))
    if exr:
        # The tone map has counted the invalid pixels already: a sound render is written as is.
        hdr = view.rgb if invalid_pixels == 0 else finite_radiance(view.rgb)
        attributes = {
            "whiteLuminance": LUMINOUS_EFFICACY_LM_W,
            "moonbot:radianceUnit": RADIANCE_UNIT,
            "moonbot:ev100": exposure.ev100,
        }
        jobs.append(lambda: _core.write_image(str(out_dir / "rgb.exr"), hdr, attributes=attributes))
    with ThreadPoolExecutor(max_workers=min(len(jobs), os.cpu_count() or 1)) as pool:
        for future in [pool.submit(job) for job in jobs]:
            future.result()
    timings["encode_write"] = time.perf_counter() - start

    instances = []
    for bag in bags:
        R, t = pose_m2c(camera, bag.world_from_model)
        m = amodal_by_id.get(bag.instance_id)
        instances.append(
            InstanceRecord(
                instance_id=bag.instance_id,
                obj_id=bag.obj_id,
                cam_R_m2c=tuple(R.reshape(-1).tolist()),
                cam_t_m2c=tuple(t.tolist()),
                px_count_visib=int(np.count_nonzero(view.instance == bag.instance_id)),
                mask_amodal=None if m is None else AMODAL_FILE.format(instance_id=m.instance_id),
                px_count_all=None if m is None else m.px_count_all,
                bbox_all=None if m is None else tuple(m.bbox_all),
            )
        )
    exr_record = (
        {
            "file": "rgb.exr",
            "unit": RADIANCE_UNIT,
            "sample_type": "float32",
            "compression": f"zip:{png_compression}",
            "white_luminance_cd_m2": LUMINOUS_EFFICACY_LM_W,
        }
        if exr
        else None
    )
    gt = GtRecord(
        cam_K=tuple(K.reshape(-1).tolist()),
        width=int(view.depth.shape[1]),
        height=int(view.depth.shape[0]),
        depth_scale=DEPTH_SCALE_MM,
        cam_R_w2c=tuple(camera.R.reshape(-1).tolist()),
        cam_t_w2c=tuple((camera.t * 1000.0).tolist()),
        instances=tuple(instances),
        exposure=exposure.metadata(),
        rgb_invalid_pixels=invalid_pixels,
        rgb_exr=exr_record,
        **meta,
        timings_s=timings,
    )
    write_gt(out_dir / GT, gt)
    return gt


def _save_npy_atomic(path: Path, array: np.ndarray) -> None:
    atomic_write(path, "wb", lambda f: np.save(f, array))
