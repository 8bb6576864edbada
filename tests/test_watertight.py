"""Rays through the edges and vertices that two or more triangles share must hit one of them.
Without watertight traversal a ray passing within ~1e-10 to 1e-6 m of a shared edge can slip
between both triangles: holes in the depth ground truth, and bag pixels that report the bag's
back face. Each ray here is aimed at a point exactly on a shared edge (its midpoint, and points at
a quarter and three quarters) or at a shared vertex, from a viewpoint above the surface; the
direction is that point minus the origin, so the ray reaches it at t = 1. A ray may meet nearer
relief first (t < 1), never nothing, and never something behind the surface (t > 1)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import load_config
from moonbot.eval.validate import depth_holes
from moonbot.render.view import build_scene
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.scene.bag_mesh import variant_meshes
from moonbot.scene.orbit import orbit_height
from moonbot.terrain.build import get_terrain

pytestmark = pytest.mark.unit

# Embree's t is float32 along a direction of length ~|point − origin|: a few ulps of 1, divided
# by the sine of the ray's angle to the surface, which the rays here keep above GRAZING_SIN.
T_SLACK = 1e-4
GRAZING_SIN = np.sin(np.radians(10.0))


@dataclasses.dataclass(frozen=True)
class Targets:
    """World points exactly on shared edges and at shared vertices of a mesh: `points` (P, 3)
    float64, and `incident` (Q, 2): (point index, triangle index) for every triangle the point
    lies on, with the triangles' world unit normals `normals` (M, 3)."""

    points: np.ndarray
    incident: np.ndarray
    normals: np.ndarray


def shared_edge_targets(
    vertices: np.ndarray, triangles: np.ndarray, world: np.ndarray, near: np.ndarray, radius: float, limit: int
) -> Targets:
    """Points on the edges that two or more triangles bound (at 1/4, 1/2 and 3/4 along them) and at
    the vertices that two or more triangles share, of a mesh placed by `world` (4, 4), within
    `radius` metres (plan distance) of `near`; at most `limit` edges and `limit` vertices, spread
    over the mesh by a fixed stride (deterministic)."""
    v = vertices.astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    n = np.cross(v[triangles[:, 1]] - v[triangles[:, 0]], v[triangles[:, 2]] - v[triangles[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    m = len(triangles)
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    edge_triangle = np.tile(np.arange(m), 3)
    unique, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    mid = (v[unique[:, 0]] + v[unique[:, 1]]) / 2
    chosen = np.flatnonzero((counts >= 2) & (np.linalg.norm(mid[:, :2] - near[:2], axis=1) < radius))
    chosen = chosen[:: max(1, len(chosen) // limit)]
    slot = np.full(len(unique), -1)
    slot[chosen] = np.arange(len(chosen))
    points, incident = [], []
    for k, f in enumerate((0.25, 0.5, 0.75)):
        a, b = v[unique[chosen, 0]], v[unique[chosen, 1]]
        points.append(a + f * (b - a))
        on = slot[inverse] >= 0
        incident.append(np.column_stack([slot[inverse[on]] + k * len(chosen), edge_triangle[on]]))
    base = 3 * len(chosen)
    corner_count = np.bincount(triangles.ravel(), minlength=len(v))
    corners = np.flatnonzero((corner_count >= 2) & (np.linalg.norm(v[:, :2] - near[:2], axis=1) < radius))
    corners = corners[:: max(1, len(corners) // limit)]
    cslot = np.full(len(v), -1)
    cslot[corners] = np.arange(len(corners))
    points.append(v[corners])
    corner_of = cslot[triangles.ravel()]
    on = corner_of >= 0
    incident.append(np.column_stack([corner_of[on] + base, np.repeat(np.arange(m), 3)[on]]))
    return Targets(np.concatenate(points), np.concatenate(incident), n)


def leaks(scene: _core.Scene, origins: np.ndarray, targets: Targets) -> dict:
    """Rays from `origins` (P, 3) through the target points, those that meet every triangle the
    point lies on from its front at more than 10 degrees (so the ray enters the surface there,
    rather than grazing it or skimming a silhouette edge): how many miss, and how many first hit
    something behind their point (t > 1: through the surface)."""
    directions = targets.points - origins
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    point, triangle = targets.incident[:, 0], targets.incident[:, 1]
    facing = np.full(len(origins), -1.0)  # the largest cosine of the ray to an incident normal
    np.maximum.at(facing, point, np.sum(unit[point] * targets.normals[triangle], axis=1))
    fair = facing < -GRAZING_SIN
    t, instance, _ = scene.intersect(origins[fair], directions[fair])
    return {
        "rays": int(fair.sum()),
        "missed": int(np.sum(instance < 0)),
        "behind": int(np.sum(t[instance >= 0] > 1 + T_SLACK)),
    }


@pytest.mark.parametrize("location", ["flat", "hilly", "crater", "plane", "slope"])
def test_rays_through_shared_terrain_edges_and_vertices_hit(location):
    config = load_config(None, {"terrain.location": location, "terrain.extent_m": 60.0, "terrain.slope_deg": 30.0})
    terrain, _ = get_terrain(config.terrain)
    vertices, triangles = terrain.mesh
    scene = _core.Scene()
    scene.add_background(scene.add_mesh(vertices, triangles), np.eye(4), (0.12,) * 3)
    scene.commit()
    # The fine tile around the bags, and the coarser grid out to 20 m.
    for radius in (1.0, 20.0):  # the fine tile around the bags, and the coarser grid out to 20 m
        targets = shared_edge_targets(vertices, triangles, np.eye(4), np.zeros(3), radius, 20000)
        # From a camera-like height above each point, looking down at 30-60 degrees.
        rng = np.random.default_rng(0)
        count = len(targets.points)
        azimuth = rng.uniform(0, 2 * np.pi, count)
        reach = rng.uniform(0.6, 1.7, count)
        origins = targets.points + np.column_stack([reach * np.cos(azimuth), reach * np.sin(azimuth), np.ones(count)])
        result = leaks(scene, origins, targets)
        # The analytic grounds' grid is 0.25 m at the origin, doubling outward: few vertices.
        assert result["rays"] > (100 if location in ("plane", "slope") else 20000)
        assert result["missed"] == 0 and result["behind"] == 0, (radius, result)


@pytest.mark.parametrize("obj_id", [1, 2, 3])
def test_rays_through_shared_bag_edges_and_vertices_hit(obj_id):
    vertices, triangles = variant_meshes(load_config(None).meshes)[obj_id]
    world = np.eye(4)
    world[:3, :3] = _rotation(0.3, 0.2, 1.1)
    world[:3, 3] = (0.4, -0.2, 0.15)
    scene = _core.Scene()
    scene.add_instance(scene.add_mesh(vertices, triangles), world, 1, (0.5,) * 3)
    scene.commit()
    targets = shared_edge_targets(vertices, triangles, world, world[:3, 3], 10.0, 100000)
    # From outside, 2 m along the outward direction from the bag's centre plus a tilt, so each
    # point is on the side facing its ray.
    rng = np.random.default_rng(1)
    out = targets.points - world[:3, 3]
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    origins = targets.points + 2.0 * (out + 0.3 * rng.normal(size=out.shape))
    result = leaks(scene, origins, targets)
    assert result["rays"] > 3000
    assert result["missed"] == 0 and result["behind"] == 0, result


def _rotation(a: float, b: float, c: float) -> np.ndarray:
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_the_default_view_at_4096x3072_has_no_depth_holes():
    """The embedded default view at 4096×3072 (its 12.6 M pixel-centre rays cross the 1 cm terrain
    grid near its vertices thousands of times): every ray below the horizon has a depth. Embree's
    default traversal left 36 holes here and 4 bag pixels reporting the bag's far side."""
    config = load_config(None, {"camera.width": 4096, "camera.height": 3072})
    spec = compose_scene(config)
    azimuth = config.orbit.start_azimuth_deg
    height = orbit_height(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth, spec.ground)
    pose = orbit_pose(spec.target, config.orbit.radius_m, height, azimuth)
    K = intrinsics(config.camera)
    camera = _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], 4096, 3072, pose.R, pose.t)
    out = _core.render(build_scene(spec), camera, _core.DirectionalLight(0.0, 30.0, 0.0), passes=["depth", "instance"])
    assert not depth_holes(out["depth"], K, pose.R).any()
    bag = out["instance"] > 0
    assert bag.sum() > 100000
    # Against the bag alone in a scene of its own (another BVH): where the full scene sees the
    # bag, both give its near surface; a ray that slipped inside would report its far side.
    (placed,) = spec.bags
    alone = _core.Scene()
    alone.add_instance(alone.add_mesh(*spec.meshes[placed.obj_id]), placed.world_from_model, 1, (0.5,) * 3)
    alone.commit()
    solo = _core.render(alone, camera, _core.DirectionalLight(0.0, 30.0, 0.0), passes=["depth"])["depth"]
    assert (solo[bag] > 0).all()
    assert np.abs(out["depth"][bag] - solo[bag]).max() < 1e-5


@pytest.mark.parametrize("location", ["flat", "hilly"])
def test_a_36_view_orbit_around_five_bags_has_no_depth_holes(location):
    """Every view of the orbit at 640×480 around five scattered bags: no pixel below the horizon
    without depth (Embree's default traversal left 36 on flat and 29 on hilly)."""
    config = load_config(
        None,
        {
            "terrain.location": location,
            "bags.count": 5,
            "bags.layout": "scattered",
            "camera.width": 640,
            "camera.height": 480,
        },
    )
    spec = compose_scene(config)
    scene = build_scene(spec)
    K = intrinsics(config.camera)
    holes = 0
    for view in range(config.orbit.views):
        azimuth = config.orbit.start_azimuth_deg + view * config.orbit.step_deg
        height = orbit_height(spec.target, config.orbit.radius_m, config.orbit.height_m, azimuth, spec.ground)
        pose = orbit_pose(spec.target, config.orbit.radius_m, height, azimuth)
        camera = _core.Camera(K[0, 0], K[1, 1], K[0, 2], K[1, 2], 640, 480, pose.R, pose.t)
        out = _core.render(scene, camera, _core.DirectionalLight(0.0, 30.0, 0.0), passes=["depth", "instance"])
        holes += int(depth_holes(out["depth"], K, pose.R).sum())
    assert config.orbit.views == 36 and holes == 0


def test_intersect_names_bad_input():
    scene = _core.Scene()
    scene.add_background(scene.add_mesh(np.eye(3, dtype=np.float32), [[0, 1, 2]]), np.eye(4), (0.1,) * 3)
    with pytest.raises(Exception, match="not committed"):
        scene.intersect(np.zeros((1, 3)), np.ones((1, 3)))
    scene.commit()
    with pytest.raises(ValueError, match="directions"):
        scene.intersect(np.zeros((2, 3)), np.ones((1, 3)))
    with pytest.raises(ValueError, match="origins"):
        scene.intersect(np.zeros((2, 2)), np.ones((2, 3)))
