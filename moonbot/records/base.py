"""What every file record shares: the schema version, reading a JSON file into a frozen dataclass
with field-path errors (moonbot.config.load's converter), and writing one back as JSON.

A record file holds one JSON object. Its `schema_version` (an integer) says which layout it has;
a file without one has the layout of version 1, written before the field existed. A reader
brings an older version up to the current one, step by step (each record module's UPGRADES),
before the typed conversion, and refuses a newer one. Every problem is reported as
"<file>: <field path>: <what is wrong>"."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TypeVar

from moonbot.atomic_io import atomic_write
from moonbot.config.load import KEEP_UNKNOWN, ConfigError, from_mapping

# The layout of every record file this moonbot writes. Version 1 of task.json, gt.json,
# stats.json and DONE.json: the files as written before they carried a schema_version; the
# benchmark result has carried its own since its version 1 (moonbot.records.bench).
SCHEMA_VERSION = 2

R = TypeVar("R")
# schema_version → a function taking a mapping of that version to the next version's mapping.
Upgrades = Mapping[int, Callable[[dict], dict]]


class RecordError(ValueError):
    """A record file that cannot be read or breaks its contract; the message starts with the file
    (or a line of one) and the field path."""


def decode(cls: type[R], data: Any, source: str, upgrades: Upgrades) -> R:
    """The record `cls` from a parsed JSON value of `source` (a file name, or "file:line"):
    brought from its schema_version (absent: 1) up to SCHEMA_VERSION by `upgrades`, then
    converted field by field. RecordError naming `source` and the field path."""
    if not isinstance(data, dict):
        raise RecordError(f"{source}: expected a JSON object, got {type(data).__name__}")
    version = data.get("schema_version", 1)
    if isinstance(version, bool) or not isinstance(version, int):
        raise RecordError(f"{source}: schema_version: must be an integer, got {version!r}")
    if version > SCHEMA_VERSION:
        raise RecordError(
            f"{source}: schema_version: {version} is newer than this moonbot reads ({SCHEMA_VERSION}); update moonbot"
        )
    if version < 1:
        raise RecordError(f"{source}: schema_version: must be at least 1, got {version}")
    while version < SCHEMA_VERSION:
        data = upgrades[version](data)
        version += 1
    try:
        return from_mapping(cls, data)
    except ConfigError as e:
        raise RecordError(f"{source}: {e}") from None


def add_schema_version(data: dict) -> dict:
    """Version 1 → 2 for a record whose fields did not change: the field itself."""
    return {**data, "schema_version": 2}


def parse_bytes(data: bytes, source: str) -> Any:
    """The JSON value in `data` (UTF-8) read from `source`; RecordError on bad UTF-8 or JSON, or a
    truncated file."""
    try:
        return json.loads(data.decode("utf-8"))
    except ValueError as e:
        raise RecordError(f"{source}: not valid JSON ({e})") from None


def read_bytes(path: Path, sha256: str | None = None) -> bytes:
    """The bytes of record file `path`; with `sha256` (hex), RecordError unless they have that
    checksum (DONE.json's, say)."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise RecordError(f"{path}: cannot read ({e.strerror or e})") from None
    if sha256 is not None and hashlib.sha256(data).hexdigest() != sha256:
        raise RecordError(f"{path}: sha256 differs from DONE.json's")
    return data


def read_json(path: Path, sha256: str | None = None) -> Any:
    """The JSON value in record file `path` (read_bytes, then parse_bytes); RecordError naming
    the file."""
    return parse_bytes(read_bytes(path, sha256), str(path))


def to_json(record: Any) -> Any:
    """A record as the JSON value it is written as: dataclasses as objects in field order, a field
    whose default is None left out while it is None, the KEEP_UNKNOWN field's keys at the end,
    tuples as lists."""
    if dataclasses.is_dataclass(record):
        out, kept = {}, {}
        for f in dataclasses.fields(record):
            value = getattr(record, f.name)
            if f.metadata.get(KEEP_UNKNOWN):
                kept = value
            elif not (value is None and f.default is None):
                out[f.name] = to_json(value)
        return {**out, **{k: to_json(v) for k, v in kept.items()}}
    if isinstance(record, dict):
        return {k: to_json(v) for k, v in record.items()}
    if isinstance(record, (list, tuple)):
        return [to_json(v) for v in record]
    return record


def write_json(path: Path, record: Any, sort_keys: bool) -> None:
    """`record` to `path` atomically as indented JSON (2 spaces, a trailing newline), its keys
    sorted or in field order."""
    text = json.dumps(to_json(record), indent=2, sort_keys=sort_keys) + "\n"
    atomic_write(Path(path), "w", lambda f: f.write(text))
