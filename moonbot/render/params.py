"""The config's sections as the core's parameter structs: the one place where a YAML field becomes
a field of a C++ struct (cpp/include/moonbot/*.h). Each struct starts from its C++ defaults
(`_core.X()`); the config sets every field it has, and the struct's keyword constructor checks
the whole (ValueError naming the field). tests/test_core_params.py checks that the schema's
defaults and ranges agree with the C++ ones where both state them."""

from __future__ import annotations

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


def photometry(config: PhotometryConfig) -> _core.Photometry:
    """Regolith's photometric function (moonbot/photometry.h)."""
    return _core.Photometry(
        model=config.model,
        phase=config.phase,
        surge_amplitude=config.surge_amplitude,
        surge_width=config.surge_width,
        w=config.w,
        b=config.b,
        c=config.c,
        roughness_deg=config.roughness_deg,
        filling_factor=config.filling_factor,
        cboe_amplitude=config.cboe_amplitude,
        cboe_width=config.cboe_width,
    )


def grain(config: GrainConfig) -> _core.GrainParams:
    """Regolith's granular micro-texture (moonbot/regolith_texture.h)."""
    return _core.GrainParams(
        albedo_rms=config.albedo_rms,
        slope_rms_deg=config.slope_rms_deg,
        finest_cell_m=config.finest_cell_m,
        coarsest_cell_m=config.coarsest_cell_m,
        hurst=config.hurst,
        seed=config.seed,
    )


def woven(fabric: FabricConfig, stain: StainConfig, metres_per_uv: float, stain_seed: int) -> _core.WovenSurface:
    """A bag's cloth (moonbot/scene.h WovenSurface): the weave laid at `metres_per_uv` fabric metres
    per atlas UV unit, its dirt made from `stain_seed` (zero stain seeds: none is made)."""
    return _core.WovenSurface(
        fabric=_core.FabricParams(
            pitch_m=fabric.pitch_m,
            relief_m=fabric.relief_m,
            contrast=fabric.contrast,
            sheen=fabric.sheen,
            sheen_along=fabric.sheen_along,
            sheen_across=fabric.sheen_across,
        ),
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
    return _core.EjectaParams(
        origin=origin,
        count=config.count,
        spawn_radius_m=config.spawn_radius_m,
        cone_half_angle_deg=config.cone_half_angle_deg,
        mean_speed_m_s=config.mean_speed_m_s,
        min_diameter_m=config.min_diameter_m,
        max_diameter_m=config.max_diameter_m,
        gravity_m_s2=config.gravity_m_s2,
        restitution=config.restitution,
        friction=config.friction,
        rest_speed_m_s=config.rest_speed_m_s,
        burst_period_s=config.burst_period_s,
    )


def cloud(config: CloudConfig, origin: np.ndarray) -> _core.CloudParams:
    """Emitter 2, the fine-dust cloud (moonbot/dust.h), standing at `origin` ((3,) world metres)."""
    return _core.CloudParams(
        origin=origin,
        box_m=config.box_m,
        vertical_offset_m=config.vertical_offset_m,
        axis=config.axis,
        cone_half_angle_deg=config.cone_half_angle_deg,
        speed_m_s=config.speed_m_s,
        gravity_m_s2=config.gravity_m_s2,
        lifetime_s=config.lifetime_s,
        rate_per_s=config.rate_per_s,
        sigma_m=config.sigma_m,
        growth_m_s=config.growth_m_s,
        optical_depth=config.optical_depth,
        rise_fraction=config.rise_fraction,
    )


def medium(config: CloudConfig, puffs: np.ndarray, floor_z: float) -> _core.Medium:
    """The cloud's `puffs` ((N, 5) float64, `_core.cloud_puffs`) as the medium a render traces
    (moonbot/medium.h), none of it below `floor_z` (world metres)."""
    return _core.Medium(
        puffs=puffs,
        albedo=config.albedo,
        asymmetry=config.asymmetry,
        voxel_m=config.voxel_m,
        floor_z=floor_z,
        march_stride_px=config.march_stride_px,
    )


def render_settings(config: RenderConfig, seed: int) -> _core.RenderSettings:
    """A view's render quality and threads (moonbot/render.h), its samples keyed by `seed`;
    adaptive anti-aliasing's samples as config.refinement_spp resolves them (0 = off)."""
    return _core.RenderSettings(
        spp=config.spp,
        seed=seed,
        threads=config.threads,
        exact_depth=config.exact_depth,
        light_samples=config.light_samples,
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
        seed=seed,
        threads=config.threads,
    )
