"""What the tone map and the optional linear EXR cost per view.

On one 640×480 view of the embedded default config (rendered once; the bytes of real radiance
matter for zip), median over repeats:
  1. the tone map alone (`_core.tonemap_reinhard`: EV100 exposure, Reinhard, sRGB, the invalid
     count), on all cores;
  2. writing rgb.exr alone (float32 RGB, zip at deflate level 1 as written, and at 4, OIIO's
     default, and 6, through the core's OpenImageIO writer), and rgb.png alone (level 1) for
     scale, with file sizes;
  3. for the float-versus-half choice: the same radiance as a half-float zip EXR written by the
     OpenEXR package (a different writer, so compare its size more than its time) and the
     largest relative error half precision makes;
  4. the whole encode + write stage of a view (`write_sample`: five files, or six with
     output.exr), which overlaps the files on the cores.

Writes bench/results/tonemap-exr-<machine>.json and prints a table.
Run: ./dev.sh bench tonemap_exr   (or .venv/bin/python bench/bench_tonemap_exr.py [--repeats N])
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenEXR

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene, render_view, resolve_exposure
from moonbot.render.exposure import LUMINOUS_EFFICACY_LM_W
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.writer import RADIANCE_UNIT, write_sample

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result

# gt.json's fields from the view stage (moonbot.records.gt), for the views this writes alone.
VIEW_META = {
    "view": 0,
    "camera_azimuth_deg": 0.0,
    "camera_height_m": 0.0,
    "sun": {},
    "render_seed": 0,
    "config_hash": "",
    "moonbot_version": "bench",
}
SCHEMA_VERSION = 1


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def median_of(repeats: int, fn) -> float:
    return statistics.median(timed(fn) for _ in range(repeats))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=21, help="timed repeats per figure (median)")
    parser.add_argument(
        "--out", type=Path, default=None, help="result file (default: bench/results/tonemap-exr-<machine>.json)"
    )
    args = parser.parse_args()
    m = machine()
    print(f"machine  {m['cpu']}, {m['cores']} cores, {m['memory_gib']} GiB, {m['os']}, commit {m['git_commit'][:12]}")

    config = load_config()
    spec = compose_scene(config)
    scene = build_scene(spec)
    K = intrinsics(config.camera)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)
    view = render_view(scene, config, K, pose, seed=1)
    rgb = view.rgb
    exposure = resolve_exposure(config)
    rgb8, invalid = _core.tonemap_reinhard(rgb, exposure.scale)
    attributes = {
        "whiteLuminance": LUMINOUS_EFFICACY_LM_W,
        "moonbot:radianceUnit": RADIANCE_UNIT,
        "moonbot:ev100": exposure.ev100,
    }
    r = args.repeats
    load_before = os.getloadavg()[0]
    result = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "tonemap-exr",
        "machine": m,
        "view": {
            "config": "embedded default",
            "width": int(rgb.shape[1]),
            "height": int(rgb.shape[0]),
            "spp": config.render.spp,
            "ev100": exposure.ev100,
            "invalid_pixels": invalid,
            "radiance_range_w_m2_sr": [float(rgb.min()), float(rgb.max())],
        },
        "repeats": r,
    }

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        tonemap_s = median_of(r, lambda: _core.tonemap_reinhard(rgb, exposure.scale))
        exr = {}
        for level in (1, 4, 6):
            path = d / f"rgb-{level}.exr"
            seconds = median_of(r, lambda: _core.write_image(str(path), rgb, level, attributes=attributes))
            exr[f"level_{level}"] = {"write_s": seconds, "bytes": path.stat().st_size}
        png_s = median_of(r, lambda: _core.write_image(str(d / "rgb.png"), rgb8, 1))
        half = rgb.astype(np.float16)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        half_s = median_of(r, lambda: OpenEXR.File(header, {"RGB": half}).write(str(d / "half.exr")))
        with np.errstate(divide="ignore", invalid="ignore"):
            lit = rgb > 6.1e-5  # half's smallest normal; below it half keeps absolute, not relative, steps
            half_rel = float(np.max(np.abs(half[lit].astype(np.float32) - rgb[lit]) / rgb[lit]))
        result["tonemap_s"] = tonemap_s
        result["rgb_exr_float32_zip"] = exr
        result["rgb_png_level1"] = {"write_s": png_s, "bytes": (d / "rgb.png").stat().st_size}
        result["rgb_exr_half_zip_openexr_package"] = {
            "write_s": half_s,
            "bytes": (d / "half.exr").stat().st_size,
            "max_relative_error_above_6.1e-5": half_rel,
            "pixels_overflowing": int(np.isinf(half).sum()),
        }

        stage = {}
        for exr in (False, True):
            seconds = []
            for i in range(r):
                out = d / f"view-{exr}-{i}"
                out.mkdir()
                gt = write_sample(
                    out, view, exposure, K, pose, spec.bags, config.output.png_compression, VIEW_META, {}, exr=exr
                )
                seconds.append(gt.timings_s["encode_write"])
            stage[f"exr_{str(exr).lower()}"] = statistics.median(seconds)
        result["encode_write_stage_s"] = stage
    # Other processes on the machine inflate every figure; the load says how much to trust them.
    result["load_average_1m"] = {"before": load_before, "after": os.getloadavg()[0]}

    e, p, h = result["rgb_exr_float32_zip"], result["rgb_png_level1"], result["rgb_exr_half_zip_openexr_package"]
    print(f"view     {rgb.shape[1]}×{rgb.shape[0]}, EV100 {exposure.ev100:.2f}, invalid pixels {invalid}")
    print(f"tone map                     {1e3 * tonemap_s:7.2f} ms")
    for level, row in e.items():
        print(
            f"rgb.exr  float32 zip {level.replace('level_', 'level '):8} {1e3 * row['write_s']:7.2f} ms  "
            f"{row['bytes'] / 1e6:6.2f} MB"
        )
    print(
        f"         half zip (OpenEXR)  {1e3 * h['write_s']:7.2f} ms  {h['bytes'] / 1e6:6.2f} MB  "
        f"(max rel. error {h['max_relative_error_above_6.1e-5']:.1e})"
    )
    print(f"rgb.png  level 1             {1e3 * p['write_s']:7.2f} ms  {p['bytes'] / 1e6:6.2f} MB")
    print(
        f"encode + write stage: {1e3 * stage['exr_false']:.1f} ms without rgb.exr, "
        f"{1e3 * stage['exr_true']:.1f} ms with it"
    )
    print(
        f"load     1-minute average {load_before:.1f} before, {result['load_average_1m']['after']:.1f} after "
        f"({m['cores']} cores)"
    )

    out = write_result(result, "tonemap-exr", args.out)
    print(f"\nwritten {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
