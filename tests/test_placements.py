"""A scene layout's bags placed and settled once for all the tasks that show them, on real Dask
LocalClusters: the placement tasks of `moonbot generate` (moonbot.pipeline.placements) are counted
from the run's result and its OUT/placements records; the tasks' bytes are those of tasks that
place their own bags, as every task did before; 1 and 2 workers give the same bytes; a resumed
run reads the kept placement back; a settle that fails fails its layout's tasks, naming it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from moonbot.cli import main
from moonbot.config import load_config
from moonbot.pipeline.generate import RETRIES, generate
from moonbot.pipeline.heartbeat import DEBUG_HANG_ENV, HEARTBEAT_DIR
from moonbot.pipeline.placements import (
    TASK_PREFIX,
    PlacementError,
    layout_id,
    place_layout,
    placement_for,
    placement_path,
    read_placements,
)
from moonbot.pipeline.stats import load_placements, summarize
from moonbot.pipeline.tasks import run_task, task_dir
from moonbot.records.stats import read_stats
from moonbot.scene.compose import place_bags
from moonbot.sweep import task_config, tasks
from moonbot.terrain import get_terrain

from test_generate import smoke_cut, task_data

pytestmark = pytest.mark.integration


def sweep_config(tmp_path: Path, **settle) -> Path:
    """The smoke config cut to 8 tasks at 48×36 with 2 views: one mesh, 1 and 2 bags (2 layouts),
    two stains (2 scenes of each layout), two Sun elevations (2 tasks of each scene)."""
    split = {
        "name": "train",
        "meshes": ["sandbag-02"],
        "bag_counts": [1, 2],
        "stain_seeds": [0, 30],
        "dust": [False],
        "sun_elevations_deg": [12.0, 22.0],
        "sun_azimuths_deg": [120.0],
        "camera_heights_m": [0.5],
    }
    return smoke_cut(tmp_path / "sweep.yaml", 48, 36, split, bags={"settle": settle} if settle else {})


def run_data(out: Path) -> dict[str, bytes]:
    return {f"{d.name}/{k}": v for d in sorted((out / "tasks").iterdir()) for k, v in task_data(d).items()}


@pytest.mark.timeout(600)
def test_each_layout_is_settled_once_and_the_tasks_bytes_do_not_change(tmp_path):
    config = load_config(sweep_config(tmp_path))
    sweep = tasks(config)
    layouts = sorted({layout_id(t) for t in sweep})
    assert len(sweep) == 8 and layouts == ["train-sandbag-02-plane-b01", "train-sandbag-02-plane-b02"]

    two = generate(config, tmp_path / "two", workers=2, merge=False, progress=None)
    assert two.failed == {} and two.rendered == 8
    # One placement per layout, each settled once: 2 settles where each of the 8 tasks settled before.
    assert (two.placed, two.placed_before) == (2, 0)
    records = read_placements(tmp_path / "two")
    assert [r["layout_id"] for r in records] == layouts
    assert all(set(r["stages_s"]) == {"place", "settle"} and r["settle"]["steps"] > 0 for r in records)
    assert [len(r["poses"]) for r in records] == [1, 2]
    for d in (tmp_path / "two" / "tasks").iterdir():  # the settle is the placement's, not the task's
        assert "settle" not in json.loads((d / "stats.json").read_text())["stages_s"]
        for view in d.glob("view_*"):
            assert "settle" not in json.loads((view / "gt.json").read_text())["timings_s"]
    # Counted once per layout in the run's stage totals.
    summary = summarize(
        [read_stats(d / "stats.json") for d in (tmp_path / "two" / "tasks").iterdir()],
        placements=load_placements(tmp_path / "two"),
    )
    assert summary.placements == 2
    assert summary.stage_seconds_per_sample["settle"] * summary.samples == pytest.approx(
        sum(r["stages_s"]["settle"] for r in records)
    )

    # Before: every task placed and settled its own bags (run_task without a placement).
    before = tmp_path / "before"
    for t in sweep:
        run_task(config, t, before, threads=1)
        assert "settle" in json.loads((task_dir(before, t) / "stats.json").read_text())["stages_s"]
    assert run_data(tmp_path / "two") == run_data(before)

    one = generate(config, tmp_path / "one", workers=1, merge=False, progress=None)
    assert one.failed == {} and (one.placed, one.placed_before) == (2, 0)
    assert run_data(tmp_path / "one") == run_data(tmp_path / "two")
    assert [r["poses"] for r in read_placements(tmp_path / "one")] == [r["poses"] for r in records]

    # A resumed run renders only what is missing and reads its layout's placement back.
    again = generate(config, tmp_path / "two", workers=2, merge=False, progress=None)
    assert (again.rendered, again.placed, again.placed_before) == (0, 0, 0)
    kept = placement_path(tmp_path / "two", "train-sandbag-02-plane-b02").read_bytes()
    missing = next(t for t in sweep if t.bags == 2)
    expected = task_data(task_dir(tmp_path / "two", missing))
    for path in sorted(task_dir(tmp_path / "two", missing).rglob("*"), reverse=True):
        path.rmdir() if path.is_dir() else path.unlink()
    task_dir(tmp_path / "two", missing).rmdir()
    resumed = generate(config, tmp_path / "two", workers=2, merge=False, progress=None)
    assert (resumed.rendered, resumed.placed, resumed.placed_before) == (1, 0, 1)
    assert placement_path(tmp_path / "two", "train-sandbag-02-plane-b02").read_bytes() == kept
    assert task_data(task_dir(tmp_path / "two", missing)) == expected


def test_a_kept_placement_reads_back_bit_for_bit(tmp_path):
    """The poses in OUT/placements are the settled float64 poses exactly (JSON's shortest
    round-trip decimals), and a task of another layout refuses them."""
    config = load_config(sweep_config(tmp_path))
    first, other = (next(t for t in tasks(config) if t.bags == n) for n in (2, 1))
    outcome = place_layout(config, first, tmp_path)
    assert outcome["placed"] and place_layout(config, first, tmp_path)["placed"] is False
    tconfig = task_config(config, first)
    direct = place_bags(tconfig, get_terrain(tconfig.terrain)[0].ground)
    kept = placement_for(tconfig, json.loads(placement_path(tmp_path, layout_id(first)).read_text()))
    assert all(np.array_equal(a, b) and a.tobytes() == b.tobytes() for a, b in zip(kept.poses, direct.poses))
    with pytest.raises(PlacementError, match="train-sandbag-02-plane-b02: its placement was made for other inputs"):
        placement_for(task_config(config, other), outcome["record"])


@pytest.mark.timeout(300)
def test_a_failed_settle_fails_the_tasks_of_its_layout_naming_it(tmp_path):
    """Bags that cannot come to rest within bags.settle.max_time_s: each layout's placement fails
    (after its retries) and every task of the layout is reported with the layout and the field;
    no task directory and no placement record is written."""
    config = load_config(sweep_config(tmp_path, max_time_s=0.004, timestep_s=0.004, contact_time_s=0.02))
    result = generate(config, tmp_path / "out", workers=2, merge=False, progress=None)
    assert result.rendered == 0 and result.placed == 0 and set(result.failed) == {t.task_id for t in tasks(config)}
    for t in tasks(config):
        error = result.failed[t.task_id]
        assert f"PlacementError('scene layout {layout_id(t)} (seed " in error
        assert "bags.settle.max_time_s: bags still moving after 0.004 s" in error
    assert not list((tmp_path / "out" / "tasks").iterdir())
    assert read_placements(tmp_path / "out") == []


@pytest.mark.timeout(420)
def test_a_hung_placement_fails_the_tasks_of_its_layout_and_the_others_finish(tmp_path, monkeypatch):
    """A placement made to block for good while placing its bags (the heartbeat's debug setting,
    inherited by the worker processes) is judged hung after --task-timeout, its worker restarted
    and the placement run again, RETRIES + 1 times; then the tasks of its layout are reported
    failed, naming the layout, the stage and the worker, while the other layout's finish. A rerun
    without the hang completes the sweep."""
    config_file = sweep_config(tmp_path)
    sweep = tasks(load_config(config_file))
    hung = "train-sandbag-02-plane-b02"
    monkeypatch.setenv(DEBUG_HANG_ENV, f"{TASK_PREFIX}{hung}@place bags")
    command = ["generate", str(config_file), "--out", str(tmp_path / "out"), "--workers", "2", "--no-merge"]
    result = CliRunner().invoke(main, [*command, "--task-timeout", "20"])
    assert result.exit_code == 1
    failures = sorted(line for line in result.output.splitlines() if line.startswith("failed: "))
    assert [f.split(":")[1].strip() for f in failures] == sorted(t.task_id for t in sweep if layout_id(t) == hung)
    for line in failures:
        assert f": the placement of its scene layout {hung} hung {RETRIES + 1} times (limit 20 s" in line
        assert line.count("in stage 'place bags' on worker tcp://127.0.0.1:") == RETRIES + 1
    assert "4 of 8 tasks failed" in result.output
    assert sorted(d.name for d in (tmp_path / "out" / "tasks").iterdir()) == sorted(
        t.task_id for t in sweep if layout_id(t) != hung
    )
    assert not (tmp_path / "out" / HEARTBEAT_DIR).exists()

    monkeypatch.delenv(DEBUG_HANG_ENV)
    again = CliRunner().invoke(main, command)
    assert again.exit_code == 0, again.output
    assert "4 tasks rendered" in again.output and "1 scene layouts placed" in again.output
