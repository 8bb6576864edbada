"""What the dust medium's knobs cost: the grid spacing `voxel_m` (the
dust is baked on it per view and camera rays march it in steps of it) and the march's pixel
stride `march_stride_px` (every S-th pixel's ray marches, the others interpolate) against the
error they leave in the image, and the cloud's puff rate against time.

Scene: the default flat location with its bag, the paper's dust cloud beside the target at the
default capture time (warm-up 6 s, the plume in steady state), seen from orbit view 0 at the
default 640×480, Sun 12° from azimuth 120°, a point so that nothing but the dust is sampled
(1 spp, direct light: the march is deterministic, so the image differs only by the dust). Each
spacing is compared with the finest grid the core allows (kMaxGridNodes nodes along the box's
longest side): the RMS, the 99th percentile and the mean (bias) of the per-pixel difference,
relative to the mean radiance of the dust-free image; seconds are the median of `--repeats`
renders, next to the dust-free render's. The spacings march every pixel (stride 1); the strides
run at the default 0.05 m spacing and are compared with the same reference and with stride 1.

Writes bench/results/medium-<machine>.json and .svg. Run:
  .venv/bin/python bench/bench_medium.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene
from moonbot.render.view import core_camera
from moonbot.scene import compose_scene, intrinsics, orbit_pose

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result_and_chart
from timing import timed

SCHEMA_VERSION = 3  # 2: a point Sun and the midpoint march (no noise columns); 3: strides
VOXELS = [0.4, 0.2, 0.1, 0.05, 0.025]
REFERENCE_VOXEL = 0.001  # clamped by the core to the box's longest side / (kMaxGridNodes - 1)
RATES = [10.0, 20.0, 40.0, 80.0, 160.0]
STRIDES = [1, 2, 4, 8]
CAPTURE_S = 6.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    config = load_config(None, {"terrain.location": "flat"})
    spec = compose_scene(config)
    scene = build_scene(spec)
    origin = spec.target + np.array([0.5, 0.3, 0.0])  # beside the target, as a rover would stir it
    origin[2] = float(spec.ground.height(origin[0], origin[1]))
    K = intrinsics(config.camera)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)
    camera = core_camera(K, config.camera.width, config.camera.height, pose)
    sun = _core.DirectionalLight(config.sun.azimuth_deg, config.sun.elevation_deg, config.sun.irradiance_w_m2, 0.0)

    def render(medium):
        return _core.render(scene, camera, sun, _core.RenderSettings(spp=1, seed=1), passes=["rgb"], medium=medium)

    def medium(voxel, rate=40.0, stride=1):
        puffs = _core.cloud_puffs(_core.CloudParams(origin=origin, rate_per_s=rate), 1, CAPTURE_S)
        return _core.Medium(puffs, voxel_m=voxel, floor_z=origin[2] - 1.0, march_stride_px=stride)

    clear, clear_s = timed(lambda: render(None), args.repeats)
    scale = float(clear["rgb"].mean())
    reference = render(medium(REFERENCE_VOXEL))
    result = {
        "schema_version": SCHEMA_VERSION,
        "machine": machine(),
        "capture_s": CAPTURE_S,
        "clear_seconds": clear_s,
        "reference_voxel_m": REFERENCE_VOXEL,
        "reference_medium_rays": reference["medium_rays"],
        "voxels": [],
        "strides": [],
        "rates": [],
    }
    print(f"dust-free render {1e3 * clear_s:.0f} ms; reference grid: {reference['medium_rays']} shadow rays")
    print(f"{'voxel m':>8} {'ms/view':>8} {'rms rel':>9} {'p99 rel':>9} {'bias':>9} {'shadow rays':>12}")
    for voxel in VOXELS:
        out, s = timed(lambda: render(medium(voxel)), args.repeats)
        diff = np.abs(out["rgb"] - reference["rgb"]) / scale
        row = {
            "voxel_m": voxel,
            "seconds_per_view": s,
            "rms_relative_error": float(np.sqrt((diff**2).mean())),
            "p99_relative_error": float(np.percentile(diff, 99)),
            "bias_relative": float((out["rgb"] - reference["rgb"]).mean() / scale),
            "medium_rays": out["medium_rays"],
        }
        result["voxels"].append(row)
        print(
            f"{voxel:>8} {1e3 * s:>8.0f} {row['rms_relative_error']:>9.2e} {row['p99_relative_error']:>9.2e} "
            f"{row['bias_relative']:>9.2e} {row['medium_rays']:>12}"
        )
    print(
        f"\n{'stride':>7} {'ms/view':>8} {'rms rel':>9} {'p99 rel':>9} {'rms vs 1':>9} {'max vs 1':>9}  (voxel 0.05 m)"
    )
    full = render(medium(0.05))
    for stride in STRIDES:
        out, s = timed(lambda: render(medium(0.05, stride=stride)), args.repeats)
        diff = np.abs(out["rgb"] - reference["rgb"]) / scale
        apart = np.abs(out["rgb"] - full["rgb"]) / scale
        row = {
            "march_stride_px": stride,
            "voxel_m": 0.05,
            "seconds_per_view": s,
            "rms_relative_error": float(np.sqrt((diff**2).mean())),
            "p99_relative_error": float(np.percentile(diff, 99)),
            "rms_relative_to_stride_1": float(np.sqrt((apart**2).mean())),
            "max_relative_to_stride_1": float(apart.max()),
        }
        result["strides"].append(row)
        print(
            f"{stride:>7} {1e3 * s:>8.0f} {row['rms_relative_error']:>9.2e} {row['p99_relative_error']:>9.2e} "
            f"{row['rms_relative_to_stride_1']:>9.2e} {row['max_relative_to_stride_1']:>9.2e}"
        )
    print(f"\n{'rate/s':>7} {'puffs':>6} {'ms/view':>8}")
    for rate in RATES:
        m = medium(0.05, rate)
        _, s = timed(lambda: render(m), args.repeats)
        result["rates"].append({"rate_per_s": rate, "puffs": m.puff_count, "voxel_m": 0.05, "seconds_per_view": s})
        print(f"{rate:>7} {m.puff_count:>6} {1e3 * s:>8.0f}")
    curve = [(r["seconds_per_view"], r["rms_relative_error"], f"{r['voxel_m']:g}") for r in result["voxels"]]
    strides = [(r["seconds_per_view"], r["rms_relative_error"], f"S{r['march_stride_px']}") for r in result["strides"]]
    write_result_and_chart(
        result,
        "medium",
        "Dust medium: grid spacing and march stride against image error",
        "640x480, 1 spp",
        {"voxel_m (stride 1)": curve, "march_stride_px (voxel 0.05 m)": strides},
        "render seconds per view",
        "RMS error / mean radiance",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
