"""Dust in a scene (the Python side): a scene without dust runs no dust code and renders
the same bytes whatever its dust settings; ejecta are opaque background geometry (depth and masks),
the cloud changes RGB only; each view rebuilds only the ejecta's BVH; outputs do not depend on
the thread count nor on which other views were rendered; `render-one --dust` writes the dust
record; bad dust settings name the field."""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import moonbot.pipeline.views as views_module
from moonbot import _core
from moonbot.cli import main
from moonbot.config import ConfigError, load_config
from moonbot.config.schema import MAX_DUST_STEP_S, CloudConfig, DustConfig, EjectaConfig
from moonbot.pipeline import run_views
from moonbot.render import SceneDust, build_scene, params
from moonbot.render.dust import DUST_NOTE, capture_time, dust_seed, emitter_origin
from moonbot.scene import compose_scene

pytestmark = pytest.mark.unit

# The fastest scene that still has everything: the analytic plane, a small image, no bounces.
SMALL = {"terrain.location": "plane", "camera.width": 96, "camera.height": 72, "render.spp": 1, "render.bounces": 0}
DUST = {"dust.enabled": True}
NO_CLOUD = {"dust.enabled": True, "dust.cloud.optical_depth": 0.0}  # ejecta alone: no puff, no medium
VIEW = 9  # looks across the emitter: fragments cover ~190 pixels
IMAGES = ("rgb.png", "depth.npy", "depth.png", "mask.png")


def config(**overrides):
    return load_config(None, {**SMALL, **overrides})


def render(out: Path, views: list[int], **overrides) -> list:
    return run_views(config(**overrides), views, out)


def read(view_dir: Path) -> dict:
    return {
        "rgb": np.array(Image.open(view_dir / "rgb.png")),
        "depth": np.load(view_dir / "depth.npy"),
        "mask": np.array(Image.open(view_dir / "mask.png")),
        "gt": json.loads((view_dir / "gt.json").read_text()),
    }


def same_bytes(a: Path, b: Path) -> None:
    for name in IMAGES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def renders(tmp_path_factory) -> dict[str, Path]:
    """View VIEW without dust, with the ejecta alone, and with ejecta and cloud (one thread)."""
    root = tmp_path_factory.mktemp("dust")
    cases = {"free": {}, "ejecta": NO_CLOUD, "dust": DUST}
    return {name: render(root / name, [VIEW], **{"render.threads": 1}, **o)[0].out_dir for name, o in cases.items()}


# Every dust setting but `enabled`, each changed from its default to another valid value.
CHANGED = {
    "dust.emitter_offset_m": [-0.4, 0.6],
    "dust.warmup_s": 1.3,
    "dust.view_interval_s": 0.7,
    "dust.time_step_s": 0.05,
    "dust.ejecta.count": 3000,
    "dust.ejecta.spawn_radius_m": 0.3,
    "dust.ejecta.cone_half_angle_deg": 20.0,
    "dust.ejecta.mean_speed_m_s": 1.5,
    "dust.ejecta.min_diameter_m": 0.05,
    "dust.ejecta.max_diameter_m": 0.1,
    "dust.ejecta.gravity_m_s2": 3.0,
    "dust.ejecta.restitution": 0.8,
    "dust.ejecta.friction": 0.1,
    "dust.ejecta.rest_speed_m_s": 0.1,
    "dust.ejecta.burst_period_s": 0.5,
    "dust.cloud.box_m": [1.0, 1.0, 1.0],
    "dust.cloud.vertical_offset_m": 0.2,
    "dust.cloud.axis": [0.0, 1.0, 1.0],
    "dust.cloud.cone_half_angle_deg": 10.0,
    "dust.cloud.speed_m_s": 0.3,
    "dust.cloud.gravity_m_s2": 1.62,
    "dust.cloud.lifetime_s": 2.0,
    "dust.cloud.rate_per_s": 500.0,
    "dust.cloud.sigma_m": 0.4,
    "dust.cloud.growth_m_s": 0.2,
    "dust.cloud.optical_depth": 20.0,
    "dust.cloud.rise_fraction": 0.5,
    "dust.cloud.albedo": [0.9, 0.1, 0.1],
    "dust.cloud.asymmetry": -0.3,
    "dust.cloud.voxel_m": 0.01,
    "dust.cloud.march_stride_px": 8,
}


def _leaves(cls, prefix: str) -> set[str]:
    """Dotted paths of every field of dataclass `cls`, sections expanded."""
    hints = typing.get_type_hints(cls)
    return set().union(
        *(
            _leaves(hints[f.name], f"{prefix}{f.name}.")
            if dataclasses.is_dataclass(hints[f.name])
            else {prefix + f.name}
            for f in dataclasses.fields(cls)
        )
    )


def _value(config, dotted: str):
    for key in dotted.split("."):
        config = getattr(config, key)
    return config


def test_a_scene_without_dust_runs_no_dust_code(tmp_path, monkeypatch):
    """A scene runs only what it calls for: with dust off — by default, or off with every other dust value changed — no
    simulation, no puffs, no medium is made or traced, no fragment mesh joins the scene, no dust
    stage is timed and gt.json has no dust record; and both render the same bytes."""
    assert set(CHANGED) == _leaves(DustConfig, "dust.") - {"dust.enabled"}
    changed, default = config(**CHANGED), config()
    assert all(_value(changed, path) != _value(default, path) for path in CHANGED)

    def forbidden(*args, **kwargs):
        raise AssertionError("dust code ran in a scene without dust")

    for name in ("simulate_ejecta", "cloud_puffs", "Medium"):
        monkeypatch.setattr(_core, name, forbidden)  # moonbot.render.dust calls them through _core
    monkeypatch.setattr(views_module, "SceneDust", forbidden)
    real_render, real_build, scenes = _core.render, views_module.build_scene, []

    def render_without_medium(*args, **kwargs):
        assert kwargs.get("medium") is None
        return real_render(*args, **kwargs)

    def build(spec, *args):
        scene = real_build(spec, *args)
        scenes.append((spec, scene))
        return scene

    monkeypatch.setattr(_core, "render", render_without_medium)
    monkeypatch.setattr(views_module, "build_scene", build)
    default = render(tmp_path / "default", [0, VIEW])
    off = render(tmp_path / "off", [0, VIEW], **CHANGED, **{"dust.enabled": False})
    for result in default + off:
        assert "dust" not in result.timings and result.dust is None
        gt = json.loads((result.out_dir / "gt.json").read_text())
        assert "dust" not in gt and "dust" not in gt["timings_s"]
    for spec, scene in scenes:  # terrain and bag meshes only, and their instances
        assert scene.mesh_count == len(spec.meshes)
        assert scene.instance_count == 1 + len(spec.rocks) + len(spec.bags)
    for a, b in zip(default, off):
        same_bytes(a.out_dir, b.out_dir)


def test_ejecta_are_background_geometry_in_depth_and_masks(renders):
    """Fragments come between the camera and whatever was there: nearer depth (or depth where
    there was none), labelled background (0), occluding the bag where they pass in front of it;
    every other pixel's depth and label is exactly the dust-free one."""
    free, ejecta = read(renders["free"]), read(renders["ejecta"])
    moved = ejecta["depth"] != free["depth"]
    assert moved.sum() >= 20
    nearer = (ejecta["depth"][moved] < free["depth"][moved]) | (free["depth"][moved] == 0)
    assert nearer.all() and (ejecta["depth"][moved] > 0).all()
    assert (ejecta["mask"][moved] == 0).all()
    np.testing.assert_array_equal(ejecta["mask"][~moved], free["mask"][~moved])
    assert not np.array_equal(ejecta["rgb"], free["rgb"])
    dust = ejecta["gt"]["dust"]
    assert dust["fragments"] == 200 and dust["puffs"] == 0  # no cloud: nothing for a medium to trace
    assert ejecta["gt"]["instances"][0]["px_count_visib"] == int((ejecta["mask"] == 1).sum())


def test_the_cloud_changes_rgb_only(renders):
    """The medium attenuates and scatters light in rgb; depth and masks are those of the same
    scene without the cloud, bit for bit (the ejecta are the same in both)."""
    ejecta, dust = read(renders["ejecta"]), read(renders["dust"])
    assert dust["depth"].tobytes() == ejecta["depth"].tobytes()
    assert dust["mask"].tobytes() == ejecta["mask"].tobytes()
    assert not np.array_equal(dust["rgb"], ejecta["rgb"])
    record = dust["gt"]["dust"]
    assert record["puffs"] > 0 and record["fragments"] == 200
    assert record["capture_time_s"] == 6.0 + VIEW * 0.25
    assert record["note"] == DUST_NOTE and "depth and masks stay geometric" in record["note"]
    assert "dust" in dust["gt"]["timings_s"] and dust["gt"]["timings_s"]["dust"] >= 0


def test_each_view_rebuilds_only_the_ejecta_bvh():
    """Every capture is simulated before the fragments' mesh joins the scene (they would hit
    themselves); then each view costs two BVH builds — the ejecta's prototype and the top level —
    not one per mesh: the terrain's and the bags' are built once. Rendering builds nothing."""
    c = config(**DUST)
    spec = compose_scene(c)
    scene = build_scene(spec)
    views = [0, 1, 2, 1]
    dust = SceneDust(scene, spec, c, views)
    assert scene.mesh_count == len(spec.meshes) and scene.committed
    assert len(spec.meshes) + 2 > 2  # a full rebuild would cost more than two
    for v in views:
        before = scene.bvh_builds
        view_dust = dust.for_view(v)
        assert scene.bvh_builds - before == 2, v
        assert scene.committed and scene.mesh_count == len(spec.meshes) + 1
        assert view_dust.meta["capture_time_s"] == capture_time(c.dust, v)


def test_the_emitter_stands_on_the_ground_beside_the_target():
    c = config(**DUST)
    spec = compose_scene(c)
    origin = emitter_origin(spec, c.dust)
    np.testing.assert_allclose(origin[:2], spec.target[:2] + np.array(c.dust.emitter_offset_m), atol=1e-12)
    assert origin[2] == 0.0  # on the plane
    slope = load_config(None, {**SMALL, **DUST, "terrain.location": "slope"})
    spec = compose_scene(slope)
    origin = emitter_origin(spec, slope.dust)
    assert origin[2] == pytest.approx(float(spec.ground.height(origin[:1], origin[1:2])[0]), abs=1e-12)
    assert origin[2] != pytest.approx(float(spec.target[2]), abs=0.01)
    assert dust_seed(0) != dust_seed(1) and dust_seed(0) == dust_seed(0)


def test_config_defaults_are_the_cores():
    """The dust section's defaults are the core's (the paper's): the same fragments and puffs."""
    scene = build_scene(compose_scene(config()))
    e, c = EjectaConfig(), CloudConfig()
    at_zero = np.zeros(3)
    ours = _core.simulate_ejecta(scene, params.ejecta(e, at_zero), 3, 1.1, dt_s=DustConfig().time_step_s)
    core = _core.simulate_ejecta(scene, _core.EjectaParams(), 3, 1.1)
    assert all(ours[k].tobytes() == core[k].tobytes() for k in core)
    ours = _core.cloud_puffs(params.cloud(c, at_zero), 3, 6.0)
    assert ours.tobytes() == _core.cloud_puffs(_core.CloudParams(), 3, 6.0).tobytes()
    assert MAX_DUST_STEP_S == _core.MAX_DUST_STEP


def test_same_bytes_on_one_and_two_threads(renders, tmp_path):
    two = render(tmp_path, [VIEW], **DUST, **{"render.threads": 2})[0]
    same_bytes(renders["dust"], two.out_dir)
    assert read(renders["dust"])["gt"]["dust"] == two.dust


def test_a_view_renders_the_same_alone_or_after_others(renders, tmp_path):
    """A view's capture time comes from its orbit index, and its fragments replace whatever the
    mesh held: view 9 after view 0 is view 9 rendered alone."""
    results = render(tmp_path, [0, VIEW], **DUST, **{"render.threads": 1})
    same_bytes(renders["dust"], results[1].out_dir)


def test_render_one_dust(tmp_path):
    """`moonbot render-one --dust` turns dust on and records it; without the flag there is none."""
    small = [arg for k, v in SMALL.items() for arg in ("--set", f"{k}={v}")]
    result = CliRunner().invoke(
        main, ["render-one", "--dust", "--out", str(tmp_path / "on"), "--view", "3", "--no-sheet", *small]
    )
    assert result.exit_code == 0, result.output
    gt = json.loads((tmp_path / "on" / "view_003" / "gt.json").read_text())
    assert gt["dust"]["capture_time_s"] == 6.75 and gt["dust"]["fragments"] == 200 and gt["dust"]["puffs"] > 0
    assert "depth and masks stay geometric" in gt["dust"]["note"] and "dust" in gt["timings_s"]
    assert "dust    200 ejecta fragments" in result.output
    result = CliRunner().invoke(
        main, ["render-one", "--out", str(tmp_path / "off"), "--view", "3", "--no-sheet", *small]
    )
    assert result.exit_code == 0, result.output
    assert "dust" not in json.loads((tmp_path / "off" / "view_003" / "gt.json").read_text())
    assert "\ndust " not in result.output
    assert "--dust" in CliRunner().invoke(main, ["render-one", "--help"]).output


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"dust.time_step_s": 0.2}, "dust.time_step_s: must be <= 0.1, got 0.2"),
        ({"dust.time_step_s": 0}, "dust.time_step_s: must be > 0.0"),
        ({"dust.ejecta.count": -1}, "dust.ejecta.count: must be >= 0, got -1"),
        ({"dust.ejecta.count": 2.5}, "dust.ejecta.count: must be an integer"),
        ({"dust.ejecta.min_diameter_m": 0.05}, "dust.ejecta.min_diameter_m: must be <= max_diameter_m"),
        ({"dust.ejecta.restitution": 1.0}, "dust.ejecta.restitution: must be <= 0.95"),
        ({"dust.emitter_offset_m": [0.5]}, "dust.emitter_offset_m: must have 2 items"),
        ({"dust.warmup_s": -1}, "dust.warmup_s: must be >= 0"),
        ({"dust.enabled": "yes"}, "dust.enabled: must be true or false"),
        ({"dust.seed": 3}, "dust.seed: unknown field"),
        ({"dust.cloud.axis": [0, 0, 0]}, "dust.cloud.axis: must not be zero"),
        ({"dust.cloud.rise_fraction": 1.0}, "dust.cloud.rise_fraction: must be < 1"),
        ({"dust.cloud.asymmetry": 1.0}, "dust.cloud.asymmetry: must be < 1"),
        ({"dust.cloud.rate_per_s": 50000.0}, "dust.cloud.rate_per_s: at most 100000 puffs"),
        ({"dust.cloud.albedo": [0.5, 0.5, 1.5]}, "dust.cloud.albedo[2]: must be <= 1.0"),
        ({"dust.cloud.voxel_m": 0}, "dust.cloud.voxel_m: must be >= 0.001"),
        ({"dust.cloud.march_stride_px": 3}, "dust.cloud.march_stride_px: must be 1, 2, 4 or 8"),
    ],
    ids=lambda x: x if isinstance(x, str) else None,
)
def test_bad_dust_settings_name_the_field(overrides, message):
    with pytest.raises(ConfigError) as caught:
        load_config(None, overrides)
    assert message in str(caught.value)


def test_bad_dust_setting_stops_render_one_before_rendering(tmp_path):
    result = CliRunner().invoke(main, ["render-one", "--dust", "--out", str(tmp_path), "--set", "dust.ejecta.count=-5"])
    assert result.exit_code != 0 and "dust.ejecta.count: must be >= 0" in result.output
    assert not any(tmp_path.iterdir())
