"""The config's sections as the core's parameter structs: the one place where a YAML field becomes
a field of a C++ struct (cpp/include/moonbot/*.h). Each struct starts from its C++ defaults
(`_core.X()`); the config sets every field it has, and the struct's keyword constructor checks
the whole (ValueError naming the field). tests/test_core_params.py checks that the schema's
defaults and ranges agree with the C++ ones where both state them."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from moonbot import _core
from moonbot.config.schema import (
    CloudConfig,
    EjectaConfig,
    FabricConfig,
    GrainConfig,
    PhotometryConfig,
    RenderConfig,
    StainConfig,
)

# CloudConfig's fields that describe the medium the cloud makes (Medium), not its emitter.
_MEDIUM_FIELDS = ("albedo", "asymmetry", "voxel_m", "march_stride_px")


def _same_named(config: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """The fields of config section `config` (a dataclass) that its struct holds under the same
    name: all but nested sections and those in `skip`. The struct's keyword constructor refuses a
    name it lacks, so a schema field without a struct field fails loudly."""
    return {
        f.name: getattr(config, f.name)
        for f in dataclasses.fields(config)
        if f.name not in skip and not dataclasses.is_dataclass(getattr(config, f.name))
    }


def photometry(config: PhotometryConfig) -> _core.Photometry:
    """Regolith's photometric function (moonbot/photometry.h)."""
    return _core.Photometry(**_same_named(config))


def grain(config: GrainConfig) -> _core.GrainParams:
    """Regolith's granular micro-texture (moonbot/regolith_texture.h)."""
    return _core.GrainParams(**_same_named(config))


def woven(fabric: FabricConfig, stain: StainConfig, metres_per_uv: float, stain_seed: int) -> _core.WovenSurface:
    """A bag's cloth (moonbot/scene.h WovenSurface): the weave laid at `metres_per_uv` fabric metres
    per atlas UV unit, its dirt made from `stain_seed` (zero stain seeds: none is made)."""
    return _core.WovenSurface(
        fabric=_core.FabricParams(**_same_named(fabric)),
        stain=_core.StainParams(
            stamps=stain.seeds, brush_size=stain.brush_size, opacity=stain.opacity, resolution=stain.resolution
        ),
        soiling=_core.SoilingParams(
            contact_height_m=stain.contact_height_m,
            deposit_radius_m=stain.deposit_radius_m,
            handled_share=stain.handled_share,
            speckle=stain.speckle,
        ),
        metres_per_uv=metres_per_uv,
        stain_seed=stain_seed,
        dirt_colour=stain.dirt_colour,
        stain_mode=stain.mode,
    )


def ejecta(config: EjectaConfig, origin: np.ndarray) -> _core.EjectaParams:
    """Emitter 1 (moonbot/dust.h) standing at `origin` ((3,) world metres, on the ground)."""
    return _core.EjectaParams(origin=origin, **_same_named(config))


def cloud(config: CloudConfig, origin: np.ndarray) -> _core.CloudParams:
    """Emitter 2, the fine-dust cloud (moonbot/dust.h), standing at `origin` ((3,) world metres)."""
    return _core.CloudParams(origin=origin, **_same_named(config, skip=_MEDIUM_FIELDS))


def medium(config: CloudConfig, puffs: np.ndarray, floor_z: float) -> _core.Medium:
    """The cloud's `puffs` ((N, 5) float64, `_core.cloud_puffs`) as the medium a render traces
    (moonbot/medium.h), none of it below `floor_z` (world metres)."""
    return _core.Medium(puffs=puffs, floor_z=floor_z, **{name: getattr(config, name) for name in _MEDIUM_FIELDS})


def render_settings(config: RenderConfig, seed: int) -> _core.RenderSettings:
    """A view's render quality and threads (moonbot/render.h), its samples keyed by `seed`;
    adaptive anti-aliasing's samples as config.refinement_spp resolves them (0 = off)."""
    return _core.RenderSettings(
        spp=config.spp,
        seed=seed,
        threads=config.threads,
        exact_depth=config.exact_depth,
        light_samples=config.light_samples,
        penumbra_light_samples=config.penumbra_light_samples,
        adaptive_full_spread=config.adaptive_full_spread,
        adaptive_contrast=config.adaptive_contrast,
        adaptive_error_target=config.adaptive_error_target,
        bounces=config.bounces,
        adaptive_spp=config.refinement_spp,
        adaptive_threshold=config.adaptive_threshold,
        texture_filter_px=config.texture_filter_px,
    )


def light_cache_settings(config: RenderConfig, seed: int) -> _core.LightCacheSettings:
    """How the task's light cache gathers (moonbot/light_cache.h), keyed by `seed` (the dataset's)."""
    return _core.LightCacheSettings(
        bounces=config.bounces,
        rays_objects=config.cache_rays_bags,
        rays_background=config.cache_rays_terrain,
        background_cell_m=config.cache_terrain_cell_m,
        object_cell_m=config.cache_bag_cell_m,
        background_filter_cells=config.cache_terrain_filter_cells,
        gather_error=config.cache_gather_error,
        max_rays_factor=config.cache_rays_max_factor,
        seed=seed,
        threads=config.threads,
    )
