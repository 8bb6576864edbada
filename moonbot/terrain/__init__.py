"""The terrain stage: grounds (analytic and gridded), procedural lunar locations reaching the
horizon, fractal roughness, craters, and a per-process cache of built terrains."""

from moonbot.terrain.build import Terrain, clear_cache, get_terrain, make_ground, terrain_key, warm

__all__ = ["Terrain", "clear_cache", "get_terrain", "make_ground", "terrain_key", "warm"]
