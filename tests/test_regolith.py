"""The regolith of the procedural locations as built: the mesh's RMS slope at several baselines
against the cited law and its split with Hapke's θ̄, craters down to 5 cm in the fine tile, rock
counts per size bin against the Surveyor power law, no rock inside a bag with the bags resting on
the ground, and the same seed giving the same bytes."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from moonbot.config.load import load_config
from moonbot.scene import compose_scene
from moonbot.scene.collision import transform
from moonbot.terrain import clear_cache, get_terrain, make_ground
from moonbot.terrain.craters import crater_profile
from moonbot.terrain.location import Location, location_axis
from moonbot.terrain.rocks import PIXELS_REACH, power_law_per_m2, rock_poses, sample_rocks
from moonbot.terrain.roughness import slope_law, unresolved_theta_bar_deg

pytestmark = pytest.mark.unit

LAGS = np.array([1, 2, 4, 8, 16, 32, 64])  # cells of the 1 cm tile
SEEDS = range(12)


def near_field(seed: int, **overrides):
    """The default terrain config with the default 1 cm tile (±2 m) but a 60 m, quickly graded
    extent, flat (no curvature), and no craters unless asked: the relief alone."""
    settings = {
        "terrain.extent_m": 60.0,
        "terrain.growth": 1.05,
        "terrain.curvature": False,
        "terrain.craters.density": 0.0,
        "terrain.seed": seed,
    }
    settings.update({f"terrain.{k}": v for k, v in overrides.items()})
    return load_config(None, settings).terrain


def tile_mean_square(config) -> np.ndarray:
    """Mean squared height difference (m²) between nodes LAGS cells apart along x and y within the
    fine tile of the built mesh."""
    ground = make_ground(config)
    inside = np.flatnonzero(np.abs(ground.x_axis) <= config.detail_extent_m + 1e-9)
    z = ground.z[inside[0] : inside[-1] + 1, inside[0] : inside[-1] + 1]
    return np.array(
        [np.mean(np.concatenate([(z[:, k:] - z[:, :-k]).ravel(), (z[k:] - z[:-k]).ravel()]) ** 2) for k in LAGS]
    )


@pytest.fixture(scope="module")
def mesh_slopes():
    """(baselines (7,) metres, tan of the mesh's 1-D RMS slope over each, the law) pooled over
    12 seeds: the law describes the ensemble, and a 4 m tile of one field sees its long octaves
    as a single tilt."""
    config = near_field(0)
    pooled = np.mean([tile_mean_square(near_field(seed)) for seed in SEEDS], axis=0)
    baselines = LAGS * config.detail_m
    return baselines, np.sqrt(pooled) / baselines, slope_law(config.roughness)


def test_the_mesh_has_the_law_s_slope_where_it_resolves_the_relief(mesh_slopes):
    baselines, measured, law = mesh_slopes
    ratio = measured / law.tan_slope(baselines)
    resolved = baselines >= 0.04  # four cells: the octaves of 2-4 cells are faded out
    np.testing.assert_allclose(ratio[resolved], 1.0, atol=0.08)
    # One and two cells: less than the law, the rest is unresolved.
    assert np.all(ratio[~resolved] < 0.95)
    # The cm-scale slope stays at the ~5-6° that Apollo photos' ~5 % shadow at 12° allows.
    assert 4.5 < math.degrees(math.atan(measured[0])) < 6.5


def test_resolved_and_unresolved_slopes_add_up_to_the_law_at_its_smallest_scale(mesh_slopes):
    """The mesh's facet slope (one cell) ⊕ the grain's relief (terrain.photometry.grain, the
    shading-normal texture below the mesh) ⊕ the photometric roughness θ̄ the default config
    gives the Hapke model = the law's total at 0.1 mm, in tan², to within 0.2° of θ̄."""
    _, measured, law = mesh_slopes
    config = load_config(None, {})
    smallest = config.terrain.roughness.smallest_m
    facet = float(measured[0])
    grain = math.tan(math.radians(config.terrain.photometry.grain.slope_rms_deg))
    expected = unresolved_theta_bar_deg(law, smallest, math.hypot(facet, grain))
    assert config.terrain.photometry.roughness_deg == pytest.approx(expected, abs=0.2)
    total = math.degrees(math.atan(float(law.tan_slope(smallest)) / math.sqrt(math.pi / 2)))
    # The mesh takes little of θ̄ (small, not zero); the grain's 1 cm–1 mm share takes a little more.
    assert 0.5 < total - expected < 3.0
    # Without the grain, θ̄ would cover everything below the mesh.
    assert unresolved_theta_bar_deg(law, smallest, facet) - expected > 1.0


def test_craters_reach_down_to_five_centimetres_in_the_fine_tile():
    config = near_field(3, **{"craters.density": 0.05})
    location = Location(config, location_axis(config))
    d, c = location.craters.diameters, location.craters.centres
    in_tile = np.all(np.abs(c) < 1.9, axis=1)
    smallest = in_tile & (d < 0.1)
    # N(>=D) = 0.05 D^-2 per m²: 0.05·(0.05^-2 - 0.1^-2) = 15 per m² of 5-10 cm craters.
    expected = 0.05 * (0.05**-2 - 0.1**-2) * 3.8**2
    assert abs(np.count_nonzero(smallest) - expected) < 4 * math.sqrt(expected)
    # The mesh is the relief plus exactly these craters' profiles (relative to the target's node).
    with_craters, without = make_ground(config), make_ground(near_field(3))
    tile = np.flatnonzero(np.abs(with_craters.x_axis) <= 1.9)
    X, Y = np.meshgrid(with_craters.x_axis[tile], with_craters.y_axis[tile], indexing="xy")
    dents = location.craters.height(X, Y) - location.craters.height(np.zeros(1), np.zeros(1))[0]
    difference = (with_craters.z - without.z)[np.ix_(tile, tile)]
    np.testing.assert_allclose(difference, dents, atol=1e-12)
    # The 5-10 cm ones are among them, each a bowl at least 0.025 D deep (the most diffused).
    small = location.craters.subset(smallest)
    floors = crater_profile(np.zeros(len(small.diameters)), small.diameters, small.degradation)
    assert np.all(floors < -0.025 * small.diameters)


def test_rock_sizes_follow_the_surveyor_power_law_within_poisson_error():
    rocks_config = load_config(None, {}).terrain.rocks
    rocks = sample_rocks(21, rocks_config)
    edges = [0.01, 0.02, 0.04, 0.08, 0.16]
    half = 2.5  # a fixed 5 m square, inside every band's square (the smallest reaches ±3 m)
    inside = np.all(np.abs(rocks.centres) < half, axis=1)
    for lo, hi in zip(edges[:-1], edges[1:]):
        expected = power_law_per_m2(rocks_config.density_per_m2, rocks_config.exponent, lo, hi) * (2 * half) ** 2
        n = np.count_nonzero(inside & (rocks.diameters >= lo) & (rocks.diameters < hi))
        assert abs(n - expected) < 3 * math.sqrt(expected) + 1, (lo, n, expected)
    # Ten times Surveyor I (Shoemaker & Morris 1969: 5.0e4 D^-2.11 per 100 m², D in mm), per m²:
    # 38.8 per m² of 1 cm and more, 1.3 of 5 cm (AS11-40-5851: ~2).
    per_m2 = [power_law_per_m2(rocks_config.density_per_m2, rocks_config.exponent, d, math.inf) for d in (0.01, 0.05)]
    np.testing.assert_allclose(per_m2, [10 * 5.0e4 / 100 * 10**-2.11, 10 * 5.0e4 / 100 * 50**-2.11], rtol=0.01)
    # Pebbles only near the target: each band within PIXELS_REACH·D.
    assert np.all(np.max(np.abs(rocks.centres), axis=1) <= PIXELS_REACH * rocks.diameters + 1e-9)


@pytest.mark.parametrize("location", ["flat", "hilly"])
def test_no_rock_in_a_bag_and_the_bags_rest_on_the_ground(location):
    config = load_config(
        None, {"terrain.location": location, "terrain.extent_m": 200.0, "bags.count": 6, "bags.layout": "scattered"}
    )
    spec = compose_scene(config)  # raises if a bag cuts into the ground or into another bag
    assert len(spec.rocks) > 200 and min(pose[2, 2] for _, pose in spec.rocks) < 0.02  # pebbles too
    bag_vertices = spec.meshes[spec.bags[0].obj_id][0].astype(np.float64)
    radius = float(np.hypot(bag_vertices[:, 0], bag_vertices[:, 1]).max())
    ground = spec.ground
    for bag in spec.bags:
        world = transform(bag_vertices, bag.world_from_model)
        under = ground.height(world[:, 0], world[:, 1])
        assert np.min(world[:, 2] - under) == pytest.approx(0.0, abs=0.005)  # resting, not floating
        centre = bag.world_from_model[:2, 3]
        for key, pose in spec.rocks:
            rock = (pose[:3, :3] @ spec.meshes[key][0].T.astype(np.float64)).T + pose[:3, 3]
            # Every rock vertex outside the bag's plan disc (plus the clearance): no shared volume.
            gap = np.hypot(*(rock[:, :2] - centre).T).min() - radius
            assert gap > config.terrain.rocks.clearance_m - 1e-9


def test_same_seed_same_bytes():
    def digest(config) -> str:
        terrain, _ = get_terrain(config)
        v, t = terrain.mesh
        poses = rock_poses(terrain.rocks, terrain.rock_meshes, terrain.ground.height)
        return hashlib.sha256(v.tobytes() + t.tobytes() + poses.tobytes()).hexdigest()

    config = near_field(4, **{"craters.density": 0.05})
    first = digest(config)
    clear_cache()
    assert digest(config) == first
    assert digest(near_field(5, **{"craters.density": 0.05})) != first
