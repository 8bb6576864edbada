"""`moonbot bench`: the quality levels are valid configs; a tiny real throughput run
(the fixed benchmark config at 64×48, one view a task, one level, one worker, coarse terrain, no
settling) writes a result with every field of the schema; `compare` reads that result and the
committed one of an earlier run (tests/data/throughput-result-v1.json, which every later reader
must still accept), prints both and writes an SVG; a malformed result is refused naming the file
and the field. No timing is asserted."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner

from moonbot.benchmark.compare import ResultError, load_result, validate
from moonbot.benchmark.levels import LEVELS, level_config, parse_levels
from moonbot.benchmark.limit import bounce_s_per_ray, encode_limit_seconds, ray_limit_seconds
from moonbot.benchmark.throughput import DEFAULT_CONFIG, SCHEMA_VERSION, scaling
from moonbot.cli import main
from moonbot.config.schema import RenderConfig

pytestmark = pytest.mark.unit

OLD_RESULT = Path(__file__).resolve().parent / "data" / "throughput-result-v1.json"
SVG = "{http://www.w3.org/2000/svg}"
TINY = [
    "camera.width=64",
    "camera.height=48",
    "orbit.views=1",
    "bags.settle.enabled=false",
    "terrain.extent_m=30",
    "terrain.detail_m=0.05",
    "terrain.detail_extent_m=1.0",
    "dust.cloud.voxel_m=0.1",
]


def is_svg(path: Path) -> bool:
    return ET.parse(path).getroot().tag == f"{SVG}svg"


def test_levels_are_valid_configs():
    assert list(LEVELS) == ["draft", "default", "high", "path"]
    refinement = []
    for name, level in LEVELS.items():
        config = level_config(DEFAULT_CONFIG, name)
        for field, value in level.overrides.items():
            assert getattr(config.render, field.split(".")[1]) == value, (name, field)
        refinement.append(config.render.refinement_spp)
    # draft < default < high in the samples a disagreeing pixel gets; path refines nothing
    assert refinement[:3] == sorted(refinement[:3]) and len(set(refinement[:3])) == 3 and refinement[3] == 0
    assert level_config(DEFAULT_CONFIG, "path").render.indirect == "path"
    # default is the config defaults: what SynBag-1.0 renders
    d, r = level_config(DEFAULT_CONFIG, "default").render, RenderConfig()
    knobs = ("spp", "adaptive_spp", "adaptive_threshold", "light_samples", "bounces", "indirect")
    knobs += ("adaptive_full_spread", "adaptive_error_target", "adaptive_contrast", "penumbra_light_samples")
    assert [getattr(d, k) for k in knobs] == [getattr(r, k) for k in knobs]
    assert parse_levels(" high,draft,high ") == ["high", "draft"]
    with pytest.raises(ValueError, match="'ultra'"):
        parse_levels("draft,ultra")


def test_limit_arithmetic():
    # Generation 1: 100 rays in 3e-5 s, 40 shadow rays from their hits in 2e-5 s; generation 2: 50
    # rays in 3e-5 s, 10 shadow rays in 1e-5 s.
    row = {
        "camera_s_per_ray": 1e-7,
        "shadow_s_per_ray": 2e-7,
        "bounce_rays": [100, 50],
        "bounce_stream_s": [3e-5, 3e-5],
        "bounce_shadow_rays": [40, 10],
        "bounce_shadow_stream_s": [2e-5, 1e-5],
    }
    rays = {
        "camera_rays": 10,
        "shadow_rays": 5,
        "bounce_shadow_rays": 2,
        "bounce_rays": 4,
        "medium_rays": 6,
        "amodal_rays": 1000,
    }
    assert bounce_s_per_ray(row, 1) == pytest.approx(3e-7)
    assert bounce_s_per_ray(row, 2) == pytest.approx(4e-7)  # pooled: 6e-5 s over 150 rays
    assert bounce_s_per_ray(row, 5) == pytest.approx(4e-7)  # no deeper generation probed: the pool
    assert bounce_s_per_ray(row, 1, "bounce_shadow") == pytest.approx(5e-7)
    assert bounce_s_per_ray(row, 2, "bounce_shadow") == pytest.approx(6e-7)
    # camera + medium rays, the camera hits' 3 shadow rays, 4 bounce rays, 2 bounce shadow rays
    assert ray_limit_seconds(rays, row, 1) == pytest.approx(1e-7 * 16 + 2e-7 * 3 + 3e-7 * 4 + 5e-7 * 2)
    assert ray_limit_seconds(rays, row, 2) == pytest.approx(1e-7 * 16 + 2e-7 * 3 + 4e-7 * 4 + 6e-7 * 2)
    assert ray_limit_seconds({"camera_rays": 10}, row, 0) == pytest.approx(1e-6)
    # A cache level: its gather rays at the pooled bounce rate, their vertices' shadow rays at the
    # pooled rate of the bounce vertices' shadow rays.
    cached = {"camera_rays": 10, "shadow_rays": 5, "light_cache_rays": 30, "light_cache_shadow_rays": 7}
    assert ray_limit_seconds(cached, row, 2) == pytest.approx(1e-7 * 10 + 2e-7 * 5 + 4e-7 * 30 + 6e-7 * 7)
    encode = {
        "views": [
            {"task_id": "a", "serial_s": 0.04, "longest_s": 0.03},
            {"task_id": "b", "serial_s": 0.02, "longest_s": 0.005},
        ]
    }
    assert encode_limit_seconds(encode, 1) == pytest.approx(0.06)
    assert encode_limit_seconds(encode, 2) == pytest.approx(0.03 + 0.01)
    assert encode_limit_seconds(encode, 2, "b") == pytest.approx(0.01)
    runs = [
        {"level": "default", "workers": w, "threads_per_worker": 1, "samples_per_s": x} for w, x in ((1, 0.5), (2, 0.9))
    ]
    assert [s["efficiency"] for s in scaling(runs)] == pytest.approx([1.0, 0.9])


@pytest.fixture(scope="module")
def tiny_result(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bench") / "tiny.json"
    args = ["bench", "throughput", "--levels", "draft", "--workers", "1", "--repeats", "1", "--out", str(out)]
    for setting in TINY:
        args += ["--set", setting]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output + repr(result.exception)
    assert "samples/s" in result.output and f"written {out}" in result.output
    return out


def test_tiny_run_writes_a_complete_result(tiny_result):
    record = load_result(tiny_result)  # every field of the schema, with its type
    assert record["schema_version"] == SCHEMA_VERSION and record["benchmark"] == "throughput"
    assert record["config"]["file"] == "throughput-v1.yaml" and record["config"]["version"] == 1
    assert record["overrides"]["camera.width"] == 64 and record["image"] == {"width": 64, "height": 48}
    assert len(record["tasks"]) == 4 and {t.split("-")[0] for t in record["tasks"]} == {"crater", "hilly", "flat"}
    m = record["machine"]
    assert m["cores"] >= 1 and m["cpu"] and m["embree"] and m["git_commit"]
    assert record["libraries"]["moonbot"] and record["libraries"]["dask"]
    assert len(record["load_before"]) == len(record["load_after"]) == 3
    (run,) = record["runs"]
    assert (run["level"], run["workers"], run["samples"], run["tasks"]) == ("draft", 1, 4, 4)
    assert run["samples_per_s"] > 0 and run["bytes_per_sample"] > 0 and run["peak_rss_mib"]["max_worker"] > 0
    # draft: the pixel-centre ray and 2 base samples a pixel, up to 64 where they disagree
    assert run["rays"]["camera_rays"] > 3 * 4 * 64 * 48
    # its bounce light comes from the task's light cache; only hits on the moving ejecta bounce
    assert run["rays"]["shadow_rays"] > 0 and run["rays"]["medium_rays"] > 0
    assert run["rays"]["bounce_rays"] < run["rays"]["camera_rays"] / 100
    assert set(run["stage_groups_s"]) == {"scene_build", "dust", "render", "encode_write"}
    assert {"compose", "build_bvh", "render", "tonemap", "encode_write", "dust"} <= set(run["stages_s"])
    assert run["limit"]["threads"] == run["workers"] * run["threads_per_worker"]
    assert run["limit"]["embree_s"] > 0 and run["limit"]["encode_s"] > 0
    assert all(v > 0 for v in run["ratio"].values())
    assert {r["task_id"] for r in record["embree_limit"]} == set(record["tasks"])
    # draft renders 2 bounces (through the light cache): the probe traced two generations of
    # bounce rays on every scene.
    assert all(
        len(r["bounce_rays"]) == 2 and r["bounce_rays"][0] > 0 and r["bounce_mrays_per_s"][0] > 0
        for r in record["embree_limit"]
    )
    assert record["encode_limit"]["draft"]["raw_mb_per_s"] > 0
    p = record["projection"]
    assert p["samples"] == 176256 and p["views_per_task"] == 36 and p["image_matches_sweep"] is False
    assert [h["nodes"] for h in p["levels"][0]["hours"]] == [1, 10, 50, 100]
    assert is_svg(tiny_result.with_suffix(".svg"))


def test_compare_reads_an_old_and_a_new_result(tiny_result, tmp_path):
    old = load_result(OLD_RESULT)
    assert json.loads(OLD_RESULT.read_text())["schema_version"] == 1 and old["schema_version"] == SCHEMA_VERSION
    # Version 1 did not probe bounce rays: the upgraded record says how its limit counted them.
    assert all(r["limit"]["bounce_cost"].startswith("camera-ray rate") for r in old["runs"])
    assert all(r["limit"]["bounce_cost"] == "measured" for r in load_result(tiny_result)["runs"])
    plot = tmp_path / "cmp.svg"
    result = CliRunner().invoke(main, ["bench", "compare", str(OLD_RESULT), str(tiny_result), "--plot", str(plot)])
    assert result.exit_code == 0, result.output
    assert OLD_RESULT.stem in result.output and tiny_result.stem in result.output
    assert old["machine"]["git_commit"][:12] in result.output
    assert is_svg(plot)
    texts = [t.text for t in ET.parse(plot).getroot().iter(f"{SVG}text")]
    assert any(f"{OLD_RESULT.stem}: draft" in t for t in texts) and any(
        f"{tiny_result.stem}: draft" in t for t in texts
    )


def test_compare_plots_beside_its_inputs_not_into_the_working_folder(tmp_path, monkeypatch):
    for name in ("a.json", "b.json"):
        shutil.copy(OLD_RESULT, tmp_path / name)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    result = CliRunner().invoke(main, ["bench", "compare", str(tmp_path / "a.json"), str(tmp_path / "b.json")])
    assert result.exit_code == 0, result.output
    assert is_svg(tmp_path / "compare-a-vs-b.svg")
    assert f"written {tmp_path / 'compare-a-vs-b.svg'}" in result.output and list(work.iterdir()) == []


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda r: r["runs"][0].pop("samples_per_s"), "runs[0].samples_per_s: missing"),
        (lambda r: r["runs"][0]["ratio"].update(pipeline="fast"), "runs[0].ratio.pipeline: must be a number"),
        (lambda r: r["machine"].pop("cpu"), "machine.cpu: missing"),
        (lambda r: r.update(runs={}), "runs: must be a list"),
        (lambda r: r["projection"]["levels"][0]["hours"][0].update(nodes=1.5), "hours[0].nodes: must be an integer"),
        (lambda r: r.update(schema_version=SCHEMA_VERSION + 1), f"schema_version: {SCHEMA_VERSION + 1} is newer"),
        (lambda r: r.update(benchmark="generate"), "benchmark: must be one of throughput, got 'generate'"),
    ],
)
def test_a_malformed_result_names_the_file_and_field(tmp_path, edit, field):
    record = json.loads(OLD_RESULT.read_text())
    edit(record)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(record))
    with pytest.raises(ResultError) as e:
        load_result(bad)
    assert str(e.value).startswith(f"{bad}: ") and field in str(e.value)
    result = CliRunner().invoke(
        main, ["bench", "compare", str(OLD_RESULT), str(bad), "--plot", str(tmp_path / "x.svg")]
    )
    assert result.exit_code == 1 and str(bad) in result.output and field in result.output
    assert not (tmp_path / "x.svg").exists()


def test_unreadable_results(tmp_path):
    (tmp_path / "text.json").write_text("not json")
    with pytest.raises(ResultError, match="text.json: not valid JSON"):
        load_result(tmp_path / "text.json")
    with pytest.raises(ResultError, match="missing.json: cannot read"):
        load_result(tmp_path / "missing.json")
    with pytest.raises(ResultError, match="x: expected a JSON object"):
        validate([], "x")


def test_validate_upgrades_the_old_result_and_leaves_it_alone():
    record = json.loads(OLD_RESULT.read_text())
    upgraded = validate(record, str(OLD_RESULT))
    assert record == json.loads(OLD_RESULT.read_text())  # the caller's record is not edited
    assert upgraded["schema_version"] == SCHEMA_VERSION and upgraded["machine"] == record["machine"]
    assert [r["ratio"]["render_encode"] for r in upgraded["runs"]] == [
        r["ratio"]["render_encode"] for r in record["runs"]
    ]
