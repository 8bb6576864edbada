"""Throughput statistics (moonbot.pipeline.stats, `moonbot stats`) and the cluster/ recipes.

The fixture writes task directories the way a generate worker leaves them (stats.json, then a
DONE.json listing every file with its size and checksum) for a run on two hosts: node-a (2 cores,
2 workers of 1 render thread) and node-b (4 cores, 1 worker of 4 threads). The summary is checked
against numbers worked out by hand from that table."""

from __future__ import annotations

import copy
import datetime
import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml
from click.testing import CliRunner

from moonbot.cli import main
from moonbot.pipeline import stats
from moonbot.pipeline.stats import Reference, StatsError

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[1]
T0 = datetime.datetime(2026, 11, 23, 10, 0, 0, tzinfo=datetime.timezone.utc)
A = dict(host="node-a", cpu_model="AMD EPYC 7B13", cores=2, threads=1)
B = dict(host="node-b", cpu_model="Intel(R) Xeon(R) Gold 6338", cores=4, threads=4)

# (task_id, host, worker, pid, start s after T0, wall s, CPU s, samples, stages)
TASKS = [
    (
        "train-s000000",
        A,
        "tcp://10.0.0.1:40001",
        101,
        0.0,
        40.0,
        38.0,
        36,
        {
            "terrain": 2.0,
            "compose": 3.0,
            "settle": 1.0,
            "build_bvh": 2.0,
            "render": 25.0,
            "tonemap": 1.0,
            "encode_write": 5.0,
        },
    ),
    (
        "train-s000001",
        A,
        "tcp://10.0.0.1:40002",
        102,
        0.5,
        42.0,
        38.0,
        36,
        {"terrain": 2.0, "compose": 3.0, "build_bvh": 2.0, "render": 27.0, "tonemap": 1.0, "encode_write": 5.0},
    ),
    (
        "train-s000002",
        A,
        "tcp://10.0.0.1:40001",
        101,
        41.0,
        40.0,
        38.0,
        36,
        {
            "terrain": 0.0,
            "compose": 3.0,
            "settle": 1.0,
            "build_bvh": 2.0,
            "dust": 4.0,
            "render": 23.0,
            "tonemap": 1.0,
            "encode_write": 5.0,
        },
    ),
    (
        "train-s000003",
        A,
        "tcp://10.0.0.1:40002",
        102,
        43.0,
        40.0,
        38.0,
        36,
        {"terrain": 0.0, "compose": 3.0, "build_bvh": 2.0, "render": 28.0, "tonemap": 1.0, "encode_write": 5.0},
    ),
    (
        "test-s000000",
        B,
        "tcp://10.0.0.2:40001",
        201,
        1.0,
        29.0,
        100.0,
        36,
        {"terrain": 1.5, "compose": 2.0, "build_bvh": 1.0, "render": 20.0, "tonemap": 0.5, "encode_write": 3.0},
    ),
    (
        "test-s000001",
        B,
        "tcp://10.0.0.2:40001",
        201,
        32.0,
        29.0,
        100.0,
        36,
        {
            "terrain": 0.0,
            "compose": 2.0,
            "build_bvh": 1.0,
            "dust": 3.0,
            "render": 19.0,
            "tonemap": 0.5,
            "encode_write": 3.0,
        },
    ),
    (
        "test-s000002",
        B,
        "tcp://10.0.0.2:40001",
        201,
        63.0,
        29.0,
        100.0,
        36,
        {"terrain": 0.0, "compose": 2.0, "build_bvh": 1.0, "render": 22.0, "tonemap": 0.5, "encode_write": 3.0},
    ),
]


def stats_record(task_id, hw, worker, pid, start, wall, cpu, samples, stages) -> dict:
    return {
        "task_id": task_id,
        "host": hw["host"],
        "pid": pid,
        "cpu_model": hw["cpu_model"],
        "cores": hw["cores"],
        "threads": hw["threads"],
        "worker": worker,
        "started_utc": (T0 + datetime.timedelta(seconds=start)).isoformat(),
        "wall_s": wall,
        "cpu_s": cpu,
        "stages_s": dict(stages),
        "samples": samples,
        "bytes_written": samples * 1_700_000,
        "samples_per_s": samples / wall,
    }


def write_task(out: Path, record: dict, name: str | None = None, done: bool = True) -> Path:
    """A task directory as a worker commits it: stats.json, then DONE.json with every file's size
    and SHA-256 (what moonbot.pipeline.tasks.is_complete checks)."""
    d = out / "tasks" / (name or record["task_id"])
    d.mkdir(parents=True)
    (d / "stats.json").write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
    if done:
        files = {
            p.name: {"bytes": p.stat().st_size, "sha256": hashlib.sha256(p.read_bytes()).hexdigest()}
            for p in sorted(d.iterdir())
        }
        # The marker of a sound task, whatever a test spoilt in stats.json.
        samples = record["samples"] if isinstance(record["samples"], int) else 0
        (d / "DONE.json").write_text(
            json.dumps({"task_id": record["task_id"], "samples": samples, "files": files}, indent=2, sort_keys=True)
            + "\n"
        )
    return d


def write_run(out: Path, tasks=TASKS, order=None) -> Path:
    for k in order or range(len(tasks)):
        write_task(out, stats_record(*tasks[k]))
    return out


@pytest.fixture()
def run(tmp_path) -> Path:
    return write_run(tmp_path / "run")


# --- collect -----------------------------------------------------------------------------------


def test_collect_writes_jsonl_and_parquet_with_the_same_values(run):
    collected = stats.collect(run)
    assert [r.task_id for r in collected.records] == sorted(t[0] for t in TASKS)
    assert collected.incomplete == []
    expected = {t[0]: stats_record(*t) for t in TASKS}
    lines = (run / "stats" / "tasks.jsonl").read_text().splitlines()
    # The tasks' stats.json are of version 1 (no schema_version): the lines are read as version 2.
    assert [json.loads(line) for line in lines] == [dict(expected[k], schema_version=2) for k in sorted(expected)]

    table = pq.read_table(run / "stats" / "tasks.parquet")
    assert table.num_rows == len(TASKS)
    stage_columns = [c for c in table.column_names if c.startswith("stage_")]
    # Pipeline order, one column per stage that ran anywhere.
    assert stage_columns == [
        "stage_terrain_s",
        "stage_compose_s",
        "stage_settle_s",
        "stage_build_bvh_s",
        "stage_dust_s",
        "stage_render_s",
        "stage_tonemap_s",
        "stage_encode_write_s",
    ]
    rows = table.to_pylist()
    for row in rows:
        rec = expected[row["task_id"]]
        for name in (
            "host",
            "pid",
            "cpu_model",
            "cores",
            "threads",
            "worker",
            "wall_s",
            "cpu_s",
            "samples",
            "bytes_written",
            "samples_per_s",
        ):
            assert row[name] == rec[name], name
        assert row["started_utc"] == datetime.datetime.fromisoformat(rec["started_utc"])
        for stage in ("terrain", "compose", "settle", "build_bvh", "dust", "render", "tonemap", "encode_write"):
            assert row[f"stage_{stage}_s"] == rec["stages_s"].get(stage), (stage, row["task_id"])  # None: absent
    # A stage absent from a task is null, not zero.
    by_id = {r["task_id"]: r for r in rows}
    assert by_id["train-s000001"]["stage_settle_s"] is None and by_id["train-s000002"]["stage_dust_s"] == 4.0


def test_collect_is_byte_deterministic_whatever_the_order_tasks_finished(tmp_path):
    first = write_run(tmp_path / "one")
    second = write_run(tmp_path / "two", order=list(reversed(range(len(TASKS)))))
    stats.collect(first)
    jsonl, parquet = ((first / "stats" / n).read_bytes() for n in ("tasks.jsonl", "tasks.parquet"))
    stats.collect(first)  # again, over its own output
    assert (first / "stats" / "tasks.jsonl").read_bytes() == jsonl
    assert (first / "stats" / "tasks.parquet").read_bytes() == parquet
    stats.collect(second)
    assert (second / "stats" / "tasks.jsonl").read_bytes() == jsonl
    assert (second / "stats" / "tasks.parquet").read_bytes() == parquet
    assert sorted(p.name for p in (first / "stats").iterdir()) == ["tasks.jsonl", "tasks.parquet"]  # no temporaries


def test_temporaries_and_unfinished_directories_are_left_out(run):
    extra = stats_record("train-s000009", A, "tcp://10.0.0.1:40001", 101, 90.0, 40.0, 38.0, 36, {"render": 30.0})
    write_task(run, extra, name=".train-s000009.abc123.tmp")  # a worker's staging dir, even if whole
    write_task(run, dict(extra, task_id="train-s000010"), done=False)  # killed before its marker
    torn = write_task(run, dict(extra, task_id="train-s000011"))
    (torn / "stats.json").write_text("{}")  # no longer the size DONE.json lists
    collected = stats.collect(run)
    assert len(collected.records) == len(TASKS)
    assert [d.name for d in collected.incomplete] == ["train-s000010", "train-s000011"]
    table = pq.read_table(run / "stats" / "tasks.parquet")
    assert "train-s000009" not in table.column("task_id").to_pylist()


def test_an_empty_run_writes_empty_files(tmp_path):
    (tmp_path / "tasks").mkdir()
    assert stats.collect(tmp_path).records == []
    assert (tmp_path / "stats" / "tasks.jsonl").read_text() == ""
    assert pq.read_table(tmp_path / "stats" / "tasks.parquet").num_rows == 0
    with pytest.raises(ValueError, match="no finished tasks"):
        stats.summarize([])


def test_extra_fields_are_kept(tmp_path):
    records = [
        dict(
            stats_record(*t),
            attempt=k % 2 + 1,
            split=t[0].split("-")[0],
            maxrss_mb=700 + k * 0.5,
            sun={"elevation_deg": 12.0},
        )
        for k, t in enumerate(TASKS)
    ]
    for r in records:
        write_task(tmp_path, r)
    stats.collect(tmp_path)
    rows = {r["task_id"]: r for r in pq.read_table(tmp_path / "stats" / "tasks.parquet").to_pylist()}
    for r in records:
        row = rows[r["task_id"]]
        assert (row["attempt"], row["split"], row["maxrss_mb"]) == (r["attempt"], r["split"], r["maxrss_mb"])
        assert json.loads(row["sun"]) == r["sun"]  # nested values as JSON text
    lines = [json.loads(x) for x in (tmp_path / "stats" / "tasks.jsonl").read_text().splitlines()]
    assert lines == [dict(r, schema_version=2) for r in sorted(records, key=lambda r: r["task_id"])]


# --- bad input ---------------------------------------------------------------------------------

BAD = [
    (lambda r: r.pop("wall_s"), "wall_s: missing"),
    (lambda r: r.update(samples="36"), "samples: must be an integer"),
    (lambda r: r.update(cores=True), "cores: must be an integer"),
    (lambda r: r.update(cpu_s=None), "cpu_s: must be a number"),
    (lambda r: r.update(wall_s=-1.0), "wall_s: must be >= 0"),
    (lambda r: r.update(threads=0), "threads: must be >= 1"),
    (lambda r: r.update(host=""), "host: must not be empty"),
    (lambda r: r.update(started_utc="yesterday"), "started_utc: not an ISO-8601 time"),
    (lambda r: r.update(stages_s=[1, 2]), "stages_s: must be a mapping"),
    (lambda r: r["stages_s"].update(render="fast"), "stages_s.render: must be a number"),
    (lambda r: r["stages_s"].update(render=-0.5), "stages_s.render: must be >= 0"),
    (lambda r: r.update(task_id="train-s000099"), "task_id: 'train-s000099' is not its directory's name"),
]


@pytest.mark.parametrize("spoil, message", BAD, ids=[m.split(":")[0] for _, m in BAD])
def test_a_bad_stats_file_is_reported_by_file_and_field(run, spoil, message):
    record = stats_record(*TASKS[2])
    spoil(record)
    path = run / "tasks" / "train-s000002" / "stats.json"
    shutil.rmtree(path.parent)
    write_task(run, record, name="train-s000002")
    with pytest.raises(StatsError) as error:
        stats.collect(run)
    assert str(error.value).startswith(f"{path}: {message}"), str(error.value)
    assert not (run / "stats" / "tasks.jsonl").exists()  # nothing written from a bad run


def test_nan_and_broken_json_are_reported(run):
    path = run / "tasks" / "train-s000000" / "stats.json"
    for text, message in (
        (json.dumps(dict(stats_record(*TASKS[0]), cpu_s=math.nan)), "cpu_s: must be finite"),
        ('{"task_id": ', "not valid JSON"),
    ):
        shutil.rmtree(path.parent)
        path.parent.mkdir()
        path.write_text(text)
        files = {"stats.json": {"bytes": path.stat().st_size, "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}}
        (path.parent / "DONE.json").write_text(json.dumps({"task_id": "train-s000000", "samples": 36, "files": files}))
        with pytest.raises(StatsError, match=f"^{path}: {message}"):
            stats.collect(run)


def test_a_bad_line_of_tasks_jsonl_is_reported_by_line(run):
    stats.collect(run)
    shutil.rmtree(run / "tasks")
    path = run / "stats" / "tasks.jsonl"
    lines = path.read_text().splitlines()
    bad = json.loads(lines[3])
    del bad["host"]
    lines[3] = json.dumps(bad)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(StatsError, match=f"^{path}:4: host: missing"):
        stats.load(run)


def test_not_a_generate_directory(tmp_path):
    with pytest.raises(StatsError, match="tasks: no such directory"):
        stats.collect(tmp_path)
    with pytest.raises(StatsError, match="neither tasks/ nor stats/tasks.jsonl"):
        stats.load(tmp_path)


# --- the summary, against hand computation ------------------------------------------------------


def test_summary_numbers(run):
    s = stats.summarize(stats.collect(run).records)
    # Ends: node-a 40, 42.5, 81, 83; node-b 30, 61, 92 (seconds after T0); first start 0.
    span = 92.0
    samples = 7 * 36
    wall = 4 * 40.0 + 42.0 - 40.0 + 3 * 29.0  # 249
    assert (s.tasks, s.samples, s.bytes_written) == (7, samples, samples * 1_700_000)
    assert s.wall_s == pytest.approx(wall) and s.cpu_s == pytest.approx(4 * 38.0 + 3 * 100.0)
    assert s.span_s == pytest.approx(span) and s.idle_s == pytest.approx(0.0)
    assert s.first_start_utc == "2026-11-23T10:00:00.000+00:00" and s.last_end_utc == "2026-11-23T10:01:32.000+00:00"
    assert s.samples_per_s == pytest.approx(samples / span)
    # Three tasks run at once from t = 1 s (two on node-a, one on node-b).
    assert (s.workers, s.worker_ids, s.cores, s.render_threads) == (3, 3, 6, 2 * 1 + 1 * 4)
    assert s.per_worker == pytest.approx(samples / span / 3)
    assert s.per_core == pytest.approx(samples / span / 6)
    assert s.per_thread == pytest.approx(samples / span / 6)
    assert s.parallel_efficiency == pytest.approx(wall / (3 * span))
    assert s.cpu_use == pytest.approx((4 * 38.0 + 3 * 100.0) / (4 * 40.0 + 2.0 + 3 * 29.0 * 4))
    assert s.scaling_efficiency is None

    a, b = s.hosts
    assert (a.host, a.cores, a.workers, a.threads, a.tasks, a.samples) == ("node-a", 2, 2, 1, 4, 144)
    assert a.span_s == pytest.approx(83.0) and a.samples_per_s == pytest.approx(144 / 83)
    assert a.samples_per_s_per_core == pytest.approx(144 / 83 / 2) and a.busy == pytest.approx(162 / (2 * 83))
    assert (b.host, b.cores, b.workers, b.threads, b.tasks, b.samples) == ("node-b", 4, 1, 4, 3, 108)
    assert b.span_s == pytest.approx(91.0) and b.samples_per_s == pytest.approx(108 / 91)
    assert b.samples_per_s_per_core == pytest.approx(108 / 91 / 4) and b.busy == pytest.approx(87 / 91)
    assert a.cpu_model == "AMD EPYC 7B13"

    timed = sum(sum(t[8].values()) for t in TASKS)
    render = 25 + 27 + 23 + 28 + 20 + 19 + 22
    assert list(s.stage_share) == [
        "terrain",
        "compose",
        "settle",
        "build_bvh",
        "dust",
        "render",
        "tonemap",
        "encode_write",
    ]
    assert s.stage_share["render"] == pytest.approx(render / timed)
    assert s.stage_share["dust"] == pytest.approx(7.0 / timed)
    assert sum(s.stage_share.values()) == pytest.approx(1.0)
    assert s.stage_seconds_per_sample["render"] == pytest.approx(render / samples)
    assert s.stage_coverage == pytest.approx(timed / wall)
    assert b.stages_s["dust"] == 3.0 and a.stages_s["settle"] == 2.0


def test_scaling_efficiency_against_a_reference(run, tmp_path):
    # The reference: one worker of node-b alone, 36 samples in 30 s.
    ref = write_run(
        tmp_path / "ref",
        tasks=[("test-s000000", B, "tcp://10.0.0.2:40001", 201, 0.0, 30.0, 100.0, 36, {"render": 25.0})],
    )
    reference = stats.reference_from_run(ref)
    assert reference.samples_per_s_per_worker == pytest.approx(36 / 30)
    s = stats.summarize(stats.load(run), reference)
    assert s.scaling_efficiency == pytest.approx((252 / 92) / (3 * 36 / 30))
    # From a rate measured elsewhere (a benchmark): the same definition.
    s = stats.summarize(stats.load(run), Reference(1.0, "bench"))
    assert s.scaling_efficiency == pytest.approx(252 / 92 / 3)


def test_scaling_efficiency_against_a_benchmark_record(tmp_path):
    """bench/bench_generate.py's record: the 1-worker run with the run's render threads is X1."""
    bench = tmp_path / "generate-amd-epyc-2c.json"
    bench.write_text(
        json.dumps(
            {
                "schema_version": 1,
                "benchmark": "generate",
                "runs": [
                    {"workers": 1, "threads_per_worker": 1, "samples_per_s": 0.5},
                    {"workers": 1, "threads_per_worker": 2, "samples_per_s": 0.9},
                    {"workers": 2, "threads_per_worker": 1, "samples_per_s": 0.95},
                ],
            }
        )
    )
    run = write_run(tmp_path / "run", tasks=TASKS[:4])  # node-a: 2 workers × 1 thread
    result = CliRunner().invoke(main, ["stats", str(run), "--reference", str(bench)])
    assert result.exit_code == 0, result.output
    s = stats.summarize(stats.load(run))
    assert f"scaling {s.samples_per_s / (2 * 0.5):.3f}" in result.output
    with pytest.raises(StatsError, match=f"^{bench}: runs: no run of 1 worker × 4 render threads"):
        stats.reference_from_bench(bench, 4)
    bench.write_text(json.dumps({"benchmark": "render-one"}))
    result = CliRunner().invoke(main, ["stats", str(run), "--reference", str(bench)])
    assert result.exit_code != 0 and f"{bench}: not a bench_generate record" in result.output


def test_a_resumed_run_counts_its_gap_as_idle_and_restarted_workers_once(run):
    # A second driver, 200 s after T0, on node-b's worker restarted by its nanny (new address, pid).
    write_task(
        run, stats_record("test-s000003", B, "tcp://10.0.0.2:40777", 299, 200.0, 29.0, 100.0, 36, {"render": 22.0})
    )
    s = stats.summarize(stats.collect(run).records)
    assert s.span_s == pytest.approx(229.0)
    assert s.idle_s == pytest.approx(229.0 - 92.0 - 29.0)
    assert (s.workers, s.worker_ids) == (3, 4)
    assert s.samples_per_s == pytest.approx(8 * 36 / 229.0)


def test_peak_concurrency_and_busy_time():
    assert stats.peak_concurrency([(0, 1), (1, 2), (2, 3)]) == 1  # back to back: one slot
    assert stats.peak_concurrency([(0, 10), (1, 2), (1.5, 3), (5, 6)]) == 3
    assert stats.busy_seconds([(0, 1), (0.5, 2), (4, 5), (4.2, 4.3)]) == pytest.approx(3.0)


def test_oversubscription_is_pointed_out(tmp_path):
    hw = dict(A, threads=2)  # two workers of two threads on two cores
    tasks = [(f"t{k}", hw, f"tcp://10.0.0.1:4000{k}", 100 + k, 0.0, 10.0, 9.0, 4, {"render": 8.0}) for k in range(2)]
    s = stats.summarize(stats.load(write_run(tmp_path, tasks=tasks)))
    assert "node-a: 2 workers × 2 threads > 2 cores (oversubscribed)" in stats.format_summary(s)


# --- the command --------------------------------------------------------------------------------


def test_cli_prints_the_summary_and_writes_the_plot(run, tmp_path):
    ref = write_run(tmp_path / "ref", tasks=[TASKS[4]])
    result = CliRunner().invoke(main, ["stats", str(run), "--reference", str(ref)])
    assert result.exit_code == 0, result.output
    out = result.output
    assert "7, 252 samples" in out and "node-a" in out and "node-b" in out
    assert f"{252 / 92:.4g} samples/s" in out
    assert f"parallel {249 / (3 * 92):.3f}" in out
    assert f"scaling {(252 / 92 / 3) / (36 / 29):.3f}" in out
    assert "render" in out and "encode_write" in out
    svg = run / "stats" / "throughput.svg"
    root = ET.parse(svg).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    texts = [t.text for t in root.iter("{http://www.w3.org/2000/svg}text")]
    assert "node-a" in texts and "node-b" in texts and "render" in texts
    assert (run / "stats" / "tasks.parquet").is_file()
    before = svg.read_bytes()
    assert CliRunner().invoke(main, ["stats", str(run), "--reference", str(ref)]).exit_code == 0
    assert svg.read_bytes() == before  # the same run, the same plot


def test_cli_reads_tasks_jsonl_when_the_task_directories_are_gone(run):
    stats.collect(run)
    shutil.rmtree(run / "tasks")
    result = CliRunner().invoke(main, ["stats", str(run), "--reference-rate", "1.0"])
    assert result.exit_code == 0, result.output
    assert f"scaling {252 / 92 / 3:.3f}" in result.output


def test_cli_errors_name_the_file_and_field(run):
    path = run / "tasks" / "test-s000001" / "stats.json"
    record = stats_record(*TASKS[5])
    record["bytes_written"] = 1.5
    shutil.rmtree(path.parent)
    write_task(run, record)
    result = CliRunner().invoke(main, ["stats", str(run)])
    assert result.exit_code != 0
    assert f"{path}: bytes_written: must be an integer" in result.output
    result = CliRunner().invoke(main, ["stats", str(run), "--reference", str(run), "--reference-rate", "2"])
    assert result.exit_code != 0 and "not both" in result.output


# --- cluster/ recipes ---------------------------------------------------------------------------


def test_the_shared_dask_config_loads_with_dask():
    import dask.config

    path = ROOT / "cluster" / "dask.yaml"
    (loaded,) = dask.config.collect_yaml([str(path)])
    merged = dask.config.update(copy.deepcopy(dask.config.config), loaded)
    with dask.config.set(merged):
        get = dask.config.get
        assert get("distributed.scheduler.allowed-failures") >= 3
        assert get("distributed.scheduler.worker-saturation") == 1.0
        memory = {k: get(f"distributed.worker.memory.{k}") for k in ("target", "spill", "pause", "terminate")}
        assert memory["target"] is False and memory["spill"] is False  # results are tiny: nothing to spill
        assert 0 < memory["pause"] < memory["terminate"] < 1
        assert get("distributed.comm.timeouts.connect") and get("distributed.comm.timeouts.tcp")
        # Task durations the scheduler assumes before it has timed any, for the prefixes of the
        # keys generate gives the sweep's tasks (render-<task_id>).
        from dask.utils import key_split

        from moonbot.config import load_config
        from moonbot.sweep import tasks

        prefixes = {key_split(f"render-{t.task_id}") for t in tasks(load_config(ROOT / "configs" / "synbag-1.0.yaml"))}
        assert prefixes <= set(get("distributed.scheduler.default-task-durations"))


def test_every_shell_recipe_parses():
    scripts = sorted((ROOT / "cluster").rglob("*.sh")) + sorted((ROOT / "cluster").rglob("*.sbatch"))
    assert len(scripts) >= 4
    for script in scripts:
        result = subprocess.run(["bash", "-n", str(script)], capture_output=True, text=True)
        assert result.returncode == 0, f"{script}: {result.stderr}"
        if script.read_text().startswith("#!") and script.suffix != ".sbatch":  # not env.sh, which is sourced
            assert os.access(script, os.X_OK), f"{script}: not executable"


def test_kubernetes_manifests_parse():
    docs = [d for p in sorted((ROOT / "cluster" / "k8s").glob("*.yaml")) for d in yaml.safe_load_all(p.read_text())]
    kinds = {d["kind"] for d in docs}
    assert {"DaskCluster", "DaskJob"} <= kinds
    for d in docs:
        if d["kind"] in ("DaskCluster", "DaskJob"):
            assert d["apiVersion"] == "kubernetes.dask.org/v1"
    text = "\n".join(p.read_text() for p in (ROOT / "cluster" / "k8s").glob("*.yaml"))
    assert "dask-worker" not in text and "dask-scheduler" not in text  # removed in distributed 2026.6


def test_the_slurm_launcher_writes_a_job_script(tmp_path):
    """dask-jobqueue (not a moonbot dependency: skipped without it) renders the worker job: the job
    books the CPUs, each worker process has one Dask thread, retires before the walltime and reads
    the shared dask.yaml; a job of several processes needs render.threads to split its CPUs."""
    pytest.importorskip("dask_jobqueue")
    launcher = ROOT / "cluster" / "slurm" / "launch.py"
    common = [
        sys.executable,
        str(launcher),
        str(ROOT / "configs" / "synbag-1.0.yaml"),
        "--out",
        str(tmp_path / "out"),
        "--cpus",
        "32",
        "--memory",
        "8GB",
        "--walltime",
        "04:00:00",
        "--queue",
        "cpu",
        "--log-directory",
        str(tmp_path / "logs"),
        "--print-job-script",
    ]
    run = subprocess.run(common, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    script = run.stdout
    for expected in (
        "#SBATCH --cpus-per-task=32",
        "#SBATCH -p cpu",
        "#SBATCH -t 04:00:00",
        f"export DASK_CONFIG={ROOT / 'cluster' / 'dask.yaml'}",
        "--nthreads 1",
        "--lifetime 13800s",
        sys.executable,
    ):
        assert expected in script, expected
    run = subprocess.run(common + ["--processes", "4"], capture_output=True, text=True, timeout=120)
    assert run.returncode != 0 and "render.threads: 4 processes a job on 32 CPUs need render.threads = 8" in run.stderr


TINY = """
seed: 7
camera: {width: 64, height: 48}
orbit: {views: 2, step_deg: 180.0}
render: {spp: 1, bounces: 0, light_samples: 1}
terrain: {location: plane}
sweep:
  splits:
    - {name: train, meshes: [sandbag-01], bag_counts: [1], stain_seeds: [0], dust: [false],
       sun_elevations_deg: [12.0, 20.0], sun_azimuths_deg: [120.0], camera_heights_m: [0.5]}
    - {name: test, meshes: [sandbag-02], bag_counts: [1], stain_seeds: [0], dust: [false],
       sun_elevations_deg: [30.0], sun_azimuths_deg: [90.0], camera_heights_m: [1.0]}
"""


def test_the_plain_recipe_renders_a_sweep_and_its_stats(tmp_path):
    """cluster/plain/ for real on loopback: a scheduler, two worker processes (--nworkers 2), and
    run-generate.sh (moonbot generate --scheduler-file, then moonbot stats) on a 3-task sweep."""
    import signal
    import time

    config = tmp_path / "tiny.yaml"
    config.write_text(TINY)
    sched = tmp_path / "scheduler.json"
    env = dict(
        os.environ,
        MOONBOT_VENV=sys.prefix,
        SCHEDULER_HOST="127.0.0.1",
        SCHEDULER_PORT="0",
        DASHBOARD_ADDRESS=":0",
        WORKER_HOST="127.0.0.1",
        LOCAL_DIR=str(tmp_path),
    )
    env.pop("DASK_CONFIG", None)  # the scripts point it at cluster/dask.yaml
    plain = ROOT / "cluster" / "plain"
    procs, logs = [], []
    try:
        for script, args, log in (
            ("start-scheduler.sh", [sched], "scheduler.log"),
            ("start-workers.sh", [sched, "2"], "workers.log"),
        ):
            logs.append(open(tmp_path / log, "w"))
            procs.append(
                subprocess.Popen(
                    [str(plain / script), *map(str, args)],
                    env=env,
                    start_new_session=True,
                    stdout=logs[-1],
                    stderr=subprocess.STDOUT,
                )
            )
            deadline = time.monotonic() + 60
            while script == "start-scheduler.sh" and not sched.exists():
                assert procs[-1].poll() is None and time.monotonic() < deadline, (tmp_path / log).read_text()
                time.sleep(0.2)
        out = tmp_path / "out"
        run = subprocess.run(
            [str(plain / "run-generate.sh"), str(config), str(out), str(sched)],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stdout + run.stderr
        assert "3 tasks rendered (6 samples)" in run.stdout and "tasks       3, 6 samples" in run.stdout
        records = stats.load(out)
        assert [r.samples for r in records] == [2, 2, 2]
        assert all(r.worker.startswith("tcp://127.0.0.1:") for r in records)
        assert {p.name for p in (out / "stats").iterdir()} == {
            "tasks.jsonl",
            "tasks.parquet",
            "placements.jsonl",
            "throughput.svg",
        }
    finally:
        for proc in reversed(procs):  # the process groups this test started, by id
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        for log in logs:
            log.close()
