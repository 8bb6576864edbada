"""Embree's instruction sets and watertight traversal, timed and checked on this machine.

Speed: view 0 of each task of configs/bench/throughput-v1.yaml at the default level (bags
unsettled, a dust scene's view-0 fragments in place, as the throughput limit's probe builds it),
rendered with every ISA this CPU offers, watertight, and with the widest ISA and AVX2 without
watertightness (Embree's default BVHs, no second look at shared vertices). The variants take turns
render by render, so a slow spell of a shared machine falls on all of them; each figure is the
median of `--repeats` renders on all cores. All renders run in Embree's incoherent mode: the
coherent kernels hang on AVX-512 CPUs in Debian's Embree 3.13.5 (moonbot's accel.h).

Leaks: depth and instance passes, watertight and not, (a) of the embedded default view at
4096×3072 and (b) of 36-view orbits at 640×480 around 5 scattered bags on the flat and hilly
locations. A hole is a pixel with no depth although its ray points more than 1° below the
horizon (moonbot.eval.validate.depth_holes, as `moonbot validate` checks); a back-face pixel is a bag pixel more than 2 cm behind the median of its
neighbours of the same bag (a ray that slipped into the bag and met its far side; at 640×480 a
bag's own creases and silhouettes trip this too, so there the count that tells is `moved`: the
pixels whose depth or instance differs by more than 1 cm between the two renders).

Writes bench/results/embree-isa-<machine>.json. Run:
  .venv/bin/python bench/bench_embree_isa.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
from pathlib import Path

import numpy as np

from moonbot import _core
from moonbot.benchmark.levels import level_config
from moonbot.config import load_config
from moonbot.eval.validate import depth_holes
from moonbot.pipeline.views import view_seed
from moonbot.render import SceneDust
from moonbot.render.view import build_scene, orbit_view, render_view, view_inputs
from moonbot.scene import compose_scene
from moonbot.sweep import task_config, tasks

from fingerprint import library_versions, machine  # bench/ is on sys.path when run as a script
from result_file import write_result

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "bench" / "throughput-v1.yaml"
SCHEMA_VERSION = 1
BACK_FACE_STEP_M = 0.02


def variants() -> list[tuple[str, bool]]:
    isas = _core.embree_isas()
    plain = [isa for isa in (isas[-1], "avx2") if isa in isas]
    return [(isa, True) for isa in isas] + [(isa, False) for isa in dict.fromkeys(plain)]


def speed(repeats: int, threads: int) -> list[dict]:
    config = level_config(CONFIG, "default", {})
    rows = []
    for task in tasks(config):
        c = task_config(config, task)
        c = dataclasses.replace(
            c,
            bags=dataclasses.replace(c.bags, settle=dataclasses.replace(c.bags.settle, enabled=False)),
            render=dataclasses.replace(c.render, threads=threads),
        )
        spec = compose_scene(c)
        K, pose = orbit_view(c, spec, 0)
        seed = view_seed(c.seed, 0)
        built = {}
        for isa, watertight in variants():
            scene = build_scene(spec, isa, watertight)
            medium = SceneDust(scene, spec, c, [0]).for_view(0).medium if c.dust.enabled else None
            render_view(scene, c, K, pose, seed, medium)  # warm-up
            built[(isa, watertight)] = (scene, medium)
        seconds = {key: [] for key in built}
        second_looks = {}
        for _ in range(repeats):
            for key, (scene, medium) in built.items():
                out = render_view(scene, c, K, pose, seed, medium)
                seconds[key].append(out.stats["core_seconds"])
                second_looks[key] = int(out.stats.get("second_look_rays", 0))
        for (isa, watertight), s in seconds.items():
            rows.append(
                {
                    "task_id": task.task_id,
                    "embree_isa": isa,
                    "watertight": watertight,
                    "render_s": s,
                    "render_median_s": statistics.median(s),
                    "second_look_rays": second_looks[(isa, watertight)],
                }
            )
            print(
                f"{task.task_id[:40]:<40} {isa:<7} {'watertight' if watertight else 'plain':<10} "
                f"{statistics.median(s):.3f} s (min {min(s):.3f})",
                flush=True,
            )
    return rows


def leaks(depth: np.ndarray, instance: np.ndarray, K: np.ndarray, R: np.ndarray) -> dict:
    """Holes and back-face bag pixels of one view (module docstring), the latter away from the border."""
    d = np.pad(depth, 1)
    ids = np.pad(instance, 1)
    h, w = depth.shape
    neighbours = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    around = np.stack([d[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] for dy, dx in neighbours])
    same = np.stack([ids[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] for dy, dx in neighbours]) == instance
    inner = np.zeros_like(depth, bool)
    inner[1:-1, 1:-1] = True
    holes = depth_holes(depth, K, R)
    peers = np.where(same & (around > 0), around, np.nan)
    with np.errstate(all="ignore"):
        local = np.nanmedian(peers, axis=0)
    back = inner & (instance > 0) & (np.sum(same, axis=0) >= 5) & (depth > local + BACK_FACE_STEP_M)
    return {"holes": int(holes.sum()), "back_face_bag_pixels": int(back.sum())}


def leak_counts() -> dict:
    out = {}
    big = load_config(None, {"camera.width": 4096, "camera.height": 3072})
    spec = compose_scene(big)
    view = view_inputs(big, spec, 0)
    cameras = [(view.K, view.pose.R, view.camera)]
    out["default_4096x3072"] = compare_watertight(spec, cameras)
    for location in ("flat", "hilly"):
        c = load_config(
            None,
            {
                "terrain.location": location,
                "bags.count": 5,
                "bags.layout": "scattered",
                "camera.width": 640,
                "camera.height": 480,
            },
        )
        spec = compose_scene(c)
        views = [view_inputs(c, spec, v) for v in range(c.orbit.views)]
        cameras = [(view.K, view.pose.R, view.camera) for view in views]
        out[f"{location}_5_bags_36_views_640x480"] = compare_watertight(spec, cameras)
    for name, counts in out.items():
        print(f"{name:<32} {counts}", flush=True)
    return out


def compare_watertight(spec, cameras: list) -> dict:
    """Depth and instance passes of every camera ((K, R_w2c, _core.Camera)), plain and watertight:
    leaks() of each, summed,
    the pixels that moved between the two, and the watertight render's second looks."""
    scenes = {w: build_scene(spec, watertight=w) for w in (False, True)}
    sun = _core.DirectionalLight(0.0, 30.0, 0.0)
    total = {
        "plain": {"holes": 0, "back_face_bag_pixels": 0},
        "watertight": {"holes": 0, "back_face_bag_pixels": 0},
        "moved": 0,
        "second_look_rays": 0,
        "pixels": 0,
    }
    for K, R, camera in cameras:
        r = {w: _core.render(scenes[w], camera, sun, passes=["depth", "instance"]) for w in scenes}
        for w, name in ((False, "plain"), (True, "watertight")):
            for k, n in leaks(r[w]["depth"], r[w]["instance"], K, R).items():
                total[name][k] += n
        moved = (np.abs(r[True]["depth"] - r[False]["depth"]) > 0.01) | (r[True]["instance"] != r[False]["instance"])
        total["moved"] += int(moved.sum())
        total["second_look_rays"] += r[True]["second_look_rays"]
        total["pixels"] += r[True]["depth"].size
    return total


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed renders a scene and variant (median)")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats: must be at least 1")
    threads = os.cpu_count() or 1
    record = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "embree-isa",
        "config": CONFIG.name,
        "machine": machine(),
        "libraries": library_versions(),
        "threads": threads,
        "repeats": args.repeats,
        "load_before": list(os.getloadavg()),
    }
    record["leaks"] = leak_counts()
    record["speed"] = speed(args.repeats, threads)
    record["load_after"] = list(os.getloadavg())
    summary = {}
    for row in record["speed"]:
        key = f"{row['embree_isa']}{'' if row['watertight'] else ' plain'}"
        summary[key] = summary.get(key, 0.0) + row["render_median_s"]
    record["summary_render_s_four_scenes"] = summary
    for key, s in summary.items():
        print(f"four scenes, {key:<14} {s:.3f} s")
    out = write_result(record, "embree-isa")
    print(f"written {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
