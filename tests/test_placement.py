"""Bag placement on flat ground: exact rigid poses, resting on the ground or on the bag below,
no two bags overlapping, deterministic from the seed, and clear errors when bags do not fit."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot.scene.bag_mesh import filled_cuboid, folded_cuboid
from moonbot.scene.placement import _footprint, _rectangles_apart, place_bags

VERTICES = filled_cuboid()[0].astype(np.float64)


def world_vertices(pose):
    return VERTICES @ pose[:3, :3].T + pose[:3, 3]


@pytest.mark.parametrize(("layout", "count"), [("single", 1), ("scattered", 5), ("scattered", 11),
                                               ("stacked", 5), ("stacked", 8), ("stacked", 11)])
def test_poses_are_rigid_deterministic_and_the_target_is_first_at_the_origin(layout, count):
    poses = place_bags(VERTICES, count, layout, seed=7, yaw_deg=20.0)
    again = place_bags(VERTICES, count, layout, seed=7, yaw_deg=20.0)
    assert len(poses) == count
    for p, q in zip(poses, again):
        np.testing.assert_array_equal(p, q)
        np.testing.assert_allclose(p[:3, :3] @ p[:3, :3].T, np.eye(3), atol=1e-9)
        assert np.linalg.det(p[:3, :3]) == pytest.approx(1.0, abs=1e-9)
        np.testing.assert_array_equal(p[3], [0, 0, 0, 1])
    np.testing.assert_allclose(poses[0][:2, 3], 0.0, atol=1e-12)


@pytest.mark.parametrize("count", [2, 5, 11])
def test_scattered_bags_stand_apart_on_the_ground(count):
    poses = place_bags(VERTICES, count, "scattered", seed=3, gap_m=0.02, radius_m=1.0)
    half = (VERTICES.max(axis=0) - VERTICES.min(axis=0)) / 2
    for i, p in enumerate(poses):
        assert world_vertices(p)[:, 2].min() == pytest.approx(0.0, abs=1e-9)  # touches, not sunk
        assert np.hypot(*p[:2, 3]) <= 1.0 + 1e-12
        for q in poses[:i]:
            assert _rectangles_apart(_footprint(p, half), _footprint(q, half), 0.02 - 1e-9)
    assert place_bags(VERTICES, count, "scattered", seed=4)[1][0, 3] != poses[1][0, 3]  # seed matters


@pytest.mark.parametrize("count", [2, 5, 8, 11])
def test_stacked_bags_rest_on_the_ground_or_the_bag_below_and_never_overlap(count):
    """Every bag's lowest point lies on the ground or on the highest points of the bags below,
    whose span along the wall holds the upper bag's centre (so it does not tip); two bags either
    are apart by the gap in plan or one lies entirely above the other."""
    poses = place_bags(VERTICES, count, "stacked", seed=0, yaw_deg=35.0, gap_m=0.02)
    half = (VERTICES.max(axis=0) - VERTICES.min(axis=0)) / 2
    boxes = [world_vertices(p) for p in poses]
    for p, v in zip(poses, boxes):
        bottom = v[:, 2].min()
        if bottom > 1e-9:
            below = [q for q, w in zip(poses, boxes) if abs(w[:, 2].max() - bottom) < 1e-9
                     and not _rectangles_apart(_footprint(p, half), _footprint(q, half), 0.0)]
            assert below, "floating bag"
            # Supports in the upper bag's frame (the wall shares one yaw): the centre (0, 0) must
            # lie within their span along the wall and within their width across it.
            d = np.array([np.linalg.solve(p[:2, :2], q[:2, 3] - p[:2, 3]) for q in below])
            assert d[:, 0].min() - half[0] <= 0.0 <= d[:, 0].max() + half[0]
            assert (np.abs(d[:, 1]) <= half[1]).all()
    for i in range(count):
        for j in range(i):
            zi, zj = boxes[i][:, 2], boxes[j][:, 2]
            vertical = zi.min() >= zj.max() - 1e-9 or zj.min() >= zi.max() - 1e-9
            plan = _rectangles_apart(_footprint(poses[i], half), _footprint(poses[j], half), 0.02 - 1e-9)
            assert vertical or plan


def test_eleven_bags_make_a_five_four_two_wall():
    poses = place_bags(VERTICES, 11, "stacked", seed=0)
    heights = np.round([p[2, 3] for p in poses], 6)
    assert sorted(np.unique(heights, return_counts=True)[1].tolist(), reverse=True) == [5, 4, 2]


def test_other_meshes_rest_on_their_lowest_point():
    v = folded_cuboid()[0].astype(np.float64)
    pose = place_bags(v, 1, "single", seed=0)[0]
    assert (v @ pose[:3, :3].T + pose[:3, 3])[:, 2].min() == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"count": 2, "layout": "single"}, "count"),
    ({"count": 0, "layout": "stacked"}, "count"),
    ({"count": 30, "layout": "scattered", "radius_m": 0.3}, "count"),
    ({"count": 1, "layout": "pyramid"}, "layout"),
])
def test_impossible_layouts_are_clear_errors(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        place_bags(VERTICES, seed=0, max_tries=2000, **kwargs)
