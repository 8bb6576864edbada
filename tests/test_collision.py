"""Exact mesh intersection tests against analytic cases and against trimesh."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from moonbot.config.schema import MeshesConfig
from moonbot.scene.bag_mesh import variant_mesh
from moonbot.scene.collision import (
    segments_cross_triangles,
    solids_intersect,
    surfaces_cross,
    vertical_extent,
    winding_number,
)

pytestmark = pytest.mark.unit

TRI = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@pytest.mark.parametrize(
    ("p0", "p1", "expected"),
    [
        ((0.2, 0.2, -1.0), (0.2, 0.2, 1.0), True),  # through the interior
        ((0.2, 0.2, 0.5), (0.2, 0.2, 1.0), False),  # stops short
        ((0.8, 0.8, -1.0), (0.8, 0.8, 1.0), False),  # beside the hypotenuse
        ((0.2, 0.2, -1.0), (0.2, 0.2, 0.0), True),  # ends on the triangle: touching counts
        ((0.0, 0.0, -1.0), (0.0, 0.0, 1.0), True),  # through a vertex
        ((-1.0, 0.2, 0.0), (2.0, 0.2, 0.0), False),  # in the triangle's plane: left to neighbours
    ],
)
def test_segment_against_triangle(p0, p1, expected):
    got = segments_cross_triangles(np.array([p0]), np.array([p1]), *(TRI[[k]] for k in range(3)))
    assert bool(got[0]) is expected


def box(size, centre):
    mesh = trimesh.creation.box(extents=size)
    mesh.apply_translation(centre)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)


@pytest.mark.parametrize(("offset", "expected"), [(1.0 + 1e-9, False), (1.0 - 1e-9, True), (0.5, True), (3.0, False)])
def test_two_unit_cubes_side_by_side(offset, expected):
    # Offset along a skew direction so no faces are coplanar.
    direction = np.array([1.0, 0.3, 0.2])
    a = box((1, 1, 1), (0, 0, 0))
    b = box((1, 1, 1), direction * offset)
    assert solids_intersect(*a, *b) is expected


def test_a_solid_inside_another_intersects_without_touching_surfaces():
    outer, inner = box((2, 2, 2), (0, 0, 0)), box((0.5, 0.5, 0.5), (0.1, 0.2, 0.3))
    assert not surfaces_cross(*outer, *inner)
    assert solids_intersect(*outer, *inner) and solids_intersect(*inner, *outer)


def test_winding_number_agrees_with_trimesh_on_the_folded_bag():
    v, t = variant_mesh(MeshesConfig(), 3)
    v = v.astype(np.float64)
    rng = np.random.default_rng(0)
    points = rng.uniform(v.min(axis=0) - 0.01, v.max(axis=0) + 0.01, size=(300, 3))
    inside = winding_number(points, v, t)
    reference = trimesh.Trimesh(v, t, process=False).contains(points)
    np.testing.assert_array_equal(inside > 0.5, reference)
    assert np.all((np.abs(inside) < 1e-6) | (np.abs(inside - 1) < 1e-6))


def test_vertical_extent_of_a_box_and_a_tilted_plane():
    v, t = box((1.0, 2.0, 0.5), (0.0, 0.0, 1.0))
    lo, hi = vertical_extent(np.array([[0.1, 0.2], [0.4, -0.9], [0.6, 0.0]]), v, t)
    np.testing.assert_allclose(lo[:2], 0.75)
    np.testing.assert_allclose(hi[:2], 1.25)
    assert np.isnan(lo[2]) and np.isnan(hi[2])
    plane = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    plane[:, 2] = 0.3 * plane[:, 0] - 0.2 * plane[:, 1]
    xy = np.random.default_rng(1).uniform(-0.9, 0.9, size=(50, 2))
    lo, hi = vertical_extent(xy, plane, np.array([[0, 1, 2], [0, 2, 3]]))
    np.testing.assert_allclose(lo, 0.3 * xy[:, 0] - 0.2 * xy[:, 1], atol=1e-15)
    np.testing.assert_array_equal(lo, hi)
