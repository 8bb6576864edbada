"""Turns a configuration into a `SceneSpec`: meshes, where each instance stands, its label and
material. Pure numpy; the render stage turns it into an Embree scene."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from moonbot.config.schema import Config
from moonbot.scene.bag_mesh import OBJ_IDS, variant_mesh
from moonbot.scene.placement import Placement, arrange_bags
from moonbot.scene.terrain import make_ground


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
    the world frame (metres); `placement` records how the bags were placed and settled."""

    meshes: dict[int, tuple[np.ndarray, np.ndarray]]
    terrain_albedo: float
    bags: tuple[BagInstance, ...]
    target: np.ndarray
    placement: Placement


TERRAIN_MESH = 0  # key of the terrain in SceneSpec.meshes; bags use their obj_id (≥ 1)


def compose_scene(config: Config) -> SceneSpec:
    """`bags.count` bags of the configured mesh variant on the configured ground, placed by
    `bags.layout` and settled (moonbot.scene.placement; deterministic from the dataset seed),
    instance ids 1..count, bag 1 the orbit target."""
    obj_id = OBJ_IDS[config.bags.mesh]
    vertices, triangles = variant_mesh(config.meshes, obj_id)
    ground = make_ground(config.terrain)
    ground_mesh = ground.mesh()
    placement = arrange_bags(vertices, triangles, config.bags, ground, ground_mesh, seed=config.seed)
    instances = tuple(BagInstance(obj_id=obj_id, instance_id=i + 1, world_from_model=pose,
                                  albedo=config.bags.albedo) for i, pose in enumerate(placement.poses))
    return SceneSpec(
        meshes={TERRAIN_MESH: ground_mesh, obj_id: (vertices, triangles)},
        terrain_albedo=config.terrain.albedo,
        bags=instances,
        target=placement.poses[0][:3, 3].copy(),
        placement=placement,
    )
