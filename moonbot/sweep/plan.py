"""What a sweep will cost before anything is rendered: its scenes, tasks and samples per split,
and the disk and time they take on this machine, scaled from the recorded generate benchmark
(bench/bench_generate.py → bench/results/generate-<machine>.json)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from moonbot.config import Config
from moonbot.sweep.tasks import tasks


@dataclass(frozen=True)
class SplitPlan:
    name: str
    scenes: int
    tasks: int
    samples: int
    megapixel_samples: float  # Σ samples × width × height × spp / 1e6: what render time scales with
    megapixels: float         # Σ samples × width × height / 1e6: what disk scales with


def split_plans(config: Config) -> list[SplitPlan]:
    """Counts per split, in sweep order. (The sweep varies neither the camera, the orbit nor the
    render settings, so every task has the base config's views, pixels and samples per pixel.)"""
    out: dict[str, list] = {}
    c = config
    for t in tasks(config):
        views = c.orbit.views
        pixels = c.camera.width * c.camera.height * views / 1e6
        entry = out.setdefault(t.split, [set(), 0, 0, 0.0, 0.0])
        entry[0].add(t.scene_id)
        entry[1] += 1
        entry[2] += views
        entry[3] += pixels * c.render.spp
        entry[4] += pixels
    return [SplitPlan(name, len(s), n, k, mps, mp) for name, (s, n, k, mps, mp) in out.items()]


@dataclass(frozen=True)
class Estimate:
    """Disk (bytes) and time (seconds on `workers` workers of this machine) for a sweep, from the
    benchmark record at `source`: seconds per sample-megapixel-spp and bytes per megapixel as
    measured there, times the sweep's totals."""

    bytes: float
    seconds: float
    workers: int
    threads: int  # render threads per worker in the benchmark run used
    source: str


def default_record() -> Path:
    """This machine's generate benchmark record in the checkout's bench/results/ (named by the
    same machine slug the benchmarks use: CPU vendor and family, cores)."""
    from moonbot.benchmark.fingerprint import machine, machine_slug

    root = Path(__file__).resolve().parents[2]
    return root / "bench" / "results" / f"generate-{machine_slug(machine())}.json"


def estimate(plans: list[SplitPlan], record_path: Path) -> Estimate | None:
    """The estimate from a generate benchmark record (None if there is none for this machine).
    The record's best throughput (the fastest of its runs) is used."""
    try:
        record = json.loads(Path(record_path).read_text())
        best = max(record["runs"], key=lambda r: r["samples_per_s"])
        s_per_mps = best["seconds"] / best["megapixel_samples"]
        b_per_mp = best["bytes"] / best["megapixels"]
    except (OSError, ValueError, KeyError, ZeroDivisionError):
        return None
    mps = sum(p.megapixel_samples for p in plans)
    mp = sum(p.megapixels for p in plans)
    return Estimate(bytes=b_per_mp * mp, seconds=s_per_mps * mps, workers=best["workers"],
                    threads=best.get("threads_per_worker", 1), source=str(record_path))
