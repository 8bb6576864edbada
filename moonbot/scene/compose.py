"""Turns a configuration into a `SceneSpec`: meshes, where each instance stands, its label and
material. Pure numpy; the render stage turns it into an Embree scene."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from moonbot.config.schema import Config
from moonbot.scene.bag_mesh import OBJ_IDS, variant_mesh
from moonbot.scene.terrain import flat_patch


@dataclass(frozen=True)
class BagInstance:
    """One bag: `obj_id` is the BOP model id (mesh variant), `instance_id` the mask label (1..255),
    `world_from_model` (4, 4) float64 rigid transform in metres."""

    obj_id: int
    instance_id: int
    world_from_model: np.ndarray
    albedo: tuple[float, float, float]


@dataclass(frozen=True)
class SceneSpec:
    """Everything the renderer needs: `meshes` maps obj_id (and 0 for the terrain) to
    (vertices (N, 3) float32 metres, triangles (M, 3) int32); `target` is the orbit centre in
    the world frame (metres)."""

    meshes: dict[int, tuple[np.ndarray, np.ndarray]]
    terrain_albedo: float
    bags: tuple[BagInstance, ...]
    target: np.ndarray


TERRAIN_MESH = 0  # key of the terrain in SceneSpec.meshes; bags use their obj_id (≥ 1)


def compose_scene(config: Config) -> SceneSpec:
    """One bag of the configured mesh variant resting flat on a flat patch (its lowest point on
    z = 0), yawed by `bags.yaw_deg`, its centre above the world origin. Deterministic: no
    randomness is involved yet (placement of several bags is the bags issue's next piece)."""
    obj_id = OBJ_IDS[config.bags.mesh]
    vertices, triangles = variant_mesh(config.meshes, obj_id)
    yaw = math.radians(config.bags.yaw_deg)
    c, s = math.cos(yaw), math.sin(yaw)
    world_from_model = np.array([[c, -s, 0.0, 0.0],
                                 [s, c, 0.0, 0.0],
                                 [0.0, 0.0, 1.0, -float(vertices[:, 2].min())],  # resting on z = 0
                                 [0.0, 0.0, 0.0, 1.0]])
    target = BagInstance(obj_id=obj_id, instance_id=1, world_from_model=world_from_model,
                         albedo=config.bags.albedo)
    return SceneSpec(
        meshes={TERRAIN_MESH: flat_patch(config.terrain.size_m), obj_id: (vertices, triangles)},
        terrain_albedo=config.terrain.albedo,
        bags=(target,),
        target=world_from_model[:3, 3].copy(),
    )
