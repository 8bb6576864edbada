"""Procedural locations: curvature against the sphere, the ground equal to its triangulation,
band-limited craters, Golombek rock counts within sampling error, the same seed giving the same
bytes, the per-process cache, and `render-one --location` on each location."""

from __future__ import annotations

import dataclasses
import hashlib
import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import quad

from moonbot import _core
from moonbot.cli import main
from moonbot.config.load import load_config
from moonbot.config.schema import RocksConfig
from moonbot.scene import compose_scene
from moonbot.scene.orbit import CAMERA_CLEARANCE_M, orbit_height
from moonbot.terrain import clear_cache, get_terrain, make_ground
from moonbot.terrain.craters import crater_profile
from moonbot.terrain.ground import GridGround, grid_triangles
from moonbot.terrain.location import Location, curvature_drop, drawable, location_axis, main_crater, node_spacing
from moonbot.terrain.rocks import (
    BURIAL,
    crater_falloff,
    golombek_q,
    rock_poses,
    rock_prototypes,
    rocks_per_m2,
    sample_rocks,
)

pytestmark = pytest.mark.unit

R = 1737400.0


def small(location: str = "flat", **terrain) -> object:
    """A quick terrain config: 60 m half-width, 5 cm detail within 1 m."""
    overrides = {
        "terrain.location": location,
        "terrain.extent_m": 60.0,
        "terrain.detail_m": 0.05,
        "terrain.detail_extent_m": 1.0,
        "terrain.growth": 1.1,
    }
    overrides.update({f"terrain.{k}": v for k, v in terrain.items()})
    return load_config(None, overrides).terrain


def bare(config, **changes):
    """The config with no roughness, craters or rocks: only the location's shape and curvature."""
    return dataclasses.replace(
        config,
        roughness=dataclasses.replace(config.roughness, rms_slope_deg=0.0),
        craters=dataclasses.replace(config.craters, density=0.0),
        **changes,
    )


def test_curvature_drop_is_the_sphere_to_1e6_and_zero_when_off():
    d = np.array([1.0, 10.0, 100.0, 1000.0, 1900.0, 2000.0, 10000.0])
    exact = R - np.sqrt(R * R - d * d)  # fine in float64 from 100 m on; d²/2R is its limit below
    np.testing.assert_allclose(curvature_drop(d)[2:], exact[2:], rtol=1e-6)
    np.testing.assert_allclose(curvature_drop(d), d * d / (2 * R) * (1 + d * d / (4 * R * R)), rtol=1e-9)
    np.testing.assert_allclose(curvature_drop(d), [_core.curvature_drop(x) for x in d], rtol=1e-14)
    assert curvature_drop(np.array([2000.0]))[0] == pytest.approx(1.15, abs=0.005)  # docs/physics.md: 1.15 m

    on = make_ground(bare(small(extent_m=2000.0, growth=1.3)))
    v, _ = on.mesh()
    x, y, z = (v[:, k].astype(np.float64) for k in range(3))
    np.testing.assert_allclose(-z, curvature_drop(np.hypot(x, y)), rtol=1e-6, atol=1e-7)
    off = make_ground(bare(small(extent_m=2000.0, growth=1.3), curvature=False))
    assert np.all(off.mesh()[0][:, 2] == 0.0)


def test_grid_ground_is_its_triangulation():
    rng = np.random.default_rng(3)
    xs, ys = np.array([-1.0, -0.2, 0.0, 0.5, 2.0]), np.array([-1.0, 0.1, 0.3, 1.5])
    ground = GridGround(xs, ys, rng.normal(size=(4, 5)))
    v, t = ground.mesh()
    np.testing.assert_array_equal(t, grid_triangles(5, 4))
    # Random points inside each triangle, by barycentric weights: the same height and slope.
    w = rng.dirichlet(np.ones(3), size=len(t))
    corners = v[t].astype(np.float64)
    p = np.einsum("tk,tkd->td", w, corners)
    np.testing.assert_allclose(ground.height(p[:, 0], p[:, 1]), p[:, 2], atol=1e-6)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    n = np.cross(b - a, c - a)
    gx, gy = ground.gradient(p[:, 0], p[:, 1])
    np.testing.assert_allclose(gx, -n[:, 0] / n[:, 2], atol=1e-5)
    np.testing.assert_allclose(gy, -n[:, 1] / n[:, 2], atol=1e-5)
    # A patch is the mesh's own triangles over the window.
    pv, pt = ground.patch(np.array([-0.1, 0.2]), np.array([0.6, 0.4]))
    assert pv[:, 0].min() <= -0.1 and pv[:, 0].max() >= 0.6 and pv[:, 1].min() <= 0.2 and pv[:, 1].max() >= 0.4
    np.testing.assert_allclose(pv[:, 2], ground.height(pv[:, 0], pv[:, 1]), atol=1e-6)
    with pytest.raises(ValueError, match="z: heights must be finite"):
        GridGround(xs, ys, np.full((4, 5), np.nan))


def test_same_seed_same_bytes_and_another_seed_differs():
    def digest(config):
        v, t = make_ground(config).mesh()
        return hashlib.sha256(v.tobytes() + t.tobytes()).hexdigest()

    config = small("crater")
    assert digest(config) == digest(config)
    assert digest(config) != digest(dataclasses.replace(config, seed=1))


def test_crater_location_has_the_crater_where_the_config_puts_it():
    config = bare(
        small("crater", crater_diameter_m=20.0, crater_distance_m=12.0, crater_azimuth_deg=90.0), curvature=False
    )
    ground = make_ground(config)
    centre, D = main_crater(config)
    np.testing.assert_allclose(centre, [12.0, 0.0], atol=1e-12)
    # At the grid's nodes, heights relative to the target's (z = 0 at the origin) are the
    # profile's differences (between nodes the ridge of the rim crest is cut by linear cells).
    X, Y = np.meshgrid(ground.x_axis, ground.y_axis, indexing="xy")
    s = np.hypot(X - 12.0, Y) / 10.0
    expected = crater_profile(s, D) - crater_profile(np.array(12.0 / 10.0), D)
    np.testing.assert_allclose(ground.z, expected, atol=1e-12)
    assert ground.z.min() == pytest.approx(
        crater_profile(np.array(0.0), D) - crater_profile(np.array(1.2), D), abs=0.05
    )  # the floor, 0.13 D below the rim


def test_craters_are_kept_only_where_the_grid_can_draw_them():
    axis = location_axis(small())
    rng = np.random.default_rng(2)
    centres = rng.uniform(-60.0, 60.0, size=(4000, 2))
    assert not drawable(axis, centres, np.full(4000, 0.01)).any()  # finer than any cell
    spacing = node_spacing(axis)
    for d in (0.5, 2.0, 8.0):
        kept = centres[drawable(axis, centres, np.full(4000, d))]
        assert len(kept)
        cell = np.maximum(np.interp(kept[:, 0], axis, spacing), np.interp(kept[:, 1], axis, spacing))
        assert cell.max() <= d / 5 + 1e-12
    # The same craters exist whatever the grid; a coarser grid draws fewer of them.
    fine, coarse = (Location(small(growth=g), location_axis(small(growth=g))).craters for g in (1.05, 1.2))
    assert 0 < len(coarse.diameters) < len(fine.diameters)
    assert {tuple(c) for c in coarse.centres} <= {tuple(c) for c in fine.centres}
    # The work site lies outside every crater larger than site_max_diameter_m.
    config = load_config(None, {}).terrain
    craters = Location(config, location_axis(config)).craters
    big = craters.diameters > config.craters.site_max_diameter_m
    assert big.any()
    assert np.all(np.hypot(*craters.centres[big].T) > craters.diameters[big] / 2 + config.detail_extent_m)


def test_golombek_count_matches_its_integral():
    for k in (0.005, 0.1):
        q = golombek_q(k)
        integral, _ = quad(lambda d: 4 * k * q / math.pi * math.exp(-q * d) / d**2, 0.05, 1.0, limit=200)
        assert rocks_per_m2(k, 0.05, 1.0) == pytest.approx(integral, rel=1e-8)
    # The covered area fraction integrates back to F(a) - F(b) = k (e^-qa - e^-qb).
    k, a, b = 0.1, 0.05, 2.0
    q = golombek_q(k)
    area, _ = quad(lambda d: 4 * k * q / math.pi * math.exp(-q * d) / d**2 * math.pi * d * d / 4, a, b)
    assert area == pytest.approx(k * (math.exp(-q * a) - math.exp(-q * b)), rel=1e-9)


def test_rock_counts_follow_the_distribution_within_sampling_error():
    config = RocksConfig(
        density_per_m2=0.01, exponent=-2.5, k_crater=0.0, min_diameter_m=0.05, max_diameter_m=0.8, reach_m=20.0
    )
    rocks = sample_rocks(7, config)
    for lo, hi in [(0.05, 0.1), (0.1, 0.2), (0.2, 0.4), (0.4, 0.8)]:
        half = min(config.reach_m, 300.0 * lo)
        expected = 0.01 * (lo**-2.5 - hi**-2.5) * (2 * half) ** 2
        n = np.count_nonzero((rocks.diameters >= lo) & (rocks.diameters < hi))
        assert abs(n - expected) < 4 * math.sqrt(expected) + 1, (lo, n, expected)
    # Clustered on a crater: counts in annuli follow λ_rim·min(1, (r/R)^-3) integrated over them.
    crater = (np.array([5.0, 0.0]), 10.0)
    config = RocksConfig(density_per_m2=0.0, k_crater=0.1, min_diameter_m=0.1, max_diameter_m=0.2, reach_m=30.0)
    rocks = sample_rocks(11, config, crater)
    r = np.hypot(*(rocks.centres - crater[0]).T)
    lam = rocks_per_m2(0.1, 0.1, 0.2)
    for r0, r1 in [(0.0, 5.0), (5.0, 7.5), (7.5, 12.5), (12.5, 20.0)]:
        expected = lam * quad(lambda x: 2 * math.pi * x * crater_falloff(np.array(x / 5.0)), r0, r1)[0]
        n = np.count_nonzero((r >= r0) & (r < r1))
        assert abs(n - expected) < 4 * math.sqrt(expected) + 1, (r0, n, expected)


def test_rocks_are_closed_shapes_sunk_into_the_ground():
    prototypes = rock_prototypes(0)
    for v, t in prototypes:
        edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert np.all(counts == 2)  # every edge shared by two faces: watertight
        assert max(np.ptp(v[:, 0]), np.ptp(v[:, 1])) == pytest.approx(1.0, abs=1e-6)
    rocks = sample_rocks(0, RocksConfig(reach_m=5.0))
    poses = rock_poses(rocks, prototypes, lambda x, y: 0.1 * x)
    for pose, p, b in zip(poses[:50], rocks.prototype, rocks.burial):
        world = (pose[:3, :3] @ prototypes[p][0].T.astype(np.float64)).T + pose[:3, 3]
        ground = 0.1 * pose[0, 3]
        height = np.ptp(world[:, 2])
        assert world[:, 2].min() == pytest.approx(ground - b * height, abs=1e-9)


def test_rocks_stand_as_high_as_the_cited_shapes_and_burial_say():
    """The prototypes' axes average 1 : 0.75 : 0.5 (impact fragments, 2 : √2 : 1) and a rock's
    exposed height averages 0.425·D (sunk 0–30 %), toward SP-8023's standard 0.5·D."""
    prototypes = rock_prototypes(0)
    extents = np.array([np.ptp(v.astype(np.float64), axis=0) for v, _ in prototypes])
    assert np.allclose(extents[:, 0], 1.0, atol=1e-6)  # every prototype's longest horizontal axis is x
    assert np.mean(extents[:, 1]) == pytest.approx(0.75, abs=0.1)
    assert np.mean(extents[:, 2]) == pytest.approx(0.5, abs=0.1)
    rocks = sample_rocks(0, RocksConfig(reach_m=5.0))
    assert len(rocks) > 1000
    assert rocks.burial.min() >= BURIAL[0] and rocks.burial.max() < BURIAL[1]
    poses = rock_poses(rocks, prototypes, lambda x, y: np.zeros_like(x))
    tops = [
        (pose[2, :3] @ prototypes[p][0].T.astype(np.float64)).max() + pose[2, 3]
        for pose, p in zip(poses, rocks.prototype)
    ]
    exposed = np.array(tops) / rocks.diameters  # top above the ground over D
    # The mean prototype height times the mean exposure (1 − mean burial), within the sample's spread.
    expected = np.mean(extents[:, 2]) * (1.0 - np.mean(BURIAL))
    assert np.mean(exposed) == pytest.approx(expected, rel=0.05)
    assert 0.38 < np.mean(exposed) < 0.48


def test_terrain_is_built_once_per_process_and_scenes_clear_rocks_off_bags():
    clear_cache()
    config = load_config(None, {"terrain.location": "crater", "terrain.extent_m": 200.0})
    first, cached = get_terrain(config.terrain)
    assert not cached and first.build_seconds > 0
    again, cached = get_terrain(config.terrain)
    assert cached and again is first
    spec = compose_scene(config)
    assert spec.terrain_seconds == 0.0  # this process had it
    assert not get_terrain(dataclasses.replace(config.terrain, seed=5))[1]
    with pytest.raises(ValueError, match="read-only"):
        first.mesh[0][0, 0] = 1.0
    # No rock within a bag's footprint or on the camera's orbit circle.
    assert len(spec.rocks) > 100
    centres = np.array([pose[:2, 3] for _, pose in spec.rocks])
    sizes = np.array([pose[2, 2] for _, pose in spec.rocks])
    from_target = np.hypot(*(centres - spec.target[:2]).T)
    assert np.all(from_target - 0.71 * sizes > 0.15)
    assert np.all(np.abs(from_target - config.orbit.radius_m) > 0.7 * sizes)


def test_cameras_stay_above_the_ground():
    ground = make_ground(load_config(None, {"terrain.location": "slope", "terrain.slope_deg": 30.0}).terrain)
    target = np.array([0.0, 0.0, 0.06])
    uphill = 270.0  # the slope falls toward +x (azimuth 90°)
    h = orbit_height(target, 1.0, 0.2, uphill, ground)
    assert h == pytest.approx(math.tan(math.radians(30.0)) + CAMERA_CLEARANCE_M - 0.06)
    assert orbit_height(target, 1.0, 0.2, 90.0, ground) == 0.2  # downhill: unchanged


@pytest.mark.parametrize("location", ["flat", "hilly", "crater"])
def test_render_one_on_each_location(tmp_path, location):
    result = CliRunner().invoke(
        main,
        [
            "render-one",
            "--location",
            location,
            "--out",
            str(tmp_path),
            "--view",
            "0",
            "--view",
            "18",
            "--no-sheet",
            "--set",
            "camera.width=96",
            "--set",
            "camera.height=72",
        ],
    )
    assert result.exit_code == 0, result.output
    assert f"{location} terrain" in result.output
    for view in ("view_000", "view_018"):
        depth = np.load(tmp_path / view / "depth.npy")
        assert np.isfinite(depth).all() and (depth > 0).mean() > 0.5  # terrain fills most of the frame
