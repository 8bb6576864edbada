"""Configuration loading: defaults, overrides, JSON, hashing and errors that name the field."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from moonbot.config import (
    Config,
    ConfigError,
    config_hash,
    default_config_path,
    load_config,
    parse_overrides,
    parse_yaml,
)
from moonbot.config.load import parse_yaml_documents

pytestmark = pytest.mark.unit


def test_embedded_default_equals_schema_defaults():
    """default.yaml spells out the schema's defaults, so neither can drift from the other."""
    assert load_config() == Config()
    assert default_config_path().is_file()


def test_overrides_and_json(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"sun": {"elevation_deg": 5}, "meshes": {"sandbag_02": {"size_m": [0.3, 0.2, 0.1]}}}))
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


@pytest.mark.parametrize(
    ("data", "message"),
    [
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
        (
            {"meshes": {"sandbag_02": {"seam_height_m": 0.003, "edge_radius_m": 0.0}}},
            "meshes.sandbag_02.seam_height_m: a seam needs rounded edges",
        ),
        ({"tonemap": {"ev100": "bright"}}, "tonemap.ev100: must be a number or auto, got 'bright'"),
        ({"tonemap": {"ev100": True}}, "tonemap.ev100: must be a number or auto, got True"),
        ({"tonemap": {"ev100": None}}, "tonemap.ev100: must be a number or auto, got None"),
        ({"tonemap": {"ev100": 31}}, "tonemap.ev100: must be <= 30.0, got 31.0"),
        ({"tonemap": {"ev100": -11.5}}, "tonemap.ev100: must be >= -10.0, got -11.5"),
        ({"tonemap": {"exposure_stops": 2.0}}, "tonemap.exposure_stops: unknown field (known: ev100, veiling_glare)"),
        ({"output": {"exr": "yes"}}, "output.exr: must be true or false, got 'yes'"),
    ],
    ids=lambda x: None if isinstance(x, str) else json.dumps(x),
)
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


ROOT = Path(__file__).resolve().parents[1]


def test_a_section_given_twice_is_an_error_naming_file_line_and_key(tmp_path):
    """PyYAML keeps the second `camera:` block and drops the first's width without a word."""
    path = tmp_path / "twice.yaml"
    path.write_text("camera:\n  width: 320\nseed: 3\ncamera:\n  height: 240\n")
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert str(caught.value) == (
        f"{path}:4: camera: duplicate key (first given at line 1; YAML would keep only the last)"
    )


def test_a_nested_duplicate_names_its_dotted_path(tmp_path):
    path = tmp_path / "nested.yaml"
    path.write_text(
        "dust:\n  enabled: true\n  cloud:\n    voxel_m: 0.05\n    march_stride_px: 2\n    march_stride_px: 4\n"
    )
    with pytest.raises(
        ConfigError,
        match=r"nested\.yaml:6: dust\.cloud\.march_stride_px: duplicate key "
        r"\(first given at line 5;",
    ):
        load_config(path)


def test_every_duplicate_is_named_in_line_order(tmp_path):
    """In a list item and in a JSON object too; keys compare as values (0x1 is 1), as in the dict."""
    path = tmp_path / "many.yaml"
    path.write_text(
        "sweep:\n  splits:\n    - name: train\n      name: test\n"
        'bags: {"count": 1, "count": 2}\nmeshes:\n  1: a\n  0x1: b\n'
    )
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert str(caught.value).splitlines() == [
        f"{path}:4: sweep.splits[0].name: duplicate key (first given at line 3; YAML would keep only the last)",
        f"{path}:5: bags.count: duplicate key (first given at line 5; YAML would keep only the last)",
        f"{path}:8: meshes.1: duplicate key (first given at line 7; YAML would keep only the last)",
    ]


def test_a_duplicate_in_a_set_value_is_an_error():
    with pytest.raises(ConfigError, match=r"--set camera:1: camera\.width: duplicate key"):
        parse_overrides(["camera={width: 1, width: 2}"])


def test_merge_keys_and_aliases_are_not_duplicates():
    text = "base: &b {width: 64, height: 48}\ncamera:\n  <<: *b\n  width: 96\nalso: *b\n"
    assert parse_yaml(text, "t.yaml") == {
        "base": {"width": 64, "height": 48},
        "camera": {"width": 96, "height": 48},
        "also": {"width": 64, "height": 48},
    }


def test_invalid_yaml_names_the_file_and_line(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("camera:\n  width: [1, 2\nseed: 3\n")
    with pytest.raises(ConfigError, match=r"broken\.yaml: not valid YAML/JSON \(line \d+: "):
        load_config(path)


@pytest.mark.parametrize("path", sorted((ROOT / "configs").rglob("*.yaml")), ids=lambda p: p.name)
def test_the_shipped_configs_load_cleanly(path):
    load_config(path)


@pytest.mark.parametrize("path", sorted((ROOT / "cluster").rglob("*.yaml")), ids=lambda p: p.name)
def test_the_cluster_recipes_have_no_duplicate_keys(path):
    """Dask and Kubernetes read these, and keep the last of two keys as PyYAML does."""
    assert parse_yaml_documents(path.read_text(), str(path))
