"""Generation throughput: samples/s of `moonbot generate` on this machine
with 1 worker on 1 core, 1 worker with 2 render threads and 2 worker processes (scaling efficiency), the peak resident memory of a worker on the
heaviest scene of the sweep (crater, 11 bags, dust; target under 2 GiB), and the projection of
the full SynBag-1.0 sweep onto N such machines.

Throughput: 2 tasks of configs/synbag-1.0.yaml's train split (flat location, one bag, clear and
dusty, Sun 12°) at its full quality (640×480, the default render level), 36 views a task as in
the sweep: a task's light cache, BVH and amodal scenes are paid once for its 36 views (the terrain
is warmed once per worker, outside the timed span). samples/s = samples / (last task's end − first task's start), from the tasks'
stats.json. Efficiency = samples/s(2 workers, or 1 worker × 2 threads) / (2 × samples/s(1 worker
× 1 thread)). Core-seconds a sample = workers × threads × seconds / samples. The record also keeps
the megapixel-samples and bytes so `moonbot plan` can scale it to any sweep.

The Embree floor: what the rays of the 1 worker × 1 thread run (its tasks' stats.json counts:
camera, shadow, medium and bounce rays and the light cache's gathers) cost at Embree's own speed,
probed on one thread on each task's scene (moonbot.benchmark.limit, as `moonbot bench
throughput` probes it), in core-seconds a sample. No shading, no encoding, no scene build: what
a renderer that traced these rays and did nothing else would take, the bound on any speed-up
that keeps the rays.

The task mix: the throughput tasks above are among the sweep's cheapest (flat, one bag, Sun
12°), so the projection is priced on a sample of the sweep's own mix instead. Its train split
(99.3 % of the samples) is a grid whose cost turns mostly on the location and the bag count
(refined edges, the bags' light-cache nodes, 11 bags to settle); the mix takes one task from each
of those 9 strata (an L9 orthogonal array: every mesh, stain count and camera height three
times, dust on in 4 of 9, every Sun elevation once or twice, both azimuths), renders them on the
fastest layout measured above, and reports their mean core-seconds a sample with its standard
error over the strata, its own Embree floor, and the projection `moonbot plan` then prints. Its
tasks are drawn in splits of their own (`mix-<location>-b<bags>`), so their scenes are the
sweep's in kind, not the same draws. The test split (36 tasks, 8 bags, Sun 30°) is left out.

Writes bench/results/generate-<machine>.json. Run:
  .venv/bin/python bench/bench_generate.py
"""

from __future__ import annotations

import dataclasses
import math
import resource
import statistics
import sys
import tempfile
from pathlib import Path

from distributed import Client, LocalCluster

from moonbot.benchmark.limit import embree_limit, ray_limit_seconds
from moonbot.config import load_config
from moonbot.pipeline.generate import generate
from moonbot.pipeline.stats import load_placements
from moonbot.records.stats import read_stats
from moonbot.sweep import tasks
from moonbot.sweep.plan import estimate_from, fastest_run, split_plans

from fingerprint import machine  # bench/ is on sys.path when run as a script
from result_file import write_result

ROOT = Path(__file__).resolve().parents[1]
SCHEMA_VERSION = 1
VIEWS = 36
NODES = [1, 10, 50, 100]


def throughput_config():
    return load_config(
        ROOT / "configs" / "synbag-1.0.yaml",
        {
            "orbit.views": VIEWS,
            "orbit.step_deg": 360.0 / VIEWS,
            "sweep.splits": [
                {
                    "name": "train",
                    "meshes": ["sandbag-01"],
                    "locations": ["flat"],
                    "bag_counts": [1],
                    "stain_seeds": [0],
                    "dust": [False, True],
                    "sun_elevations_deg": [12.0],
                    "sun_azimuths_deg": [120.0],
                    "camera_heights_m": [0.5],
                }
            ],
        },
    )


def task_mix_config():
    """SynBag-1.0 reduced to the module docstring's task mix: one single-task split per
    location × bag count of its train split, the other axes set by an L9 orthogonal array over
    (location a, bag count b): mesh (a + b), stain (a + 2b), camera height (2a + b), each mod 3;
    dust on for odd j = 3a + b, Sun elevation j mod 5, azimuth ⌊j / 2⌋ mod 2, indices into the
    split's own lists."""
    sweep = load_config(ROOT / "configs" / "synbag-1.0.yaml")
    train = next(s for s in sweep.sweep.splits if s.name == "train")

    def pick(values: tuple, k: int) -> list:
        return [values[k % len(values)]]

    splits = []
    for a, location in enumerate(train.locations):
        for b, bags in enumerate(train.bag_counts):
            j = 3 * a + b
            splits.append(
                {
                    "name": f"mix-{location}-b{bags}",
                    "meshes": pick(train.meshes, a + b),
                    "locations": [location],
                    "bag_counts": [bags],
                    "stain_seeds": pick(train.stain_seeds, a + 2 * b),
                    "dust": pick(train.dust, j),
                    "sun_elevations_deg": pick(train.sun_elevations_deg, j),
                    "sun_azimuths_deg": pick(train.sun_azimuths_deg, j // 2),
                    "camera_heights_m": pick(train.camera_heights_m, 2 * a + b),
                }
            )
    return load_config(
        ROOT / "configs" / "synbag-1.0.yaml",
        {"orbit.views": VIEWS, "orbit.step_deg": 360.0 / VIEWS, "sweep.splits": splits},
    )


def run(workers: int, threads: int, config=None) -> dict:
    """`moonbot generate` of `config` (default: throughput_config()) on a fresh local cluster of
    `workers` × `threads`: the run's row of the record (its tasks' rays and stages, and each task's
    core-seconds a sample: its render threads × its wall seconds / its samples)."""
    config = config or throughput_config()
    with tempfile.TemporaryDirectory() as tmp:
        result = generate(config, Path(tmp), workers=workers, threads=threads, progress=None)
        assert not result.failed, result.failed
        stats = [read_stats(p) for p in Path(tmp).glob("tasks/*/stats.json")]
        # The layouts' placing and settling, once each (moonbot.pipeline.placements): stages too.
        placements = load_placements(Path(tmp))
    starts = [s.start_seconds() for s in stats]
    ends = [t + s.wall_s for t, s in zip(starts, stats)]
    samples = sum(s.samples for s in stats)
    span = max(ends) - min(starts)
    plans = split_plans(config)
    stages = [s.stages_s for s in stats] + [p["stages_s"] for p in placements]
    return {
        "workers": workers,
        "threads_per_worker": threads,
        "tasks": len(stats),
        "samples": samples,
        "seconds": span,
        "samples_per_s": samples / span,
        "core_seconds_per_sample": workers * threads * span / samples,
        "bytes": sum(s.bytes_written for s in stats),
        "megapixel_samples": sum(p.megapixel_samples for p in plans),
        "megapixels": sum(p.megapixels for p in plans),
        "layouts": len(placements),
        "stages_s": {k: sum(s.get(k, 0.0) for s in stages) for k in sorted({k for s in stages for k in s})},
        "rays_by_task": {s.task_id: dict(s.rays or {}) for s in stats},
        # A task runs on one worker, on its `threads` render threads.
        "core_seconds_per_sample_by_task": {s.task_id: threads * s.wall_s / s.samples for s in stats},
    }


def embree_floor(run_row: dict, config=None) -> dict:
    """The module docstring's Embree floor of `run_row` (a run of `run` on `config`, default
    throughput_config()): core-seconds a sample, in all and by kind of ray, with the probe's
    per-ray costs."""
    config = config or throughput_config()
    bounces = config.render.bounces
    seconds = {"camera": 0.0, "shadow": 0.0, "light_cache_and_bounces": 0.0}
    for task in tasks(config):
        rays = run_row["rays_by_task"][task.task_id]
        (row,) = embree_limit(config, task, [1], bounces)
        # As ray_limit_seconds prices them: the camera hits' shadow rays at the shadow-ray rate,
        # the bounce vertices' with the bounce and gather rays at the pooled bounce rates.
        camera = row["camera_s_per_ray"] * (rays.get("camera_rays", 0) + rays.get("medium_rays", 0))
        shadow = row["shadow_s_per_ray"] * (rays.get("shadow_rays", 0) - rays.get("bounce_shadow_rays", 0))
        seconds["camera"] += camera
        seconds["shadow"] += shadow
        seconds["light_cache_and_bounces"] += ray_limit_seconds(rays, row, bounces) - camera - shadow
    samples = run_row["samples"]
    floor = sum(seconds.values()) / samples
    return {
        "core_seconds_per_sample": floor,
        "by_kind_core_seconds_per_sample": {k: v / samples for k, v in seconds.items()},
        "rays_per_sample": {
            k: sum(r.get(k, 0) for r in run_row["rays_by_task"].values()) / samples
            for k in sorted({k for r in run_row["rays_by_task"].values() for k in r})
        },
        "ratio": run_row["core_seconds_per_sample"] / floor if floor > 0 else 0.0,
        "probe": "moonbot.benchmark.limit.embree_limit on one thread, view 0 of each task, bags unsettled",
    }


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def heaviest_task_memory() -> dict:
    """Peak RSS of a fresh worker process after one task of the crater location with 11 bags and
    dust at full quality (VIEWS views: the light cache grows with the views it serves)."""
    config = load_config(
        ROOT / "configs" / "synbag-1.0.yaml",
        {
            "orbit.views": VIEWS,
            "orbit.step_deg": 360.0 / VIEWS,
            "sweep.splits": [
                {
                    "name": "train",
                    "meshes": ["sandbag-03"],
                    "locations": ["crater"],
                    "bag_counts": [11],
                    "stain_seeds": [90],
                    "dust": [True],
                    "sun_elevations_deg": [12.0],
                    "sun_azimuths_deg": [120.0],
                    "camera_heights_m": [0.5],
                }
            ],
        },
    )
    with (
        tempfile.TemporaryDirectory() as tmp,
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=40
        ) as cluster,
        Client(cluster) as client,
    ):
        before = max(client.run(_peak_rss_mib).values())
        result = generate(config, Path(tmp), client=client, progress=None)
        assert not result.failed, result.failed
        peak = max(client.run(_peak_rss_mib).values())
    return {
        "scene": "crater, 11 bags of sandbag-03, 90 stain seeds, dust",
        "views": VIEWS,
        "worker_peak_rss_mib_before": before,
        "worker_peak_rss_mib": peak,
        "target_mib": 2048,
    }


def main() -> int:
    record = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "generate",
        "machine": machine(),
        "views_per_task": VIEWS,
        "runs": [],
    }
    for workers, threads in ((1, 1), (1, 2), (2, 1)):
        row = run(workers, threads)
        record["runs"].append(row)
        print(
            f"{workers} worker(s) × {threads} render thread(s): {row['samples']} samples in {row['seconds']:.1f} s = "
            f"{row['samples_per_s']:.3f} samples/s, {row['core_seconds_per_sample']:.2f} core-s a sample; {row['bytes'] / row['samples'] / 1e6:.2f} MB a sample"
        )
    one, threaded, two = record["runs"]
    record["embree_floor"] = embree_floor(one)
    floor = record["embree_floor"]
    print(
        f"Embree floor of the 1 × 1 run's rays: {floor['core_seconds_per_sample']:.2f} core-s a sample "
        + ", ".join(f"{k} {v:.2f}" for k, v in floor["by_kind_core_seconds_per_sample"].items())
        + f"; the run took {floor['ratio']:.2f}× that"
    )
    # Against one worker on one core: what a second worker process, or a second render thread, buys.
    record["scaling_efficiency_2_workers"] = two["samples_per_s"] / (2 * one["samples_per_s"])
    record["scaling_efficiency_2_threads"] = threaded["samples_per_s"] / (2 * one["samples_per_s"])
    print(
        f"scaling efficiency on 2 cores: 2 workers {record['scaling_efficiency_2_workers']:.2f}, "
        f"1 worker × 2 threads {record['scaling_efficiency_2_threads']:.2f}"
    )
    best = fastest_run(record)
    mix_config = task_mix_config()
    mix = run(best["workers"], best["threads_per_worker"], mix_config)
    by_task = list(mix["core_seconds_per_sample_by_task"].values())
    mix["standard_error_core_seconds_per_sample"] = statistics.stdev(by_task) / math.sqrt(len(by_task))
    mix["embree_floor"] = embree_floor(mix, mix_config)
    mix["splits"] = [dataclasses.asdict(split) for split in mix_config.sweep.splits]
    record["task_mix"] = mix
    print(
        f"the sweep's task mix ({mix['tasks']} tasks, {best['workers']} worker(s) × {best['threads_per_worker']} "
        f"thread(s)): {mix['core_seconds_per_sample']:.2f} ± {mix['standard_error_core_seconds_per_sample']:.2f} "
        f"core-s a sample (per task {min(by_task):.2f}–{max(by_task):.2f}); Embree floor "
        f"{mix['embree_floor']['core_seconds_per_sample']:.2f}, {mix['embree_floor']['ratio']:.2f}× that"
    )
    memory = heaviest_task_memory()
    record["memory"] = memory
    print(
        f"worker peak RSS on {memory['scene']}: {memory['worker_peak_rss_mib']:.0f} MiB "
        f"(target {memory['target_mib']} MiB)"
    )
    # As `moonbot plan` prices it: the task mix's time split by stage into per sample, per task
    # and per layout, each scaled by the sweep's count.
    found = estimate_from(split_plans(load_config(ROOT / "configs" / "synbag-1.0.yaml")), record, "this run")
    record["projection"] = [{"nodes": n, "hours": found.seconds / n / 3600} for n in NODES]
    record["projection_note"] = (
        "moonbot.sweep.plan.estimate of the task mix, linear in nodes of this machine's kind, each "
        "run as the fastest layout measured here; the scheduler's ~1 ms a task is negligible next to a task"
    )
    for p in record["projection"]:
        print(f"full SynBag-1.0 sweep on {p['nodes']:>3} node(s): {p['hours']:.1f} h")
    out = write_result(record, "generate")
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
