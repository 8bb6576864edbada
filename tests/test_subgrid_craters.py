"""The terrain's subgrid craters (moonbot/subgrid_craters.h, location.py's subgrid_craters): the
small craters the graded mesh could not draw, given back to the shading as their slopes and their
walls' shadows. Checked against craters.py's profiles, a brute-force march of the same profiles,
the mesh's own crater population, and rendered views."""

from __future__ import annotations

import numpy as np
import pytest

from moonbot import _core
from moonbot.config import load_config
from moonbot.render import build_scene, render_view
from moonbot.scene import compose_scene, intrinsics, orbit_pose
from moonbot.terrain.build import get_terrain
from moonbot.terrain.craters import CraterField, crater_profile, profile_table
from moonbot.terrain.location import (
    CRATER_REACH,
    SUBGRID_CRATER_REACH,
    crater_population,
    drawable,
    location_axis,
    subgrid_craters,
)

pytestmark = pytest.mark.unit

UP = np.array([0.0, 0.0, 1.0])


def one_crater(diameter: float = 0.4, degradation: float = 0.05, centre=(1.0, 2.0)) -> _core.SubgridCraters:
    return _core.SubgridCraters(
        centres=np.array([centre]),
        diameters=np.array([diameter]),
        degradation=np.array([degradation]),
        **profile_table(),
    )


def toward(elevation_deg: float, azimuth_deg: float = 30.0) -> np.ndarray:
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def brute_force_shadow(points, centre, diameter, degradation, to_light) -> np.ndarray:
    """Whether the profile rises above the ray toward the light anywhere within 5 radii, marched
    in 4000 steps: the shadow the core's 16-point march approximates (on flat ground)."""
    radius = diameter / 2.0
    heading = to_light[:2] / np.hypot(*to_light[:2])
    tan_e = to_light[2] / np.hypot(*to_light[:2])
    q0 = points[:, :2] - centre
    z0 = crater_profile(np.hypot(*q0.T) / radius, diameter, degradation)
    t = np.linspace(1e-4, 5 * radius, 4000)
    q = q0[:, None, :] + t[None, :, None] * heading
    z = crater_profile(np.hypot(q[..., 0], q[..., 1]) / radius, diameter, degradation)
    return np.any(z - z0[:, None] > t[None, :] * tan_e, axis=1)


@pytest.fixture(scope="module")
def flat_craters():
    return subgrid_craters(load_config(None, {"terrain.location": "flat"}).terrain)


def test_heights_and_slopes_are_the_python_profiles(flat_craters):
    core = _core.SubgridCraters(**vars(flat_craters))
    assert len(core) == len(flat_craters.diameters) > 1000
    rng = np.random.default_rng(1)
    pick = rng.choice(len(flat_craters.diameters), 300)
    points = flat_craters.centres[pick] + rng.normal(size=(300, 2)) * flat_craters.diameters[pick, None]
    field = CraterField(flat_craters.centres, flat_craters.diameters, flat_craters.degradation)
    want = field.height(points[:, 0], points[:, 1])
    assert np.abs(want).max() > 0.01
    np.testing.assert_allclose(core.height(points), want, rtol=0, atol=1e-12)
    # The gradient is the heights' slope (central differences of the piecewise-linear table, off
    # its kinks: a step far below the table's 1 % of a radius).
    h = 1e-7
    dx = (core.height(points + [h, 0.0]) - core.height(points - [h, 0.0])) / (2 * h)
    dy = (core.height(points + [0.0, h]) - core.height(points - [0.0, h])) / (2 * h)
    gradient = core.gradient(points)
    close = np.abs(gradient - np.column_stack([dx, dy])) < 1e-5
    assert close.mean() > 0.98


def test_a_crater_narrower_than_two_footprints_shows_no_slope():
    core = one_crater(diameter=0.4)
    point = np.array([[1.1, 2.0]])  # on the wall
    full = core.gradient(point, 0.0)
    assert np.hypot(*full[0]) > 0.05
    np.testing.assert_allclose(core.gradient(point, 0.1), full)  # 4 footprints: whole
    np.testing.assert_allclose(core.gradient(point, 0.4 / 3.0), 0.5 * full)  # 3: half
    assert np.all(core.gradient(point, 0.2) == 0.0)  # 2: none


@pytest.mark.parametrize("degradation", [0.05, 0.2, 0.4])
@pytest.mark.parametrize("elevation", [5.0, 12.5])
def test_shadows_match_a_brute_force_march(degradation, elevation):
    centre, diameter = np.array([1.0, 2.0]), 0.4
    core = one_crater(diameter, degradation, tuple(centre))
    g = np.linspace(-0.25, 0.25, 81)
    X, Y = np.meshgrid(g, g)
    points = np.column_stack([X.ravel() + centre[0], Y.ravel() + centre[1], np.zeros(X.size)])
    to_light = toward(elevation)
    got = core.shadowed(points, to_light, UP)
    want = brute_force_shadow(points, centre, diameter, degradation, to_light)
    # Only points within the rim crest are tested (outside, the flank falls away from it).
    s = np.linspace(0.0, 3.0, 3001)
    crest = s[np.argmax(crater_profile(s, 1.0, degradation))]
    inside = np.hypot(*(points[:, :2] - centre).T) < crest * diameter / 2.0
    assert not got[~inside].any()
    assert (got == want)[inside].mean() > 0.995
    if want[inside].any():
        assert got.sum() > 0.95 * want[inside].sum()


def test_shadows_follow_the_facet_and_the_light():
    core = one_crater(0.4, 0.05)
    g = np.linspace(-0.2, 0.2, 41)
    X, Y = np.meshgrid(g, g)
    points = np.column_stack([X.ravel() + 1.0, Y.ravel() + 2.0, np.zeros(X.size)])
    low, high = core.shadowed(points, toward(5.0), UP), core.shadowed(points, toward(40.0), UP)
    assert low.mean() > 0.2 and not high.any()  # above every wall nothing is hidden
    # The crater lies on its facet: a facet turned 10° toward the light sees it 10° higher.
    a = np.radians(30.0)
    tilt = np.radians(10.0)
    normal = np.array([np.sin(tilt) * np.cos(a), np.sin(tilt) * np.sin(a), np.cos(tilt)])
    lifted = core.shadowed(points, toward(5.0), normal)
    np.testing.assert_array_equal(lifted, core.shadowed(points, toward(15.0), UP))
    assert not core.shadowed(points, toward(-2.0), UP).any()  # below the horizon: not its business


def test_the_subgrid_craters_are_those_the_mesh_could_not_draw(flat_craters):
    config = load_config(None, {"terrain.location": "flat"}).terrain
    axis = location_axis(config)
    population = crater_population(config)
    drawn = drawable(axis, population.centres, population.diameters)
    assert drawn.any() and (~drawn).any()
    # None of them can be drawn where it lies; every crater the mesh sampled and could not draw is
    # among them (none of this location's reach the site), and the rest lie beyond the mesh's squares.
    assert not drawable(axis, flat_craters.centres, flat_craters.diameters).any()
    undrawn = {(tuple(c), d) for c, d in zip(population.centres[~drawn], population.diameters[~drawn])}
    ours = {(tuple(c), d) for c, d in zip(flat_craters.centres, flat_craters.diameters)}
    assert undrawn <= ours
    beyond = np.array([(c, d) not in undrawn for c, d in zip(map(tuple, flat_craters.centres), flat_craters.diameters)])
    band = 2.0 ** np.floor(np.log2(flat_craters.diameters[beyond] / config.craters.min_diameter_m))
    d = band * config.craters.min_diameter_m
    side = np.max(np.abs(flat_craters.centres[beyond]), axis=1)
    assert np.all(side > np.minimum(CRATER_REACH * d, config.extent_m))
    assert np.all(side <= np.minimum(SUBGRID_CRATER_REACH * d, config.extent_m))
    # Band [0.4, 0.8) m holds the law's count over its ring (Poisson: within 5 σ).
    lo = 0.4
    in_band = beyond & (flat_craters.diameters >= lo) & (flat_craters.diameters < 2 * lo)
    area = (2 * SUBGRID_CRATER_REACH * lo) ** 2 - (2 * CRATER_REACH * lo) ** 2
    expected = config.craters.density * area * (lo**-2 - (2 * lo) ** -2)
    assert abs(in_band.sum() - expected) < 5 * np.sqrt(expected)


def test_bad_input_names_the_argument():
    table = profile_table()
    good = dict(centres=np.zeros((1, 2)), diameters=np.ones(1), degradation=np.zeros(1), **table)
    cases = {
        "centres": {"centres": np.full((1, 2), np.nan)},
        "diameters": {"diameters": np.array([-1.0])},
        "degradation": {"degradation": np.array([2.0])},
        "table_degradation": {"table_degradation": np.array([0.1, 0.2] + [0.3] * (len(table["table_reach"]) - 2))},
        "table_reach": {"table_reach": np.zeros(len(table["table_reach"]))},
        "radius_step": {"radius_step": 0.0},
    }
    for field, bad in cases.items():
        with pytest.raises(ValueError, match=field):
            _core.SubgridCraters(**{**good, **bad})
    scene = _core.Scene()
    mesh = scene.add_mesh(np.zeros((3, 3), np.float32), np.array([[0, 1, 2]], np.int32))
    with pytest.raises(ValueError, match="craters"):  # read with a grain
        scene.add_background(mesh, np.eye(4), (0.1, 0.1, 0.1), craters=_core.SubgridCraters(**good))


def test_off_builds_nothing_and_the_analytic_grounds_have_none():
    off = load_config(None, {"terrain.craters.subgrid_shading": False, "terrain.location": "flat"})
    assert subgrid_craters(off.terrain) is None
    assert get_terrain(off.terrain)[0].craters is None
    assert compose_scene(off).terrain_craters is None
    plane = load_config(None, {"terrain.location": "plane"})
    assert get_terrain(plane.terrain)[0].craters is None


def render(subgrid: bool):
    config = load_config(
        None,
        {
            "terrain.location": "flat",
            "terrain.craters.subgrid_shading": subgrid,
            "sun.elevation_deg": 10.0,
            "camera.width": 320,
            "camera.height": 240,
            "orbit.radius_m": 6.0,
            "orbit.height_m": 1.5,
        },
    )
    spec = compose_scene(config)
    pose = orbit_pose(spec.target, config.orbit.radius_m, config.orbit.height_m, 40.0)
    return render_view(build_scene(spec), config, intrinsics(config.camera), pose, seed=5)


def test_a_rendered_view_gains_the_craters_shadows_and_keeps_its_geometry():
    with_craters, without = render(True), render(False)
    np.testing.assert_array_equal(with_craters.depth, without.depth)
    np.testing.assert_array_equal(with_craters.instance, without.instance)
    ground = (with_craters.instance == 0) & (with_craters.depth > 0)
    far = ground & (with_craters.depth > 8.0)
    assert far.sum() > 2000

    def dark(view):
        luma = view.rgb.astype(np.float64) @ [0.2126, 0.7152, 0.0722]
        return luma[far] < 0.2 * np.median(luma[far])

    # Their shadows darken more of the far ground (1.6 % → 2.1 % of it at this seed); its mean
    # light stays within a few per cent.
    assert dark(with_craters).mean() > 1.2 * dark(without).mean()
    mean = [v.rgb[ground].mean() for v in (with_craters, without)]
    assert abs(mean[0] / mean[1] - 1.0) < 0.05
