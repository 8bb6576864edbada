"""A task's heartbeat and the driver's judgement of a hang (moonbot.pipeline.heartbeat), on real
files with the driver's clock passed in: the stall limit's numbers, a beat timed from when the
driver first read it, a new stage as the only progress, and the debug settings that name a task."""

from __future__ import annotations

import json
import os
import threading
import time

import pytest

from moonbot.config import load_config
from moonbot.pipeline.heartbeat import (
    DEBUG_HANG_ENV,
    DEBUG_HOLD_ENV,
    HEARTBEAT_DIR,
    RENDER_BUDGET_S_PER_MEGASAMPLE,
    STALL_FACTOR,
    STALL_FLOOR_S,
    Heartbeat,
    StallLimit,
    Watchdog,
    debug_hang_stage,
    debug_hold_stage,
    default_floor_s,
    release_path,
)

pytestmark = pytest.mark.unit


def test_the_default_limit_is_the_floor_the_render_budget_or_the_slowest_stage_times_the_factor():
    default = load_config()  # 640 x 480 at 4 spp: 1.2288 million samples a view, 74 s of budget
    assert default_floor_s(default) == STALL_FLOOR_S == 300.0
    heavy = load_config(None, {"camera.width": 1920, "camera.height": 1080, "render.spp": 64})
    assert default_floor_s(heavy) == pytest.approx(RENDER_BUDGET_S_PER_MEGASAMPLE * 1920 * 1080 * 64 / 1e6)
    limit = StallLimit(default)
    assert limit.seconds == 300.0
    limit.finished(12.0)  # 10 x 12 s = 120 s: under the floor
    assert limit.seconds == 300.0
    limit.finished(45.0)
    limit.finished(7.0)  # the longest stage so far counts
    assert limit.seconds == STALL_FACTOR * 45.0 == 450.0
    assert StallLimit(default, fixed_s=20.0).seconds == 20.0
    assert StallLimit(default, fixed_s=0.0).seconds is None  # --task-timeout 0: never hung


def test_only_a_new_stage_is_progress_timed_by_the_driver(tmp_path):
    limit = StallLimit(load_config(), fixed_s=10.0)
    watchdog = Watchdog(tmp_path, limit)
    beat = Heartbeat(tmp_path, "train-000002", "tcp://10.0.0.5:4000")
    beat.stage("render view 0")
    record = json.loads((tmp_path / HEARTBEAT_DIR / "train-000002.json").read_text())
    assert record["stage"] == "render view 0" and record["beat"] == 1 and record["pid"] == os.getpid()
    assert watchdog.poll({"train-000002"}, now=1000.0) == []
    assert watchdog.poll({"train-000002"}, now=1010.0) == []  # 10 s: not past the limit
    stalled = watchdog.poll({"train-000002"}, now=1010.5)
    assert [b.stage for b in stalled] == ["render view 0"] and stalled[0].stalled_s(1010.5) == 10.5
    assert stalled[0].worker == "tcp://10.0.0.5:4000" and stalled[0].task_s(1010.5) >= 10.5
    # A task the driver no longer waits for is never judged.
    assert watchdog.poll({"train-000003"}, now=2000.0) == []
    beat.stage("encode view 0")  # progress: timed afresh from when the driver reads it
    assert watchdog.poll({"train-000002"}, now=1011.0) == []
    assert watchdog.poll({"train-000002"}, now=1021.5)[0].stage == "encode view 0"
    beat.close()
    assert not (tmp_path / HEARTBEAT_DIR / "train-000002.json").exists()
    assert beat.longest_stage_s >= 0.0 and beat.beats == 2


def test_a_restarted_task_beats_afresh(tmp_path):
    watchdog = Watchdog(tmp_path, StallLimit(load_config(), fixed_s=5.0))
    first = Heartbeat(tmp_path, "test-000000", "tcp://a:1")
    first.stage("compose scene")
    assert watchdog.poll({"test-000000"}, now=0.0) == []
    [hung] = watchdog.poll({"test-000000"}, now=6.0)
    watchdog.dismiss(hung)  # its worker restarted: that run's beat, still on disk, is never judged again
    assert watchdog.poll({"test-000000"}, now=100.0) == []
    second = Heartbeat(tmp_path, "test-000000", "tcp://b:2")
    second.stage("start")  # the same beat number, another run: new progress
    assert watchdog.poll({"test-000000"}, now=101.0) == []
    assert watchdog.poll({"test-000000"}, now=106.5)[0].worker == "tcp://b:2"
    watchdog.forget("test-000000")  # it ended
    assert not (tmp_path / HEARTBEAT_DIR / "test-000000.json").exists()


def test_the_debug_hang_names_a_task_and_optionally_a_stage(monkeypatch):
    monkeypatch.delenv(DEBUG_HANG_ENV, raising=False)
    assert debug_hang_stage("train-000001") is None
    monkeypatch.setenv(DEBUG_HANG_ENV, "train-000001")
    assert debug_hang_stage("train-000001") == "" and debug_hang_stage("train-000010") is None
    monkeypatch.setenv(DEBUG_HANG_ENV, "train-000001@render view 3")
    assert debug_hang_stage("train-000001") == "render view 3"


def test_a_held_task_waits_at_its_stage_until_released(tmp_path, monkeypatch):
    """MOONBOT_DEBUG_HOLD_TASK=<task>@<stage>: that task reports the stage, then waits there until
    OUT/running/<task>.release exists; other stages and tasks pass."""
    monkeypatch.setenv(DEBUG_HOLD_ENV, "train-000001@render view 1")
    assert debug_hold_stage("train-000001") == "render view 1" and debug_hold_stage("train-000002") is None
    Heartbeat(tmp_path, "train-000002", "tcp://127.0.0.1:1").stage("render view 1")  # another task: passes
    beat = Heartbeat(tmp_path, "train-000001", "tcp://127.0.0.1:1")
    beat.stage("render view 0")  # another stage: passes
    held = threading.Thread(target=beat.stage, args=("render view 1",), daemon=True)
    held.start()
    deadline = time.monotonic() + 60
    while json.loads(beat.path.read_text())["stage"] != "render view 1" and time.monotonic() < deadline:
        time.sleep(0.01)
    assert json.loads(beat.path.read_text())["stage"] == "render view 1"  # reported, then held
    assert held.is_alive()
    release_path(tmp_path, "train-000001").touch()
    held.join(timeout=60)
    assert not held.is_alive()
