"""The file records (moonbot.records): task.json, gt.json, stats.json, DONE.json and the benchmark
result each have one writer and one reader. Reading what the writer wrote gives the record back; a malformed file is
refused naming the file and the field path, a truncated one naming the file; a file of version 1
(as moonbot wrote them before they carried a schema_version: tests/data/records_v1 holds one task
of the smoke sweep, written then) reads, and writes back as the same bytes plus that one field; a
newer version is refused."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from moonbot.records.base import SCHEMA_VERSION, RecordError
from moonbot.records.bench import UPGRADES as bench_upgrades
from moonbot.records.bench import read_bench_result, write_bench_result
from moonbot.records.done import DONE, DoneRecord, FileEntry, complete_files, read_done, write_done
from moonbot.records.gt import GT, GtRecord, InstanceRecord, read_gt, write_gt
from moonbot.records.stats import STATS, StatsRecord, decode_stats, read_stats, write_stats
from moonbot.records.task import TASK, TaskRecord, read_task, write_task

pytestmark = pytest.mark.unit

V1_TASK = Path(__file__).parent / "data" / "records_v1" / "test-s000001-t00-sandbag-01-plane-b02-st00-dust-el30-az90-h1"
SHA = "ab" * 32

INSTANCE = InstanceRecord(
    instance_id=1,
    obj_id=3,
    cam_R_m2c=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    cam_t_m2c=(0.0, 0.0, 1500.0),
    px_count_visib=120,
    mask_amodal="amodal_001.png",
    px_count_all=130,
    bbox_all=(4, 5, 20, 10),
)
GT_RECORD = GtRecord(
    cam_K=(100.0, 0.0, 32.0, 0.0, 100.0, 24.0, 0.0, 0.0, 1.0),
    width=64,
    height=48,
    depth_scale=1.0,
    cam_R_w2c=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    cam_t_w2c=(0.0, 0.0, 1000.0),
    instances=(
        INSTANCE,
        dataclasses.replace(INSTANCE, instance_id=2, mask_amodal=None, px_count_all=None, bbox_all=None),
    ),
    exposure={"ev100": 13.0, "tonemap": "reinhard2002-luminance-srgb8"},
    rgb_invalid_pixels=0,
    view=3,
    camera_azimuth_deg=30.0,
    camera_height_m=1.0,
    sun={"azimuth_deg": 90.0, "elevation_deg": 30.0},
    render_seed=7,
    config_hash="c" * 64,
    moonbot_version="1.0",
    dust={"grains": 3},
    timings_s={"render": 0.5},
)
TASK_RECORD = TaskRecord(
    task_id="train-s000002-t01",
    index=5,
    split="train",
    scene_id=2,
    task_in_scene=1,
    tasks_per_scene=2,
    mesh="sandbag-01",
    obj_id=1,
    location="plane",
    bags=2,
    stain_seeds=0,
    dust=False,
    sun_elevation_deg=30.0,
    sun_azimuth_deg=90.0,
    camera_height_m=1.0,
    views=(0, 1),
    views_per_task=2,
    seed=11,
    config={"camera": {"width": 64}, "output": {"png_compression": 1}},
    config_hash="d" * 64,
    moonbot_version="1.0",
)
STATS_RECORD = StatsRecord(
    task_id="train-s000002-t01",
    host="node-a",
    pid=42,
    cpu_model="AMD EPYC",
    cores=2,
    threads=1,
    worker="tcp://10.0.0.1:4000",
    started_utc="2026-11-26T06:49:54.176319+00:00",
    wall_s=2.5,
    cpu_s=2.0,
    stages_s={"render": 1.5, "encode_write": 0.5},
    samples=2,
    rays={"camera_rays": 100},
    bytes_written=4096,
    samples_per_s=0.8,
    other={"embree_isa": "avx2", "simd_flags": ["sse2", "avx2"]},
)
DONE_RECORD = DoneRecord(
    task_id="train-s000002-t01",
    samples=2,
    files={"task.json": FileEntry(sha256=SHA, bytes=10), "view_000/gt.json": FileEntry(sha256=SHA)},
)

# (file name, record, writer, reader)
KINDS = [
    (GT, GT_RECORD, write_gt, read_gt),
    (TASK, TASK_RECORD, write_task, read_task),
    (STATS, STATS_RECORD, write_stats, read_stats),
    (DONE, DONE_RECORD, write_done, read_done),
]
IDS = [k[0] for k in KINDS]


@pytest.mark.parametrize("name, record, write, read", KINDS, ids=IDS)
def test_a_record_reads_back_as_written(tmp_path, name, record, write, read):
    path = tmp_path / name
    write(path, record)
    assert read(path) == record
    assert json.loads(path.read_text())["schema_version"] == SCHEMA_VERSION == 2
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary left beside it


# (file name, record, writer, what to spoil in its JSON, the message after "<file>: ")
MALFORMED = [
    (
        GT,
        GT_RECORD,
        write_gt,
        lambda d: d["instances"][1]["cam_R_m2c"].pop(),
        "instances[1].cam_R_m2c: must have 9 items, got 8",
    ),
    (
        GT,
        GT_RECORD,
        write_gt,
        lambda d: d["instances"][0].update(mask_amodal="../rgb.png"),
        "instances[0].mask_amodal: must be a file name in the view, got '../rgb.png'",
    ),
    (GT, GT_RECORD, write_gt, lambda d: d.update(width="64"), "width: must be an integer, got '64'"),
    (GT, GT_RECORD, write_gt, lambda d: d["timings_s"].update(render=None), "timings_s.render: must be a number"),
    (GT, GT_RECORD, write_gt, lambda d: d.pop("cam_K"), "cam_K: missing"),
    (TASK, TASK_RECORD, write_task, lambda d: d.update(scene_id=-1), "scene_id: must be >= 0, got -1"),
    (TASK, TASK_RECORD, write_task, lambda d: d.update(views=[0, 0]), "views: must be distinct orbit indices"),
    (TASK, TASK_RECORD, write_task, lambda d: d.update(dust="no"), "dust: must be true or false, got 'no'"),
    (TASK, TASK_RECORD, write_task, lambda d: d.update(mesh="../x"), "mesh: must be a plain name, got '../x'"),
    (
        STATS,
        STATS_RECORD,
        write_stats,
        lambda d: d["stages_s"].update(render=-1.0),
        "stages_s.render: must be >= 0.0, got -1.0",
    ),
    (STATS, STATS_RECORD, write_stats, lambda d: d.update(started_utc="noon"), "started_utc: not an ISO-8601 time"),
    (
        DONE,
        DONE_RECORD,
        write_done,
        lambda d: d["files"]["task.json"].update(bytes="10"),
        "files.task.json.bytes: must be an integer or null, got '10'",
    ),
    (
        DONE,
        DONE_RECORD,
        write_done,
        lambda d: d["files"]["task.json"].update(sha256="xyz"),
        "files.task.json.sha256: must be 64 lower-case hex digits, got 'xyz'",
    ),
    (DONE, DONE_RECORD, write_done, lambda d: d.pop("task_id"), "task_id: missing"),
]


@pytest.mark.parametrize(
    "name, record, write, spoil, message", MALFORMED, ids=[f"{m[0]}-{m[4].split(':')[0]}" for m in MALFORMED]
)
def test_a_malformed_file_is_refused_naming_the_file_and_the_field_path(tmp_path, name, record, write, spoil, message):
    path = tmp_path / name
    write(path, record)
    data = json.loads(path.read_text())
    spoil(data)
    path.write_text(json.dumps(data))
    read = {k[0]: k[3] for k in KINDS}[name]
    with pytest.raises(RecordError) as error:
        read(path)
    assert str(error.value).startswith(f"{path}: {message}"), str(error.value)


@pytest.mark.parametrize("name, record, write, read", KINDS, ids=IDS)
def test_a_truncated_or_missing_file_is_refused_naming_the_file(tmp_path, name, record, write, read):
    path = tmp_path / name
    write(path, record)
    path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    with pytest.raises(RecordError, match=f"^{path}: not valid JSON"):
        read(path)
    path.write_text("[1, 2]")
    with pytest.raises(RecordError, match=f"^{path}: expected a JSON object, got list"):
        read(path)
    path.unlink()
    with pytest.raises(RecordError, match=f"^{path}: cannot read"):
        read(path)


@pytest.mark.parametrize("name, record, write, read", KINDS, ids=IDS)
def test_a_newer_version_is_refused(tmp_path, name, record, write, read):
    path = tmp_path / name
    write(path, record)
    path.write_text(json.dumps({**json.loads(path.read_text()), "schema_version": SCHEMA_VERSION + 1}))
    with pytest.raises(RecordError, match=f"^{path}: schema_version: 3 is newer than this moonbot reads \\(2\\)"):
        read(path)


def test_a_checksum_other_than_done_json_s_is_refused(tmp_path):
    path = tmp_path / TASK
    write_task(path, TASK_RECORD)
    with pytest.raises(RecordError, match=f"^{path}: sha256 differs from DONE.json's"):
        read_task(path, sha256=SHA)


# --- version 1: the files as moonbot wrote them before schema_version ----------------------------

# (file in the task directory, reader, whether the writer sorts the keys)
V1_FILES = [
    (TASK, read_task, write_task, True),
    (STATS, read_stats, write_stats, True),
    (DONE, read_done, write_done, True),
    (f"view_000/{GT}", read_gt, write_gt, False),
]


@pytest.mark.parametrize("name, read, write, sorted_keys", V1_FILES, ids=[f[0] for f in V1_FILES])
def test_version_1_reads_and_writes_back_as_its_bytes_plus_the_version(tmp_path, name, read, write, sorted_keys):
    """A version-1 file (no schema_version) reads as version 2; written back, it is the old file's
    bytes with `"schema_version": 2` added (in sorted place, or last where keys keep their order)."""
    old_bytes = (V1_TASK / name).read_bytes()
    old = json.loads(old_bytes)
    assert "schema_version" not in old
    assert old_bytes == (json.dumps(old, indent=2, sort_keys=sorted_keys) + "\n").encode()  # today's layout
    record = read(V1_TASK / name)
    assert record.schema_version == 2
    write(tmp_path / "again.json", record)
    expected = json.dumps({**old, "schema_version": 2}, indent=2, sort_keys=sorted_keys) + "\n"
    assert (tmp_path / "again.json").read_text() == expected


def test_version_1_values_are_read_as_written():
    task = read_task(V1_TASK / TASK)
    assert (task.task_id, task.split, task.scene_id, task.dust, task.views) == (V1_TASK.name, "test", 1, True, (0, 1))
    assert (
        task.config["output"]["png_compression"]
        == json.loads((V1_TASK / TASK).read_text())["config"]["output"]["png_compression"]
    )
    gt = read_gt(V1_TASK / "view_000" / GT)
    assert (gt.width, gt.height, len(gt.instances), gt.site) == (64, 48, 2, None) and gt.dust is not None
    assert all(i.mask_amodal == f"amodal_{i.instance_id:03d}.png" for i in gt.instances)
    stats = read_stats(V1_TASK / STATS)
    assert stats.samples == 2 and stats.other["embree_isa"] == "avx2" and stats.rays["camera_rays"] == 28608
    done = read_done(V1_TASK / DONE)
    assert done.samples == 2 and done.files[TASK].bytes == (V1_TASK / TASK).stat().st_size


def test_a_version_1_marker_with_bare_checksums_reads_without_sizes(tmp_path):
    """Version 1 let a listed file be its bare sha256: read as an entry without a size, whose
    presence alone makes the task complete."""
    (tmp_path / "task.json").write_text("{}")
    (tmp_path / DONE).write_text(json.dumps({"task_id": "t", "samples": 0, "files": {"task.json": SHA}}))
    assert read_done(tmp_path / DONE).files == {"task.json": FileEntry(sha256=SHA)}
    assert complete_files(tmp_path) == {"task.json": FileEntry(sha256=SHA)}
    (tmp_path / "task.json").unlink()
    assert complete_files(tmp_path) is None


def test_a_task_is_complete_only_while_its_files_have_their_sizes(tmp_path):
    task_dir = tmp_path / V1_TASK.name
    shutil.copytree(V1_TASK, task_dir)
    # The fixture holds view_000/gt.json alone of the task's files: list only what is there.
    done = read_done(task_dir / DONE)
    kept = {k: v for k, v in done.files.items() if (task_dir / k).is_file()}
    write_done(task_dir / DONE, dataclasses.replace(done, files=kept))
    assert complete_files(task_dir) == kept
    (task_dir / STATS).write_text("{}")
    assert complete_files(task_dir) is None


def test_a_line_of_a_stats_jsonl_is_named_by_its_line():
    with pytest.raises(RecordError, match="^tasks.jsonl:4: cores: must be >= 1, got 0"):
        decode_stats({**STATS_RECORD.as_json(), "cores": 0}, "tasks.jsonl:4")


# --- the benchmark result: version 1 is tests/data/throughput-result-v1.json -----------------------

BENCH_V1 = Path(__file__).parent / "data" / "throughput-result-v1.json"


def test_a_version_1_bench_result_reads_and_round_trips(tmp_path):
    """Version 1 reads as version 2 (its limit's bounce cost named, its assumed-incoherent limits
    dropped); written and read again it is the same record, and the same JSON values as the
    upgrade gives."""
    old = json.loads(BENCH_V1.read_text())
    assert old["schema_version"] == 1
    record = read_bench_result(BENCH_V1)
    assert record.schema_version == 2 and record.benchmark == "throughput"
    assert all(r.limit.bounce_cost.startswith("camera-ray rate") for r in record.runs)
    assert all("seconds_per_sample_bounce_incoherent" not in r.limit.other for r in record.runs)
    assert record.machine.cpu == old["machine"]["cpu"] and record.machine.embree_isa is None
    write_bench_result(tmp_path / "again.json", record)
    assert read_bench_result(tmp_path / "again.json") == record
    assert json.loads((tmp_path / "again.json").read_text()) == bench_upgrades[1](old)


@pytest.mark.parametrize(
    "spoil, message",
    [
        (
            lambda d: d["runs"][0]["peak_rss_mib"].update(max_worker="big"),
            "runs[0].peak_rss_mib.max_worker: must be a number",
        ),
        (lambda d: d["runs"][0]["load_before"].pop(), "runs[0].load_before: must have 3 items, got 2"),
        (lambda d: d.pop("schema_version"), "schema_version: missing"),
        (lambda d: d.update(schema_version=3), "schema_version: 3 is newer than this moonbot reads (2)"),
    ],
)
def test_a_malformed_bench_result_names_the_field(tmp_path, spoil, message):
    data = json.loads(BENCH_V1.read_text())
    spoil(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(RecordError) as error:
        read_bench_result(path)
    assert str(error.value).startswith(f"{path}: {message}"), str(error.value)
