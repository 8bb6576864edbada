"""What accuracy costs in time (issue 5; principle 1): each lighting quality knob against the
error it leaves, on the three procedural locations at a low and a high Sun.

For every scene (flat, hilly, crater × Sun elevation 5°, 22°; default camera, view 0 of the
orbit, at `--width` × 3/4 pixels) one knob at a time is swept with the others at their
defaults, against a high-sample reference of that knob with the others at their defaults:

  spp            samples per pixel (pixel jitter: how well a pixel's many regolith facets are
                 averaged; every other estimate is averaged over them too); reference 64
  light_samples  shadow rays per sample toward the Sun's 0.533° disk (soft shadow edges);
                 reference 64
  bounces        diffuse inter-reflections (0 = direct sunlight only: shadows black); reference 6
  earthshine     the faint sunlit Earth as a second light; reference: on

Random numbers are keyed by (seed, pixel, sample, dimension), so renders that differ in one
knob share everything else — the same pixel jitter, the same first bounces — and the error
isolates that knob. For each level: the core's render seconds (median of `--repeats`) and the
error: RMSE of linear RGB relative to the reference's mean, PSNR of linear RGB (peak = the
reference's 99.9th percentile), and PSNR of the tone-mapped 8-bit images.

Writes bench/results/accuracy-<machine>.json and .svg (time against relative RMSE, one curve per
knob, all scenes pooled by median) and prints tables. Run:
  .venv/bin/python bench/bench_accuracy.py [--width 320] [--repeats 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene, exposure_scale, render_view
from moonbot.scene import compose_scene, intrinsics, orbit_pose

from fingerprint import machine, machine_slug  # bench/ is on sys.path when run as a script
from svgplot import time_error_plot

RESULTS = Path(__file__).resolve().parent / "results"
SCHEMA_VERSION = 1
LOCATIONS = ("flat", "hilly", "crater")
ELEVATIONS = (5.0, 22.0)
REFERENCE = {"spp": 64, "light_samples": 64, "bounces": 6, "earthshine": True}
KNOBS = {
    "spp": [1, 2, 4, 8, 16],
    "light_samples": [1, 2, 4, 8],
    "bounces": [0, 1, 2, 3],
    "earthshine": [False, True],
}


def with_render(config, **changes):
    return dataclasses.replace(config, render=dataclasses.replace(config.render, **changes))


def with_sun(config, **changes):
    return dataclasses.replace(config, sun=dataclasses.replace(config.sun, **changes))


def render(config, scene, spec, repeats: int):
    """The view's linear RGB (H, W, 3) float64 and the median core seconds of `repeats` renders
    (the same seed each time, so the same image)."""
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)
    K = intrinsics(config.camera)
    seconds, rgb = [], None
    for _ in range(repeats):
        out = render_view(scene, config, K, pose, seed=7)
        seconds.append(out.stats["core_seconds"])
        rgb = out.rgb.astype(np.float64)
    return rgb, statistics.median(seconds)


def errors(rgb: np.ndarray, reference: np.ndarray, exposure: float) -> dict:
    """Relative RMSE and PSNR of linear RGB, PSNR of the tone-mapped 8-bit images."""
    rmse = float(np.sqrt(np.mean((rgb - reference) ** 2)))
    mean = float(reference.mean())
    peak = float(np.percentile(reference, 99.9))
    a = _core.tonemap_reinhard(rgb.astype(np.float32), exposure)[0].astype(np.float64)
    b = _core.tonemap_reinhard(reference.astype(np.float32), exposure)[0].astype(np.float64)
    rmse8 = float(np.sqrt(np.mean((a - b) ** 2)))
    return {"rel_rmse": rmse / mean if mean > 0 else float("nan"),
            "psnr_linear_db": 20 * np.log10(peak / rmse) if rmse > 0 else float("inf"),
            "psnr_8bit_db": 20 * np.log10(255.0 / rmse8) if rmse8 > 0 else float("inf")}


def scene_rows(location: str, elevation: float, width: int, repeats: int) -> list[dict]:
    overrides = {"terrain.location": location, "sun.elevation_deg": elevation,
                 "camera.width": width, "camera.height": width * 3 // 4}
    config = load_config(None, overrides)
    spec = compose_scene(config)
    scene = build_scene(spec)
    exposure = exposure_scale(config)

    def knob_config(knob, level):
        if knob == "earthshine":
            return with_sun(config, earthshine=level)
        return with_render(config, **{knob: level})

    rows = []
    for knob, levels in KNOBS.items():
        reference, ref_s = render(knob_config(knob, REFERENCE[knob]), scene, spec, 1)
        rows.append({"location": location, "sun_elevation_deg": elevation, "knob": knob,
                     "level": f"reference {REFERENCE[knob]}", "seconds": ref_s})
        for level in levels:
            rgb, seconds = render(knob_config(knob, level), scene, spec, repeats)
            rows.append({"location": location, "sun_elevation_deg": elevation, "knob": knob, "level": level,
                         "seconds": seconds, **errors(rgb, reference, exposure)})
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=320, help="image width, pixels (height = 3/4 of it)")
    parser.add_argument("--repeats", type=int, default=3, help="renders per level, timed by their median")
    args = parser.parse_args()
    defaults = load_config(None).render
    result = {"schema_version": SCHEMA_VERSION, "machine": machine(), "width": args.width,
              "reference": REFERENCE, "defaults": {"spp": defaults.spp, "light_samples": defaults.light_samples,
                                                   "bounces": defaults.bounces, "earthshine": False},
              "rows": []}
    start = time.perf_counter()
    for location in LOCATIONS:
        for elevation in ELEVATIONS:
            rows = scene_rows(location, elevation, args.width, args.repeats)
            result["rows"] += rows
            print(f"\n{location}, Sun {elevation:g}°")
            print(f"{'knob':<14} {'level':>6} {'ms':>8} {'rel RMSE':>9} {'PSNR lin':>9} {'PSNR 8-bit':>10}")
            for r in rows:
                if "rel_rmse" not in r:
                    print(f"{r['knob']:<14} {r['level']:>6} {1e3 * r['seconds']:>8.0f}")
                    continue
                print(f"{r['knob']:<14} {str(r['level']):>6} {1e3 * r['seconds']:>8.1f} {r['rel_rmse']:>9.4f} "
                      f"{r['psnr_linear_db']:>8.1f}  {r['psnr_8bit_db']:>9.1f}")
    # One curve per knob: medians over the six scenes of time and of relative RMSE.
    curves = {}
    summary = []
    for knob, levels in KNOBS.items():
        curve = []
        for level in levels:
            rows = [r for r in result["rows"] if r["knob"] == knob and r["level"] == level]
            t = statistics.median(r["seconds"] for r in rows)
            e = statistics.median(r["rel_rmse"] for r in rows)
            p8 = statistics.median(r["psnr_8bit_db"] for r in rows)
            curve.append((t, e, str(level)))
            summary.append({"knob": knob, "level": level, "median_seconds": t, "median_rel_rmse": e,
                            "median_psnr_8bit_db": p8})
        curves[knob] = curve
    result["summary"] = summary
    result["seconds_total"] = time.perf_counter() - start
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / f"accuracy-{machine_slug(result['machine'])}.json"
    out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    time_error_plot(out.with_suffix(".svg"), f"Lighting quality: render time against error "
                    f"({result['machine']['git_commit'][:7]}, {args.width} px, median of 6 scenes)", curves,
                    "core render seconds per view", "RMSE / mean vs reference")
    print("\nmedian over scenes:")
    for s in summary:
        print(f"{s['knob']:<14} {str(s['level']):>6} {1e3 * s['median_seconds']:>8.1f} ms "
              f"{s['median_rel_rmse']:>8.4f} {s['median_psnr_8bit_db']:>6.1f} dB")
    print(f"\nwritten {out} and {out.with_suffix('.svg').name} in {result['seconds_total']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
