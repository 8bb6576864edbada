"""Scene building and view rendering through `moonbot._core`."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from moonbot import _core
from moonbot.config.schema import Config
from moonbot.scene.compose import TERRAIN_MESH, SceneSpec
from moonbot.scene.orbit import CameraPose


@dataclass(frozen=True)
class RenderedView:
    """One rendered view. rgb (H, W, 3) float32 linear radiance W/(m²·sr); depth (H, W) float32
    z-depth in metres, 0 where nothing is hit; instance (H, W) uint8 labels, 0 = background.
    `stats` holds camera_rays, shadow_rays and the core's render seconds."""

    rgb: np.ndarray
    depth: np.ndarray
    instance: np.ndarray
    stats: dict


def build_scene(spec: SceneSpec) -> _core.Scene:
    """Builds the Embree scene once: one prototype BVH per mesh (bags of one obj_id share it,
    rocks of one prototype too), the terrain and rocks as background, each bag as a labelled
    instance; then commits."""
    scene = _core.Scene()
    mesh_index = {key: scene.add_mesh(v, t) for key, (v, t) in spec.meshes.items()}
    albedo = (spec.terrain_albedo,) * 3
    scene.add_background(mesh_index[TERRAIN_MESH], np.eye(4), albedo)
    for key, pose in spec.rocks:  # rocks are regolith-coloured background (label 0)
        scene.add_background(mesh_index[key], pose, albedo)
    for bag in spec.bags:
        scene.add_instance(mesh_index[bag.obj_id], bag.world_from_model, bag.instance_id, bag.albedo)
    scene.commit()
    return scene


def render_view(scene: _core.Scene, config: Config, K: np.ndarray, pose: CameraPose,
                seed: int) -> RenderedView:
    """Renders rgb, depth and instance passes of one view with the config's Sun and quality."""
    camera = _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], config.camera.width,
                          config.camera.height, pose.R, pose.t)
    sun = _core.Sun(config.sun.azimuth_deg, config.sun.elevation_deg, config.sun.irradiance_w_m2)
    start = time.perf_counter()
    out = _core.render(scene, camera, sun, spp=config.render.spp, seed=seed,
                       threads=config.render.threads, exact_depth=config.render.exact_depth)
    stats = {"camera_rays": out["camera_rays"], "shadow_rays": out["shadow_rays"],
             "core_seconds": out["seconds"], "seconds": time.perf_counter() - start}
    return RenderedView(rgb=out["rgb"], depth=out["depth"], instance=out["instance"], stats=stats)
