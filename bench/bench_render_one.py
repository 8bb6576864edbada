"""Benchmark of `moonbot render-one` and of the renderer against Embree's own limit.

Measures, on this machine:
  1. render-one's stages (compose, BVH build, render, tone map, encode + write) on the embedded
     default config, median over repeats;
  2. what samples per pixel cost: time per frame against RMSE / PSNR versus a high-spp reference
     of the same view (accuracy against time);
  3. our render time against raw Embree time for exactly the same rays (`measure_embree_limit`:
     pixel-centre camera rays and the Sun shadow rays from their hits, as 64-ray streams and one
     ray at a time), on the default scene and on a 2.1 M-triangle terrain like the reference's
     (docs/design.md), on 1 and 2 threads.

Writes bench/results/render-one-<machine>.json and prints a table.
Run: ./dev.sh bench   (or .venv/bin/python bench/bench_render_one.py [--repeats N])
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.config import load_config
from moonbot.pipeline import run_views
from moonbot.render import build_scene, exposure_scale
from moonbot.render.view import core_camera
from moonbot.scene import compose_scene, intrinsics, orbit_pose, pixel_directions
from moonbot.scene.bag_mesh import variant_mesh
from moonbot.terrain.ground import flat_patch

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result

SCHEMA_VERSION = 1


def median_of(repeats: int, fn) -> float:
    return statistics.median(fn() for _ in range(repeats))


def stage_timings(repeats: int) -> dict:
    """render-one's stages on the default config: each repeat composes and builds afresh."""
    config = load_config()
    per_stage: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats):
            result = run_views(config, [0], Path(tmp) / str(r))[0]
            for stage, seconds in result.timings.items():
                per_stage.setdefault(stage, []).append(seconds)
    medians = {stage: statistics.median(v) for stage, v in per_stage.items()}
    medians["total"] = sum(medians.values())
    return {
        "config": "embedded default",
        "width": config.camera.width,
        "height": config.camera.height,
        "spp": config.render.spp,
        "median_s": medians,
    }


def default_view():
    config = load_config()
    spec = compose_scene(config)
    scene = build_scene(spec)
    K = intrinsics(config.camera)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, 0.0)
    camera = core_camera(K, config.camera.width, config.camera.height, pose)
    sun = _core.DirectionalLight(config.sun.azimuth_deg, config.sun.elevation_deg, config.sun.irradiance_w_m2)
    return config, scene, camera, sun


def spp_sweep(repeats: int, reference_spp: int) -> dict:
    """Time per frame and error against a `reference_spp` render of the same view, for the
    RGB pass (depth and masks do not depend on spp)."""
    config, scene, camera, sun = default_view()
    exposure = exposure_scale(config)
    ref = _core.render(scene, camera, sun, _core.RenderSettings(spp=reference_spp, seed=12345))["rgb"].astype(
        np.float64
    )
    ref8 = _core.tonemap_reinhard(ref.astype(np.float32), exposure)[0].astype(np.float64)
    rows = []
    for spp in (1, 2, 4, 8, 16):
        seconds = median_of(repeats, lambda: _core.render(scene, camera, sun, _core.RenderSettings(spp=spp))["seconds"])
        rgb = _core.render(scene, camera, sun, _core.RenderSettings(spp=spp))["rgb"].astype(np.float64)
        rmse = float(np.sqrt(np.mean((rgb - ref) ** 2)))
        mse8 = float(np.mean((_core.tonemap_reinhard(rgb.astype(np.float32), exposure)[0] - ref8) ** 2))
        rows.append(
            {
                "spp": spp,
                "render_s": seconds,
                "rmse_linear_w_m2_sr": rmse,
                "rel_rmse_linear": rmse / float(np.sqrt(np.mean(ref**2))),
                "psnr_8bit_db": float("inf") if mse8 == 0 else 10 * np.log10(255**2 / mse8),
            }
        )
    return {"reference_spp": reference_spp, "rows": rows}


def exact_depth_tradeoff(repeats: int, terrain) -> dict:
    """What `render.exact_depth` costs and buys: the geometry pass's time with and without it on
    the 2.1 M-triangle terrain, and the worst relative z-depth error on a tilted plane against
    its analytic value, near the origin and kilometres away."""
    scene, camera, sun, _ = terrain
    timing = {
        exact: median_of(
            repeats,
            lambda: _core.render(
                scene, camera, sun, _core.RenderSettings(exact_depth=exact), passes=["depth", "instance"]
            )["seconds"],
        )
        for exact in (True, False)
    }
    rows = []
    w, h = 160, 120
    K = np.array([[120.0, 0, w / 2], [0, 120.0, h / 2], [0, 0, 1]])
    for offset in (0.0, 100.0, 2000.0, 10000.0):
        plane_scene = _core.Scene()
        world = np.eye(4)
        c, s = np.cos(np.radians(10)), np.sin(np.radians(10))
        world[1:3, 1:3] = [[c, -s], [s, c]]
        world[:3, 3] = (offset, offset, 0.0)
        plane_scene.add_background(plane_scene.add_mesh(*flat_patch(100.0)), world, (0.1,) * 3)
        plane_scene.commit()
        pose = orbit_pose(np.array([offset, offset, 0.0]), 1.0, 0.6, 30.0)
        cam = core_camera(K, w, h, pose)
        d = pixel_directions(K, pose, w, h)
        n = world[:3, :3] @ np.array([0.0, 0.0, 1.0])
        t = (n @ (world[:3, 3] - pose.center)) / (d @ n)
        row = {"offset_m": offset}
        for exact in (True, False):
            depth = _core.render(plane_scene, cam, sun, _core.RenderSettings(exact_depth=exact), passes=["depth"])[
                "depth"
            ]
            hit = depth > 0
            row[f"max_rel_error_exact_{str(exact).lower()}"] = float(np.max(np.abs(depth[hit] - t[hit]) / t[hit]))
        rows.append(row)
    return {"terrain_geometry_pass_s": {"exact": timing[True], "embree_t": timing[False]}, "plane_error": rows}


def heightfield(n: int = 1024, size_m: float = 200.0, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A rolling n×n-quad terrain over size_m (2·n² triangles; n = 1024 gives the reference's
    2,097,152), sums of sinusoids with falling amplitude, zero height at the centre."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-size_m / 2, size_m / 2, n + 1)
    X, Y = np.meshgrid(x, x)
    Z = np.zeros_like(X)
    for octave in range(8):
        f = 4 * np.pi * 2**octave / size_m
        a = 1.5 / 2 ** (0.9 * octave)
        p = rng.uniform(0, 2 * np.pi, 3)
        Z += a * np.sin(f * X + p[0]) * np.cos(0.7 * f * Y + p[1]) + 0.5 * a * np.sin(1.3 * f * Y + 0.4 * f * X + p[2])
    Z -= Z[n // 2, n // 2]
    vertices = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]).astype(np.float32)
    i = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])]).astype(np.int32)
    return vertices, triangles


def terrain_view():
    config = load_config()
    vertices, triangles = heightfield()
    scene = _core.Scene()
    start = time.perf_counter()
    terrain = scene.add_mesh(vertices, triangles)
    build_s = time.perf_counter() - start
    bag_vertices, bag_triangles = variant_mesh(config.meshes, config.meshes.obj_id(config.bags.mesh))
    bag = scene.add_mesh(bag_vertices, bag_triangles)
    scene.add_background(terrain, np.eye(4), (config.terrain.albedo,) * 3)
    world = np.eye(4)
    world[2, 3] = -float(bag_vertices[:, 2].min())
    scene.add_instance(bag, world, 1, config.bags.albedo)
    scene.commit()
    K = intrinsics(config.camera)
    pose = orbit_pose(world[:3, 3], config.orbit.radius_m, config.orbit.height_m, 0.0)
    camera = core_camera(K, config.camera.width, config.camera.height, pose)
    sun = _core.DirectionalLight(config.sun.azimuth_deg, config.sun.elevation_deg, config.sun.irradiance_w_m2)
    return scene, camera, sun, {"triangles": int(len(triangles) + len(bag_triangles)), "terrain_bvh_build_s": build_s}


def against_limit(name: str, scene, camera, sun, repeats: int, extra: dict) -> dict:
    """Our spp = 1 render (rgb + depth + instance: centre rays + shadow rays) and geometry-only
    render (depth + instance: centre rays) against Embree alone on the same rays."""
    rows = []
    for threads in (1, 2):
        limit = _core.measure_embree_limit(scene, camera, sun, threads=threads, repeats=repeats)
        full = median_of(
            repeats, lambda: _core.render(scene, camera, sun, _core.RenderSettings(threads=threads))["seconds"]
        )
        geometry = median_of(
            repeats,
            lambda: _core.render(
                scene, camera, sun, _core.RenderSettings(threads=threads), passes=["depth", "instance"]
            )["seconds"],
        )
        raw_full = limit["intersect_stream_s"] + limit["occluded_stream_s"]
        rows.append(
            {
                "threads": threads,
                **limit,
                "render_full_s": full,
                "render_geometry_s": geometry,
                "ratio_full_vs_stream": full / raw_full,
                "ratio_geometry_vs_stream": geometry / limit["intersect_stream_s"],
                "ratio_full_vs_single": full / (limit["intersect_single_s"] + limit["occluded_single_s"]),
                "mrays_per_s_full": (limit["camera_rays"] + limit["shadow_rays"]) / full / 1e6,
            }
        )
    return {"scene": name, **extra, "rows": rows}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=9, help="timed repeats per figure (median)")
    parser.add_argument("--reference-spp", type=int, default=256)
    parser.add_argument(
        "--out", type=Path, default=None, help="result file (default: bench/results/render-one-<machine>.json)"
    )
    args = parser.parse_args()

    m = machine()
    print(f"machine  {m['cpu']}, {m['cores']} cores, {m['memory_gib']} GiB, {m['os']}, commit {m['git_commit'][:12]}")
    result = {"schema_version": SCHEMA_VERSION, "benchmark": "render-one", "machine": m}

    result["stages"] = stage_timings(args.repeats)
    print("\nrender-one stages, default config (median ms):")
    print("  " + "  ".join(f"{k} {1e3 * v:.1f}" for k, v in result["stages"]["median_s"].items()))

    result["spp"] = spp_sweep(args.repeats, args.reference_spp)
    print(f"\nsamples per pixel vs a {args.reference_spp}-spp reference (default view, all threads):")
    print(f"  {'spp':>4} {'ms':>7} {'rel RMSE':>9} {'PSNR 8-bit':>10}")
    for r in result["spp"]["rows"]:
        print(f"  {r['spp']:>4} {1e3 * r['render_s']:>7.2f} {r['rel_rmse_linear']:>9.4f} {r['psnr_8bit_db']:>9.2f} dB")

    config, scene, camera, sun = default_view()
    limits = [against_limit("default (flat patch + sandbag-01)", scene, camera, sun, args.repeats, {})]
    terrain = terrain_view()
    t_scene, t_camera, t_sun, t_extra = terrain
    limits.append(
        against_limit("terrain 2.1 M triangles + sandbag-01", t_scene, t_camera, t_sun, args.repeats, t_extra)
    )
    result["embree_limit"] = limits
    print("\nour render vs Embree alone on the same rays (spp 1; ms, median):")
    print(
        f"  {'scene':<44} {'thr':>3} {'cam rays':>9} {'shadow':>8} {'E1 isect':>8} {'E1M isect':>9} "
        f"{'E1M occl':>8} {'ours full':>9} {'ours geo':>8} {'full/raw':>8} {'geo/raw':>7}"
    )
    for block in limits:
        for r in block["rows"]:
            print(
                f"  {block['scene']:<44} {r['threads']:>3} {r['camera_rays']:>9} {r['shadow_rays']:>8} "
                f"{1e3 * r['intersect_single_s']:>8.2f} {1e3 * r['intersect_stream_s']:>9.2f} "
                f"{1e3 * r['occluded_stream_s']:>8.2f} {1e3 * r['render_full_s']:>9.2f} "
                f"{1e3 * r['render_geometry_s']:>8.2f} {r['ratio_full_vs_stream']:>8.2f} "
                f"{r['ratio_geometry_vs_stream']:>7.2f}"
            )

    result["exact_depth"] = exact_depth_tradeoff(args.repeats, terrain)
    e = result["exact_depth"]
    print(
        "\nrender.exact_depth: geometry pass on the terrain "
        f"{1e3 * e['terrain_geometry_pass_s']['exact']:.2f} ms exact vs "
        f"{1e3 * e['terrain_geometry_pass_s']['embree_t']:.2f} ms with Embree's t; worst relative depth error:"
    )
    for r in e["plane_error"]:
        print(
            f"  {r['offset_m']:>7.0f} m from the origin: exact {r['max_rel_error_exact_true']:.1e}, "
            f"Embree's t {r['max_rel_error_exact_false']:.1e}"
        )

    out = write_result(result, "render-one", args.out)
    print(f"\nwritten {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
