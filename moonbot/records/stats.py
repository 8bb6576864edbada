"""stats.json: one task's throughput, written by its worker (moonbot.pipeline.tasks) before
DONE.json; `moonbot stats` and `moonbot bench throughput` read it. Keys sorted, indent 2. Times
in seconds, rates in samples per second.

Version 1 (no schema_version) has the same fields."""

from __future__ import annotations

import dataclasses
import datetime
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from moonbot.config.load import KEEP_UNKNOWN
from moonbot.records.base import SCHEMA_VERSION, add_schema_version, decode, read_json, to_json, write_json

STATS = "stats.json"
_SECONDS = {"lo": 0.0}


@dataclass(frozen=True, kw_only=True)
class StatsRecord:
    """stats.json. `host`, `pid` and `worker` ("local", or a Dask worker's address) say who ran
    the task; `cpu_model` and `cores` (os.cpu_count) the machine; `threads` its render threads;
    `started_utc` an ISO-8601 time (UTC when it has no offset); `stages_s` seconds per timed
    stage; `rays` rays traced by kind, summed over the views; `bytes_written` every file but
    stats.json and DONE.json. `other`: the fields no reader interprets (the CPU id, SIMD flags and
    Embree ISA of moonbot.host.host_record, say), kept as written."""

    task_id: str
    host: str
    pid: int = dataclasses.field(metadata={"lo": 0})
    cpu_model: str
    cores: int = dataclasses.field(metadata={"lo": 1})
    threads: int = dataclasses.field(metadata={"lo": 1})
    worker: str
    started_utc: str
    wall_s: float = dataclasses.field(metadata=_SECONDS)
    cpu_s: float = dataclasses.field(metadata=_SECONDS)
    stages_s: dict[str, float] = dataclasses.field(metadata=_SECONDS)
    samples: int = dataclasses.field(metadata={"lo": 0})
    rays: dict[str, int] | None = None
    bytes_written: int = dataclasses.field(metadata={"lo": 0})
    samples_per_s: float = dataclasses.field(metadata=_SECONDS)
    schema_version: int = SCHEMA_VERSION
    other: dict[str, Any] = dataclasses.field(default_factory=dict, metadata={KEEP_UNKNOWN: True})

    def __post_init__(self) -> None:
        for name in ("task_id", "host", "cpu_model", "worker"):
            if not getattr(self, name):
                raise ValueError(f"{name}: must not be empty")
        try:
            self.start_time()
        except ValueError:
            raise ValueError(f"started_utc: not an ISO-8601 time: {self.started_utc!r}") from None

    def start_time(self) -> datetime.datetime:
        """started_utc as an aware UTC datetime (a time without an offset is read as UTC)."""
        t = datetime.datetime.fromisoformat(self.started_utc)
        if t.tzinfo is None:
            return t.replace(tzinfo=datetime.timezone.utc)
        return t.astimezone(datetime.timezone.utc)

    def start_seconds(self) -> float:
        """started_utc in seconds since the Unix epoch."""
        return self.start_time().timestamp()

    def as_json(self) -> dict:
        """The record as the JSON object stats.json holds."""
        return to_json(self)


UPGRADES = {1: add_schema_version}


def decode_stats(data: Any, source: str) -> StatsRecord:
    """A stats record from a parsed JSON value of `source` (a stats.json, or a line of
    OUT/stats/tasks.jsonl as "file:line"). RecordError naming the source and field."""
    return decode(StatsRecord, data, source, UPGRADES)


def read_stats(path: Path) -> StatsRecord:
    """A stats.json file. RecordError naming the file and field."""
    return decode_stats(read_json(path), str(path))


def write_stats(path: Path, record: StatsRecord) -> None:
    """`record` to `path` atomically (keys sorted, indent 2)."""
    write_json(path, record, sort_keys=True)
