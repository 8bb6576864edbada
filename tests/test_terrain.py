"""Analytic grounds: heights and gradients against the crater proportions and finite
differences; meshes that lie on the height field, wind counter-clockwise and grade smoothly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from moonbot.config.load import ConfigError, load_config
from moonbot.terrain import make_ground
from moonbot.terrain.ground import CraterGround, FlatGround, SlopedGround, graded_axis, grid_triangles

pytestmark = pytest.mark.unit

GROUNDS = [
    FlatGround(size_m=50.0),
    SlopedGround(slope_deg=30.0, downhill_azimuth_deg=60.0, size_m=50.0),
    CraterGround(diameter_m=8.0, size_m=50.0),
]


@pytest.mark.parametrize("ground", GROUNDS, ids=["flat", "slope", "crater"])
def test_gradient_is_the_derivative_of_height(ground):
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-10, 10, size=(2, 200))
    if isinstance(ground, CraterGround):  # away from the rim crest, where the slope jumps
        cx, cy = ground.centre
        keep = np.abs(np.hypot(x - cx, y - cy) - ground.diameter_m / 2) > 1e-3
        x, y = x[keep], y[keep]
    h = 1e-6
    gx, gy = ground.gradient(x, y)
    np.testing.assert_allclose(gx, (ground.height(x + h, y) - ground.height(x - h, y)) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(gy, (ground.height(x, y + h) - ground.height(x, y - h)) / (2 * h), atol=1e-7)


def test_slope_plane_and_normal():
    ground = SlopedGround(slope_deg=30.0, downhill_azimuth_deg=90.0)
    assert ground.height(1.0, 0.0) == pytest.approx(-math.tan(math.radians(30.0)), abs=1e-15)  # downhill east
    assert ground.height(0.0, 5.0) == pytest.approx(0.0, abs=1e-15)
    _, normal = ground.plane()
    np.testing.assert_allclose(normal, [0.5, 0.0, math.sqrt(3) / 2], atol=1e-15)


def test_crater_profile_follows_the_stated_proportions():
    D = 8.0
    g = CraterGround(diameter_m=D, centre_distance_m=0.0)
    R = D / 2
    assert g.height(0.0, 0.0) == pytest.approx(0.036 * D - 0.13 * D)  # floor: rim minus depth
    assert g.height(R, 0.0) == pytest.approx(0.036 * D)  # rim crest
    assert g.height(R - 1e-9, 0.0) == pytest.approx(g.height(R + 1e-9, 0.0), abs=1e-8)  # continuous
    assert g.height(0.0, 2 * R) == pytest.approx(0.036 * D / 8)  # ejecta ~ (r/R)^-3
    on_rim = CraterGround(diameter_m=D, centre_distance_m=R, azimuth_deg=90.0)
    assert on_rim.height(0.0, 0.0) == pytest.approx(0.036 * D)  # the default puts the target on the crest


@pytest.mark.parametrize("ground", GROUNDS, ids=["flat", "slope", "crater"])
def test_meshes_lie_on_the_ground_and_face_up(ground):
    v, t = ground.mesh()
    assert v.dtype == np.float32 and t.dtype == np.int32
    np.testing.assert_allclose(
        v[:, 2], ground.height(v[:, 0].astype(np.float64), v[:, 1].astype(np.float64)), atol=1e-5
    )
    a, b, c = (v[t[:, k]].astype(np.float64) for k in range(3))
    assert (np.cross(b - a, c - a)[:, 2] > 0).all()
    assert np.abs(v[:, :2]).max() == pytest.approx(ground.size_m / 2)


def test_graded_axis_is_fine_near_the_bags_and_grows_outward():
    axis = graded_axis(100.0, 2.0, 0.01, 1.1)
    steps = np.diff(axis)
    assert (steps > 0).all()
    np.testing.assert_allclose(axis, -axis[::-1], atol=1e-12)
    assert axis[0] == -100.0 and axis[-1] == 100.0
    fine = np.abs(axis[:-1] + steps / 2) < 2.0
    np.testing.assert_allclose(steps[fine], 0.01, atol=1e-12)
    outer = steps[len(steps) // 2 :]
    assert (outer[1:-1] / outer[:-2] <= 1.1 + 1e-9).all()
    assert len(axis) < 600  # ~0.3 M vertices for a 100 m patch at 1 cm detail
    assert grid_triangles(3, 2).tolist() == [[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]


def test_terrain_config_builds_the_ground_and_checks_ranges():
    ground = make_ground(load_config(None, {"terrain.location": "slope", "terrain.slope_deg": 12.0}).terrain)
    assert isinstance(ground, SlopedGround) and ground.slope_deg == 12.0
    with pytest.raises(ConfigError, match="terrain.location: must be one of"):
        load_config(None, {"terrain.location": "mare"})
    with pytest.raises(ConfigError, match="terrain.detail_extent_m"):
        load_config(None, {"terrain.extent_m": 1.0})
    with pytest.raises(ConfigError, match="terrain.slope_deg"):
        load_config(None, {"terrain.slope_deg": 75.0})
