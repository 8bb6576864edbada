"""What a sweep will cost before anything is rendered: its scenes, tasks and samples per split,
and the disk and time they take, scaled from a recorded generate benchmark (bench/bench_generate.py
→ bench/results/generate-<machine>.json). Nothing is measured here: the time is that of the
machine the record measured, which `moonbot plan` names (CPU, cores, date, file) beside this
machine's CPU and how far the two may differ (provenance()).

Time scales with what each stage is paid per: rendering, masks, dust and encoding per
megapixel-sample; composing the scene and building its BVH per task; placing and settling the
bags per layout (moonbot.pipeline.placements: once for all the tasks of its scenes). The
benchmark's tasks are fewer than the sweep's, and share few layouts, so scaling its whole time by
megapixel-samples alone would overstate the per-task and per-layout stages. A record with a
`task_mix` (a sample of the sweep's own locations and bag counts) is priced on that, not on its
throughput runs' tasks, which are among the sweep's cheapest."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from moonbot.config import Config
from moonbot.sweep.tasks import tasks

# How far one machine strays from its own record: the default level of the throughput benchmark ran
# this many times slower while other processes loaded the 2-core machine
# (bench/results/amd-epyc-2c-2026-11-23.json) than on the same machine quiet an hour later (its
# -quiet.json): 0.0973 against 0.2576 samples/s.
LOADED_SLOWDOWN = 2.6

# The stages (stats.json's stages_s, and the placements') paid once per layout and once per task;
# every other stage is paid per sample and scales with megapixel-samples.
PER_LAYOUT_STAGES = ("place", "settle")
PER_TASK_STAGES = ("terrain", "compose", "build_bvh")


@dataclass(frozen=True)
class SplitPlan:
    name: str
    scenes: int
    tasks: int
    samples: int
    megapixel_samples: float  # Σ samples × width × height × spp / 1e6: what render time scales with
    megapixels: float  # Σ samples × width × height / 1e6: what disk scales with
    layouts: int = 0  # bag layouts (split, mesh, location, bag count): placed and settled once each


def split_plans(config: Config) -> list[SplitPlan]:
    """Counts per split, in sweep order. (The sweep varies neither the camera, the orbit nor the
    render settings, so every task has the base config's views, pixels and samples per pixel.)"""
    out: dict[str, list] = {}
    c = config
    for t in tasks(config):
        views = c.orbit.views
        pixels = c.camera.width * c.camera.height * views / 1e6
        entry = out.setdefault(t.split, [set(), 0, 0, 0.0, 0.0, set()])
        entry[0].add(t.scene_id)
        entry[1] += 1
        entry[2] += views
        entry[3] += pixels * c.render.spp
        entry[4] += pixels
        entry[5].add((t.mesh, t.location, t.bags))
    return [SplitPlan(name, len(s), n, k, mps, mp, len(lay)) for name, (s, n, k, mps, mp, lay) in out.items()]


@dataclass(frozen=True)
class Estimate:
    """Disk (bytes) and time (seconds on `workers` workers of the recorded machine) for a sweep,
    from the benchmark record at `source`: bytes per megapixel as measured there, times the
    sweep's; its time split by stage into what is paid per megapixel-sample, per task and per
    layout, each scaled by the sweep's count of it (see the module docstring). `machine`: the
    record's fingerprint (moonbot.benchmark.fingerprint.machine; empty when it has none)."""

    bytes: float
    seconds: float
    workers: int
    threads: int  # render threads per worker in the benchmark run used
    source: str
    machine: dict
    mix_tasks: int = 0  # tasks of the sweep's mix the record priced it on (0: its throughput runs' tasks)


def default_record(results: Path = Path("bench") / "results") -> Path:
    """The generate benchmark record in `results` (default: bench/results/ under the working
    directory, the checkout's when run from it) for a machine like this one (named by the
    machine slug the benchmarks use: CPU vendor and family, cores); when there is none, the first
    other machine's record there, if any (provenance() then says it is another machine's)."""
    from moonbot.host import cpu_model, machine_slug

    own = results / f"generate-{machine_slug({'cpu': cpu_model(), 'cores': os.cpu_count()})}.json"
    others = sorted(results.glob("generate-*.json"))
    return own if own.exists() or not others else others[0]


def provenance(estimate: Estimate) -> list[str]:
    """Lines saying whose record the estimate scaled (file, CPU, cores, Embree ISA, date) and
    this machine's CPU, with how far its time may differ: the same CPU model and core count still
    strays by up to LOADED_SLOWDOWN under other load; another CPU is not estimated at all."""
    from moonbot.host import cpu_id, cpu_model

    here = f"{cpu_model()} ({cpu_id()}), {os.cpu_count()} cores"
    m = estimate.machine
    if not m.get("cpu"):
        return [
            f"from    {estimate.source}, a record that names no machine",
            f"here    {here}: not measured; run bench/bench_generate.py here for this machine's record",
        ]
    there = f"{m['cpu']} ({m.get('cpu_id', '?')}), {m.get('cores', '?')} cores"
    lines = [
        f"from    {estimate.source}: measured on {there}, Embree {m.get('embree_isa', '?')}, "
        f"{str(m.get('date', '?'))[:10]}"
    ]
    if (m["cpu"], m.get("cpu_id"), m.get("cores")) == (cpu_model(), cpu_id(), os.cpu_count()):
        lines.append(
            f"here    {here}, the same CPU model and cores, not measured here: load, clock and memory "
            f"can make it up to {LOADED_SLOWDOWN:g}x slower (one such machine loaded by other processes "
            "against itself quiet)"
        )
    else:
        lines.append(
            f"here    {here}: another CPU or core count, so the time above is that machine's, "
            "not this one's; run bench/bench_generate.py here for this machine's record"
        )
    return lines


def estimate(plans: list[SplitPlan], record_path: Path) -> Estimate | None:
    """The estimate from the generate benchmark record at `record_path` (None if it cannot be
    read or is not one): priced_run()'s run, its span split by its stage seconds' shares (a
    record without stages scales by megapixel-samples alone). A record from before placements
    (no `layouts`) settled once per task."""
    try:
        record = json.loads(Path(record_path).read_text())
        return estimate_from(plans, record, str(record_path))
    except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError, AttributeError):
        return None


def fastest_run(record: dict) -> dict:
    """The fastest (most samples a second) of a generate benchmark record's `runs`: the layout
    the bench renders its task mix on and a sweep is priced on."""
    return max(record["runs"], key=lambda r: r["samples_per_s"])


def priced_run(record: dict) -> dict:
    """The run of a generate benchmark record that prices a sweep: its `task_mix` (the sweep's
    own mix of locations and bag counts, rendered on the fastest layout measured) where it has
    one, else fastest_run()."""
    return record.get("task_mix") or fastest_run(record)


def estimate_from(plans: list[SplitPlan], record: dict, source: str) -> Estimate:
    """estimate() of a record already read; raises KeyError, TypeError or ZeroDivisionError on a
    record that lacks what it needs."""
    best = priced_run(record)
    b_per_mp = best["bytes"] / best["megapixels"]
    stages = best.get("stages_s") or {}
    timed = sum(stages.values())
    layout_share = sum(stages.get(k, 0.0) for k in PER_LAYOUT_STAGES) / timed if timed > 0 else 0.0
    task_share = sum(stages.get(k, 0.0) for k in PER_TASK_STAGES) / timed if timed > 0 else 0.0
    mps = sum(p.megapixel_samples for p in plans)
    scale = (1.0 - layout_share - task_share) * mps / best["megapixel_samples"]
    if task_share:
        scale += task_share * sum(p.tasks for p in plans) / best["tasks"]
    if layout_share:
        scale += layout_share * sum(p.layouts for p in plans) / best.get("layouts", best["tasks"])
    mp = sum(p.megapixels for p in plans)
    machine = record.get("machine") if isinstance(record.get("machine"), dict) else {}
    return Estimate(
        bytes=b_per_mp * mp,
        seconds=best["seconds"] * scale,
        workers=best["workers"],
        threads=best.get("threads_per_worker", 1),
        source=source,
        machine=machine,
        mix_tasks=best["tasks"] if record.get("task_mix") else 0,
    )
