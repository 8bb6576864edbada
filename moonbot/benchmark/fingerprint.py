"""What a benchmark result was measured on: the machine's fingerprint, and where results go.
Shared by `moonbot bench` and every script in bench/ (through bench/fingerprint.py). The git
commit is that of the checkout moonbot was installed from, as the install's own record names it
(PEP 610 direct_url.json: an editable or local-directory install); for any other install it is
empty."""

from __future__ import annotations

import json
import os
import platform
import re
import subprocess
import time
from importlib import metadata
from pathlib import Path
from urllib.parse import unquote, urlparse

from moonbot.host import host_record

# Where benchmark results are written and looked for: bench/results under the working directory
# (a checkout's when the commands run from it).
RESULTS_DIR = Path("bench") / "results"


def installed_from() -> Path | None:
    """The local directory moonbot was installed from (an editable or `pip install DIR` install:
    PEP 610's direct_url.json names it), or None (an index install, or no record)."""
    try:
        record = json.loads(metadata.distribution("moonbot").read_text("direct_url.json") or "null")
    except (metadata.PackageNotFoundError, ValueError):
        return None
    url = urlparse(record.get("url", "")) if isinstance(record, dict) else None
    if url is None or url.scheme != "file" or "dir_info" not in record:
        return None
    return Path(unquote(url.path))


def machine(embree_isa: str = "auto") -> dict:
    """What the numbers were measured on: with the CPU's model, id and SIMD flags, the ISA a scene
    asked for `embree_isa` traces in (moonbot.host.host_record)."""
    mem_kb = int(re.search(r"MemTotal:\s+(\d+)", Path("/proc/meminfo").read_text()).group(1))
    os_name = (
        dict(line.split("=", 1) for line in Path("/etc/os-release").read_text().splitlines() if "=" in line)
        .get("PRETTY_NAME", "")
        .strip('"')
    )

    def run(*cmd: str) -> str:
        try:
            return subprocess.run(cmd, capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    def deb(package: str) -> str:
        return run("dpkg-query", "-W", "-f=${Version}", package)

    root = installed_from()
    commit = run("git", "-C", str(root), "rev-parse", "HEAD") if root is not None else ""
    # Dirty means uncommitted source changes; the result files themselves do not count.
    dirty = bool(commit) and bool(
        run("git", "-C", str(root), "status", "--porcelain", "--untracked-files=no", "--", ".", ":!bench/results")
    )
    host = host_record(embree_isa)
    return {
        "cpu": host["cpu_model"],
        "cpu_id": host["cpu_id"],
        "simd_flags": host["simd_flags"],
        "embree_isa": host["embree_isa"],
        "embree_isas": host["embree_isas"],
        "cores": os.cpu_count(),
        "memory_gib": round(mem_kb / 2**20, 1),
        "os": os_name,
        "python": platform.python_version(),
        "compiler": run("c++", "--version").split("\n")[0],
        "embree": deb("libembree-dev"),
        "openimageio": deb("libopenimageio-dev"),
        "tbb": deb("libtbb-dev"),
        "git_commit": commit + ("-dirty" if dirty else ""),
        "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def library_versions() -> dict:
    """Versions of the Python packages a generate run goes through (moonbot itself included);
    the C++ libraries' are in `machine()`."""
    from importlib import metadata

    out = {}
    for name in ("moonbot", "numpy", "scipy", "dask", "distributed", "mujoco-core", "pyarrow", "click"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = ""
    return out
