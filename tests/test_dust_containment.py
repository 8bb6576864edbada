"""Ejecta never tunnel (moonbot/dust.h): through a whole capture sequence — every 20 ms across
four bursts — no fragment's centre is ever under the ground or inside a bag or a rock, on every
location (flat, hilly, crater, the analytic plane and slope) and around the 11-bag stacked wall,
at the default launch and at ten times its speed stepping 0.1 s; at launch every vertex of every
fragment's mesh is clear of them; no fragment ever has to be put back out of a solid in these
scenes; and every fragment of a burst is returned, none dropped.

The checks use the scene's own meshes (the very triangles given to Embree), and nothing of the
core: a vertical line through a point meets a triangle where the point's barycentrics in the
triangle's plan are all ≥ 0, at the height they interpolate, in float64 from the float32
vertices. The ground's height at a point is the highest such crossing of the terrain mesh (a
height field: one crossing, two on a shared edge, at the same height); a point is inside a closed
mesh when the line crosses it an odd number of times above the point — and also below it, or the
line grazed an edge and trimesh's own `contains` decides."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import trimesh

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene
from moonbot.render.dust import capture_time, dust_seed, ejecta_state, emitter_origin
from moonbot.scene import compose_scene
from moonbot.scene.compose import TERRAIN_MESH

pytestmark = pytest.mark.unit

# A 3 m terrain square (its 2 m fine tile whole) keeps each scene's build near a second; the
# default fragments land within a metre of the emitter.
SMALL = {"dust.enabled": True, "terrain.extent_m": 3.0}
SCENES = {
    "flat": {},
    "hilly": {"terrain.location": "hilly"},
    "crater": {"terrain.location": "crater"},
    "plane": {"terrain.location": "plane"},
    "slope": {"terrain.location": "slope"},
    "wall": {"bags.count": 11, "bags.layout": "stacked"},
}
# The capture sequence, sampled: every 20 ms through bursts 0-3 (view v of the orbit is captured
# at warmup + v × interval, 6 s on, in burst 3).
TIMES = np.arange(0.0, 8.0, 0.02)
FAST = {"dust.ejecta.mean_speed_m_s": 5.0, "dust.time_step_s": 0.1}  # 1.25-3.75 m/s, the largest step


class VerticalLines:
    """Where vertical lines meet a triangle mesh. `vertices` (V, 3) and `triangles` (T, 3) in the
    world frame, metres; triangles are binned by their plan's bounding box on a square grid of
    about their median size, and each line tests the triangles of its cell."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray):
        self.corners = np.asarray(vertices, np.float64)[np.asarray(triangles)]  # (T, 3, 3)

    def crossings(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every crossing of the vertical lines through `xy` ((N, 2) metres): (line index (K,),
        height (K,) metres), a line through a shared edge or vertex once per triangle."""
        lo, hi = xy.min(0), xy.max(0)
        plan = self.corners[:, :, :2]
        low, high = plan.min(1), plan.max(1)
        near = np.flatnonzero(np.all(high >= lo, 1) & np.all(low <= hi, 1))
        if len(near) == 0 or len(xy) == 0:
            return np.zeros(0, np.int64), np.zeros(0)
        cell = max(float(np.median(high[near] - low[near])), 1e-6)
        first = np.floor((low[near] - lo) / cell).astype(np.int64)
        last = np.floor((high[near] - lo) / cell).astype(np.int64)
        columns = int(np.floor((hi - lo) / cell).max()) + 1
        span = last - first + 1
        cells = span[:, 0] * span[:, 1]
        owner = np.repeat(np.arange(len(near)), cells)
        k = np.arange(cells.sum()) - np.repeat(np.cumsum(cells) - cells, cells)
        key = (first[owner, 0] + k % span[owner, 0]) * columns + first[owner, 1] + k // span[owner, 0]
        order = np.argsort(key, kind="stable")
        key, owner = key[order], near[owner[order]]
        q = np.floor((xy - lo) / cell).astype(np.int64)
        q_key = q[:, 0] * columns + q[:, 1]
        start, stop = np.searchsorted(key, q_key, "left"), np.searchsorted(key, q_key, "right")
        count = stop - start
        line = np.repeat(np.arange(len(xy)), count)
        tri = owner[np.repeat(start, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)]
        a, b, c = (self.corners[tri, i] for i in range(3))
        p = xy[line]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            u = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1])) / det
            v = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (p[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1)
        z = a[:, 2] + u * (b[:, 2] - a[:, 2]) + v * (c[:, 2] - a[:, 2])
        return line[hit], z[hit]

    def height(self, xy: np.ndarray) -> np.ndarray:
        """The highest crossing of each line, (N,) metres; NaN off the mesh."""
        line, z = self.crossings(xy)
        top = np.full(len(xy), -np.inf)
        np.maximum.at(top, line, z)
        return np.where(np.isfinite(top), top, np.nan)


class Solid:
    """A closed, outward-facing mesh placed in the world (a bag or a rock)."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray, world_from_model: np.ndarray):
        v = np.asarray(vertices, np.float64)
        self.vertices = v @ world_from_model[:3, :3].T + world_from_model[:3, 3]
        self.triangles = np.asarray(triangles)
        self.bounds = self.vertices.min(0), self.vertices.max(0)
        self._mesh: trimesh.Trimesh | None = None

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: which of `points` ((N, 3) metres) are strictly inside."""
        inside = np.zeros(len(points), bool)
        lo, hi = self.bounds
        idx = np.flatnonzero(np.all((points > lo) & (points < hi), 1))
        if len(idx) == 0:
            return inside
        if self._mesh is None:  # built for the solids a point comes near
            self._mesh = trimesh.Trimesh(self.vertices, self.triangles, process=False)
            assert self._mesh.is_watertight and self._mesh.volume > 0  # closed, normals out
            self._lines = VerticalLines(self.vertices, self.triangles)
        line, z = self._lines.crossings(points[idx, :2])
        above = np.bincount(line, z > points[idx, 2][line], len(idx)).astype(int) % 2
        below = np.bincount(line, z < points[idx, 2][line], len(idx)).astype(int) % 2
        inside[idx] = above == 1
        grazed = idx[above != below]  # the line met a shared edge or vertex: counted twice
        if len(grazed):
            inside[grazed] = self._mesh.contains(points[grazed])
        return inside


def inside_any(solids: list[Solid], points: np.ndarray) -> np.ndarray:
    """(N,) bool: which of `points` ((N, 3) metres) are inside any of `solids`. Points are sorted
    by x once, so each solid looks only at those within its x range."""
    order = np.argsort(points[:, 0], kind="stable")
    xs = points[order, 0]
    inside = np.zeros(len(points), bool)
    for solid in solids:
        lo, hi = solid.bounds
        near = order[np.searchsorted(xs, lo[0], "right") : np.searchsorted(xs, hi[0], "left")]
        if len(near):
            inside[near] |= solid.contains(points[near])
    return inside


@functools.cache
def built(name: str):
    """Scene `name` built once for every test here: its spec and Embree scene, its ground and its
    solids (bags first, then rocks). Dust settings do not change the scene."""
    spec = compose_scene(load_config(None, {**SMALL, **SCENES[name]}))
    ground = VerticalLines(*spec.meshes[TERRAIN_MESH])
    solids = [Solid(*spec.meshes[bag.obj_id], bag.world_from_model) for bag in spec.bags]
    solids += [Solid(*spec.meshes[key], pose) for key, pose in spec.rocks]
    return spec, build_scene(spec), ground, solids


def scene_of(name: str, **overrides):
    """The config of scene `name` with `overrides`, and the scene built (see `built`)."""
    return (load_config(None, {**SMALL, **SCENES[name], **overrides}), *built(name))


def sequence(config, spec, scene, times=TIMES) -> list[dict]:
    """The ejecta states at `times` (seconds after the emitter starts), as the pipeline makes them."""
    origin = emitter_origin(spec, config.dust)
    seed = dust_seed(config.seed)
    return [ejecta_state(scene, config.dust, seed, origin, float(t)) for t in times]


def assert_never_under_or_inside(states, ground: VerticalLines, solids: list[Solid], count: int) -> None:
    """Every state holds all `count` fragments, finite, none with its centre on or under the
    terrain mesh (where there is terrain) nor inside a solid, none ever put back out of one."""
    centres = np.stack([s["position"] for s in states])  # (T, N, 3)
    assert centres.shape == (len(states), count, 3) and np.isfinite(centres).all()  # none dropped
    points = centres.reshape(-1, 3)
    height = ground.height(points[:, :2])
    on_terrain = ~np.isnan(height)  # a fast fragment can fly off the 3 m square
    assert on_terrain.mean() > 0.5
    under = np.flatnonzero(on_terrain & (points[:, 2] <= np.where(on_terrain, height, 0.0)))
    assert len(under) == 0, f"{len(under)} samples under the ground, first {points[under[:3]]}"
    inside = np.flatnonzero(inside_any(solids, points))
    assert len(inside) == 0, f"{len(inside)} samples inside a bag or rock, first {points[inside[:3]]}"
    assert all(int(s["corrections"].max(initial=0)) == 0 for s in states)  # never behind a surface


@pytest.mark.parametrize("name", list(SCENES))
def test_fragments_never_under_the_ground_nor_inside_a_bag_or_rock(name):
    config, spec, scene, ground, solids = scene_of(name)
    assert len(spec.bags) == (11 if name == "wall" else 1)
    states = sequence(config, spec, scene)
    assert_never_under_or_inside(states, ground, solids, config.dust.ejecta.count)
    # The sequence is a real one: fragments bounce, and by the end of a burst nearly all rest.
    assert np.mean([s["bounces"].max() for s in states]) > 1 and states[-1]["resting"].mean() > 0.9


@pytest.mark.parametrize("name", ["wall", "crater"])
def test_fast_fragments_do_not_cross_bag_walls_or_rocks(name):
    """Ten times the launch speed at the largest step: a step carries a fragment up to 0.4 m,
    through a bag or a rock many times over, unless the step's chord finds the wall."""
    config, spec, scene, ground, solids = scene_of(name, **FAST)
    states = sequence(config, spec, scene, TIMES[::2])
    assert_never_under_or_inside(states, ground, solids, config.dust.ejecta.count)
    assert max(np.linalg.norm(s["velocity"], axis=1).max() for s in states) > 3.0


@pytest.mark.parametrize("name", list(SCENES))
def test_every_fragment_starts_clear_of_the_ground_and_bags(name):
    """At launch, with its mesh in its launch orientation, every vertex of every fragment lies
    above the terrain mesh (by at least half the spawn clearance) and outside every bag and
    rock."""
    config, spec, scene, ground, solids = scene_of(name)
    for t in (0.0, 2.0, 4.0):  # three bursts' launches
        state = ejecta_state(scene, config.dust, dust_seed(config.seed), emitter_origin(spec, config.dust), t)
        vertices = state["vertices"].astype(np.float64)
        gap = vertices[:, 2] - ground.height(vertices[:, :2])
        assert gap.min() >= 0.5 * _core.SPAWN_CLEARANCE, gap.min()
        assert not inside_any(solids, vertices).any()
        radius = state["diameter"] / 2
        lowest = state["position"][:, 2] - radius
        # Embree's float32 distances along the launch probes (robust traversal): the height
        # under it is known to ~1e-7 m.
        above_ground = lowest - ground.height(state["position"][:, :2])
        assert np.all(above_ground >= _core.SPAWN_CLEARANCE - 5e-7)
        if name == "wall":  # the emitter's disc reaches under the wall: those start on a bag's top
            assert (above_ground > 0.03).sum() > 20


def test_same_bytes_on_one_and_two_threads_around_the_wall():
    config, spec, scene, _, _ = scene_of("wall")
    seed, origin = dust_seed(config.seed), emitter_origin(spec, config.dust)
    for t in (0.0, 0.731, capture_time(config.dust, 5)):
        one = ejecta_state(scene, config.dust, seed, origin, t, threads=1)
        two = ejecta_state(scene, config.dust, seed, origin, t, threads=2)
        assert all(one[key].tobytes() == two[key].tobytes() for key in one)
