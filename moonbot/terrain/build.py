"""The terrain a config asks for, built once per process and reused.

Building a location samples millions of nodes (seconds); every task of a sweep on one worker
uses the same terrain config, so the built terrain is kept in a small per-process cache keyed
by the SHA-256 of the terrain config (every field, defaults filled in). A second task on the
same worker process gets the same object back without building (bench/bench_terrain.py
measures both).
"""

from __future__ import annotations

import hashlib
import os
import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from moonbot.config.load import config_hash
from moonbot.config.schema import TerrainConfig
from moonbot.terrain.albedo import albedo_factor
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.ground import FlatGround, Ground, SlopedGround
from moonbot.terrain.location import (
    LOCATIONS,
    DemSite,
    SubgridCraters,
    SubgridRelief,
    build_location,
    dem_site,
    main_crater,
    subgrid_craters,
    subgrid_relief,
)
from moonbot.terrain.rocks import RockField, rock_prototypes, sample_rocks

CACHE_SIZE = 2  # terrains kept per process: a location's mesh and ground take ~100 MB


@dataclass(frozen=True)
class Terrain:
    """A built terrain: the `ground` (heights for placement and physics), its `mesh`
    ((N, 3) float32 metres, (M, 3) int32) for the renderer with `albedo_scale` ((N,) float32
    factors on the regolith albedo per vertex) and smooth shading `normals` ((N, 3) float32),
    both None for the analytic grounds, its `rocks`
    (positions and sizes; scenes drop those in the way of bags or camera) with the
    `rock_meshes` they instance, the config `key` it was built from and the wall-clock
    `build_seconds` it took. `site` says where a `dem` location's world frame lies on the Moon
    (None for the other locations, which are nowhere in particular). `subgrid` is the roughness
    its mesh could not hold, for the shading (None for the analytic grounds, or when
    terrain.roughness.subgrid_shading is off), `craters` the small craters it could not draw
    (None for the analytic grounds, or when terrain.craters.subgrid_shading is off)."""

    ground: Ground
    mesh: tuple[np.ndarray, np.ndarray]
    albedo_scale: np.ndarray | None
    normals: np.ndarray | None
    rocks: RockField | None
    rock_meshes: list[tuple[np.ndarray, np.ndarray]]
    key: str
    build_seconds: float
    site: DemSite | None = None
    subgrid: SubgridRelief | None = None
    craters: SubgridCraters | None = None


_cache: OrderedDict[str, Terrain] = OrderedDict()
_capacity = 0  # raised by warm() above CACHE_SIZE for a sweep's locations


def terrain_key(config: TerrainConfig) -> str:
    """SHA-256 of the canonical JSON of a terrain config; for a `dem` location also of the DEM
    file's size and modification time, so a re-imported file is rebuilt (a stat per task, not a
    read of the whole file)."""
    key = config_hash(config)
    if config.location != "dem":
        return key
    try:
        stat = os.stat(config.dem_file)
    except OSError as e:
        raise OSError(f"terrain.dem_file: {config.dem_file}: cannot read ({e.strerror or e})") from None
    return hashlib.sha256(f"{key}:{stat.st_size}:{stat.st_mtime_ns}".encode()).hexdigest()


def make_ground(config: TerrainConfig, dem: LocalDem | None = None) -> Ground:
    """The ground a terrain config describes (built, not cached); `dem` is the `dem` location's
    DEM when the caller has read it already."""
    if config.location == "plane":
        return FlatGround(size_m=2.0 * config.extent_m)
    if config.location == "slope":
        return SlopedGround(config.slope_deg, config.slope_azimuth_deg, size_m=2.0 * config.extent_m)
    if config.location == "dem":
        return build_location(config, dem if dem is not None else LocalDem.load(config.dem_file))
    if config.location in LOCATIONS:
        return build_location(config)
    raise ValueError(f"terrain.location: unknown location {config.location!r}")


def get_terrain(config: TerrainConfig) -> tuple[Terrain, bool]:
    """(the terrain of `config`, whether it came from this process's cache)."""
    key = terrain_key(config)
    if key in _cache:
        _cache.move_to_end(key)
        return _cache[key], True
    start = time.perf_counter()
    dem = LocalDem.load(config.dem_file) if config.location == "dem" else None
    ground = make_ground(config, dem)
    mesh = ground.mesh()
    rocks, rock_meshes, albedo_scale, normals, subgrid, craters = None, [], None, None, None, None
    if config.location in LOCATIONS:
        rocks = sample_rocks(config.seed, config.rocks, main_crater(config))
        rock_meshes = rock_prototypes(config.seed)
        albedo_scale = albedo_factor(config, mesh[0][:, 0], mesh[0][:, 1])
        normals = ground.vertex_normals()
        subgrid = subgrid_relief(config, dem)
        craters = subgrid_craters(config, dem)
    per_vertex = [a for a in (albedo_scale, normals) if a is not None]
    subgrid_arrays = [
        a for s in (subgrid, craters) if s is not None for a in vars(s).values() if isinstance(a, np.ndarray)
    ]
    for array in (*mesh, *(a for m in rock_meshes for a in m), *per_vertex, *subgrid_arrays):
        array.setflags(write=False)  # shared by every task of this process: nobody may edit it
    terrain = Terrain(
        ground=ground,
        mesh=mesh,
        albedo_scale=albedo_scale,
        normals=normals,
        rocks=rocks,
        rock_meshes=rock_meshes,
        key=key,
        build_seconds=time.perf_counter() - start,
        site=dem_site(config, dem) if dem is not None else None,
        subgrid=subgrid,
        craters=craters,
    )
    _cache[key] = terrain
    while len(_cache) > max(CACHE_SIZE, _capacity):
        _cache.popitem(last=False)
    return terrain, False


def warm(configs: list[TerrainConfig]) -> float:
    """Builds the terrains of `configs` into this process's cache and keeps room for all of them
    (a worker of a sweep over three locations then builds each once, however its tasks alternate).
    Returns the seconds spent building."""
    global _capacity
    _capacity = max(_capacity, len({terrain_key(c) for c in configs}))
    return sum(terrain.build_seconds for terrain, cached in map(get_terrain, configs) if not cached)


def clear_cache() -> None:
    """Forgets every cached terrain (benchmarks measure cold builds with it)."""
    _cache.clear()
