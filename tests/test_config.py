"""Configuration loading: defaults, overrides, JSON, hashing and errors that name the field."""

from __future__ import annotations

import dataclasses
import json

import pytest

from moonbot.config import Config, ConfigError, config_hash, default_config_path, load_config


def test_embedded_default_equals_schema_defaults():
    """default.yaml spells out the schema's defaults, so neither can drift from the other."""
    assert load_config() == Config()
    assert default_config_path().is_file()


def test_overrides_and_json(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"sun": {"elevation_deg": 5},
                                "meshes": {"sandbag_02": {"size_m": [0.3, 0.2, 0.1]}}}))
    config = load_config(path, {"orbit.height_m": 0.9})
    assert config.sun.elevation_deg == 5.0 and isinstance(config.sun.elevation_deg, float)
    assert config.meshes.sandbag_02.size_m == (0.3, 0.2, 0.1)
    assert config.meshes.sandbag_02.seam_height_m == 0.0  # a mapping replaces the variant's defaults
    assert config.orbit.height_m == 0.9
    assert config.camera == Config().camera


def test_hash_is_stable_and_sensitive():
    a, b = load_config(), load_config(None, {"seed": 1})
    assert config_hash(a) == config_hash(load_config()) != config_hash(b)
    assert len(config_hash(a)) == 64


@pytest.mark.parametrize(("data", "message"), [
    ({"camera": {"width": 0}}, "camera.width: must be >= 1, got 0"),
    ({"camera": {"width": 1.5}}, "camera.width: must be an integer"),
    ({"camera": {"width": True}}, "camera.width: must be an integer"),
    ({"camera": {"hfov_deg": 0}}, "camera.hfov_deg: must be > 0"),
    ({"camera": 3}, "camera: must be a mapping"),
    ({"sun": {"elevation_deg": -91}}, "sun.elevation_deg: must be >= -90"),
    ({"bags": {"albedo": [0.5, 0.5, 1.5]}}, "bags.albedo[2]: must be <= 1.0"),
    ({"bags": {"count": 256}}, "bags.count: must be <= 255"),
    ({"bags": {"count": 3}}, "bags.count: the single layout holds one bag"),
    ({"typo": 1}, "typo: unknown field"),
    ({"render": {"spp": -4}}, "render.spp: must be >= 1"),
    ({"bags": {"mesh": "sandbag-04"}}, "bags.mesh: must be one of sandbag-01"),
    ({"meshes": {"sandbag_01": {"edge_radius_m": 0.5}}}, "meshes.sandbag_01.edge_radius_m: must be in"),
    ({"meshes": {"sandbag_02": {"seam_height_m": 0.003, "edge_radius_m": 0.0}}},
     "meshes.sandbag_02.seam_height_m: a seam needs rounded edges"),
    ({"tonemap": {"ev100": "bright"}}, "tonemap.ev100: must be a number or auto, got 'bright'"),
    ({"tonemap": {"ev100": True}}, "tonemap.ev100: must be a number or auto, got True"),
    ({"tonemap": {"ev100": None}}, "tonemap.ev100: must be a number or auto, got None"),
    ({"tonemap": {"ev100": 31}}, "tonemap.ev100: must be <= 30.0, got 31.0"),
    ({"tonemap": {"ev100": -11.5}}, "tonemap.ev100: must be >= -10.0, got -11.5"),
    ({"tonemap": {"exposure_stops": 2.0}}, "tonemap.exposure_stops: unknown field (known: ev100)"),
    ({"output": {"exr": "yes"}}, "output.exr: must be true or false, got 'yes'"),
], ids=lambda x: None if isinstance(x, str) else json.dumps(x))
def test_errors_name_the_field(tmp_path, data, message):
    path = tmp_path / "bad.yaml"
    path.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match="bad.yaml") as caught:
        load_config(path)
    assert message in str(caught.value)


def test_ev100_is_a_number_or_auto(tmp_path):
    """YAML's number or `auto`, from a file or from --set; a number stays a float."""
    assert load_config(None, {"tonemap.ev100": 14}).tonemap.ev100 == 14.0
    assert isinstance(load_config(None, {"tonemap.ev100": 14}).tonemap.ev100, float)
    assert load_config(None, {"tonemap.ev100": "auto"}).tonemap.ev100 == "auto"
    path = tmp_path / "c.yaml"
    path.write_text("tonemap:\n  ev100: 12.7\noutput:\n  exr: true\n")
    config = load_config(path)
    assert config.tonemap.ev100 == 12.7 and config.output.exr is True
    with pytest.raises(ConfigError, match="tonemap.ev100: must be finite"):
        load_config(None, {"tonemap.ev100": float("nan")})


def test_top_level_must_be_a_mapping(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="top level must be a mapping"):
        load_config(path)


def test_config_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        Config().seed = 3  # type: ignore[misc]
