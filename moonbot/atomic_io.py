"""Atomic outputs: a file, or a whole directory, is either the complete result of one write or
absent; a failure (a full disk, a killed process) never leaves a mix or a half-written file."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


def process_umask() -> int:
    """The process umask, read without changing it (`os.umask` can only swap it, which races with
    threads creating files meanwhile). Linux: /proc/self/status; elsewhere the usual 022."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


def atomic_write(path: Path, mode: str, write: Callable[[IO[Any]], object]) -> None:
    """Writes through `write(file)` to a temporary beside `path`, then renames it over `path`.
    On failure the temporary is removed, `path` is untouched, and OSError names `path`."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8") as f:
            write(f)
        os.chmod(tmp, 0o666 & ~process_umask())  # mkstemp makes 0600; data is for all to read
        os.replace(tmp, path)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        raise OSError(f"{path}: write failed ({e.strerror or e})") from e
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def staged_directory(final: Path) -> Iterator[Path]:
    """Yields a fresh temporary directory beside `final`; on success it replaces `final` whole,
    on any failure it is removed and `final` (a previous complete output) is left as it was."""
    final.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    try:
        yield staging
        staging.chmod(0o777 & ~process_umask())  # mkdtemp makes 0700
        if final.exists():
            # A directory cannot be renamed over a non-empty one: move the old one aside first.
            old = final.with_name(f".{final.name}.{os.getpid()}.old")
            final.rename(old)
            staging.rename(final)
            shutil.rmtree(old)
        else:
            staging.rename(final)
    except OSError as e:
        shutil.rmtree(staging, ignore_errors=True)
        # Name the files as the user knows them, not by the hidden staging directory.
        reason = str(e).replace(str(staging), str(final))
        kept = "the previous content is kept" if final.exists() else "nothing was written"
        raise OSError(f"{reason}; {kept} in {final}") from e
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
