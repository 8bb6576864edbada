"""Bag placement: exact rigid poses, deterministic from the seed; every bag resting on the ground
or on the bags below (within a few mm), tilted with the local slope, never cutting into the
ground or another bag (exact mesh tests); hard cases (30° slope, a crater rim, too little room)
and clear errors. Settling itself is tested in test_settle.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.config.schema import BagsConfig, MeshesConfig, SettleConfig
from moonbot.scene.bag_mesh import variant_collision_points, variant_mesh
from moonbot.scene.collision import solids_intersect, surfaces_cross, transform
from moonbot.scene.placement import _plan_outline, arrange_bags, place_bags, polygons_apart, yaw_tilt_rotation
from moonbot.terrain.ground import CraterGround, FlatGround, SlopedGround

pytestmark = pytest.mark.unit

MESHES = {k: variant_mesh(MeshesConfig(), k) for k in (1, 3)}
COLLISION = {k: variant_collision_points(MeshesConfig(), k) for k in (1, 3)}  # as compose_scene settles them
VERTICES, TRIANGLES = MESHES[1][0].astype(np.float64), MESHES[1][1]
GEOMETRIC = SettleConfig(enabled=False)


def arrange(count, layout, ground, settle=GEOMETRIC, obj_id=1, seed=0, **kw):
    v, t = MESHES[obj_id]
    bags = BagsConfig(count=count, layout=layout, settle=settle, **kw)
    return arrange_bags(v, t, bags, ground, seed=seed, collision=COLLISION[obj_id]).poses


def hits_something(k, world, triangles, ground, ground_mesh):
    """Whether bag k (world vertices) meets the ground or another bag (exact tests)."""
    w = world[k]
    if surfaces_cross(w, triangles, *ground_mesh) or (w[:, 2] < ground.height(w[:, 0], w[:, 1])).any():
        return True
    return any(solids_intersect(w, triangles, other, triangles) for j, other in enumerate(world) if j != k)


def assert_valid(poses, ground, obj_id=1, max_gap=0.003):
    """Rigid poses; no bag meets the ground or another bag; and every bag is held: lowered by
    `max_gap` it would meet the ground or a bag, so it rests within that distance of a support."""
    v, t = MESHES[obj_id]
    gv, gt = ground.mesh()
    ground_mesh = (gv.astype(np.float64), gt)
    world = [transform(v, p) for p in poses]
    for p in poses:
        np.testing.assert_allclose(p[:3, :3] @ p[:3, :3].T, np.eye(3), atol=1e-9)
        assert np.linalg.det(p[:3, :3]) == pytest.approx(1.0, abs=1e-9)
        np.testing.assert_array_equal(p[3], [0, 0, 0, 1])
    for k in range(len(world)):
        assert not hits_something(k, world, t, ground, ground_mesh), f"bag {k + 1} overlaps"
        lowered = list(world)
        lowered[k] = world[k] - [0.0, 0.0, max_gap]
        assert hits_something(k, lowered, t, ground, ground_mesh), f"bag {k + 1} floats"


@pytest.mark.parametrize(
    ("layout", "count"),
    [("single", 1), ("scattered", 5), ("scattered", 11), ("stacked", 5), ("stacked", 8), ("stacked", 11)],
)
def test_geometric_rest_on_flat_ground(layout, count):
    ground = FlatGround()
    poses = arrange(count, layout, ground, seed=7)
    again = arrange(count, layout, ground, seed=7)
    for p, q in zip(poses, again):
        np.testing.assert_array_equal(p, q)
    np.testing.assert_allclose(poses[0][:2, 3], 0.0, atol=1e-12)  # the target at the origin
    assert_valid(poses, ground)
    if layout == "scattered":
        assert arrange(count, layout, ground, seed=8)[1][0, 3] != poses[1][0, 3]  # seed matters


def test_eleven_bags_make_a_five_four_two_wall_whose_upper_bags_sit_over_their_supports():
    poses = place_bags(VERTICES, TRIANGLES, 11, "stacked", seed=0, yaw_deg=35.0)
    heights = np.round([p[2, 3] for p in poses], 4)
    assert sorted(np.unique(heights, return_counts=True)[1].tolist(), reverse=True) == [5, 4, 2]
    half = (VERTICES.max(axis=0) - VERTICES.min(axis=0)) / 2
    for p in poses:
        below = [q for q in poses if q[2, 3] < p[2, 3] - 0.05 and q[2, 3] > p[2, 3] - 0.2]
        if p[2, 3] > 0.1:  # an upper bag's centre lies within its supports' span along the wall
            along = [np.linalg.solve(p[:2, :2], q[:2, 3] - p[:2, 3])[0] for q in below]
            assert min(along) - half[0] <= 0.0 <= max(along) + half[0]


def test_tilt_follows_the_slope():
    ground = SlopedGround(slope_deg=30.0, downhill_azimuth_deg=60.0)
    pose = place_bags(VERTICES, TRIANGLES, 1, "single", seed=0, ground=ground, yaw_deg=20.0)[0]
    _, normal = ground.plane()
    np.testing.assert_allclose(pose[:3, 2], normal, atol=1e-12)  # the bag's up axis is the normal
    np.testing.assert_allclose(
        yaw_tilt_rotation(0.3, (0.0, 0.0))[:2, :2],
        [[math.cos(0.3), -math.sin(0.3)], [math.sin(0.3), math.cos(0.3)]],
        atol=1e-15,
    )


@pytest.mark.parametrize("settle", [GEOMETRIC, SettleConfig()], ids=["geometric", "settled"])
@pytest.mark.parametrize(("layout", "count"), [("single", 1), ("scattered", 5), ("stacked", 5)])
def test_hard_case_a_30_degree_slope(settle, layout, count):
    ground = SlopedGround(slope_deg=30.0, downhill_azimuth_deg=90.0)
    poses = arrange(count, layout, ground, settle=settle, seed=1)
    assert_valid(poses, ground)
    _, normal = ground.plane()
    # Bags on the ground lie with it. A rigid bag with bulged faces also rolls downhill on its
    # bulge until its contact is below its centre of mass: up to ~4° across its 0.2 m width.
    for p in poses[:1] if layout == "stacked" else poses:
        assert math.degrees(math.acos(np.clip(p[:3, 2] @ normal, -1, 1))) < (1e-6 if settle is GEOMETRIC else 7.0)


@pytest.mark.parametrize("settle", [GEOMETRIC, SettleConfig()], ids=["geometric", "settled"])
@pytest.mark.parametrize("obj_id", [1, 3])
def test_hard_case_a_bag_across_a_crater_rim(settle, obj_id):
    """The target lies across the sharp rim crest of an 8 m crater (the slope jumps from 27° in
    to 12° out); it must touch the crest and cut into neither side."""
    ground = CraterGround(diameter_m=8.0, centre_distance_m=4.0, azimuth_deg=90.0, size_m=40.0)
    poses = arrange(3, "scattered", ground, settle=settle, obj_id=obj_id, scatter_radius_m=0.6)
    assert_valid(poses, ground, obj_id)
    crest = ground.height(0.0, 0.0)
    assert crest == pytest.approx(0.036 * 8.0)
    assert poses[0][2, 3] > crest  # resting on the crest, not sunk through it


def test_hard_case_eleven_bags_on_a_small_patch():
    """With little room the scattered layout is a clear error naming the field, never an
    overlap; where they just fit, none overlaps."""
    with pytest.raises(ValueError, match="^count: 11 bags do not fit within scatter_radius_m = 0.4"):
        place_bags(VERTICES, TRIANGLES, 11, "scattered", seed=0, radius_m=0.4, max_tries=3000)
    poses = arrange(11, "scattered", FlatGround(), scatter_radius_m=0.75, gap_m=0.0, seed=2)
    assert_valid(poses, FlatGround())


def test_plan_outlines_of_tilted_bags_keep_the_gap():
    ground = SlopedGround(slope_deg=30.0)
    poses = place_bags(VERTICES, TRIANGLES, 6, "scattered", seed=4, ground=ground, gap_m=0.05, radius_m=0.8)
    outlines = [_plan_outline(VERTICES, p) for p in poses]
    for i in range(len(outlines)):
        for j in range(i):
            assert polygons_apart(outlines[i], outlines[j], 0.05 - 1e-9)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert polygons_apart(square, square + [1.1, 0.0], 0.1 - 1e-9)
    assert not polygons_apart(square, square + [1.1, 0.0], 0.1 + 1e-9)
    assert not polygons_apart(square, square + [0.5, 0.5], 0.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"count": 2, "layout": "single"}, "count"),
        ({"count": 0, "layout": "stacked"}, "count"),
        ({"count": 30, "layout": "scattered", "radius_m": 0.3}, "count"),
        ({"count": 1, "layout": "pyramid"}, "layout"),
    ],
)
def test_impossible_layouts_are_clear_errors(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        place_bags(VERTICES, TRIANGLES, seed=0, max_tries=2000, **kwargs)
