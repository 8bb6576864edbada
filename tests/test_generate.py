"""`moonbot generate` on real Dask clusters: a LocalCluster of worker processes, an
external `dask scheduler` with two `dask worker` processes on loopback, a worker SIGKILLed in the
middle of a run, a driver killed and rerun, a task that hangs. Whatever happens, every task ends
complete exactly once (or, hung, is reported with its stage) and the data are byte-identical to an
uninterrupted run (images, depth, masks, ground truth; only the measured timings differ)."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from distributed import Client, LocalCluster

from moonbot.cli import main
from moonbot.config import load_config
from moonbot.pipeline.generate import RETRIES, generate, running_tasks
from moonbot.pipeline.heartbeat import (
    DEBUG_HANG_ENV,
    DEBUG_HOLD_ENV,
    HEARTBEAT_DIR,
    Heartbeat,
    StallLimit,
    Watchdog,
    heartbeat_dir,
    release_path,
)
from moonbot.pipeline.tasks import DONE, is_complete, verify_task
from moonbot.sweep import tasks

pytestmark = pytest.mark.integration

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
DATA_FILES = ("rgb.png", "depth.png", "depth.npy", "mask.png")
# Where the interruption tests hold a task (MOONBOT_DEBUG_HOLD_TASK): its first view written, mid-task.
HOLD_STAGE = "render view 1"
# The longest wait for a run to reach a point it reaches in seconds: a bound against a hang, not a pace.
REACH_S = 120


def smoke_cut(path: Path, width: int, height: int, split: dict, **sections) -> Path:
    """configs/smoke.yaml at `width` × `height` pixels with `split` as its one sweep split and
    `sections` in place of those top-level sections, written to `path`."""
    data = yaml.safe_load((CONFIGS / "smoke.yaml").read_text())
    data["camera"] = {"width": width, "height": height}
    data.update(sections)
    data["sweep"]["splits"] = [split]
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    """The smoke config cut to 8 tasks of one split, at 96×72 so a task lasts long enough to be
    interrupted."""
    split = {
        "name": "train",
        "meshes": ["sandbag-01", "sandbag-03"],
        "bag_counts": [1, 2],
        "stain_seeds": [0],
        "dust": [False],
        "sun_elevations_deg": [12.0, 22.0],
        "sun_azimuths_deg": [120.0],
        "camera_heights_m": [0.5],
    }
    return smoke_cut(tmp_path_factory.mktemp("config") / "mini.yaml", 96, 72, split)


def task_data(task: Path) -> dict[str, bytes]:
    """A task's deterministic bytes: task.json, the data files, and gt.json without its measured
    timings, keyed by the path in the task directory."""
    data = {"task.json": (task / "task.json").read_bytes()}
    for view in sorted(task.glob("view_*")):
        for name in DATA_FILES:
            data[f"{view.name}/{name}"] = (view / name).read_bytes()
        gt = json.loads((view / "gt.json").read_text())
        gt.pop("timings_s")
        data[f"{view.name}/gt.json"] = json.dumps(gt, sort_keys=True).encode()
    return data


def dataset_data(out: Path) -> dict[str, bytes]:
    """Every deterministic byte of a run: each task's task_data, keyed "<task>/<path>"; every task
    complete and verified, none left half-written."""
    data = {}
    for task in sorted((out / "tasks").iterdir()):
        assert not task.name.startswith("."), f"stray temporary {task}"
        assert is_complete(task) and verify_task(task) == [], task
        data.update({f"{task.name}/{k}": v for k, v in task_data(task).items()})
    return data


@pytest.fixture(scope="module")
def reference_run(config_file, tmp_path_factory) -> Path:
    """An uninterrupted run on a LocalCluster of 2 worker processes, merged."""
    out = tmp_path_factory.mktemp("reference")
    result = generate(load_config(config_file), out, workers=2, progress=None)
    assert result.failed == {} and result.rendered == result.tasks == 8
    assert result.merge.images == 16 and result.merge.missing == ()
    return out


@pytest.fixture(scope="module")
def reference(reference_run) -> dict[str, bytes]:
    return dataset_data(reference_run)


def test_two_workers_render_every_task_once_and_a_rerun_renders_none(reference, config_file, tmp_path):
    config = load_config(config_file)
    assert len(reference) == 8 * (1 + 2 * (len(DATA_FILES) + 1))
    out = tmp_path / "run"
    first = generate(config, out, workers=2, merge=False, progress=None)
    assert first.rendered == 8 and first.samples == 16
    done_times = {p: p.stat().st_mtime_ns for p in (out / "tasks").glob(f"*/{DONE}")}
    again = generate(config, out, workers=2, merge=False, progress=None)
    assert again.rendered == 0 and again.complete_before == 8 and again.samples == 0
    assert {p: p.stat().st_mtime_ns for p in (out / "tasks").glob(f"*/{DONE}")} == done_times
    task = json.loads(next((out / "tasks").glob("*/task.json")).read_text())
    assert task["views_per_task"] == 2 and task["obj_id"] in (1, 3) and isinstance(task["config"], dict)
    stats = json.loads(next((out / "tasks").glob("*/stats.json")).read_text())
    assert stats["samples"] == 2 and stats["wall_s"] > 0 and stats["bytes_written"] > 0
    assert stats["worker"].startswith("tcp://") and set(stats["stages_s"]) >= {"render", "encode_write"}


def test_one_worker_gives_the_same_bytes(reference, reference_run, config_file, tmp_path):
    generate(load_config(config_file), tmp_path, workers=1, progress=None)
    assert dataset_data(tmp_path) == reference
    # The merged BOP datasets too, file for file (the manifest lists every file's sha256).
    manifest = (tmp_path / "dataset" / "manifest.json").read_bytes()
    assert manifest == (reference_run / "dataset" / "manifest.json").read_bytes()
    assert (tmp_path / "stats" / "tasks.jsonl").is_file() and (tmp_path / "stats" / "tasks.parquet").is_file()


def test_another_config_cannot_join_a_dataset(config_file, tmp_path):
    generate(load_config(config_file), tmp_path, workers=1, merge=False, progress=None)
    other = load_config(config_file, {"camera.width": 80})
    with pytest.raises(OSError, match="config.json"):
        generate(other, tmp_path, workers=1, merge=False, progress=None)


def held_beat(out: Path, task_id: str, other_than: str | None = None) -> dict:
    """The heartbeat of `task_id` once it reports HOLD_STAGE (where MOONBOT_DEBUG_HOLD_TASK holds
    it) in a run (attempt) other than `other_than`: task_id, attempt, stage, worker, pid, ..."""
    path = heartbeat_dir(out) / f"{task_id}.json"
    deadline = time.monotonic() + REACH_S
    while time.monotonic() < deadline:
        try:
            beat = json.loads(path.read_text())
        except (OSError, ValueError):
            beat = {}  # not there yet (heartbeats are replaced whole, never half-written)
        if beat.get("stage") == HOLD_STAGE and beat.get("attempt") != other_than:
            return beat
        time.sleep(0.05)
    raise AssertionError(f"{task_id} did not reach {HOLD_STAGE!r} within {REACH_S} s")


def test_a_worker_killed_mid_run_loses_nothing(reference, config_file, tmp_path, monkeypatch):
    """The worker running a task is SIGKILLed while the task is held in its second view's render
    (MOONBOT_DEBUG_HOLD_TASK, inherited by the worker processes); the task runs again on another
    worker process, is let go, and the run ends complete, byte for byte the uninterrupted one."""
    config = load_config(config_file)
    held = tasks(config)[5].task_id
    monkeypatch.setenv(DEBUG_HOLD_ENV, f"{held}@{HOLD_STAGE}")
    beats = []

    def kill_the_holding_worker_then_release():
        try:
            beats.append(held_beat(tmp_path, held))
            os.kill(beats[0]["pid"], signal.SIGKILL)
            beats.append(held_beat(tmp_path, held, other_than=beats[0]["attempt"]))  # its next run
        finally:  # whatever happened, the run can end
            release_path(tmp_path, held).parent.mkdir(parents=True, exist_ok=True)
            release_path(tmp_path, held).touch()

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=50
        ) as cluster,
        Client(cluster) as client,
    ):
        killer = threading.Thread(target=kill_the_holding_worker_then_release)
        killer.start()
        result = generate(config, tmp_path, client=client, merge=False, progress=None)
        killer.join()
    assert len(beats) == 2 and beats[1]["pid"] != beats[0]["pid"]
    assert result.failed == {} and result.rendered == 8
    assert dataset_data(tmp_path) == reference


def generate_argv(config_file: Path, out: Path, *options: str) -> list[str]:
    """The argv of `moonbot generate CONFIG --out OUT --workers 2 [options]` in a child Python."""
    return [
        sys.executable,
        "-m",
        "moonbot.cli",
        "generate",
        str(config_file),
        "--out",
        str(out),
        "--workers",
        "2",
        *options,
    ]


def test_a_killed_driver_resumes_without_redoing_finished_tasks(reference, config_file, tmp_path):
    """The driver and its local cluster are SIGKILLed at once while a task is held mid-render
    (MOONBOT_DEBUG_HOLD_TASK, never released) and at least two others are complete; the rerun
    with --resume leaves the complete ones alone and ends byte for byte the uninterrupted run."""
    held = tasks(load_config(config_file))[5].task_id
    driver = subprocess.Popen(
        generate_argv(config_file, tmp_path),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        env={**os.environ, DEBUG_HOLD_ENV: f"{held}@{HOLD_STAGE}"},
    )
    try:
        held_beat(tmp_path, held)
        deadline = time.monotonic() + REACH_S
        while time.monotonic() < deadline and len(list((tmp_path / "tasks").glob(f"*/{DONE}"))) < 2:
            time.sleep(0.05)
    finally:
        os.killpg(driver.pid, signal.SIGKILL)  # the driver and its local cluster, at once
        driver.wait()
    finished = {p.parent.name: p.stat().st_mtime_ns for p in (tmp_path / "tasks").glob(f"*/{DONE}")}
    assert len(finished) >= 2 and held not in finished  # the held task cannot have finished
    result = CliRunner().invoke(
        main, ["generate", str(config_file), "--out", str(tmp_path), "--resume", "--workers", "2"]
    )
    assert result.exit_code == 0, result.output
    assert f"{len(finished)} were complete already" in result.output
    assert {name: (tmp_path / "tasks" / name / DONE).stat().st_mtime_ns for name in finished} == finished
    assert dataset_data(tmp_path) == reference


def test_an_external_scheduler_and_workers(reference, config_file, tmp_path):
    scheduler_file = tmp_path / "scheduler.json"
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    processes = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--dashboard-address",
                ":0",
                "--scheduler-file",
                str(scheduler_file),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        for _ in range(2):
            processes.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "distributed.cli.dask_worker",
                        "--scheduler-file",
                        str(scheduler_file),
                        "--nthreads",
                        "1",
                        "--host",
                        "127.0.0.1",
                        "--no-dashboard",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=env,
                )
            )
        with Client(scheduler_file=str(scheduler_file)) as client:
            client.wait_for_workers(2, timeout=60)
        out = tmp_path / "out"
        result = CliRunner().invoke(
            main, ["generate", str(config_file), "--out", str(out), "--scheduler-file", str(scheduler_file)]
        )
        assert result.exit_code == 0, result.output
    finally:
        for p in reversed(processes):
            p.terminate()
        for p in processes:
            p.wait(timeout=30)
    assert dataset_data(out) == reference


def test_a_bad_config_runs_no_task(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text((CONFIGS / "smoke.yaml").read_text().replace("bag_counts: [1, 3]", "bag_counts: [1, 300]"))
    result = CliRunner().invoke(main, ["generate", str(bad), "--out", str(tmp_path / "out")])
    assert result.exit_code != 0 and "bag_counts[1]" in result.output
    assert not (tmp_path / "out").exists()
    # An output that cannot be a directory fails before any task, naming it.
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = CliRunner().invoke(main, ["generate", str(CONFIGS / "smoke.yaml"), "--out", str(blocker)])
    assert result.exit_code != 0 and str(blocker) in result.output


def test_the_smoke_sweep_has_every_split_mesh_and_dust():
    ts = tasks(load_config(CONFIGS / "smoke.yaml"))
    assert {t.split for t in ts} == {"train", "val", "test"}
    assert {t.mesh for t in ts} == {"sandbag-01", "sandbag-02", "sandbag-03"} and {t.dust for t in ts} == {False, True}


def test_a_failed_write_leaves_no_task_and_loses_nothing(config_file, tmp_path):
    """A write that fails mid-task (here: a file-size limit, as a full disk would) fails that task
    with an error, leaves neither it nor a temporary behind, and leaves complete tasks alone."""
    import resource

    from moonbot.pipeline.tasks import run_task, sweep_temporaries, task_dir

    config = load_config(config_file)
    first, second = tasks(config)[:2]
    run_task(config, first, tmp_path, threads=1)
    before = {p.name: p.read_bytes() for p in task_dir(tmp_path, first).rglob("*") if p.is_file()}
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, hard))  # an rgb.png is bigger than 4 KiB
    try:
        with pytest.raises(OSError):
            run_task(config, second, tmp_path, threads=1)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert not task_dir(tmp_path, second).exists()
    assert sweep_temporaries(tmp_path) == []  # the failed task cleaned up after itself
    assert {p.name: p.read_bytes() for p in task_dir(tmp_path, first).rglob("*") if p.is_file()} == before
    assert verify_task(task_dir(tmp_path, first)) == []


def test_the_progress_line_names_running_tasks_with_their_ages(tmp_path):
    """Each running task with its age and its stage's, oldest first, on the driver's clock; three
    at most, then how many more."""
    watchdog = Watchdog(tmp_path, StallLimit(load_config(), fixed_s=0.0))
    for task_id, stage in (
        ("train-000001", "render view 2"),
        ("train-000002", "compose scene"),
        ("train-000003", "encode view 0"),
        ("train-000004", "build BVH"),
    ):
        Heartbeat(tmp_path, task_id, "tcp://127.0.0.1:1").stage(stage)
    ids = {f"train-00000{i}" for i in range(1, 5)}
    watchdog.poll({"train-000001"}, 1000.0)  # seen first: the oldest
    watchdog.poll(ids, 1030.0)
    text = running_tasks(list(watchdog.beats.values()), 1041.0)
    assert text == (
        "4 running: train-000001 for 41 s (in 'render view 2' for 41 s), "
        "train-000002 for 11 s (in 'compose scene' for 11 s), "
        "train-000003 for 11 s (in 'encode view 0' for 11 s), and 1 more"
    )
    assert running_tasks([], 1041.0) == ""


class InterruptAfterTheFirstTask(io.StringIO):
    """generate's progress stream, which sends this process `signum` as the first task is reported
    finished: a Ctrl-C (SIGINT) or a `kill` (SIGTERM) at a known point of the run."""

    def __init__(self, signum: int) -> None:
        super().__init__()
        self.signum = signum

    def write(self, text: str) -> int:
        written = super().write(text)
        if text.startswith("[1/"):
            os.kill(os.getpid(), self.signum)
        return written


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_leaves_no_temporaries(config_file, tmp_path, monkeypatch, signum):
    """Interrupted as its first task finishes, a run on a real LocalCluster stops: the cluster
    closed, no Dask scratch space, staging folder or heartbeat left, the complete tasks intact and
    nothing merged; `moonbot merge` then makes a dataset of what is complete."""
    scratch_root = tmp_path / "tmp"
    scratch_root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch_root))  # where the local cluster's scratch goes
    out = tmp_path / "out"
    handler = signal.getsignal(signal.SIGTERM)
    result = generate(load_config(config_file), out, workers=2, progress=InterruptAfterTheFirstTask(signum))
    assert result.interrupted == signal.Signals(signum).name and result.merge is None
    assert list(scratch_root.iterdir()) == []
    assert not (out / HEARTBEAT_DIR).exists() and not (out / "dataset").exists()
    assert all(not p.name.startswith(".") for p in (out / "tasks").iterdir())
    complete = [p for p in (out / "tasks").iterdir() if is_complete(p)]
    assert 1 <= result.complete == len(complete) < 8
    assert all(verify_task(p) == [] for p in complete)
    assert signal.getsignal(signal.SIGTERM) == handler  # the run's own handler is gone with it
    merged = CliRunner().invoke(main, ["merge", str(out)])
    assert merged.exit_code == 3 and f"merged {len(complete)} tasks" in merged.output


def test_ctrl_c_prints_the_merge_command(config_file, tmp_path):
    """The command line, interrupted by SIGINT once a task is complete, exits 130 and prints the
    exact commands that merge what is complete and render the rest; no scratch space is left."""
    scratch_root = tmp_path / "tmp"
    scratch_root.mkdir()
    out = tmp_path / "out"
    driver = subprocess.Popen(
        generate_argv(config_file, out, "--no-merge"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TMPDIR": str(scratch_root)},
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not any((out / "tasks").glob(f"*/{DONE}")):
        time.sleep(0.05)
    driver.send_signal(signal.SIGINT)
    _, stderr = driver.communicate(timeout=120)
    assert driver.returncode == 130, stderr
    assert f"\n  moonbot merge {out}    # a BOP dataset of the complete tasks" in stderr
    assert f"\n  moonbot generate {config_file} --out {out}    # renders the " in stderr
    assert list(scratch_root.iterdir()) == []


@pytest.mark.timeout(420)
def test_a_hung_task_is_reported_with_its_stage_and_the_others_finish(reference, config_file, tmp_path, monkeypatch):
    """A task made to block for good in its second view's render (the debug setting, inherited by
    the worker processes) is judged hung after --task-timeout without a new stage, its worker is
    restarted through the nanny and it runs again, RETRIES + 1 times; then it is reported failed,
    naming the stage, the worker and the host, while the 7 others finish with the reference's
    bytes. A rerun without the hang completes the sweep, byte for byte."""
    hung = tasks(load_config(config_file))[5].task_id
    monkeypatch.setenv(DEBUG_HANG_ENV, f"{hung}@render view 1")
    command = ["generate", str(config_file), "--out", str(tmp_path), "--workers", "2", "--no-merge"]
    # 20 s: on this loaded 2-core machine a 96x72 task's stages last a second or two.
    result = CliRunner().invoke(main, [*command, "--task-timeout", "20"])
    assert result.exit_code == 1
    failures = [line for line in result.output.splitlines() if line.startswith("failed: ")]
    assert len(failures) == 1 and failures[0].startswith(f"failed: {hung}: hung {RETRIES + 1} times (limit 20 s")
    tries = failures[0].split(") no progress for ")[1:]
    assert len(tries) == RETRIES + 1
    for attempt in tries:
        assert "in stage 'render view 1' on worker tcp://127.0.0.1:" in attempt
        assert f"(host {os.uname().nodename}, pid " in attempt and "worker restarted" in attempt
        stalled = float(attempt.split(" s ", 1)[0])
        assert stalled >= 20  # judged hung only past the limit (printed rounded)
    assert "1 of 8 tasks failed" in result.output
    assert dataset_data(tmp_path) == {k: v for k, v in reference.items() if not k.startswith(f"{hung}/")}
    assert not (tmp_path / HEARTBEAT_DIR).exists()

    monkeypatch.delenv(DEBUG_HANG_ENV)
    again = CliRunner().invoke(main, command)
    assert again.exit_code == 0, again.output
    assert "1 tasks rendered" in again.output and "7 were complete already" in again.output
    assert dataset_data(tmp_path) == reference
