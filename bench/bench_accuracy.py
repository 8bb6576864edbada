"""What accuracy costs in time: each lighting quality knob against the
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

and one curve against a converged reference of the brute-force path tracer (per-pixel bounce
paths, as render.indirect: path renders them, so that the light cache's bias counts as error;
spp 1024 at the default bounces and 2 Sun-disk rays a sample, two independent 512-sample halves of
seeds 1 and 2 averaged; cached under build/bench_accuracy/, `--fresh-reference` renders it again),
each level rendered on one thread (core seconds):

  adaptive       (base spp, adaptive_spp, adaptive_threshold): brute force (adaptive_spp 0) at
                 growing spp, and adaptive anti-aliasing of direct light at several caps and
                 thresholds. Besides the whole image's error, the error per region of the
                 reference's pixel-centre buffers: sunlit and shadowed ground and bag faces
                 (instance label, and the Sun's visibility V from the centre hit: 1 sunlit,
                 0 shadowed) and the penumbra (0 < V < 1), each as bias (the region's mean error)
                 and noise (its standard deviation), both relative to the image's mean, so that
                 rel_rmse² = Σ_region fraction·(bias² + noise²). The reference's own noise is
                 half the RMS difference of its halves (also relative to the mean).
                 `--direct-only`: the same with bounces 0 everywhere, reference included: what
                 anti-aliasing does to the direct light, apart from the indirect light's noise.
                 `--indirect cache`: the levels take their indirect light from the light cache
                 (one per scene, filled by an untimed render first: a task's steady state).
                 `--dust`: the same scenes with dust stirred up beside the target (view 0's
                 ejecta fragments and fine-dust cloud), reference included.
                 `--quality-levels`: only the product's draft, default and high levels, as
                 moonbot/benchmark/levels.py defines them over the config's defaults: few
                 enough renders to measure at the sweep's 640×480 (`--width 640`).

With --light-cache, the indirect light instead (render.indirect; light_cache.h), against a
`--reference-spp` (1024) path-traced reference of today's per-pixel bounces (render.bounces of the
config, cached under build/bench_accuracy/), at the default spp and light_samples:

  path_spp       per-pixel bounce paths (render.indirect = path) at 1, 2, 4, 8, 16 spp
  cache_rays     the light cache's gather rays per terrain node (bags: 4×) at 8 .. 128; each
                 level timed cold (view 0 fills the cache) and warm (a second view of the filled
                 cache, the steady state of a task's 36 views)
  cache_cell_cm  the cache's lattice spacings, terrain / bags in cm (0: every vertex gathers),
                 timed the same way; with --orbit-views, each layout's whole task too
  cache_gather_error  adaptive gathering: each node gathers its rays again while their relative
                 standard error is above 0.2 .. 0.05, up to render.cache_rays_max_factor times
  cache_terrain_filter_cells  the tent a terrain vertex reads the lattice's nodes through, radius
                 1 (bilinear), 1.5, 2 and 3 cells

and for path at the default spp and the cache at its default rays, the bias and the noise of the
indirect component (render minus a bounce-free render of the same seed) per region: sunlit and
shadowed ground, sunlit and shadowed bag faces. Bias: the region's mean error relative to the
reference's mean there; noise: the RMS difference of two seeds (of the cache: two cache seeds)
over √2, relative to the same mean. --orbit-views N adds one task's N views of the first scene
with one cache: its fill and render seconds, the vertices and bytes it ends with.

Random numbers are keyed by (seed, pixel, sample, dimension), so renders that differ in one
knob share everything else — the same pixel jitter, the same first bounces — and the error
isolates that knob. For each level: the core's render seconds (median of `--repeats`) and the
error: RMSE of linear RGB relative to the reference's mean, PSNR of linear RGB (peak = the
reference's 99.9th percentile), and PSNR of the tone-mapped 8-bit images.

Writes bench/results/accuracy-<machine>.json and .svg (time against relative RMSE, one curve per
knob, all scenes pooled by median; `--knobs` naming some knobs only: accuracy-<knobs>-<machine>;
`-levels` with --quality-levels, `-<width>px` at a width other than 320) and prints tables. Run:
  .venv/bin/python bench/bench_accuracy.py [--width 320] [--repeats 3] [--knobs adaptive] [--direct-only]
  .venv/bin/python bench/bench_accuracy.py --knobs adaptive --indirect cache --quality-levels --width 640
  .venv/bin/python bench/bench_accuracy.py --light-cache [--reference-spp 1024] [--orbit-views 36]
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.benchmark.levels import level_config
from moonbot.charts import time_error_plot
from moonbot.config import config_hash, load_config
from moonbot.render import SceneDust, build_light_cache, build_scene, exposure_scale, render_view
from moonbot.render.view import scene_lights
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.scene.orbit import orbit_height, pixel_directions

from fingerprint import machine, machine_slug  # bench/ is on sys.path when run as a script

RESULTS = Path(__file__).resolve().parent / "results"
SCHEMA_VERSION = 2  # 2: the adaptive curve (rows with knob "adaptive" carry regions)
REFERENCE_CACHE = Path(__file__).resolve().parent.parent / "build" / "bench_accuracy"  # both kinds of reference
LOCATIONS = ("flat", "hilly", "crater")
ELEVATIONS = (5.0, 22.0)
REFERENCE = {"spp": 64, "light_samples": 64, "bounces": 6, "earthshine": True}
KNOBS = {
    "spp": [1, 2, 4, 8, 16],
    "light_samples": [1, 2, 4, 8],
    "bounces": [0, 1, 2, 3],
    "earthshine": [False, True],
}
# The adaptive curve's reference: the brute-force path tracer converged (two halves, seeds 1 and 2).
CONVERGED = {"spp": 1024, "halves_seeds": (1, 2)}
# The light cache's settings as the converged reference's key holds them, pinned as its quality
# knobs are: the reference renders without a cache, so they change nothing in it.
REFERENCE_KEY_CACHE = {
    "indirect": "cache",
    "cache_rays_terrain": 64,
    "cache_rays_bags": 256,
    "cache_gather_error": 0.0,
    "cache_rays_max_factor": 8,
    "cache_terrain_cell_m": 0.025,
    "cache_bag_cell_m": 0.01,
    "cache_terrain_filter_cells": 1.0,
}
# (spp, adaptive_spp, adaptive_threshold, light_samples, adaptive_full_spread, adaptive_error_target);
# adaptive_spp 0: brute force, today's path tracer. Base spp 1 is the pixel-centre sample, refined
# where its 3×3 neighbourhood disagrees. adaptive_full_spread 0: every refined pixel gets
# adaptive_spp. adaptive_error_target > 0: the spread f is chosen per view from there up.
ADAPTIVE_LEVELS = [
    (4, 0, 0.25, 2, 0.0, 0.0),
    (8, 0, 0.25, 2, 0.0, 0.0),
    (16, 0, 0.25, 2, 0.0, 0.0),
    (32, 0, 0.25, 2, 0.0, 0.0),
    (64, 0, 0.25, 2, 0.0, 0.0),
    (4, 16, 0.25, 2, 0.0, 0.0),
    (4, 32, 0.25, 2, 0.0, 0.0),
    (4, 64, 0.25, 2, 0.0, 0.0),
    (4, 64, 0.25, 1, 0.0, 0.0),
    (4, 64, 0.5, 1, 4.0, 0.0),
    (4, 128, 0.5, 1, 8.0, 0.0),
    (4, 128, 0.5, 1, 10.0, 0.0),
    (4, 128, 0.5, 1, 12.0, 0.0),
    (4, 128, 0.5, 1, 4.0, 0.02),
    (4, 128, 0.5, 1, 4.0, 0.014),
    (4, 128, 0.5, 1, 4.0, 0.01),
    (4, 256, 0.25, 1, 4.0, 0.0),
    (4, 32, 0.1, 2, 0.0, 0.0),
    (4, 32, 0.5, 2, 0.0, 0.0),
    (4, 32, 0.5, 1, 0.0, 0.0),
    (4, 32, 1.0, 2, 0.0, 0.0),
    (2, 16, 0.25, 2, 0.0, 0.0),
    (2, 32, 0.25, 2, 0.0, 0.0),
    (8, 64, 0.25, 2, 0.0, 0.0),
    (2, 16, 0.5, 1, 0.0, 0.0),
    (2, 64, 0.5, 1, 10.0, 0.0),
    (1, 16, 1.0, 1, 0.0, 0.0),
    (1, 32, 1.0, 1, 0.0, 0.0),
    (1, 16, 0.5, 1, 0.0, 0.0),
    (1, 32, 0.5, 1, 0.0, 0.0),
    (1, 64, 0.5, 1, 0.0, 0.0),
    (1, 32, 0.25, 1, 0.0, 0.0),
]
QUALITY_LEVELS = ("draft", "default", "high")


def quality_level_tuples() -> dict[str, tuple]:
    """The quality levels (moonbot/benchmark/levels.py) as ADAPTIVE_LEVELS tuples, by name: what
    `--quality-levels` measures (their penumbra_light_samples is the config's, as with every tuple)."""
    out = {}
    for name in QUALITY_LEVELS:
        r = level_config(None, name).render
        out[name] = (
            r.spp,
            r.adaptive_spp,
            r.adaptive_threshold,
            r.light_samples,
            r.adaptive_full_spread,
            r.adaptive_error_target,
        )
    return out


# Sample points on the Sun's disk for the visibility V that defines the region masks.
SUN_DISK_POINTS = 64
REGIONS = ("sunlit_ground", "shadowed_ground", "sunlit_bag", "shadowed_bag", "penumbra")


def with_render(config, **changes):
    return dataclasses.replace(config, render=dataclasses.replace(config.render, **changes))


def with_sun(config, **changes):
    return dataclasses.replace(config, sun=dataclasses.replace(config.sun, **changes))


def view_pose(config, spec):
    return orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)


def render(config, scene, spec, repeats: int, seed: int = 7, full: bool = False, light_cache=None, medium=None):
    """The view's linear RGB (H, W, 3) float64 and the median core seconds of `repeats` renders
    (the same seed each time, so the same image); `full`: the last RenderedView in place of the RGB."""
    pose = view_pose(config, spec)
    K = intrinsics(config.camera)
    seconds, out = [], None
    for _ in range(repeats):
        out = render_view(scene, config, K, pose, seed=seed, medium=medium, light_cache=light_cache)
        seconds.append(out.stats["core_seconds"])
    return (out if full else out.rgb.astype(np.float64)), statistics.median(seconds)


def errors(rgb: np.ndarray, reference: np.ndarray, exposure: float) -> dict:
    """Relative RMSE and PSNR of linear RGB, PSNR of the tone-mapped 8-bit images."""
    rmse = float(np.sqrt(np.mean((rgb - reference) ** 2)))
    mean = float(reference.mean())
    peak = float(np.percentile(reference, 99.9))
    a = _core.tonemap_reinhard(rgb.astype(np.float32), exposure)[0].astype(np.float64)
    b = _core.tonemap_reinhard(reference.astype(np.float32), exposure)[0].astype(np.float64)
    rmse8 = float(np.sqrt(np.mean((a - b) ** 2)))
    return {
        "rel_rmse": rmse / mean if mean > 0 else float("nan"),
        "psnr_linear_db": 20 * np.log10(peak / rmse) if rmse > 0 else float("inf"),
        "psnr_8bit_db": 20 * np.log10(255.0 / rmse8) if rmse8 > 0 else float("inf"),
    }


def sun_visibility(config, scene, spec, depth: np.ndarray) -> np.ndarray:
    """The fraction V (H, W) float64 of SUN_DISK_POINTS directions spread evenly over the Sun's
    disk (Vogel's spiral) along which the pixel-centre hit sees the sky; NaN where the centre ray
    hits nothing. The shadow rays leave from the hit moved back toward the camera by 1e-4 of its
    distance (plus 0.1 mm): off the surface, on its visible side."""
    K = intrinsics(config.camera)
    pose = view_pose(config, spec)
    dirs = pixel_directions(K, pose, config.camera.width, config.camera.height)
    hit = depth > 0
    points = pose.center + depth[hit][:, None] * dirs[hit]
    back = -dirs[hit] / np.linalg.norm(dirs[hit], axis=1, keepdims=True)
    distance = depth[hit] * np.linalg.norm(dirs[hit], axis=1)
    origins = points + back * (1e-4 * distance + 1e-4)[:, None]
    s = config.sun
    to_sun = np.asarray(scene_lights(config)[0].direction, dtype=np.float64)
    a = np.cross(to_sun, [0.0, 0.0, 1.0] if abs(to_sun[2]) < 0.9 else [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(to_sun, a)
    k = np.arange(SUN_DISK_POINTS) + 0.5
    radius = np.tan(np.radians(s.angular_diameter_deg / 2)) * np.sqrt(k / SUN_DISK_POINTS)
    angle = k * np.pi * (3.0 - np.sqrt(5.0))  # the golden angle
    seen = np.zeros(len(origins))
    for r, phi in zip(radius, angle):
        d = to_sun + r * (np.cos(phi) * a + np.sin(phi) * b)
        t, _, _ = scene.intersect(origins, np.broadcast_to(d / np.linalg.norm(d), origins.shape))
        seen += np.isinf(t)
    v = np.full(depth.shape, np.nan)
    v[hit] = seen / SUN_DISK_POINTS
    return v


def converged_reference(config, scene, spec, fresh: bool, medium=None) -> dict:
    """The brute-force path tracer at CONVERGED spp (two halves of different seeds, averaged)
    with the pixel-centre depth, instance labels and Sun visibility: float32/uint8 arrays under
    the keys rgb (H, W, 3), half_difference (H, W, 3: the halves' difference), depth, instance,
    visibility. Cached in build/ under the config's hash and the bytes of a one-sample render of
    the same scene, so that code which changes the scene or the renderer's answers (the config
    unchanged) renders a fresh reference instead of reading a stale one. Its renders get no light
    cache, so their indirect light is per-pixel bounce paths, as render.indirect: path renders it:
    the cache's own bias counts as error."""
    # Pinned, not the config's: the quality knobs' and the cache's defaults may move without the
    # reference's key.
    half = with_render(
        config,
        spp=CONVERGED["spp"] // 2,
        adaptive_spp=0,
        threads=0,
        adaptive_threshold=0.5,
        adaptive_full_spread=0.0,
        adaptive_contrast=0.0,
        adaptive_error_target=0.0,
        light_samples=2,
        **REFERENCE_KEY_CACHE,
    )
    probe = render(
        with_render(half, spp=1), scene, spec, 1, seed=CONVERGED["halves_seeds"][0], full=True, medium=medium
    )[0]
    scene_bytes = hashlib.blake2b(probe.rgb.astype(np.float32).tobytes(), digest_size=8)
    scene_bytes.update(probe.depth.astype(np.float32).tobytes())
    key = f"{config_hash(with_render(half, threads=0))[:16]}-{scene_bytes.hexdigest()}"
    path = REFERENCE_CACHE / f"{config.terrain.location}-{config.sun.elevation_deg:g}-{config.camera.width}-{key}.npz"
    if path.exists() and not fresh:
        with np.load(path) as f:
            return dict(f)
    halves = [
        render(half, scene, spec, 1, seed=seed, full=True, medium=medium)[0] for seed in CONVERGED["halves_seeds"]
    ]
    a, b = (h.rgb.astype(np.float64) for h in halves)
    ref = {
        "rgb": ((a + b) / 2).astype(np.float32),
        "half_difference": (a - b).astype(np.float32),
        "depth": halves[0].depth,
        "instance": halves[0].instance,
    }
    ref["visibility"] = sun_visibility(config, scene, spec, ref["depth"]).astype(np.float32)
    REFERENCE_CACHE.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".partial.npz")
    np.savez_compressed(partial, **ref)
    partial.replace(path)  # whole or not at all
    return ref


def region_masks(ref: dict) -> dict[str, np.ndarray]:
    """REGIONS as (H, W) bool masks of the reference's pixel-centre buffers."""
    v, bag, hit = ref["visibility"], ref["instance"] > 0, ref["depth"] > 0
    lit, dark, penumbra = hit & (v == 1), hit & (v == 0), hit & (v > 0) & (v < 1)
    return {
        "sunlit_ground": lit & ~bag,
        "shadowed_ground": dark & ~bag,
        "sunlit_bag": lit & bag,
        "shadowed_bag": dark & bag,
        "penumbra": penumbra,
    }


def region_errors(rgb: np.ndarray, ref: dict, masks: dict[str, np.ndarray]) -> dict:
    """Per region: its fraction of the pixels, bias and noise of rgb − reference relative to the
    reference image's mean, and its share of the image's squared error."""
    error = rgb - ref["rgb"].astype(np.float64)
    mean = float(ref["rgb"].mean())
    total = float(np.sum(error**2))
    out = {}
    for name, mask in masks.items():
        e = error[mask]
        if e.size == 0:
            out[name] = {"fraction": 0.0}
            continue
        out[name] = {
            "fraction": float(mask.mean()),
            "bias": float(e.mean()) / mean,
            "noise": float(e.std()) / mean,
            "share_of_squared_error": float(np.sum(e**2)) / total if total > 0 else 0.0,
        }
    return out


def adaptive_rows(
    config,
    scene,
    spec,
    exposure: float,
    repeats: int,
    fresh_reference: bool,
    indirect: str = "path",
    levels: list[tuple] = ADAPTIVE_LEVELS,
    medium=None,
) -> list[dict]:
    """The adaptive curve of one scene against its converged reference (module docstring)."""
    location, elevation = config.terrain.location, config.sun.elevation_deg
    start = time.perf_counter()
    ref = converged_reference(config, scene, spec, fresh_reference, medium)
    mean = float(ref["rgb"].mean())
    reference_noise = float(np.sqrt(np.mean(ref["half_difference"].astype(np.float64) ** 2)) / 2) / mean
    rows = [
        {
            "location": location,
            "sun_elevation_deg": elevation,
            "knob": "adaptive",
            "level": f"reference {CONVERGED['spp']}",
            "seconds": time.perf_counter() - start,
            "reference_rel_noise": reference_noise,
        }
    ]
    masks = region_masks(ref)
    one_thread = with_render(config, threads=1, indirect=indirect)
    cache = build_light_cache(scene, one_thread)
    if cache is not None:
        render(one_thread, scene, spec, 1, light_cache=cache, medium=medium)  # fills what view 0 touches
    for spp, cap, threshold, light_samples, full_spread, error_target in levels:
        level = with_render(
            one_thread,
            spp=spp,
            adaptive_spp=cap,
            adaptive_threshold=threshold,
            light_samples=light_samples,
            adaptive_full_spread=full_spread,
            adaptive_error_target=error_target,
        )
        out, seconds = render(level, scene, spec, repeats, full=True, light_cache=cache, medium=medium)
        rgb = out.rgb.astype(np.float64)
        e = errors(rgb, ref["rgb"].astype(np.float64), exposure)
        rays = sum(out.stats[k] for k in ("camera_rays", "second_look_rays", "shadow_rays", "bounce_rays"))
        rows.append(
            {
                "location": location,
                "sun_elevation_deg": elevation,
                "knob": "adaptive",
                "level": adaptive_label(spp, cap, threshold, light_samples, full_spread, error_target),
                "spp": spp,
                "adaptive_spp": cap,
                "adaptive_threshold": threshold,
                "light_samples": light_samples,
                "adaptive_full_spread": full_spread,
                "adaptive_error_target": error_target,
                "seconds": seconds,
                **e,
                # the error left once the reference's own noise is taken out (they add in squares)
                "rel_rmse_vs_truth": float(np.sqrt(max(e["rel_rmse"] ** 2 - reference_noise**2, 0.0))),
                "rays": int(rays),
                "refined_pixels": int(out.stats["refined_pixels"]),
                "refinement_rays": int(out.stats["refinement_rays"]),
                "regions": region_errors(rgb, ref, masks),
            }
        )
    return rows


def adaptive_label(
    spp: int,
    cap: int,
    threshold: float,
    light_samples: int = 2,
    full_spread: float = 0.0,
    error_target: float = 0.0,
) -> str:
    label = f"spp {spp}" if cap == 0 else f"{spp}/{cap}/{threshold:g}"
    label = label if light_samples == 2 else f"{label} ls{light_samples}"
    label = label if full_spread == 0.0 else f"{label} f{full_spread:g}"
    return label if error_target == 0.0 else f"{label} e{100 * error_target:g}%"


def scene_rows(
    location: str,
    elevation: float,
    width: int,
    repeats: int,
    knobs: list[str],
    fresh_reference: bool,
    direct_only: bool = False,
    indirect: str = "path",
    dust: bool = False,
    adaptive_levels: list[tuple] = ADAPTIVE_LEVELS,
) -> list[dict]:
    overrides = {
        "terrain.location": location,
        "sun.elevation_deg": elevation,
        "camera.width": width,
        "camera.height": width * 3 // 4,
        "dust.enabled": dust,
    }
    config = load_config(None, overrides)
    spec = compose_scene(config)
    scene = build_scene(spec)
    exposure = exposure_scale(config)
    # A dusty scene: view 0's ejecta fragments in the scene (moving: no light cache serves or
    # sees them) and its cloud as the render's medium, for the reference and every level alike.
    medium = SceneDust(scene, spec, config, [0]).for_view(0).medium if dust else None

    def knob_config(knob, level):
        if knob == "earthshine":
            return with_sun(config, earthshine=level)
        return with_render(config, **{knob: level})

    rows = []
    if "adaptive" in knobs:
        direct = with_render(config, bounces=0) if direct_only else config
        rows += adaptive_rows(
            direct, scene, spec, exposure, repeats, fresh_reference, indirect, levels=adaptive_levels, medium=medium
        )
    for knob, levels in KNOBS.items():
        if knob not in knobs:
            continue
        reference, ref_s = render(knob_config(knob, REFERENCE[knob]), scene, spec, 1)
        rows.append(
            {
                "location": location,
                "sun_elevation_deg": elevation,
                "knob": knob,
                "level": f"reference {REFERENCE[knob]}",
                "seconds": ref_s,
            }
        )
        for level in levels:
            rgb, seconds = render(knob_config(knob, level), scene, spec, repeats)
            rows.append(
                {
                    "location": location,
                    "sun_elevation_deg": elevation,
                    "knob": knob,
                    "level": level,
                    "seconds": seconds,
                    **errors(rgb, reference, exposure),
                }
            )
    return rows


def print_rows(rows: list[dict]) -> None:
    print(f"{'knob':<14} {'level':>12} {'ms':>8} {'rel RMSE':>9} {'PSNR lin':>9} {'PSNR 8-bit':>10} {'refined':>8}")
    for r in rows:
        if "rel_rmse" not in r:
            noise = f"  reference noise {r['reference_rel_noise']:.4f}" if "reference_rel_noise" in r else ""
            print(f"{r['knob']:<14} {r['level']:>12} {1e3 * r['seconds']:>8.0f}{noise}")
            continue
        refined = f"{r['refined_pixels']:>8}" if "refined_pixels" in r else ""
        print(
            f"{r['knob']:<14} {str(r['level']):>12} {1e3 * r['seconds']:>8.1f} {r['rel_rmse']:>9.4f} "
            f"{r['psnr_linear_db']:>8.1f}  {r['psnr_8bit_db']:>9.1f} {refined}"
        )


def knob_summary(rows: list[dict], knob: str, levels: list) -> tuple[list, list]:
    """Medians over the scenes of time, relative RMSE and 8-bit PSNR per level (and for the
    adaptive curve: rays, refined pixels, the error net of the reference's noise, and per region
    bias and noise): the summary rows and the curve's points."""
    summary, curve = [], []
    for level in levels:
        at = [r for r in rows if r["knob"] == knob and r["level"] == level]
        t = statistics.median(r["seconds"] for r in at)
        e = statistics.median(r["rel_rmse"] for r in at)
        row = {
            "knob": knob,
            "level": level,
            "median_seconds": t,
            "median_rel_rmse": e,
            "median_psnr_8bit_db": statistics.median(r["psnr_8bit_db"] for r in at),
        }
        if knob == "adaptive":
            row["median_rel_rmse_vs_truth"] = statistics.median(r["rel_rmse_vs_truth"] for r in at)
            row["max_rel_rmse"] = max(r["rel_rmse"] for r in at)
            row["median_rays"] = statistics.median(r["rays"] for r in at)
            row["median_refined_pixels"] = statistics.median(r["refined_pixels"] for r in at)
            row["regions"] = {
                name: {
                    q: statistics.median(r["regions"][name][q] for r in at if q in r["regions"][name])
                    for q in ("bias", "noise", "share_of_squared_error")
                    if any(q in r["regions"][name] for r in at)
                }
                for name in REGIONS
            }
        summary.append(row)
        curve.append((t, e, str(level)))
    return summary, curve


def adaptive_curves(rows: list[dict], levels: list[tuple] = ADAPTIVE_LEVELS) -> dict[str, list]:
    """The adaptive levels grouped into the plot's curves: brute force, then the adaptive levels
    by base spp and threshold (growing cap along each), then by threshold at base 4 cap 32; the
    quality levels alone (`--quality-levels`) as one curve."""
    if levels != ADAPTIVE_LEVELS:
        return {"quality levels": knob_summary(rows, "adaptive", [adaptive_label(*level) for level in levels])[1]}
    groups: dict[str, list] = {}
    for spp, cap, threshold, light_samples, full_spread, error_target in ADAPTIVE_LEVELS:
        name = "brute force spp" if cap == 0 else f"adaptive base {spp}, threshold {threshold:g}"
        if full_spread > 0.0:
            name = f"adaptive base {spp}, refined by the spread"
        if error_target > 0.0:
            name = f"adaptive base {spp}, the spread chosen per view for an error target"
        groups.setdefault(name, []).append(
            adaptive_label(spp, cap, threshold, light_samples, full_spread, error_target)
        )
    groups["adaptive 4/32, threshold"] = [
        adaptive_label(4, 32, t) for s, c, t, ls, f, e in ADAPTIVE_LEVELS if (s, c, ls, f, e) == (4, 32, 2, 0.0, 0.0)
    ]
    curves = {}
    for name, labels in groups.items():
        points = [p for p in knob_summary(rows, "adaptive", labels)[1]]
        if len(points) > 1:
            curves[name] = points
    return curves


CACHE_KNOBS = {
    "path_spp": [1, 2, 4, 8, 16],
    "cache_rays": [8, 16, 32, 64, 128],
    # (terrain, bag) lattice spacing, cm; 0 = every vertex gathers (render.cache_terrain_cell_m, cache_bag_cell_m)
    "cache_cell_cm": ["5/2", "2.5/1", "5/0", "0/2", "0/0"],
    # adaptive gathering: a node gathers again while its relative standard error is above this (0 = off)
    "cache_gather_error": [0.2, 0.1, 0.05],
    # the tent a terrain vertex reads the lattice through, radius in cells (1 = bilinear)
    "cache_terrain_filter_cells": [1.0, 1.5, 2.0, 3.0],
}


def scene_setup(location: str, elevation: float, width: int):
    overrides = {
        "terrain.location": location,
        "sun.elevation_deg": elevation,
        "camera.width": width,
        "camera.height": width * 3 // 4,
    }
    config = load_config(None, overrides)
    spec = compose_scene(config)
    return config, spec, build_scene(spec)


def path_reference(config, scene, spec, location: str, elevation: float, spp: int):
    """The path-traced reference (render.indirect = path at `spp`) and its bounce-free twin of the
    same seed (their difference is the reference indirect light), linear RGB float64, read from
    build/bench_accuracy/ when computed before for this scene, size and render settings."""
    r = config.render
    key = (
        f"{location}-{elevation:g}-{config.camera.width}x{config.camera.height}-spp{spp}-b{r.bounces}"
        f"-ls{r.light_samples}"
    )
    path = REFERENCE_CACHE / f"{key}.npz"
    if path.exists():
        with np.load(path) as f:
            return f["rgb"], f["direct"]
    rgb, _ = render(with_render(config, spp=spp, indirect="path"), scene, spec, 1)
    direct, _ = render(with_render(config, spp=spp, bounces=0), scene, spec, 1)
    REFERENCE_CACHE.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, rgb=rgb, direct=direct)
    return rgb, direct


def render_with(config, scene, spec, seed: int = 7, cache=None):
    """One render of view 0: linear RGB float64, the core's stats."""
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, config.orbit.start_azimuth_deg)
    out = render_view(scene, config, intrinsics(config.camera), pose, seed=seed, light_cache=cache)
    return out.rgb.astype(np.float64), out


def regions(direct: np.ndarray, labels: np.ndarray) -> dict[str, np.ndarray]:
    """Pixel masks: ground and bag faces, sunlit (direct light > 0 in the reference) or shadowed."""
    lit = direct.sum(axis=2) > 0
    ground, bag = labels == 0, labels > 0
    return {
        "ground_sunlit": ground & lit,
        "ground_shadowed": ground & ~lit,
        "bag_sunlit": bag & lit,
        "bag_shadowed": bag & ~lit,
    }


def bias_and_noise(first: np.ndarray, second: np.ndarray, reference: np.ndarray, masks: dict[str, np.ndarray]) -> dict:
    """Per region: bias (mean of the first estimate minus the reference) and noise (RMS of the two
    estimates' difference over √2), both relative to the reference's mean there; indirect light
    only (each argument is a render minus its bounce-free twin)."""
    out = {}
    for name, mask in masks.items():
        if mask.sum() == 0:
            continue
        mean = float(reference[mask].mean())
        out[name] = {
            "pixels": int(mask.sum()),
            "reference_mean": mean,
            "bias": float((first[mask] - reference[mask]).mean()) / mean if mean > 0 else float("nan"),
            "noise": float(np.sqrt(np.mean((first[mask] - second[mask]) ** 2) / 2)) / mean
            if mean > 0
            else float("nan"),
        }
    return out


def cache_cells(cells: str) -> dict:
    """render's lattice spacings for a "terrain/bag" level of CACHE_KNOBS["cache_cell_cm"] (centimetres)."""
    terrain_cm, bag_cm = (float(c) for c in cells.split("/"))
    return {"cache_terrain_cell_m": terrain_cm / 100, "cache_bag_cell_m": bag_cm / 100}


def cache_knob_levels() -> list[tuple[str, object, dict]]:
    """(knob, level, the render settings it changes) for every level of the cache's knobs."""
    levels = [("cache_rays", r, {"cache_rays_terrain": r, "cache_rays_bags": 4 * r}) for r in CACHE_KNOBS["cache_rays"]]
    levels += [("cache_cell_cm", c, cache_cells(c)) for c in CACHE_KNOBS["cache_cell_cm"]]
    levels += [("cache_gather_error", e, {"cache_gather_error": e}) for e in CACHE_KNOBS["cache_gather_error"]]
    levels += [
        ("cache_terrain_filter_cells", r, {"cache_terrain_filter_cells": r})
        for r in CACHE_KNOBS["cache_terrain_filter_cells"]
    ]
    return levels


def light_cache_rows(location: str, elevation: float, width: int, repeats: int, reference_spp: int) -> list[dict]:
    config, spec, scene = scene_setup(location, elevation, width)
    exposure = exposure_scale(config)
    start = time.perf_counter()
    reference, reference_direct = path_reference(config, scene, spec, location, elevation, reference_spp)
    base = {"location": location, "sun_elevation_deg": elevation}
    rows = [{**base, "knob": "reference", "level": f"path {reference_spp} spp", "seconds": time.perf_counter() - start}]
    for spp in CACHE_KNOBS["path_spp"]:
        times = []
        for _ in range(repeats):
            rgb, out = render_with(with_render(config, spp=spp, indirect="path"), scene, spec)
            times.append(out.stats["core_seconds"])
        rows.append(
            {
                **base,
                "knob": "path_spp",
                "level": spp,
                "seconds": statistics.median(times),
                "bounce_rays": out.stats["bounce_rays"],
                **errors(rgb, reference, exposure),
            }
        )
    for knob, level, changes in cache_knob_levels():
        cached = with_render(config, indirect="cache", **changes)
        cache = build_light_cache(scene, cached)
        rgb, cold = render_with(cached, scene, spec, cache=cache)
        filled = cache.stats()
        warm = [render_with(cached, scene, spec, cache=cache)[1].stats["core_seconds"] for _ in range(repeats)]
        rows.append(
            {
                **base,
                "knob": knob,
                "level": level,
                "seconds": statistics.median(warm),
                "seconds_cold": cold.stats["core_seconds"],
                "fill_thread_seconds": filled["fill_seconds"],
                "cache": {
                    k: filled[k] for k in ("vertices", "nodes", "probe_rays", "gather_rays", "shadow_rays", "bytes")
                },
                **errors(rgb, reference, exposure),
            }
        )
    # Bias and noise of the indirect light per region, at the defaults of each mode.
    reference_indirect = reference - reference_direct
    labels = render_with(config, scene, spec)[1].instance
    masks = regions(reference_direct, labels)
    no_bounce = with_render(config, bounces=0)
    direct = {seed: render_with(no_bounce, scene, spec, seed=seed)[0] for seed in (7, 8)}
    path = [render_with(config, scene, spec, seed=seed)[0] - direct[seed] for seed in (7, 8)]
    cached = with_render(config, indirect="cache")
    caches = [build_light_cache(scene, dataclasses.replace(cached, seed=config.seed + k)) for k in (0, 1)]
    cache = [render_with(cached, scene, spec, seed=7, cache=c)[0] - direct[7] for c in caches]
    rows.append(
        {
            **base,
            "knob": "regions",
            "level": "path",
            "spp": config.render.spp,
            "regions": bias_and_noise(path[0], path[1], reference_indirect, masks),
        }
    )
    rows.append(
        {
            **base,
            "knob": "regions",
            "level": "cache",
            "spp": config.render.spp,
            "cache_rays_terrain": config.render.cache_rays_terrain,
            "cache_rays_bags": config.render.cache_rays_bags,
            "regions": bias_and_noise(cache[0], cache[1], reference_indirect, masks),
        }
    )
    return rows


def orbit_rows(location: str, elevation: float, width: int, views: int, changes: dict | None = None) -> dict:
    """One task's `views` orbit views with one light cache: per view the core's render seconds,
    the vertices it filled and the fill's thread-seconds; the cache at the end. `changes`: render
    settings in place of the config's (a cache knob's level)."""
    config, spec, scene = scene_setup(location, elevation, width)
    config = with_render(config, indirect="cache", **(changes or {}))
    cache = build_light_cache(scene, config)
    K = intrinsics(config.camera)
    per_view, path_seconds = [], []
    for v in range(views):
        azimuth = config.orbit.start_azimuth_deg + v * config.orbit.step_deg
        height = orbit_height(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth, spec.ground)
        pose = orbit_pose(spec.target, config.orbit.radius_m, height, azimuth)
        before = cache.stats()
        out = render_view(scene, config, K, pose, seed=v, light_cache=cache)
        after = cache.stats()
        per_view.append(
            {
                "view": v,
                "seconds": out.stats["core_seconds"],
                "vertices_filled": after["vertices"] - before["vertices"],
                "fill_thread_seconds": after["fill_seconds"] - before["fill_seconds"],
            }
        )
        if v % 6 == 0:  # today's path tracer on the same view, for the comparison
            path = render_view(scene, with_render(config, indirect="path"), K, pose, seed=v)
            path_seconds.append(path.stats["core_seconds"])
    return {
        "location": location,
        "sun_elevation_deg": elevation,
        "views": per_view,
        "cache": cache.stats(),
        "render_seconds_total": sum(v["seconds"] for v in per_view),
        "path_seconds_median_every_6th_view": statistics.median(path_seconds),
    }


def light_cache_main(args) -> int:
    result = {
        "schema_version": SCHEMA_VERSION,
        "machine": machine(),
        "width": args.width,
        "reference": f"path {args.reference_spp} spp",
        "defaults": dataclasses.asdict(load_config(None).render),
        "rows": [],
    }
    start = time.perf_counter()
    for location in LOCATIONS:
        for elevation in ELEVATIONS:
            rows = light_cache_rows(location, elevation, args.width, args.repeats, args.reference_spp)
            result["rows"] += rows
            print(f"\n{location}, Sun {elevation:g}°")
            for r in rows:
                if r["knob"] in CACHE_KNOBS:
                    cold = f"  cold {1e3 * r['seconds_cold']:.0f} ms" if "seconds_cold" in r else ""
                    print(
                        f"{r['knob']:<11} {str(r['level']):>5} {1e3 * r['seconds']:>8.1f} ms "
                        f"rel RMSE {r['rel_rmse']:.4f}{cold}"
                    )
                elif r["knob"] == "regions":
                    cells = "  ".join(f"{k} {v['bias']:+.3f}/{v['noise']:.3f}" for k, v in r["regions"].items())
                    print(f"{r['level']:<6} bias/noise  {cells}")
    curves, summary = {}, []
    for knob, levels in CACHE_KNOBS.items():
        curve = []
        for level in levels:
            rows = [r for r in result["rows"] if r["knob"] == knob and r["level"] == level]
            t = statistics.median(r["seconds"] for r in rows)
            e = statistics.median(r["rel_rmse"] for r in rows)
            curve.append((t, e, str(level)))
            summary.append(
                {
                    "knob": knob,
                    "level": level,
                    "median_seconds": t,
                    "median_rel_rmse": e,
                    **(
                        {"median_seconds_cold": statistics.median(r["seconds_cold"] for r in rows)}
                        if knob != "path_spp"
                        else {}
                    ),
                }
            )
        curves[knob] = curve
    result["summary"] = summary
    if args.orbit_views:
        result["orbit"] = orbit_rows(LOCATIONS[1], ELEVATIONS[1], args.width, args.orbit_views)
        # What each lattice layout and gathering error costs a whole task (the fill grows with
        # what the views see).
        result["orbit_by_cache_level"] = []
        for knob, level, changes in cache_knob_levels():
            if knob == "cache_rays":
                continue
            o = orbit_rows(LOCATIONS[1], ELEVATIONS[1], args.width, args.orbit_views, changes)
            c = o["cache"]
            result["orbit_by_cache_level"].append(
                {
                    "knob": knob,
                    "level": level,
                    "render_seconds_total": o["render_seconds_total"],
                    "fill_thread_seconds": c["fill_seconds"],
                    **{k: c[k] for k in ("vertices", "nodes", "gather_rays", "bytes")},
                }
            )
            print(
                f"task of {args.orbit_views} views, {knob} {level}: {o['render_seconds_total']:.1f} core-s, "
                f"fill {c['fill_seconds']:.1f} thread-s, {c['bytes'] / 1e6:.1f} MB"
            )
    result["seconds_total"] = time.perf_counter() - start
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / f"accuracy-light-cache-{machine_slug(result['machine'])}.json"
    out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    time_error_plot(
        out.with_suffix(".svg"),
        f"Indirect light: per-pixel paths vs the light cache "
        f"({result['machine']['git_commit'][:7]}, {args.width} px, median of 6 scenes; cache warm)",
        curves,
        "core render seconds per view",
        "RMSE / mean vs path reference",
    )
    print("\nmedian over scenes:")
    for s in summary:
        cold = f" (cold {1e3 * s['median_seconds_cold']:.0f} ms)" if "median_seconds_cold" in s else ""
        print(
            f"{s['knob']:<11} {str(s['level']):>5} {1e3 * s['median_seconds']:>8.1f} ms "
            f"{s['median_rel_rmse']:>8.4f}{cold}"
        )
    print(f"\nwritten {out} in {result['seconds_total']:.0f} s")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=320, help="image width, pixels (height = 3/4 of it)")
    parser.add_argument("--repeats", type=int, default=3, help="renders per level, timed by their median")
    parser.add_argument(
        "--knobs",
        nargs="+",
        choices=[*KNOBS, "adaptive"],
        default=[*KNOBS, "adaptive"],
        help="the curves to measure (default: all)",
    )
    parser.add_argument(
        "--fresh-reference",
        action="store_true",
        help="render the adaptive curve's converged references again, not from build/",
    )
    parser.add_argument(
        "--direct-only",
        action="store_true",
        help="the adaptive curve with bounces 0, its reference too (direct light alone)",
    )
    parser.add_argument(
        "--indirect",
        choices=["path", "cache"],
        default="path",
        help="the adaptive curve's levels: indirect light from bounce paths or the light cache",
    )
    parser.add_argument(
        "--dust",
        action="store_true",
        help="the scenes with dust stirred up (ejecta fragments and the fine-dust cloud of view 0)",
    )
    parser.add_argument(
        "--elevations", type=float, nargs="+", default=list(ELEVATIONS), help="Sun elevations, degrees (default: 5 22)"
    )
    parser.add_argument(
        "--quality-levels",
        action="store_true",
        help="the adaptive curve at the quality levels only (draft, default, high): affordable at 640 px",
    )
    parser.add_argument(
        "--light-cache",
        action="store_true",
        help="the indirect-light study (per-pixel paths vs the light cache) instead of the knobs",
    )
    parser.add_argument("--reference-spp", type=int, default=1024, help="--light-cache: the path reference's spp")
    parser.add_argument(
        "--orbit-views",
        type=int,
        default=0,
        help="--light-cache: also render this many orbit views of hilly, 22°, with one cache",
    )
    args = parser.parse_args()
    if args.light_cache:
        return light_cache_main(args)
    defaults = load_config(None).render
    named = quality_level_tuples() if args.quality_levels else {}
    adaptive_levels = list(named.values()) if args.quality_levels else ADAPTIVE_LEVELS
    level_names = {adaptive_label(*t): n for n, t in named.items()}  # a row's level label → its name
    result = {
        "schema_version": SCHEMA_VERSION,
        "machine": machine(),
        "width": args.width,
        "knobs": args.knobs,
        "quality_levels": named,
        "direct_only": args.direct_only,
        "indirect": args.indirect,
        "dust": args.dust,
        "elevations": args.elevations,
        "reference": REFERENCE,
        "converged_reference": CONVERGED,
        "defaults": {
            "spp": defaults.spp,
            "light_samples": defaults.light_samples,
            "bounces": defaults.bounces,
            "earthshine": False,
        },
        "rows": [],
    }
    start = time.perf_counter()
    for location in LOCATIONS:
        for elevation in args.elevations:
            rows = scene_rows(
                location,
                elevation,
                args.width,
                args.repeats,
                args.knobs,
                args.fresh_reference,
                args.direct_only,
                args.indirect,
                args.dust,
                adaptive_levels,
            )
            for row in rows:
                row["quality_level"] = level_names.get(row.get("level"))
            result["rows"] += rows
            print(f"\n{location}, Sun {elevation:g}°")
            print_rows(rows)
    # One curve per knob: medians over the six scenes of time and of relative RMSE.
    curves = {}
    summary = []
    for knob, levels in KNOBS.items():
        if knob in args.knobs:
            summary_rows, curves[knob] = knob_summary(result["rows"], knob, levels)
            summary += summary_rows
    if "adaptive" in args.knobs:
        summary += knob_summary(result["rows"], "adaptive", [adaptive_label(*level) for level in adaptive_levels])[0]
    result["summary"] = summary
    result["seconds_total"] = time.perf_counter() - start
    RESULTS.mkdir(exist_ok=True)
    subset = "" if set(args.knobs) == {*KNOBS, "adaptive"} else "-".join(args.knobs) + "-"
    subset += "direct-" if args.direct_only else ""
    subset += "cache-" if args.indirect == "cache" else ""
    subset += "dust-" if args.dust else ""
    subset += "levels-" if args.quality_levels else ""
    subset += f"{args.width}px-" if args.width != 320 else ""
    out = RESULTS / f"accuracy-{subset}{machine_slug(result['machine'])}.json"
    out.write_text(json.dumps(result, indent=2, default=str) + "\n")
    commit = result["machine"]["git_commit"][:7]
    written = [out]
    if curves:
        written.append(out.with_suffix(".svg"))
        time_error_plot(
            written[-1],
            f"Lighting quality: render time against error ({commit}, {args.width} px, median of 6 scenes)",
            curves,
            "core render seconds per view",
            "RMSE / mean vs reference",
        )
    if "adaptive" in args.knobs:
        written.append(out.with_name(out.stem + "-adaptive.svg"))
        scenes = len(LOCATIONS) * len(args.elevations)
        time_error_plot(
            written[-1],
            f"Adaptive anti-aliasing against brute force ({commit}, {args.width} px, "
            f"one thread, median of {scenes} scenes)",
            adaptive_curves(result["rows"], adaptive_levels),
            "core seconds per view",
            f"RMSE / mean vs {CONVERGED['spp']} spp",
        )
    print("\nmedian over scenes:")
    for s in summary:
        print(
            f"{s['knob']:<14} {str(s['level']):>12} {1e3 * s['median_seconds']:>8.1f} ms "
            f"{s['median_rel_rmse']:>8.4f} {s['median_psnr_8bit_db']:>6.1f} dB"
        )
        for name, q in s.get("regions", {}).items():
            if q:
                print(
                    f"{'':>30} {name:<16} bias {q['bias']:+.4f} noise {q['noise']:.4f} "
                    f"share {q['share_of_squared_error']:.2f}"
                )
    print(f"\nwritten {', '.join(p.name for p in written)} in {result['seconds_total']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
