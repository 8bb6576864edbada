"""Embree's instruction set: which ones this CPU offers, how a scene picks one, what every record
says of it, and the sequence that hung Debian's Embree 3.13.5 on AVX-512 CPUs (a view, its amodal
masks, the next view), run under every ISA this machine offers, each in its own process with a
deadline so that a hang fails the test instead of the run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import ConfigError, load_config
from moonbot.host import host_record, simd_flags

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parents[1]
ISAS = _core.embree_isas()
# What "auto" means in this run: `./dev.sh test` re-runs these tests with the variable set.
AUTO = os.environ.get("MOONBOT_EMBREE_ISA") or ("avx2" if "avx2" in ISAS else ISAS[-1])

# What each ISA needs of /proc/cpuinfo's flags, as Embree requires them (an independent reading of
# the CPU from the core's cpuid one).
NEEDS = {
    "sse2": {"sse2"},
    "sse4.2": {"sse4_2", "popcnt"},
    "avx": {"avx"},
    "avx2": {"avx2", "fma", "bmi1", "bmi2", "abm"},
    "avx512": {"avx512f", "avx512dq", "avx512cd", "avx512bw", "avx512vl"},
}
ORDER = ["sse2", "sse4.2", "avx", "avx2", "avx512"]


def test_the_isas_offered_follow_the_cpu_flags():
    flags = set(simd_flags())
    expected, needed = [], set()
    for isa in ORDER:
        needed |= NEEDS[isa]
        if needed <= flags:
            expected.append(isa)
    assert ISAS == expected
    assert _core.resolve_embree_isa("auto") == AUTO  # avx2 (or the widest below it), unless pinned
    for isa in ISAS:
        assert _core.Scene(isa).embree_isa == isa


def test_names_are_checked():
    with pytest.raises(ValueError, match="embree_isa: must be one of auto, sse2"):
        _core.Scene("avx1024")
    lacking = [isa for isa in ORDER if isa not in ISAS]
    if lacking:
        with pytest.raises(ValueError, match=f"cannot run '{lacking[0]}'; it runs"):
            _core.Scene(lacking[0])
    assert load_config(None, {"render.embree_isa": "avx2"}).render.embree_isa == "avx2"
    with pytest.raises(ConfigError, match="render.embree_isa"):
        load_config(None, {"render.embree_isa": "avx3"})


def _python(code: str, env: dict | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
        env={**os.environ, **(env or {})},
    )


def test_the_environment_pins_auto():
    code = "from moonbot import _core; print(_core.Scene().embree_isa, _core.Scene('auto').embree_isa)"
    assert _python(code, {"MOONBOT_EMBREE_ISA": ISAS[0]}).stdout.split() == [ISAS[0]] * 2
    bad = _python(code, {"MOONBOT_EMBREE_ISA": "avx9"})
    assert bad.returncode != 0 and "MOONBOT_EMBREE_ISA: must be one of" in bad.stderr


# One smoke-sweep task of the test split (two bags, the analytic plane), as `moonbot generate`
# runs it: view 0, its amodal masks, then view 1; the depth and masks are written for comparison.
_SEQUENCE = """
import sys
from pathlib import Path
from moonbot.config import load_config
from moonbot.pipeline.views import run_views
from moonbot.sweep import task_config, tasks
config = load_config("configs/smoke.yaml", {"render.embree_isa": sys.argv[1]})
task = next(t for t in tasks(config) if t.split == "test")
run_views(task_config(config, task), [0, 1], Path(sys.argv[2]), threads=2)
"""


@pytest.mark.parametrize("isa", ISAS)
def test_view_amodal_view_finishes(isa, tmp_path):
    try:
        done = subprocess.run(
            [sys.executable, "-c", _SEQUENCE, isa, str(tmp_path)], capture_output=True, text=True, timeout=120, cwd=ROOT
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"view 0, its amodal masks, then view 1 did not finish in 120 s with embree_isa={isa}")
    assert done.returncode == 0, done.stderr[-2000:]
    gt = json.loads((tmp_path / "view_001" / "gt.json").read_text())
    assert len(gt["instances"]) == 2


def test_images_do_not_depend_on_the_isa(tmp_path):
    """The default scene's view at 160×120 under every ISA: the same masks byte for byte; depth
    the same to a float32 ulp (kernels with and without FMA may pick the other of two triangles
    sharing the edge a pixel's ray passes through); rgb the same but for a few pixels in a
    thousand, by a few levels: a shadow ray that grazes a rock's or a pebble's edge may be
    decided the other way by a kernel without FMA."""
    outputs = {}
    for isa in ISAS:
        out = tmp_path / isa
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "moonbot.cli",
                "render-one",
                "--out",
                str(out),
                "--no-sheet",
                "--set",
                "camera.width=160",
                "--set",
                "camera.height=120",
                "--set",
                f"render.embree_isa={isa}",
            ],
            capture_output=True,
            text=True,
            timeout=300,
            cwd=ROOT,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        outputs[isa] = out / "view_000"
    reference = outputs[ISAS[-1]]  # the widest
    depth = np.load(reference / "depth.npy")
    for isa, out in outputs.items():
        for name in ("mask.png", "amodal_001.png"):
            assert (out / name).read_bytes() == (reference / name).read_bytes(), (isa, name)
        rgb, rgb_reference = (_core.read_image(str(o / "rgb.png")).astype(int) for o in (out, reference))
        differ = np.abs(rgb - rgb_reference).max(axis=2)
        assert np.count_nonzero(differ) <= 0.002 * differ.size and differ.max() <= 16, (isa, np.count_nonzero(differ))
        other = np.load(out / "depth.npy")
        assert np.array_equal(other > 0, depth > 0)
        assert np.all(np.abs(other - depth) <= np.spacing(depth)), isa


def test_records_name_the_cpu_and_the_isa(tmp_path):
    record = host_record("auto")
    assert record["embree_isa"] == AUTO and record["embree_isas"] == ISAS
    flags_line = next(line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags"))
    assert record["simd_flags"] and set(record["simd_flags"]) <= set(flags_line.split(":", 1)[1].split())
    assert record["cpu_id"].count("/") == 2
    assert host_record(ISAS[0])["embree_isa"] == ISAS[0]
    # A task's stats.json carries them, with the ISA its config asked for.
    from moonbot.pipeline.tasks import run_task
    from moonbot.sweep import tasks

    config = load_config("configs/smoke.yaml", {"render.embree_isa": ISAS[0]})
    task = next(t for t in tasks(config) if t.split == "test")
    stats = run_task(config, task, tmp_path, threads=1).stats.as_json()
    assert {k: stats[k] for k in record} == {**record, "embree_isa": ISAS[0]}
