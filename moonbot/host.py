"""What machine this process runs on, as every record of work done here states it (a task's
stats.json, a benchmark result): the CPU by name and by number, the SIMD extensions it offers
and the instruction set Embree traces rays in. A model name alone can hide what matters: a
hypervisor may report "AMD EPYC" for CPUs with and without AVX-512, and Debian's Embree hangs in
its coherent AVX-512 kernels on only the former."""

from __future__ import annotations

import platform
import re
from pathlib import Path

# The /proc/cpuinfo flags of the x86-64 SIMD extensions, narrowest first: those Embree's kernels
# are chosen by (SSE2 … AVX-512 F/DQ/CD/BW/VL) and the AVX-512 extensions past them that tell CPU
# generations apart.
SIMD_FLAGS = (
    "sse2",
    "ssse3",
    "sse4_1",
    "sse4_2",
    "popcnt",
    "avx",
    "f16c",
    "fma",
    "bmi1",
    "bmi2",
    "abm",
    "avx2",
    "avx512f",
    "avx512dq",
    "avx512cd",
    "avx512bw",
    "avx512vl",
    "avx512ifma",
    "avx512vbmi",
    "avx512_vbmi2",
    "avx512_vnni",
    "avx512_bf16",
    "avx512_fp16",
    "avx_vnni",
    "amx_tile",
)


def _cpuinfo() -> dict[str, str]:
    """The first processor's fields of /proc/cpuinfo (empty where there is none: not Linux)."""
    fields: dict[str, str] = {}
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return fields
    for line in text.splitlines():
        if not line.strip():
            break  # the first processor's block ends here
        key, sep, value = line.partition(":")
        if sep:
            fields.setdefault(key.strip(), value.strip())
    return fields


def cpu_model() -> str:
    """The CPU's model name (Linux: /proc/cpuinfo), or the platform's processor string."""
    return _cpuinfo().get("model name") or platform.processor() or "unknown"


def cpu_id() -> str:
    """The CPU's vendor, family, model and stepping as numbers ("AuthenticAMD 25/17/1"), which
    name the microarchitecture where the model name does not; empty where unknown."""
    info = _cpuinfo()
    parts = [info.get(k, "") for k in ("cpu family", "model", "stepping")]
    if not any(parts):
        return ""
    return f"{info.get('vendor_id', '')} {'/'.join(parts)}".strip()


def simd_flags() -> list[str]:
    """The SIMD extensions this CPU offers (SIMD_FLAGS' names, in its order)."""
    offered = set(_cpuinfo().get("flags", "").split())
    return [flag for flag in SIMD_FLAGS if flag in offered]


def embree_record(requested: str = "auto") -> dict:
    """The Embree side of a record: `embree_isa`, the ISA a scene asked for `requested`
    (render.embree_isa) traces in here, and `embree_isas`, every ISA this CPU could run."""
    from moonbot import _core

    return {"embree_isa": _core.resolve_embree_isa(requested), "embree_isas": _core.embree_isas()}


def host_record(requested_isa: str = "auto") -> dict:
    """CPU model, id and SIMD flags, and embree_record(requested_isa): what every task's
    stats.json and every benchmark result carries."""
    return {"cpu_model": cpu_model(), "cpu_id": cpu_id(), "simd_flags": simd_flags(), **embree_record(requested_isa)}


def machine_slug(m: dict) -> str:
    """A record's machine as a file-name part: its CPU model, lower-case and dashed, and its core
    count ("amd-epyc-2c"): bench/results/<slug>.json."""
    cpu = re.sub(r"[^a-z0-9]+", "-", m["cpu"].lower()).strip("-")
    cpu = re.sub(r"-(processor|cpu|with-radeon-graphics).*$", "", cpu)
    return f"{cpu}-{m['cores']}c"
