"""Scene building and view rendering through `moonbot._core`."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from moonbot import _core
from moonbot.config.schema import Config, GrainConfig, PhotometryConfig
from moonbot.render import params
from moonbot.scene.compose import TERRAIN_MESH, SceneSpec
from moonbot.scene.normals import vertex_normals
from moonbot.scene.orbit import CameraPose, intrinsics, orbit_height, orbit_pose
from moonbot.terrain.location import SubgridRelief

# The Earth seen from the Moon: 2·asin(6371 km / 384 400 km) = 1.90° (docs/physics.md).
EARTH_DIAMETER_DEG = 1.9


@dataclass(frozen=True)
class RenderedView:
    """One rendered view. rgb (H, W, 3) float32 linear radiance W/(m²·sr); depth (H, W) float32
    z-depth in metres, 0 where nothing is hit; instance (H, W) uint8 labels, 0 = background.
    `stats` holds camera_rays (second_look_rays: those traced again at a shared vertex), shadow_rays (bounce_shadow_rays of them leave bounce vertices),
    bounce_rays, medium_rays (the dust medium's shadow rays toward the Sun, 0 without dust),
    refined_pixels and refinement_rays (adaptive anti-aliasing's pixels and their extra rays) and the
    core's render seconds."""

    rgb: np.ndarray
    depth: np.ndarray
    instance: np.ndarray
    stats: dict


def build_scene(
    spec: SceneSpec, embree_isa: str = "auto", watertight: bool = True, smooth_bags: bool = True
) -> _core.Scene:
    """Builds the Embree scene once: one prototype BVH per mesh (bags of one obj_id share it,
    rocks of one prototype too); the terrain (with its per-vertex albedo factors and smooth
    normals) and the rocks as regolith background, with its granular micro-texture; each bag as
    a labelled instance of woven cloth on its atlas UVs, shaded with its mesh's area-weighted
    vertex normals (its BOP model's), its stain painted (or its dust gathered) by the core (none
    for zero seeds); then commits.
    `embree_isa` is render.embree_isa: the SIMD kernels Embree traces it with; watertight=False
    only measures what watertight traversal costs (bench/bench_embree_isa.py); smooth_bags=False
    shades the bags flat, by their facets, as the peers comparison's parity asks (bench/peers)."""

    scene = _core.Scene(embree_isa, watertight)
    bag_ids = {bag.obj_id for bag in spec.bags}
    terrain = {"vertex_albedo": spec.terrain_albedo_scale, "vertex_normals": spec.terrain_normals}

    def extras(key: int, v: np.ndarray, t: np.ndarray) -> dict:
        if key == TERRAIN_MESH:
            return terrain
        if key in bag_ids:  # wrinkles shaded smooth, not as a mosaic of 5 mm facets
            normals = vertex_normals(v, t) if smooth_bags else None
            return {"vertex_normals": normals, "vertex_albedo": spec.bag_vertex_albedo}
        return {}

    mesh_index = {
        key: scene.add_mesh(v, t, spec.bag_uvs.reshape(len(t), 6) if key in bag_ids else None, **extras(key, v, t))
        for key, (v, t) in spec.meshes.items()
    }
    photometry, albedo = regolith(spec.terrain_photometry, spec.terrain_albedo)
    grain = regolith_grain(spec.terrain_photometry.grain)
    craters = spec.terrain_craters
    terrain_grain = regolith_grain(spec.terrain_photometry.grain, spec.terrain_subgrid, needed=craters is not None)
    scene.add_background(
        mesh_index[TERRAIN_MESH],
        np.eye(4),
        albedo,
        photometry,
        grain=terrain_grain,
        craters=_core.SubgridCraters(**vars(craters)) if craters is not None else None,
    )
    for key, pose in spec.rocks:  # rocks are regolith (label 0), their own meshes: no subgrid relief
        scene.add_background(mesh_index[key], pose, albedo, photometry, grain=grain)
    f, st = spec.fabric, spec.stain
    for bag in spec.bags:
        # Zero stain seeds: the core paints and allocates no mask.
        woven = params.woven(f, st, spec.bag_metres_per_uv, bag.stain_seed)
        scene.add_instance(mesh_index[bag.obj_id], bag.world_from_model, bag.instance_id, bag.albedo, woven=woven)
    scene.commit()
    return scene


def regolith(config: PhotometryConfig, normal_albedo: float) -> tuple[_core.Photometry, tuple[float, ...]]:
    """The core's photometric function and albedo A (linear RGB) for regolith of the given
    normal albedo (reflectance at zero incidence, emission and phase). The core's BRDF is
    A/π·shape, so A = normal albedo / shape(1, 1, 1): Lambert's shape is 1 there, Lunar-Lambert's
    1 + B0 (the full opposition surge) and Hapke's 1 (it is normalised by its own normal albedo)."""
    photometry = params.photometry(config)
    # i = e = g = 0: cos i = cos e = cos g = 1.
    return photometry, (normal_albedo / photometry.shape(1.0, 1.0, 1.0),) * 3


def regolith_grain(
    config: GrainConfig, subgrid: SubgridRelief | None = None, needed: bool = False
) -> _core.RegolithGrain | None:
    """The core's granular micro-texture for regolith surfaces (terrain, rocks, ejecta), with the
    terrain's `subgrid` relief read along with it, or None when the config turns the grain off,
    there is no subgrid relief and it is not `needed` (the terrain's subgrid craters are read with
    it); then no texture code runs."""
    if not config.enabled and subgrid is None and not needed:
        return None
    core_subgrid = _core.SubgridRelief(**vars(subgrid)) if subgrid is not None else None
    return _core.RegolithGrain(params.grain(config), subgrid=core_subgrid)


def scene_lights(config: Config) -> tuple[_core.DirectionalLight, _core.DirectionalLight | None]:
    """The config's Sun, and the Earth as a second light where earthshine is on (else None: no
    second light, no shadow rays toward it)."""
    s = config.sun
    sun = _core.DirectionalLight(s.azimuth_deg, s.elevation_deg, s.irradiance_w_m2, s.angular_diameter_deg)
    earth = (
        _core.DirectionalLight(
            s.earth_azimuth_deg, s.earth_elevation_deg, s.earth_irradiance_w_m2, EARTH_DIAMETER_DEG, s.earth_color
        )
        if s.earthshine
        else None
    )
    return sun, earth


def core_camera(K: np.ndarray, width: int, height: int, pose: CameraPose) -> _core.Camera:
    """The core's pinhole camera: intrinsics K (3, 3) in pixels, an image of width × height
    pixels, and the world-to-camera pose (OpenCV axes: x right, y down, z forward)."""
    return _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], width, height, pose.R, pose.t)


def orbit_view(config: Config, spec: SceneSpec, view: int) -> tuple[np.ndarray, CameraPose]:
    """K (3, 3) and the world-to-camera pose of orbit view `view` (0: orbit.start_azimuth_deg,
    then steps of orbit.step_deg), its height kept above the ground as the pipeline places it."""
    o = config.orbit
    azimuth = o.start_azimuth_deg + view * o.step_deg
    height = orbit_height(spec.target, o.radius_m, o.height_m, azimuth, spec.ground)
    return intrinsics(config.camera), orbit_pose(spec.target, o.radius_m, height, azimuth)


@dataclass(frozen=True)
class ViewInputs:
    """What the core renders one orbit view with: K (3, 3) px, the world-to-camera pose, the
    camera at the config's image size, the Sun and the Earth (None without earthshine)."""

    K: np.ndarray
    pose: CameraPose
    camera: _core.Camera
    sun: _core.DirectionalLight
    earth: _core.DirectionalLight | None


def view_inputs(config: Config, spec: SceneSpec, view: int) -> ViewInputs:
    """The camera and lights of orbit view `view` of the scene `spec` under `config`."""
    K, pose = orbit_view(config, spec, view)
    return ViewInputs(K, pose, core_camera(K, config.camera.width, config.camera.height, pose), *scene_lights(config))


def build_light_cache(scene: _core.Scene, config: Config) -> _core.LightCache | None:
    """The task's light cache (render.indirect = cache) over the committed scene's non-moving
    instances, keyed by the dataset seed so that every view of the task reads the same values;
    empty until views touch it. None where render.indirect is path or render.bounces is 0: no
    indirect light is asked of a cache, so none is built."""
    r = config.render
    if r.indirect != "cache" or r.bounces == 0:
        return None
    sun, earth = scene_lights(config)
    return _core.LightCache(scene, sun, earth, params.light_cache_settings(r, config.seed))


def render_view(
    scene: _core.Scene,
    config: Config,
    K: np.ndarray,
    pose: CameraPose,
    seed: int,
    medium: _core.Medium | None = None,
    light_cache: _core.LightCache | None = None,
) -> RenderedView:
    """Renders rgb, depth and instance passes of one view with the config's Sun and quality, and
    with `medium` (a dust scene's cloud; moonbot.render.dust) attenuating and scattering the
    sunlight in rgb only. `light_cache` (build_light_cache's, for this scene and config) gives
    the camera hits on the static scene their indirect light in place of per-pixel bounces."""
    camera = core_camera(K, config.camera.width, config.camera.height, pose)
    sun, earth = scene_lights(config)
    start = time.perf_counter()
    out = _core.render(
        scene,
        camera,
        sun,
        params.render_settings(config.render, seed),
        earth=earth,
        medium=medium,
        light_cache=light_cache,
    )
    stats = {
        "camera_rays": out["camera_rays"],
        "second_look_rays": out["second_look_rays"],
        "shadow_rays": out["shadow_rays"],
        "bounce_shadow_rays": out["bounce_shadow_rays"],
        "bounce_rays": out["bounce_rays"],
        "medium_rays": out["medium_rays"],
        "refined_pixels": out["refined_pixels"],
        "refinement_rays": out["refinement_rays"],
        "core_seconds": out["seconds"],
        "seconds": time.perf_counter() - start,
    }
    return RenderedView(rgb=out["rgb"], depth=out["depth"], instance=out["instance"], stats=stats)
