"""Turns a configuration into a `SceneSpec`: meshes, where each instance stands, its label and
material. Pure numpy; the render stage turns it into an Embree scene."""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

from moonbot.config.schema import Config, FabricConfig, PhotometryConfig, StainConfig
from moonbot.scene.bag_mesh import bag_collision, bag_model
from moonbot.scene.placement import Placement, arrange_bags
from moonbot.terrain import get_terrain
from moonbot.terrain.ground import Ground
from moonbot.terrain.location import DemSite, SubgridCraters, SubgridRelief
from moonbot.terrain.rocks import RockField, rock_poses


@dataclass(frozen=True)
class BagInstance:
    """One bag: `obj_id` is the BOP model id (mesh variant), `instance_id` the mask label (1..255),
    `world_from_model` (4, 4) float64 rigid transform in metres, `albedo` its cloth's mean
    linear RGB, `stain_seed` the seed its dirt stain is painted from."""

    obj_id: int
    instance_id: int
    world_from_model: np.ndarray
    albedo: tuple[float, float, float]
    stain_seed: int


@dataclass(frozen=True)
class SceneSpec:
    """Everything the renderer needs: `meshes` maps obj_id (and 0 for the terrain) to
    (vertices (N, 3) float32 metres, triangles (M, 3) int32); `target` is the orbit centre in
    the world frame (metres); `placement` records how the bags were placed and settled;
    `terrain_albedo` is regolith's normal albedo, varied per terrain vertex by
    `terrain_albedo_scale` ((N,) float32 or None), shaded with the smooth `terrain_normals`
    ((N, 3) float32 or None), shaped by `terrain_photometry`, and given back in its shading the
    roughness its graded mesh could not hold by `terrain_subgrid` and the small craters it could
    not draw by `terrain_craters` (None: none); `bag_uvs`
    (M, 3, 2) float32 are the bag mesh's corner UVs (its cloth's atlas, `bag_metres_per_uv`
    metres per unit), woven and stained as `fabric` and `stain` say, its albedo varied per vertex
    and channel by `bag_vertex_albedo` ((N, 3) float32, a user mesh's texture; None: uniform);
    `ground` is the terrain's height field (the camera keeps clear of it); `rocks` are
    (mesh key, world-from-model (4, 4) float64) background instances, scaled by diameter;
    `terrain_seconds` is what building the terrain cost this scene (0 when this process had it
    cached); `site` is where a `dem` location's world frame lies on the Moon (None elsewhere)."""

    meshes: dict[int, tuple[np.ndarray, np.ndarray]]
    terrain_albedo: float
    terrain_albedo_scale: np.ndarray | None
    terrain_normals: np.ndarray | None
    terrain_photometry: PhotometryConfig
    bag_uvs: np.ndarray
    bag_metres_per_uv: float
    fabric: FabricConfig
    stain: StainConfig
    bags: tuple[BagInstance, ...]
    target: np.ndarray
    placement: Placement
    ground: Ground
    rocks: tuple[tuple[int, np.ndarray], ...]
    terrain_seconds: float
    site: DemSite | None = None
    bag_vertex_albedo: np.ndarray | None = None
    terrain_subgrid: SubgridRelief | None = None
    terrain_craters: SubgridCraters | None = None


TERRAIN_MESH = 0  # key of the terrain in SceneSpec.meshes; bags use their obj_id (≥ 1)
ROCK_MESH_BASE = 1000  # rock prototype p is SceneSpec.meshes[ROCK_MESH_BASE + p]
ROCK_PLAN_RADIUS = math.sqrt(0.5)  # a rock's plan radius over its diameter (unit longest extent)


def clear_site(
    rocks: RockField, bag_poses: list[np.ndarray], bag_radius: float, orbit_radius: float, clearance: float
) -> RockField:
    """The rocks that neither touch a bag (plan discs of `bag_radius` around each bag centre,
    plus `clearance`, metres) nor stand on the camera's orbit circle around the target: the
    work site is cleared, and no camera sits inside a rock."""
    reach = ROCK_PLAN_RADIUS * rocks.diameters + clearance
    keep = np.ones(len(rocks), dtype=bool)
    for pose in bag_poses:
        keep &= np.hypot(*(rocks.centres - pose[:2, 3]).T) > bag_radius + reach
    from_target = np.hypot(*(rocks.centres - bag_poses[0][:2, 3]).T)
    keep &= np.abs(from_target - orbit_radius) > reach
    return rocks.subset(keep)


def stain_seed(dataset_seed: int, instance_id: int) -> int:
    """The seed a bag's dirt stain is painted from: a 64-bit hash of the dataset seed and the
    bag's instance id, so every bag of every sample is stained differently and reproducibly."""
    digest = hashlib.blake2b(f"moonbot.stain:{dataset_seed}:{instance_id}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little")


def place_bags(config: Config, ground: Ground) -> Placement:
    """The config's bags placed by `bags.layout` on `ground` (the terrain's) and, where
    `bags.settle.enabled`, settled against it (moonbot.scene.placement; deterministic from the
    dataset seed). Settling collides the mesh's convex shapes (bag_mesh.bag_collision: a variant's
    smooth hull, a user mesh's hull or convex parts), which a scene that does not settle never
    builds."""
    model = bag_model(config.meshes, config.bags.mesh)
    collision = bag_collision(config.meshes, config.bags.mesh) if config.bags.settle.enabled else None
    return arrange_bags(model.vertices, model.triangles, config.bags, ground, seed=config.seed, collision=collision)


def compose_scene(config: Config, placement: Placement | None = None) -> SceneSpec:
    """`bags.count` bags of the configured mesh (bags.mesh) on the configured ground, placed by
    `bags.layout` and settled (moonbot.scene.placement; deterministic from the dataset seed),
    instance ids 1..count, bag 1 the orbit target. A `placement` given (the same config's, made
    once for every task of its scene: moonbot.pipeline.placements) is used as it is."""
    model = bag_model(config.meshes, config.bags.mesh)
    obj_id, vertices, triangles = model.obj_id, model.vertices, model.triangles
    albedo = model.albedo if model.albedo is not None else config.bags.albedo
    terrain, cached = get_terrain(config.terrain)
    if placement is None:
        placement = place_bags(config, terrain.ground)
    elif len(placement.poses) != config.bags.count:
        raise ValueError(f"bags.count: {config.bags.count} bags, but the placement given has {len(placement.poses)}")
    instances = tuple(
        BagInstance(
            obj_id=obj_id,
            instance_id=i + 1,
            world_from_model=pose,
            albedo=albedo,
            stain_seed=stain_seed(config.seed, i + 1),
        )
        for i, pose in enumerate(placement.poses)
    )
    meshes = {TERRAIN_MESH: terrain.mesh, obj_id: (vertices, triangles)}
    rocks: tuple[tuple[int, np.ndarray], ...] = ()
    if terrain.rocks is not None and len(terrain.rocks):
        bag_radius = float(np.hypot(vertices[:, 0], vertices[:, 1]).max())
        field = clear_site(
            terrain.rocks, placement.poses, bag_radius, config.orbit.radius_m, config.terrain.rocks.clearance_m
        )
        poses = rock_poses(field, terrain.rock_meshes, terrain.ground.height)
        rocks = tuple((ROCK_MESH_BASE + int(p), pose) for p, pose in zip(field.prototype, poses))
        meshes.update({ROCK_MESH_BASE + p: m for p, m in enumerate(terrain.rock_meshes)})
    return SceneSpec(
        meshes=meshes,
        terrain_albedo=config.terrain.albedo,
        terrain_albedo_scale=terrain.albedo_scale,
        terrain_normals=terrain.normals,
        terrain_photometry=config.terrain.photometry,
        bag_uvs=model.corner_uvs,
        bag_metres_per_uv=model.metres_per_uv,
        fabric=config.bags.fabric,
        stain=config.bags.stain,
        bags=instances,
        target=placement.poses[0][:3, 3].copy(),
        placement=placement,
        ground=terrain.ground,
        rocks=rocks,
        terrain_seconds=0.0 if cached else terrain.build_seconds,
        site=terrain.site,
        bag_vertex_albedo=model.vertex_albedo,
        terrain_subgrid=terrain.subgrid,
        terrain_craters=terrain.craters,
    )
