"""DONE.json: a task directory's completion marker, written last, listing every other file of the
task with its size and sha256 (moonbot.pipeline.tasks writes it; generate, merge and stats read
it). A task directory whose DONE.json reads and whose listed files are all there with their
sizes is complete.

    {"files": {"<path relative to the task directory>": {"bytes": int, "sha256": hex}, ...},
     "samples": int, "schema_version": 2, "task_id": str}

Version 1 (no schema_version) is the same, except that a file's entry may be its bare sha256 hex
string (then its size is not checked)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from moonbot.records.base import SCHEMA_VERSION, RecordError, decode, read_json, write_json

# The marker's file name in a task directory.
DONE = "DONE.json"


@dataclass(frozen=True)
class FileEntry:
    """One listed file: its size in bytes (None: not recorded, a version-1 bare checksum) and its
    sha256 (64 lower-case hex digits)."""

    sha256: str
    bytes: int | None = dataclasses.field(default=None, metadata={"lo": 0})

    def __post_init__(self) -> None:
        if len(self.sha256) != 64 or any(c not in "0123456789abcdef" for c in self.sha256):
            raise ValueError(f"sha256: must be 64 lower-case hex digits, got {self.sha256!r}")


@dataclass(frozen=True, kw_only=True)
class DoneRecord:
    """DONE.json: the task, the samples (views) it wrote, and its files (path → FileEntry)."""

    files: dict[str, FileEntry]
    samples: int = dataclasses.field(metadata={"lo": 0})
    task_id: str
    schema_version: int = SCHEMA_VERSION


def _upgrade_1(data: dict) -> dict:
    files = data.get("files")
    if isinstance(files, dict):  # a bare checksum → an entry without a size
        files = {name: {"sha256": e} if isinstance(e, str) else e for name, e in files.items()}
    return {**data, "files": files, "schema_version": 2}


UPGRADES = {1: _upgrade_1}


def read_done(path: Path) -> DoneRecord:
    """A DONE.json file (`path`: the file itself). RecordError naming the file and field."""
    return decode(DoneRecord, read_json(path), str(path), UPGRADES)


def write_done(path: Path, record: DoneRecord) -> None:
    """`record` to `path` atomically (keys sorted, indent 2)."""
    write_json(path, record, sort_keys=True)


def complete_files(directory: Path) -> dict[str, FileEntry] | None:
    """The files DONE.json lists in task `directory` when the task is complete (the marker reads and
    every listed file is there, with its recorded size where it has one); None otherwise.
    Checksums are not read."""
    try:
        done = read_done(Path(directory) / DONE)
        for name, entry in done.files.items():
            size = (Path(directory) / name).stat().st_size  # OSError when it is missing
            if entry.bytes is not None and size != entry.bytes:
                return None
    except (RecordError, OSError):
        return None
    return done.files
