"""The core's parameter structs as Python sees them (cpp/bindings/params.h) and the config that
builds them (moonbot/render/params.py): `X()` is the C++ defaults, `X(**fields)` validates, every
config field reaches its struct, and where the schema states a default or a range that the C++
struct states too, the two agree (or the difference is listed here, with its reason)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from moonbot import _core
from moonbot.config.schema import (
    CloudConfig,
    EjectaConfig,
    FabricConfig,
    GrainConfig,
    PhotometryConfig,
    RenderConfig,
    StainConfig,
    SunConfig,
)
from moonbot.render import params

pytestmark = pytest.mark.unit

# Schema defaults that differ from the C++ struct's on purpose: the config's are the dataset's
# choices, the struct's the plain model (effects off, or the reference's values).
DEFAULTS_DIFFER = {  # (struct, struct field): why the schema's default is another
    ("Photometry", "model"): "the dataset renders Lunar-Lambert; the core's default is Lambert",
    ("Photometry", "surge_amplitude"): "the dataset's opposition surge is on; the core's is off",
    ("Photometry", "roughness_deg"): "the dataset's θ̄ leaves out the relief its mesh and grain hold; "
    "the core's is Sato et al. 2014's 23.4°",
    ("GrainParams", "albedo_rms"): "the dataset's grain is on; the core's is off",
    ("GrainParams", "slope_rms_deg"): "the dataset's grain is on; the core's is off",
    ("FabricParams", "sheen"): "the dataset's tapes are glossy; the core's default is the matte weave",
    ("Medium", "march_stride_px"): "the dataset marches every 4th pixel; the core's default marches all",
    ("RenderSettings", "spp"): "the dataset's quality; the core's default is one pixel-centre ray",
    (
        "RenderSettings",
        "penumbra_light_samples",
    ): "the dataset's soft shadow edges; the core's default is one shadow ray",
    ("RenderSettings", "bounces"): "the dataset's inter-reflection; the core's default is direct light",
    ("RenderSettings", "adaptive_threshold"): "the dataset's; the core's default matters only when adaptive_spp is on",
    (
        "RenderSettings",
        "adaptive_full_spread",
    ): "the dataset's; the core's default brings every refined pixel to adaptive_spp",
    (
        "RenderSettings",
        "adaptive_contrast",
    ): "the dataset's; the core's default refines by the pixels' own spreads alone",
    (
        "RenderSettings",
        "adaptive_error_target",
    ): "the dataset's; the core's default keeps adaptive_full_spread for every view",
    ("LightCacheSettings", "background_cell_m"): "the dataset's lattice; the core's default gathers per vertex",
    ("LightCacheSettings", "object_cell_m"): "the dataset's lattice; the core's default gathers per vertex",
    ("LightCacheSettings", "background_filter_cells"): "the dataset's filter; the core's default is bilinear",
}


def config_fields(config) -> dict:
    return {
        f.name: getattr(config, f.name)
        for f in dataclasses.fields(config)
        if not dataclasses.is_dataclass(getattr(config, f.name))
    }


def built():
    """(config, the core struct params.py builds from it, {config field: struct field}) per section."""
    origin = np.array([0.5, -0.25, 1.5])
    cloud = CloudConfig()
    puffs = _core.cloud_puffs(params.cloud(cloud, origin), 1, 6.0)
    woven = params.woven(FabricConfig(), StainConfig(), 2.0, 7)
    same = lambda config, *skip: {k: k for k in config_fields(config) if k not in skip}  # noqa: E731
    return [
        (PhotometryConfig(), params.photometry(PhotometryConfig()), same(PhotometryConfig())),
        (GrainConfig(), params.grain(GrainConfig()), same(GrainConfig())),
        (EjectaConfig(), params.ejecta(EjectaConfig(), origin), same(EjectaConfig())),
        (cloud, params.cloud(cloud, origin), same(cloud, "albedo", "asymmetry", "voxel_m", "march_stride_px")),
        (
            cloud,
            params.medium(cloud, puffs, -1.0),
            {"albedo": "albedo", "asymmetry": "asymmetry", "voxel_m": "voxel_m", "march_stride_px": "march_stride_px"},
        ),
        (FabricConfig(), woven.fabric, same(FabricConfig())),
        (
            StainConfig(),
            woven.stain,
            {"seeds": "stamps", "brush_size": "brush_size", "opacity": "opacity", "resolution": "resolution"},
        ),
        (
            StainConfig(),
            woven.soiling,
            {k: k for k in ("contact_height_m", "deposit_radius_m", "handled_share", "speckle")},
        ),
        (StainConfig(), woven, {"dirt_colour": "dirt_colour", "mode": "stain_mode"}),
        (
            RenderConfig(),
            params.render_settings(RenderConfig(), 9),
            {
                k: k
                for k in (
                    "spp",
                    "threads",
                    "exact_depth",
                    "light_samples",
                    "penumbra_light_samples",
                    "adaptive_full_spread",
                    "adaptive_contrast",
                    "adaptive_error_target",
                    "bounces",
                    "adaptive_threshold",
                    "texture_filter_px",
                )
            },
        ),
        (
            RenderConfig(),
            params.light_cache_settings(RenderConfig(), 9),
            {
                "bounces": "bounces",
                "cache_rays_bags": "rays_objects",
                "cache_rays_terrain": "rays_background",
                "cache_terrain_cell_m": "background_cell_m",
                "cache_bag_cell_m": "object_cell_m",
                "cache_terrain_filter_cells": "background_filter_cells",
                "cache_gather_error": "gather_error",
                "cache_rays_max_factor": "max_rays_factor",
                "threads": "threads",
            },
        ),
    ]


def same_value(a, b) -> bool:
    if isinstance(a, tuple) or isinstance(b, tuple):
        return tuple(a) == tuple(b)
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-15, abs_tol=0.0)
    return a == b


def test_every_config_field_reaches_its_struct():
    covered: dict[str, set] = {}
    for config, struct, mapping in built():
        for ours, theirs in mapping.items():
            assert same_value(getattr(config, ours), getattr(struct, theirs)), (type(config).__name__, ours)
        covered.setdefault(type(config).__name__, set()).update(mapping)
    for config in (PhotometryConfig(), GrainConfig(), EjectaConfig(), CloudConfig(), FabricConfig()):
        assert covered[type(config).__name__] == set(config_fields(config)), type(config).__name__
    # StainConfig's seeds and colour are per bag, the rest per dataset: every field is used.
    assert covered["StainConfig"] == set(config_fields(StainConfig()))
    woven = params.woven(FabricConfig(), StainConfig(), 2.0, 7)
    assert woven.metres_per_uv == 2.0 and woven.stain_seed == 7
    render = RenderConfig()
    assert params.render_settings(render, 9).seed == params.light_cache_settings(render, 9).seed == 9
    assert params.render_settings(render, 9).adaptive_spp == render.refinement_spp


def test_schema_defaults_are_the_cores_or_differ_on_purpose():
    for config, struct, mapping in built():
        default = type(struct)()
        for ours, theirs in mapping.items():
            key = (type(struct).__name__, theirs)
            if key in DEFAULTS_DIFFER:
                assert not same_value(getattr(config, ours), getattr(default, theirs)), key
                continue
            if ours == "seed" or (isinstance(struct, (_core.EjectaParams, _core.CloudParams)) and ours == "origin"):
                continue
            assert same_value(getattr(config, ours), getattr(default, theirs)), key


def test_the_suns_irradiance_is_the_cores_default():
    assert _core.DirectionalLight(0.0, 90.0).irradiance == SunConfig().irradiance_w_m2


def test_photometry_ranges_come_from_the_core_and_the_schema_keeps_within_them():
    """The C++ ranges are the source; the schema states them again for its error messages, within
    them (its ranges are closed above, so b's [0, 1) is [0, 0.99] there)."""
    ranges = _core.Photometry.ranges
    schema = {f.name: f.metadata for f in dataclasses.fields(PhotometryConfig) if f.metadata.get("lo") is not None}
    assert set(schema) == set(ranges)
    for name, (lo, hi, lo_open, hi_open) in ranges.items():
        spec = schema[name]
        assert (spec["lo"], spec["lo_open"]) == (lo, lo_open), name
        assert spec["hi"] == hi if not hi_open else spec["hi"] < hi, name


@pytest.mark.parametrize("name", sorted(_core.Photometry.ranges))
def test_photometry_refuses_each_field_past_its_range(name):
    lo, hi, lo_open, hi_open = _core.Photometry.ranges[name]
    for bad in (lo - 1e-9, hi + 1e-9, float("nan")):
        with pytest.raises(ValueError, match=f"^{name}: must be in "):
            _core.Photometry(model="hapke", **{name: bad})
    if not lo_open:
        _core.Photometry(**{name: lo})
    if not hi_open:
        _core.Photometry(**{name: hi})


def test_structs_read_write_and_validate():
    e = _core.EjectaParams()
    assert e.count == 200 and e.origin == (0.0, 0.0, 0.0)
    e.count = 7
    e.origin = np.array([1.0, 2.0, 3.0])
    assert e.count == 7 and e.origin == (1.0, 2.0, 3.0)
    e.restitution = 0.99  # a write is not checked ...
    with pytest.raises(ValueError, match="^restitution: must be in"):
        e.validate()  # ... until the struct is validated, as the core does where it takes it
    with pytest.raises(ValueError, match="^restitution: must be in"):
        _core.EjectaParams(restitution=0.99)
    with pytest.raises(TypeError, match="EjectaParams: no field 'restitutoin'"):
        _core.EjectaParams(restitutoin=0.5)
    with pytest.raises(ValueError, match="origin"):
        _core.EjectaParams(origin=(1.0, 2.0))
    assert "count=200" in repr(_core.EjectaParams())
    assert _core.Photometry().model == "lambert"
    with pytest.raises(ValueError, match="^model: "):
        _core.Photometry(model="hapk")
    medium = _core.Medium([[0.0, 0.0, 0.0, 0.1, 1.0]], voxel_m=0.02)
    assert medium.puff_count == 1 and medium.voxel_m == 0.02 and medium.puffs.shape == (1, 5)
