"""The render stage against Embree alone, scene by scene: where the gap to
`moonbot bench throughput`'s limit is, without the pipeline around it.

For each task of configs/bench/throughput-v1.yaml and each quality level, view 0 is built as the
throughput limit's probe builds it (moonbot.benchmark.limit.limit_scene: bags unsettled, a dust
scene's view-0 fragments in place), rendered once to warm up and then `--repeats` times with the
machine's cores, and probed (`_core.measure_embree_limit`, the level's bounce generations). The
render's own ray counts at the probe's per-ray costs give its Embree limit (ray_limit_seconds,
as the throughput benchmark charges a run); the ratio is the render's median (and fastest)
seconds over it. Unlike the throughput benchmark's per-task figures, no amodal pass, tone map or
second view is mixed in, and the probe and the renders see the same view.

A level that reads indirect light from the light cache (render.indirect = cache) gets the task's
cache (moonbot.render.view.build_light_cache), which the warm-up render fills for view 0's
vertices: the timed renders then read it as a 36-view task's later views read what earlier views
filled, and trace no gather ray. The fill is recorded apart (`light_cache_fill`: its rays, its
thread-seconds, its bytes); the ratio is the steady state of a view, our shading and the cache's
reads included, against Embree on the rays that view traces.

With `--perf` (Linux `perf` on PATH), the timed renders are also sampled by `perf record` and
the share of samples per shared object is recorded: Embree's share is its time inside the
renderer, the rest is shading, the tile loop and the dust.

Writes bench/results/render-scenes-<machine>.json. Run:
  .venv/bin/python bench/bench_render_scenes.py [--repeats 7] [--levels default] [--perf]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from moonbot.benchmark.levels import LEVELS, level_config
from moonbot.benchmark.limit import limit_scene, probe, ray_limit_seconds
from moonbot.pipeline.views import view_seed
from moonbot.render.view import build_light_cache, render_view
from moonbot.sweep import tasks

from fingerprint import library_versions, machine  # bench/ is on sys.path when run as a script
from result_file import write_result

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "bench" / "throughput-v1.yaml"
SCHEMA_VERSION = 1
RAY_KINDS = ("camera_rays", "shadow_rays", "bounce_shadow_rays", "bounce_rays", "medium_rays")


class Profile:
    """`perf record` attached to this process while in the `with` block; `shares` then maps each
    shared object to its percentage of the samples (empty if perf is missing or fails)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled and shutil.which("perf") is not None
        self.shares: dict[str, float] = {}

    def __enter__(self):
        if self.enabled:
            self._dir = tempfile.TemporaryDirectory()
            self._data = Path(self._dir.name) / "perf.data"
            self._proc = subprocess.Popen(
                ["perf", "record", "-q", "-F", "999", "-p", str(os.getpid()), "-o", str(self._data)],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            time.sleep(0.5)  # perf takes a moment to attach; renders before that go unsampled
        return self

    def __exit__(self, *exc):
        if not self.enabled:
            return
        self._proc.send_signal(signal.SIGINT)
        self._proc.wait(timeout=60)
        report = subprocess.run(
            ["perf", "report", "-i", str(self._data), "--stdio", "--sort", "dso"], capture_output=True, text=True
        ).stdout
        for line in report.splitlines():
            m = re.match(r"\s+([0-9.]+)%\s+(\S+)", line)
            if m:
                self.shares[m.group(2)] = float(m.group(1))
        self._dir.cleanup()


def measure(level: str, task, repeats: int, threads: int, perf: bool) -> dict:
    config = level_config(CONFIG, level, {})
    view = limit_scene(config, task)
    c = dataclasses.replace(view.config, render=dataclasses.replace(view.config.render, threads=threads))
    seed = view_seed(c.seed, 0)
    cache = build_light_cache(view.scene, c)
    # Warm-up: first-touch pages, caches, and the light cache's fill for this view.
    render_view(view.scene, c, view.K, view.pose, seed, view.medium, light_cache=cache)
    fill = cache.stats() if cache is not None else None
    row = probe(view, task.task_id, threads, c.render.bounces)
    seconds = []
    with Profile(perf) as profile:
        for _ in range(repeats):
            out = render_view(view.scene, c, view.K, view.pose, seed, view.medium, light_cache=cache)
            seconds.append(out.stats["core_seconds"])
    rays = {k: int(out.stats[k]) for k in RAY_KINDS}
    limit_s = ray_limit_seconds(rays, row, c.render.bounces)
    median = statistics.median(seconds)
    return {
        "task_id": task.task_id,
        "dust": c.dust.enabled,
        "bags": c.bags.count,
        "rays": rays,
        "render_s": seconds,
        "render_median_s": median,
        "render_min_s": min(seconds),
        "limit_s": limit_s,
        "ratio": median / limit_s,
        "ratio_fastest": min(seconds) / limit_s,
        "perf_dso_percent": profile.shares,
        "light_cache_fill": (
            None
            if fill is None
            else {k: fill[k] for k in ("gather_rays", "shadow_rays", "probe_rays", "fill_seconds", "bytes")}
        ),
        "probe": row,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7, help="timed renders a scene (median reported)")
    parser.add_argument("--levels", default=",".join(LEVELS), help="comma-separated quality levels")
    parser.add_argument("--perf", action="store_true", help="sample the timed renders with Linux perf")
    args = parser.parse_args()
    levels = [lv for lv in args.levels.split(",") if lv]
    unknown = [lv for lv in levels if lv not in LEVELS]
    if unknown or args.repeats < 1:
        parser.error(
            f"--levels: unknown {unknown} (known: {', '.join(LEVELS)})" if unknown else "--repeats: must be at least 1"
        )
    threads = os.cpu_count() or 1
    record = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "render-scenes",
        "config": CONFIG.name,
        "machine": machine(),
        "libraries": library_versions(),
        "threads": threads,
        "repeats": args.repeats,
        "levels": {},
    }
    bench_tasks = tasks(level_config(CONFIG, levels[0], {}))
    for level in levels:
        rows = [measure(level, t, args.repeats, threads, args.perf) for t in bench_tasks]
        render, limit = sum(r["render_median_s"] for r in rows), sum(r["limit_s"] for r in rows)
        record["levels"][level] = {"scenes": rows, "render_s": render, "limit_s": limit, "ratio": render / limit}
        for r in rows:
            shares = r["perf_dso_percent"]
            embree = next((v for k, v in shares.items() if "embree" in k), None)
            print(
                f"{level:<8} {r['task_id'][:40]:<40} render {r['render_median_s']:.3f} s (fastest "
                f"{r['render_min_s']:.3f}), Embree limit {r['limit_s']:.3f} s: {r['ratio']:.2f}×"
                + (f", Embree {embree:.0f} % of samples" if embree is not None else "")
            )
        print(f"{level:<8} all four: {render:.3f} s against {limit:.3f} s = {render / limit:.2f}×")
    out = write_result(record, "render-scenes")
    print(f"written {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
