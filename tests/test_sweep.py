"""The sweep (moonbot/sweep): configs/synbag-1.0.yaml is the paper's sweep exactly, tasks
come in a fixed order with unique names, a scene's seed follows its layout alone, a task's config
carries its identity, bad sweeps are refused naming the field, and `moonbot plan` prints it all
without rendering."""

from __future__ import annotations

import collections
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from moonbot.cli import main
from moonbot.config import ConfigError, load_config
from moonbot.sweep import scene_seed, task_config, tasks
from moonbot.sweep.plan import split_plans

pytestmark = pytest.mark.unit

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def test_synbag_sweep_is_the_papers():
    config = load_config(CONFIGS / "synbag-1.0.yaml")
    ts = tasks(config)
    scenes = collections.Counter(t.split for t in ts if t.task_in_scene == 0)
    assert scenes == {"train": 162, "test": 36}
    samples = collections.Counter()
    for t in ts:
        samples[t.split] += config.orbit.views  # the sweep varies no orbit setting (test below)
    assert samples == {"train": 174_960, "test": 1_296}
    assert task_config(config, ts[-1]).orbit.views == config.orbit.views  # heights vary, views do not
    assert len(ts) == 162 * 30 + 36
    train = [t for t in ts if t.split == "train"]
    assert {t.sun_elevation_deg for t in train} == {5.0, 8.0, 12.0, 18.0, 22.0}
    assert {t.sun_azimuth_deg for t in train} == {120.0, 210.0}
    assert {t.camera_height_m for t in train} == {0.2, 0.5, 0.9}
    assert {t.bags for t in train} == {1, 5, 11} and {t.stain_seeds for t in train} == {0, 30, 90}
    test = [t for t in ts if t.split == "test"]
    assert {(t.bags, t.sun_elevation_deg, t.sun_azimuth_deg, t.camera_height_m) for t in test} == {(8, 30.0, 90.0, 1.0)}
    assert {t.stain_seeds for t in test} == {0, 15} and {t.dust for t in test} == {False, True}
    assert len({t.task_id for t in ts}) == len(ts)
    assert [t.index for t in ts] == list(range(len(ts)))


def test_sweep_order_and_scene_seeds():
    config = load_config(CONFIGS / "smoke.yaml")
    ts = tasks(config)
    # Scenes nest meshes › locations › bag counts › stains › dust.
    first = [(t.mesh, t.bags, t.stain_seeds, t.dust) for t in ts if t.split == "train"][:4]
    assert first == [
        ("sandbag-01", 1, 0, False),
        ("sandbag-01", 1, 0, True),
        ("sandbag-01", 1, 15, False),
        ("sandbag-01", 1, 15, True),
    ]
    seeds = {t.task_id: task_config(config, t).seed for t in ts}
    by_layout = collections.defaultdict(set)
    for t in ts:
        by_layout[(t.split, t.mesh, t.location, t.bags)].add(seeds[t.task_id])
    assert all(len(s) == 1 for s in by_layout.values())  # stain and dust variants share the layout
    assert len({next(iter(s)) for s in by_layout.values()}) == len(by_layout)
    assert scene_seed(7, "train", "sandbag-01", "plane", 1) != scene_seed(8, "train", "sandbag-01", "plane", 1)


def test_task_config_carries_the_task():
    config = load_config(CONFIGS / "smoke.yaml")
    t = [t for t in tasks(config) if t.bags == 3 and t.dust and t.stain_seeds == 15][0]
    c = task_config(config, t)
    assert (c.bags.mesh, c.bags.count, c.bags.layout, c.bags.stain.seeds, c.dust.enabled) == (
        t.mesh,
        3,
        "scattered",
        15,
        True,
    )
    assert (c.sun.elevation_deg, c.sun.azimuth_deg, c.orbit.height_m) == (12.0, 120.0, 0.5)
    assert c.sweep.splits == () and c.camera.width == 64
    # A config without a sweep is one task that renders as render-one would.
    plain = load_config(None)
    (only,) = tasks(plain)
    assert task_config(plain, only) == plain


@pytest.mark.parametrize(
    "override, field",
    [
        ({"sweep.splits": [{"name": "train", "colour": [1]}]}, "sweep.splits[0].colour"),
        ({"sweep.splits": [{"name": "train", "bag_counts": [-1]}]}, "sweep.splits[0].bag_counts[0]"),
        ({"sweep.splits": [{"name": "train", "bag_counts": [256]}]}, "sweep.splits[0].bag_counts[0]"),
        ({"sweep.splits": [{"name": "train", "sun_elevations_deg": [91]}]}, "sweep.splits[0].sun_elevations_deg[0]"),
        ({"sweep.splits": [{"name": "train", "meshes": ["sandbag-09"]}]}, "sweep.splits[0].meshes[0]"),
        ({"sweep.splits": [{"name": "a"}, {"name": "a"}]}, "sweep.splits"),
        ({"sweep.splits": [{"name": "../x"}]}, "name"),
        ({"sweep.splits": [{"name": "t", "dust": [True, True]}]}, "dust"),
    ],
)
def test_bad_sweeps_name_the_field(override, field):
    with pytest.raises(ConfigError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_config(CONFIGS / "smoke.yaml", override)


def test_plan_prints_the_sweep_without_rendering(tmp_path):
    result = CliRunner().invoke(main, ["plan", str(CONFIGS / "synbag-1.0.yaml")])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[1].split() == ["train", "162", "4860", "174960"]
    assert lines[2].split() == ["test", "36", "36", "1296"]
    assert lines[3].split() == ["total", "198", "4896", "176256"]
    # The estimate scales a benchmark record: seconds per megapixel-sample, bytes per megapixel.
    record = tmp_path / "generate-test.json"
    record.write_text(
        '{"runs": [{"workers": 2, "threads_per_worker": 1, "samples_per_s": 0.5, "seconds": 100.0, '
        '"megapixel_samples": 10.0, "bytes": 2e9, "megapixels": 1000.0}]}'
    )
    result = CliRunner().invoke(main, ["plan", str(CONFIGS / "synbag-1.0.yaml"), "--bench-record", str(record)])
    mps = 176_256 * 640 * 480 * 4 / 1e6
    assert f"~{mps * 10.0 / 3600:.1f} h" in result.output  # 10 s a megapixel-sample
    assert f"~{176_256 * 640 * 480 / 1e6 * 2e6 / 1e9:.1f} GB" in result.output  # 2 MB a megapixel
    # With its stages, the time splits into what is paid per megapixel-sample (here 80 %), per task
    # (composing, the BVH: 15 %) and per layout (placing, settling: 5 %); the benchmark's 4 tasks of
    # 6 views share 1 layout; the sweep has 4896 tasks and 36 layouts (27 train, 9 test).
    record.write_text(
        '{"runs": [{"workers": 2, "threads_per_worker": 1, "samples_per_s": 0.5, "seconds": 100.0, '
        '"megapixel_samples": 10.0, "bytes": 2e9, "megapixels": 1000.0, "tasks": 4, "layouts": 1, '
        '"stages_s": {"render": 70.0, "encode_write": 10.0, "compose": 5.0, "build_bvh": 10.0, '
        '"place": 1.0, "settle": 4.0}}]}'
    )
    result = CliRunner().invoke(main, ["plan", str(CONFIGS / "synbag-1.0.yaml"), "--bench-record", str(record)])
    seconds = 100.0 * (0.80 * mps / 10.0 + 0.15 * 4896 / 4 + 0.05 * 36 / 1)
    assert f"~{seconds / 3600:.1f} h" in result.output
    assert "sweep's mix" not in result.output
    # A record with a task mix is priced on the mix (9 tasks of 9 layouts, here 3× the seconds a
    # megapixel-sample of the throughput runs and 3 MB a megapixel), not on its faster runs.
    mix = {
        "workers": 1,
        "threads_per_worker": 2,
        "samples_per_s": 0.1,
        "seconds": 300.0,
        "megapixel_samples": 10.0,
        "bytes": 3e9,
        "megapixels": 1000.0,
        "tasks": 9,
        "layouts": 9,
        "stages_s": {"render": 80.0, "compose": 5.0, "build_bvh": 10.0, "place": 1.0, "settle": 4.0},
    }
    record.write_text(json.dumps({**json.loads(record.read_text()), "task_mix": mix}))
    result = CliRunner().invoke(main, ["plan", str(CONFIGS / "synbag-1.0.yaml"), "--bench-record", str(record)])
    seconds = 300.0 * (0.80 * mps / 10.0 + 0.15 * 4896 / 9 + 0.05 * 36 / 9)
    assert f"~{seconds / 3600:.1f} h" in result.output
    assert f"~{176_256 * 640 * 480 / 1e6 * 3e6 / 1e9:.1f} GB" in result.output
    assert "(1 worker × 2 render threads, the fastest layout it measured, priced on 9 tasks of the sweep's mix)" in (
        result.output
    )
    assert sum(p.layouts for p in split_plans(load_config(CONFIGS / "synbag-1.0.yaml"))) == 36
    bad = tmp_path / "bad.yaml"
    bad.write_text("sweep:\n  splits:\n    - name: train\n      sun_elevations_deg: [95]\n")
    result = CliRunner().invoke(main, ["plan", str(bad)])
    assert result.exit_code != 0 and "sun_elevations_deg[0]" in result.output


def test_plan_names_whose_record_it_scaled(tmp_path):
    """The estimate is the recorded machine's: plan names that machine (CPU, cores, date, file) and
    this one, and never claims to have measured "this machine"."""
    import os

    from moonbot.host import cpu_id, cpu_model
    from moonbot.sweep.plan import LOADED_SLOWDOWN

    run = {
        "workers": 1,
        "threads_per_worker": 2,
        "samples_per_s": 0.5,
        "seconds": 100.0,
        "megapixel_samples": 10.0,
        "bytes": 2e9,
        "megapixels": 1000.0,
    }
    other = {
        "cpu": "Imaginary CPU 9000",
        "cpu_id": "GenuineImaginary 1/2/3",
        "cores": 64,
        "embree_isa": "avx512",
        "date": "2031-02-03T04:05:06Z",
    }
    same = {
        "cpu": cpu_model(),
        "cpu_id": cpu_id(),
        "cores": os.cpu_count(),
        "embree_isa": "avx2",
        "date": "2026-11-26T02:42:09Z",
    }
    outputs = {}
    for name, machine in (("other", other), ("same", same)):
        record = tmp_path / f"generate-{name}.json"
        record.write_text(json.dumps({"machine": machine, "runs": [run]}))
        result = CliRunner().invoke(main, ["plan", str(CONFIGS / "synbag-1.0.yaml"), "--bench-record", str(record)])
        assert result.exit_code == 0, result.output
        assert "this machine" not in result.output.replace("this machine's record", "")
        assert (
            f"from    {record}: measured on {machine['cpu']} ({machine['cpu_id']}), {machine['cores']} cores"
            in result.output
            and machine["date"][:10] in result.output
        )
        assert f"here    {cpu_model()} ({cpu_id()}), {os.cpu_count()} cores" in result.output
        outputs[name] = result.output
    assert "another CPU or core count" in outputs["other"] and "bench/bench_generate.py" in outputs["other"]
    assert "the same CPU model and cores" in outputs["same"] and f"{LOADED_SLOWDOWN:g}x slower" in outputs["same"]


@pytest.mark.timeout(900)  # 36 layouts settled: 112 s on a loaded 2-core machine; room for a slower one
def test_every_layout_of_the_synbag_sweep_composes():
    """Every bag layout of SynBag-1.0 (split × mesh × location × bag count: 27 train, 9 test) is
    placed, settled and passes the exact ground and overlap checks, so no task of the full sweep
    fails on its scene. (Stain, dust, Sun and camera do not move the bags.)"""
    from moonbot.scene import compose_scene
    from moonbot.terrain import warm

    config = load_config(CONFIGS / "synbag-1.0.yaml")
    layouts = {}
    for t in tasks(config):
        layouts.setdefault((t.split, t.mesh, t.location, t.bags), t)
    assert len(layouts) == 36
    warm([task_config(config, t).terrain for t in layouts.values()])
    for t in layouts.values():
        spec = compose_scene(task_config(config, t))
        assert len(spec.bags) == t.bags
