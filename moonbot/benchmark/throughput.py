"""`moonbot bench throughput`: the fixed benchmark config (configs/bench/throughput-v1.yaml) run
through moonbot's real `generate` on a LocalCluster, at each quality level (levels.py) and each
worker count asked for, against the limit (limit.py), with a projection of the full SynBag-1.0
sweep. The result is one JSON file (schema: compare.py) named after the machine and the date.

Definitions (a run = one level on one worker count W with T render threads a worker; times in
seconds; "worker-seconds" are sums over tasks, which on W workers run W at a time):

- span = last task end − first task start (stats.json's started_utc + wall_s): cluster start,
  terrain warm-up (once per worker process, timed apart as `terrain_warmup_s`) and the encode
  limit's measurement fall outside it. samples/s = samples / span.
- stages: stats.json's own (terrain, compose, settle, build_bvh, dust, render, amodal, tonemap,
  encode_write), in worker-seconds, and grouped as the issue names them: scene build = terrain +
  compose + settle + build_bvh; dust; render = render + amodal + tonemap; encode/write.
- Mrays/s = (camera + shadow + bounce + dust-medium rays, all traced in the render stage) /
  render-stage seconds: what a worker's T threads sustain while rendering, shading and the dust
  medium's grid included (the amodal masks' rays, against one-bag scenes, are left out).
- peak memory: ru_maxrss of each worker process after the run (the largest since the worker
  started, terrain warm-up and earlier levels of the same W included) and of this driver.
- the limit, on P = W·T threads: Embree seconds for the run's rays at the per-ray costs (camera,
  shadow, bounce) measured on each task's own scene (limit.py) plus the encoders' best time for the run's own files.
  Ratios: render = (render stage / W) / Embree's; encode = (encode_write / W) / the encoders';
  render_encode = the two together (render + tonemap + encode_write, the issue's "encoding
  included"); pipeline = (span / samples) / (limit / samples), everything the run does per sample
  (scene build, settling, dust, amodal masks included) against rays + encoding only.
- scaling efficiency of W workers = (samples/s(W) / W) / (samples/s(W0) / W0), W0 the fewest
  workers measured at that level (the same T a worker).
- projection: a task's worker-seconds = fixed + views × per view, fixed = its scene-build stages,
  per view the rest of its wall time; the best run's seconds per sample rescaled from the
  benchmark's views per task to the sweep's, times the sweep's samples; on N nodes / N. Disk:
  bytes per sample × samples. The light cache's fill happens within the views' render stage, and
  how much of it a task's later views add depends on how much new ground they see, so it counts
  as per view: with few views a task, an upper bound for the sweep (bench/bench_generate.py runs
  tasks of the sweep's 36 views).
"""

from __future__ import annotations

import datetime
import hashlib
import os
import re
import resource
import tempfile
import time
from pathlib import Path

from moonbot.benchmark.fingerprint import RESULTS_DIR, library_versions, machine
from moonbot.benchmark.levels import LEVELS, level_config
from moonbot.benchmark.limit import embree_limit, encode_limit, encode_limit_seconds, ray_limit_seconds
from moonbot.host import machine_slug
from moonbot.pipeline.stats.collect import read_task_stats
from moonbot.records.bench import SCHEMA_VERSION, decode_bench_result, write_bench_result
from moonbot.records.stats import StatsRecord

# The checkout's configs, relative to the working directory (the checkout when run from it).
DEFAULT_CONFIG = Path("configs") / "bench" / "throughput-v1.yaml"
SWEEP_CONFIG = Path("configs") / "synbag-1.0.yaml"
NODES = (1, 10, 50, 100)
STAGE_GROUPS = {
    "scene_build": ("terrain", "compose", "settle", "build_bvh"),
    "dust": ("dust",),
    "render": ("render", "amodal", "tonemap"),
    "encode_write": ("encode_write",),
}
RAY_KINDS = ("camera_rays", "shadow_rays", "bounce_shadow_rays", "bounce_rays", "medium_rays", "amodal_rays")


def default_out(m: dict) -> Path:
    """bench/results/<machine slug>-<UTC date>.json."""
    return RESULTS_DIR / f"{machine_slug(m)}-{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d}.json"


def config_identity(path: Path) -> dict:
    """The benchmark config's file name, version (from its name: throughput-v<N>.yaml) and sha256."""
    path = Path(path)
    match = re.search(r"-v(\d+)$", path.stem)
    return {
        "file": path.name,
        "name": path.stem,
        "version": int(match.group(1)) if match else 0,
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
    }


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _sum_stages(stats: list[StatsRecord]) -> dict:
    names = sorted({k for s in stats for k in s.stages_s})
    return {k: sum(s.stages_s.get(k, 0.0) for s in stats) for k in names}


def _groups(stages: dict) -> dict:
    return {g: sum(stages.get(k, 0.0) for k in names) for g, names in STAGE_GROUPS.items()}


def summarize_run(level: str, workers: int, threads: int, stats: list[StatsRecord]) -> dict:
    """One run's figures from its tasks' stats.json records (the module docstring's definitions);
    the limit and ratios are added by `add_limits`."""
    starts = [s.start_seconds() for s in stats]
    span = max(t + s.wall_s for t, s in zip(starts, stats)) - min(starts)
    samples = sum(s.samples for s in stats)
    stages = _sum_stages(stats)
    groups = _groups(stages)
    rays = {k: sum((s.rays or {}).get(k, 0) for s in stats) for k in RAY_KINDS}
    traced = rays["camera_rays"] + rays["shadow_rays"] + rays["bounce_rays"] + rays["medium_rays"]
    render_s = stages.get("render", 0.0)
    return {
        "level": level,
        "workers": workers,
        "threads_per_worker": threads,
        "tasks": len(stats),
        "samples": samples,
        "views_per_task": samples / len(stats),
        "span_s": span,
        "samples_per_s": samples / span if span > 0 else 0.0,
        "seconds_per_sample": span / samples if samples else 0.0,
        "task_wall_s": sum(s.wall_s for s in stats),
        "scene_build_s": groups["scene_build"],
        "bytes": sum(s.bytes_written for s in stats),
        "bytes_per_sample": sum(s.bytes_written for s in stats) / samples if samples else 0.0,
        "stages_s": stages,
        "stage_groups_s": groups,
        "stage_groups_s_per_sample": {g: v / samples for g, v in groups.items()} if samples else {},
        "rays": rays,
        "mrays_per_s": traced / render_s / 1e6 if render_s > 0 else 0.0,
        "tasks_detail": [
            {
                "task_id": s.task_id,
                "samples": s.samples,
                "wall_s": s.wall_s,
                "stage_groups_s": _groups(s.stages_s),
                "rays": s.rays or {},
            }
            for s in sorted(stats, key=lambda s: s.task_id)
        ],
    }


def add_limits(run: dict, embree: list[dict], encode: dict, bounces: int) -> None:
    """Adds the run's limit (on P = workers × threads threads, for renders of `bounces` bounces)
    and its ratios to `run`."""
    p = run["workers"] * run["threads_per_worker"]
    per_task = {r["task_id"]: r for r in embree if r["threads"] == p}
    rays_s = sum(ray_limit_seconds(t["rays"], per_task[t["task_id"]], bounces) for t in run["tasks_detail"])
    enc_s = encode_limit_seconds(encode, p)
    w, samples = run["workers"], run["samples"]
    st = run["stages_s"]
    ours_render = st.get("render", 0.0) / w
    ours_encode = st.get("encode_write", 0.0) / w
    ours_render_encode = (st.get("render", 0.0) + st.get("tonemap", 0.0) + st.get("encode_write", 0.0)) / w

    def ratio(a: float, b: float) -> float:
        return a / b if b > 0 else 0.0

    run["limit"] = {
        "threads": p,
        "embree_s": rays_s,
        "encode_s": enc_s,
        "bounce_cost": "measured",
        "seconds_per_sample": (rays_s + enc_s) / samples if samples else 0.0,
        "encode_raw_mb_per_s": encode["raw_mb_per_s"],
    }
    run["ratio"] = {
        "render": ratio(ours_render, rays_s),
        "encode": ratio(ours_encode, enc_s),
        "render_encode": ratio(ours_render_encode, rays_s + enc_s),
        "pipeline": ratio(run["span_s"], rays_s + enc_s),
    }


def scaling(runs: list[dict]) -> list[dict]:
    """Scaling efficiency of each run against the fewest workers measured at its level."""
    out = []
    for level in dict.fromkeys(r["level"] for r in runs):
        mine = sorted((r for r in runs if r["level"] == level), key=lambda r: r["workers"])
        base = mine[0]
        for r in mine:
            e = (r["samples_per_s"] / r["workers"]) / (base["samples_per_s"] / base["workers"])
            out.append(
                {
                    "level": level,
                    "workers": r["workers"],
                    "threads_per_worker": r["threads_per_worker"],
                    "reference_workers": base["workers"],
                    "efficiency": e,
                }
            )
    return out


def projection(runs: list[dict], sweep_path: Path, image: dict) -> dict:
    """The full sweep of `sweep_path` on this machine and on N such nodes, per level, from the
    fastest run of the level (module docstring)."""
    from moonbot.config import load_config
    from moonbot.sweep import tasks

    sweep = load_config(sweep_path)
    sweep_tasks = tasks(sweep)
    views = sweep.orbit.views
    samples = len(sweep_tasks) * views
    levels = []
    for level in dict.fromkeys(r["level"] for r in runs):
        best = max((r for r in runs if r["level"] == level), key=lambda r: r["samples_per_s"])
        n = best["tasks"]
        fixed = best["scene_build_s"] / n  # worker-seconds a task, whatever its views
        per_view = (best["task_wall_s"] - best["scene_build_s"]) / best["samples"]
        bench_views = best["views_per_task"]
        scale = (fixed / views + per_view) / (fixed / bench_views + per_view)
        seconds_per_sample = best["seconds_per_sample"] * scale
        seconds = seconds_per_sample * samples
        levels.append(
            {
                "level": level,
                "from_run": {"workers": best["workers"], "threads_per_worker": best["threads_per_worker"]},
                "task_fixed_s": fixed,
                "per_view_s": per_view,
                "seconds_per_sample": seconds_per_sample,
                "samples_per_s": 1.0 / seconds_per_sample if seconds_per_sample > 0 else 0.0,
                "ratio_pipeline": (
                    seconds_per_sample / best["limit"]["seconds_per_sample"]
                    if best.get("limit", {}).get("seconds_per_sample")
                    else 0.0
                ),
                "bytes": best["bytes_per_sample"] * samples,
                "hours": [{"nodes": k, "hours": seconds / k / 3600.0} for k in NODES],
            }
        )
    same_image = (sweep.camera.width, sweep.camera.height) == (image["width"], image["height"])
    return {
        "sweep": sweep_path.name,
        "tasks": len(sweep_tasks),
        "samples": samples,
        "views_per_task": views,
        "image_matches_sweep": same_image,
        "levels": levels,
        "note": (
            "linear in nodes of this machine's kind; each node runs the level's fastest layout measured "
            "here; the benchmark's four scenes stand for the sweep's mix (mean 6 bags against 5.7, half "
            "dusty as in the sweep); per-worker terrain warm-up and the merge are left out; the light "
            "cache's fill is counted per view, as these tasks' few views pay it, where a sweep task's views share "
            "it (bench/bench_generate.py measures tasks of the sweep's views)"
            + ("" if same_image else "; NOT the sweep's image size: the figures are not the sweep's")
        ),
    }


def _generate_level(client, config, threads: int, png_compression: int, encode: dict | None, repeats: int):
    """Runs one level's generate on `client`; returns (its stats records, the generate wall
    seconds, the encode limit: `encode` if given, else measured on this run's files)."""
    from moonbot.pipeline.generate import generate

    with tempfile.TemporaryDirectory(prefix="moonbot-bench-") as tmp:
        start = time.perf_counter()
        result = generate(config, Path(tmp), client=client, threads=threads, merge=False, progress=None)
        wall = time.perf_counter() - start
        if result.failed:
            raise RuntimeError(f"benchmark tasks failed: {result.failed}")
        task_dirs = sorted(p for p in (Path(tmp) / "tasks").iterdir() if p.is_dir() and not p.name.startswith("."))
        stats = [read_task_stats(d) for d in task_dirs]
        if encode is None:
            encode = encode_limit(task_dirs, png_compression, repeats)
    return stats, wall, encode


def run_throughput(
    config_path: Path | None = None,
    levels: list[str] | None = None,
    workers: list[int] | None = None,
    threads: int | None = None,
    overrides: dict | None = None,
    out: Path | None = None,
    repeats: int = 3,
    say=print,
) -> tuple[dict, Path]:
    """Runs the benchmark (module docstring) and writes its result; returns (record, path).
    `threads`: render threads a worker (default: cores // the most workers, at least 1)."""
    from distributed import Client, LocalCluster

    from moonbot.pipeline.generate import TerrainWarmup
    from moonbot.sweep import task_config, tasks

    config_path = Path(config_path or DEFAULT_CONFIG)
    levels = list(levels or LEVELS)
    workers = sorted(set(workers or [1]))
    cores = os.cpu_count() or 1
    threads = threads or max(1, cores // max(workers))
    overrides = dict(overrides or {})
    began = time.perf_counter()
    m = machine()
    configs = {level: level_config(config_path, level, overrides) for level in levels}
    base = configs[levels[0]]
    bench_tasks = tasks(base)
    record = {
        "schema_version": SCHEMA_VERSION,
        "benchmark": "throughput",
        "config": config_identity(config_path),
        "overrides": overrides,
        "image": {"width": base.camera.width, "height": base.camera.height},
        "levels": {n: {"overrides": LEVELS[n].overrides, "description": LEVELS[n].description} for n in levels},
        "tasks": [t.task_id for t in bench_tasks],
        "workers": workers,
        "threads_per_worker": threads,
        "machine": m,
        "libraries": library_versions(),
        "started_utc": m["date"],
        "load_before": _load(),
        "terrain_warmup_s": {},
        "runs": [],
        "embree_limit": [],
        "encode_limit": {},
        "limit_notes": (
            "Embree: view 0's pixel-centre camera rays, Sun shadow rays and diffuse bounce rays (as many "
            "generations as the level's bounces) on each task's scene (bags unsettled), as the renderer "
            "traces them (64-ray streams), busiest thread; medium rays at the camera rays' rate; amodal "
            "passes and the dust medium's marching have no counterpart. Encoders: every file re-encoded "
            "alone by the same encoder, best schedule on the run's threads. moonbot/benchmark/limit.py"
        ),
    }
    say(f"machine  {m['cpu']}, {m['cores']} cores, {m['memory_gib']} GiB, {m['os']}, commit {m['git_commit'][:12]}")
    say(
        f"config   {config_path.name}: {len(bench_tasks)} tasks × {base.orbit.views} views at "
        f"{base.camera.width}×{base.camera.height}; levels {', '.join(levels)}; workers {workers} × {threads} threads"
    )
    thread_counts = sorted({w * threads for w in workers})
    most_bounces = max(c.render.bounces for c in configs.values())  # the probe's bounce generations
    encode: dict[str, dict] = {}
    for w in workers:
        with (
            LocalCluster(
                n_workers=w, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=40
            ) as cluster,
            Client(cluster) as client,
        ):
            start = time.perf_counter()
            terrains = list({task_config(base, t).terrain: None for t in bench_tasks})
            client.register_plugin(TerrainWarmup(terrains))
            record["terrain_warmup_s"][str(w)] = time.perf_counter() - start
            for level in levels:
                load_before = _load()
                stats, wall, encode[level] = _generate_level(
                    client, configs[level], threads, configs[level].output.png_compression, encode.get(level), repeats
                )
                run = summarize_run(level, w, threads, stats)
                rss = client.run(_peak_rss_mib)
                run.update(
                    generate_wall_s=wall,
                    load_before=load_before,
                    load_after=_load(),
                    peak_rss_mib={
                        "workers": sorted(rss.values()),
                        "max_worker": max(rss.values()),
                        "driver": _peak_rss_mib(),
                    },
                )
                record["runs"].append(run)
                say(
                    f"  {level:<8} {w} worker(s) × {threads}: {run['samples']} samples in {run['span_s']:.1f} s = "
                    f"{run['samples_per_s']:.3f} samples/s, {run['mrays_per_s']:.1f} Mrays/s, "
                    f"{run['bytes_per_sample'] / 1e6:.2f} MB a sample, worker peak {run['peak_rss_mib']['max_worker']:.0f} MiB "
                    f"(load {load_before[0]:.1f} → {run['load_after'][0]:.1f})"
                )
            if not record["embree_limit"]:  # the same scenes for every W: measured once, on a warm worker
                load_before = _load()
                futures = [
                    client.submit(
                        embree_limit,
                        configs["default" if "default" in configs else levels[0]],
                        t,
                        thread_counts,
                        most_bounces,
                        repeats,
                        pure=False,
                    )
                    for t in bench_tasks
                ]
                record["embree_limit"] = [row for f in futures for row in f.result()]
                record["embree_limit_load"] = {"before": load_before, "after": _load()}
    for level in levels:
        record["encode_limit"][level] = encode[level]
    for run in record["runs"]:
        add_limits(run, record["embree_limit"], encode[run["level"]], configs[run["level"]].render.bounces)
    record["scaling"] = scaling(record["runs"])
    record["projection"] = projection(record["runs"], SWEEP_CONFIG, record["image"])
    record["load_after"] = _load()
    record["driver_peak_rss_mib"] = _peak_rss_mib()
    record["seconds_total"] = time.perf_counter() - began
    path = Path(out) if out else default_out(m)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_bench_result(path, decode_bench_result(record, f"{path} (as measured)"))
    return record, path
