"""Renders chosen orbit views of the configured scene into one directory per view. The scene is
composed and its BVH built once, then every view reuses it; in a dust scene each view moves only
the ejecta's mesh (moonbot.render.dust). Every view also gets each bag's amodal mask (the bag
rendered alone, moonbot.render.amodal): one single-bag scene per bag, built once, an instance
pass per bag and view; its cost is the `amodal` stage of the view's timings."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from moonbot import __version__
from moonbot.atomic_io import staged_directory
from moonbot.config import Config, config_hash
from moonbot.render import SceneDust, build_light_cache, build_scene, render_view, resolve_exposure
from moonbot.render.amodal import build_amodal_scenes, render_amodal_masks
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.scene.orbit import orbit_height
from moonbot.scene.placement import Placement
from moonbot.writer import write_sample


@dataclass(frozen=True)
class ViewResult:
    """Where a view was written and what it cost: `timings` in seconds per stage, `rays` counts
    (camera_rays, shadow_rays with bounce_shadow_rays of them, bounce_rays and medium_rays of the
    render, amodal_rays of the amodal masks' instance passes);
    `dust` is the view's dust record in gt.json (None in a scene without dust); `light_cache`
    (None without one) the task's light cache after this view: vertices_filled by this view, the
    thread-seconds that took within the render stage (fill_thread_s) and the bytes it holds. With a cache, `rays` also counts light_cache_rays and
    light_cache_shadow_rays, traced to fill this view's new vertices."""

    view: int
    out_dir: Path
    timings: dict
    rays: dict
    instance_pixels: dict
    dust: dict | None = None
    light_cache: dict | None = None


def view_seed(dataset_seed: int, view: int) -> int:
    """Render seed of one view: a pure function of the dataset seed and the view index (never of
    the worker, the thread count or the time), mixed so neighbouring views are unrelated."""
    z = (dataset_seed * 0x9E3779B97F4A7C15 + view + 1) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    return z ^ (z >> 31)


def run_views(
    config: Config,
    views: list[int],
    out_root: Path,
    threads: int | None = None,
    on_stage: Callable[[str], None] | None = None,
    placement: Placement | None = None,
) -> list[ViewResult]:
    """Renders `views` (orbit indices) of the config's scene into `out_root/view_NNN/` and returns
    per-view timings. A `placement` given (the scene's bags placed and settled once for all its
    tasks: moonbot.pipeline.placements) is used as it is, and its cost is not this run's: the
    views' timings then have no `settle` stage. `threads` overrides render.threads (the images
    do not depend on it, nor
    does the config hash the samples record). `on_stage(name)` is told each stage as it starts
    ("compose scene", "build BVH", "light cache" (render.indirect = cache), "dust setup", "amodal scenes", then per view k "dust view k",
    "render view k", "amodal view k", "encode view k"): a task's heartbeat. Raises ValueError for
    a view outside the orbit."""
    stage = on_stage or (lambda name: None)
    for v in views:
        if not 0 <= v < config.orbit.views:
            raise ValueError(f"view: must be in 0..{config.orbit.views - 1}, got {v}")
    digest = config_hash(config)
    if threads is not None:
        config = dataclasses.replace(config, render=dataclasses.replace(config.render, threads=threads))
    stage("compose scene")
    start = time.perf_counter()
    spec = compose_scene(config, placement)
    # Settling is its own stage, present only in scenes that settle here.
    settle_s = spec.placement.settle_seconds if placement is None else None
    terrain_s = spec.terrain_seconds  # 0 when this process had the terrain cached
    compose_s = time.perf_counter() - start - (settle_s or 0.0) - terrain_s
    stage("build BVH")
    start = time.perf_counter()
    scene = build_scene(spec, config.render.embree_isa)
    build_s = time.perf_counter() - start
    # The light cache (render.indirect = cache, bounces > 0) over the static scene, before the
    # dust adds its moving ejecta; empty here, filled as the views touch it.
    light_cache = None
    if config.render.indirect == "cache" and config.render.bounces > 0:
        stage("light cache")
        start = time.perf_counter()
        light_cache = build_light_cache(scene, config)
        light_cache_s = time.perf_counter() - start
    # Dust only when the scene calls for it: otherwise no simulation, no mesh, no medium, no stage.
    dust = None
    if config.dust.enabled:
        stage("dust setup")
        dust = SceneDust(scene, spec, config, views)
    # Each bag alone, for its amodal mask (BOP mask/); built once, paid by the first view.
    stage("amodal scenes")
    amodal_scenes = build_amodal_scenes(spec, config.render.embree_isa)
    amodal_build_s = amodal_scenes.seconds

    K = intrinsics(config.camera)
    exposure = resolve_exposure(config)
    results = []
    for v in views:
        azimuth = config.orbit.start_azimuth_deg + v * config.orbit.step_deg
        height = orbit_height(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth, spec.ground)
        pose = orbit_pose(spec.target, config.orbit.radius_m, height, azimuth)
        seed = view_seed(config.seed, v)
        view_dust = None
        if dust is not None:
            stage(f"dust view {v}")
            view_dust = dust.for_view(v)
        stage(f"render view {v}")
        cache_before = light_cache.stats() if light_cache is not None else None
        rendered = render_view(scene, config, K, pose, seed, view_dust.medium if view_dust else None, light_cache)
        out_dir = out_root / f"view_{v:03d}"
        timings = {"terrain": terrain_s, "compose": compose_s, "build_bvh": build_s}
        if light_cache is not None:
            # Its construction, paid by the first view; its filling runs inside the render stage.
            cache_after = light_cache.stats()
            timings["light_cache"] = light_cache_s
            light_cache_s = 0.0
        if view_dust is not None:  # its ejecta simulation, fragment mesh update and cloud
            timings["dust"] = view_dust.seconds
        timings["render"] = rendered.stats["seconds"]
        stage(f"amodal view {v}")
        amodal = render_amodal_masks(
            amodal_scenes, K, pose, config.camera.width, config.camera.height, config.render.threads
        )
        timings["amodal"] = amodal_build_s + amodal.seconds
        if settle_s is not None:
            timings["settle"] = settle_s
        meta = {
            "view": v,
            "camera_azimuth_deg": azimuth,
            "camera_height_m": height,  # above the target; above orbit.height_m where the ground rises
            "sun": {
                "azimuth_deg": config.sun.azimuth_deg,
                "elevation_deg": config.sun.elevation_deg,
                "irradiance_w_m2": config.sun.irradiance_w_m2,
            },
            "render_seed": seed,
            "config_hash": digest,
            "moonbot_version": __version__,
        }
        if view_dust is not None:
            meta["dust"] = view_dust.meta
        if spec.site is not None:  # a dem location: the world frame is this site's East-North-Up
            meta["site"] = spec.site.as_json()
        stage(f"encode view {v}")
        with staged_directory(out_dir) as staging:
            gt = write_sample(
                staging,
                rendered,
                exposure,
                K,
                pose,
                spec.bags,
                config.output.png_compression,
                meta,
                timings,
                exr=config.output.exr,
                amodal=amodal,
            )
        rays = {
            k: rendered.stats[k]
            for k in ("camera_rays", "shadow_rays", "bounce_shadow_rays", "bounce_rays", "medium_rays")
        }
        rays["amodal_rays"] = amodal.rays
        cache_record = None
        if light_cache is not None:  # what this view filled (each vertex once: deterministic)
            rays["light_cache_rays"] = cache_after["gather_rays"] - cache_before["gather_rays"]
            rays["light_cache_shadow_rays"] = cache_after["shadow_rays"] - cache_before["shadow_rays"]
            cache_record = {
                "vertices_filled": cache_after["vertices"] - cache_before["vertices"],
                "fill_thread_s": cache_after["fill_seconds"] - cache_before["fill_seconds"],
                "bytes": cache_after["bytes"],
            }
        pixels = {i.instance_id: i.px_count_visib for i in gt.instances}
        results.append(ViewResult(v, out_dir, gt.timings_s, rays, pixels, meta.get("dust"), cache_record))
        terrain_s = compose_s = build_s = amodal_build_s = 0.0  # paid once, by the first view
        settle_s = None if settle_s is None else 0.0
    return results
