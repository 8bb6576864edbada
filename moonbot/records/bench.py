"""The result of `moonbot bench throughput` (moonbot.benchmark.throughput writes it; `moonbot bench
compare` reads it): the machine, one entry per run (quality level × workers), the limits it is
measured against, scaling and the projection to the full sweep. Times in seconds, rates per
second, sizes in bytes unless a field's name says otherwise. Keys in the order below, indent 2.

Every object may hold more fields than these (kept as written, in `other`). Version 1 counted
bounce rays at the camera rays' rate in its limit (UPGRADES says how it is read)."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from moonbot.config.load import KEEP_UNKNOWN
from moonbot.records.base import SCHEMA_VERSION, RecordError, decode, read_json, to_json, write_json


def _other() -> Any:
    """The field that keeps an object's further fields as written."""
    return dataclasses.field(default_factory=dict, metadata={KEEP_UNKNOWN: True})


def _three() -> Any:
    return dataclasses.field(metadata={"length": 3})


@dataclass(frozen=True, kw_only=True)
class ConfigIdentity:
    """The benchmark config: its file name, name, version and sha256."""

    file: str
    name: str
    version: int
    sha256: str
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Image:
    width: int
    height: int
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Machine:
    """What the numbers were measured on (moonbot.benchmark.fingerprint.machine); the CPU id, SIMD
    flags and Embree ISAs are absent from results older than their recording."""

    cpu: str
    cpu_id: str | None = None
    simd_flags: tuple[str, ...] | None = None
    embree_isa: str | None = None
    embree_isas: tuple[str, ...] | None = None
    cores: int
    memory_gib: float
    os: str
    python: str
    compiler: str
    embree: str
    openimageio: str
    tbb: str
    git_commit: str
    date: str
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class StageGroups:
    """Worker-seconds (or worker-seconds a sample) in each stage group."""

    scene_build: float
    dust: float
    render: float
    encode_write: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Rays:
    camera_rays: int
    shadow_rays: int
    bounce_rays: int
    medium_rays: int
    amodal_rays: int
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class PeakRss:
    """Peak resident memory in MiB: each worker's, the largest, the driver's."""

    workers: tuple[float, ...]
    max_worker: float
    driver: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Limit:
    """The run's limit: Embree alone on its rays and the encoders alone on its files, on `threads`."""

    threads: int
    embree_s: float
    encode_s: float
    bounce_cost: str
    seconds_per_sample: float
    encode_raw_mb_per_s: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Ratio:
    """The run's time over the limit's: render, encode, both, and the whole pipeline."""

    render: float
    encode: float
    render_encode: float
    pipeline: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Run:
    """One level on `workers` workers of `threads_per_worker` render threads."""

    level: str
    workers: int
    threads_per_worker: int
    tasks: int
    samples: int
    views_per_task: float
    span_s: float
    samples_per_s: float
    seconds_per_sample: float
    task_wall_s: float
    scene_build_s: float
    bytes: int
    bytes_per_sample: float
    stages_s: dict[str, Any]
    stage_groups_s: StageGroups
    stage_groups_s_per_sample: StageGroups
    rays: Rays
    mrays_per_s: float
    tasks_detail: tuple[dict[str, Any], ...] | None = None
    generate_wall_s: float
    load_before: tuple[float, ...] = _three()
    load_after: tuple[float, ...] = _three()
    peak_rss_mib: PeakRss
    limit: Limit
    ratio: Ratio
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class EmbreeRow:
    """Embree alone on view 0 of one task's scene, on `threads` threads: rays traced, seconds in
    64-ray streams and one ray at a time, and the rates. The bounce fields (one entry per bounce
    generation) are absent from version 1, which did not probe bounce rays."""

    task_id: str
    threads: int
    camera_rays: int
    shadow_rays: int
    bounce_rays: tuple[int, ...] | None = None
    intersect_stream_s: float
    occluded_stream_s: float
    bounce_stream_s: tuple[float, ...] | None = None
    bounce_shadow_rays: tuple[int, ...] | None = None
    bounce_shadow_stream_s: tuple[float, ...] | None = None
    intersect_single_s: float | None = None
    occluded_single_s: float | None = None
    bounce_single_s: tuple[float, ...] | None = None
    camera_s_per_ray: float | None = None
    shadow_s_per_ray: float | None = None
    primary_mrays_per_s: float
    shadow_mrays_per_s: float
    bounce_mrays_per_s: tuple[float, ...] | None = None
    bounce_shadow_mrays_per_s: tuple[float, ...] | None = None
    primary_single_mrays_per_s: float | None = None
    shadow_single_mrays_per_s: float | None = None
    bounce_single_mrays_per_s: tuple[float, ...] | None = None
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Scaling:
    level: str
    workers: int
    threads_per_worker: int | None = None
    reference_workers: int | None = None
    efficiency: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class NodeHours:
    nodes: int
    hours: float
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class ProjectionLevel:
    level: str
    from_run: dict[str, Any] | None = None
    task_fixed_s: float | None = None
    per_view_s: float | None = None
    seconds_per_sample: float
    samples_per_s: float | None = None
    ratio_pipeline: float | None = None
    bytes: float
    hours: tuple[NodeHours, ...]
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class Projection:
    """The full sweep `sweep` (its samples and views a task) at each level, on N nodes."""

    sweep: str
    tasks: int | None = None
    samples: int
    views_per_task: int
    image_matches_sweep: bool
    levels: tuple[ProjectionLevel, ...]
    other: dict[str, Any] = _other()


@dataclass(frozen=True, kw_only=True)
class BenchResult:
    """A `moonbot bench throughput` result."""

    schema_version: int = SCHEMA_VERSION
    benchmark: Literal["throughput"]
    config: ConfigIdentity
    overrides: dict[str, Any]
    image: Image
    levels: dict[str, Any]
    tasks: tuple[str, ...]
    workers: tuple[int, ...]
    threads_per_worker: int
    machine: Machine
    libraries: dict[str, Any]
    started_utc: str
    load_before: tuple[float, ...] = _three()
    terrain_warmup_s: dict[str, Any]
    runs: tuple[Run, ...]
    embree_limit: tuple[EmbreeRow, ...]
    encode_limit: dict[str, Any]
    limit_notes: str | None = None
    embree_limit_load: dict[str, Any] | None = None
    scaling: tuple[Scaling, ...]
    projection: Projection
    load_after: tuple[float, ...] = _three()
    driver_peak_rss_mib: float | None = None
    seconds_total: float
    other: dict[str, Any] = _other()

    def as_json(self) -> dict:
        """The record as the JSON object the result file holds."""
        return to_json(self)


def _upgrade_1(record: dict) -> dict:
    """Schema 1 → 2. Version 1's probe traced no bounce rays: its limit counted them at the camera
    rays' rate (`bounce_cost` says so now) and added a second limit with an assumed incoherent
    cost, which version 2, measuring them, drops. Returns a new record; `record` is left as it was."""
    record = copy.deepcopy(record)
    for run in record.get("runs", []) if isinstance(record.get("runs"), list) else []:
        if isinstance(run, dict) and isinstance(run.get("limit"), dict):
            run["limit"]["bounce_cost"] = "camera-ray rate (schema 1: bounce rays not probed)"
            for key in ("embree_s_bounce_incoherent", "seconds_per_sample_bounce_incoherent"):
                run["limit"].pop(key, None)
        if isinstance(run, dict) and isinstance(run.get("ratio"), dict):
            for key in ("render_encode_bounce_incoherent", "pipeline_bounce_incoherent"):
                run["ratio"].pop(key, None)
    return {**record, "schema_version": 2}


# schema_version → a function bringing a result of that version to the next one.
UPGRADES = {1: _upgrade_1}


def decode_bench_result(data: Any, source: str) -> BenchResult:
    """A result from a parsed JSON value of `source`. RecordError naming the source and field;
    a result without schema_version is refused (every version has one)."""
    if isinstance(data, dict) and "schema_version" not in data:
        raise RecordError(f"{source}: schema_version: missing")
    return decode(BenchResult, data, source, UPGRADES)


def read_bench_result(path: Path) -> BenchResult:
    """A result file. RecordError naming the file and field."""
    return decode_bench_result(read_json(path), str(path))


def write_bench_result(path: Path, record: BenchResult) -> None:
    """`record` to `path` atomically (keys in field order, indent 2)."""
    write_json(path, record, sort_keys=False)
