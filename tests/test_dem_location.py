"""The `dem` location: a LocalDem interpolated smoothly (equal to the DEM at its nodes, exact for
quadratics, C1 across pixel edges), the world frame the site's own East-North-Up (checked point
by point through GeographicLib, and at polar sites 5 km out where the DEM's north is 58.8° off
the site's, down to which way a rendered shadow falls), fractal detail only below the DEM's pixel,
clear errors for a DEM that does not cover the terrain, and a bag 2 km from the DEM's origin
rendering like one at the origin."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from moonbot import _core
from moonbot.bop import merge_dataset
from moonbot.cli import main
from moonbot.config.load import ConfigError, load_config
from moonbot.pipeline import run_views
from moonbot.pipeline.tasks import run_task
from moonbot.sweep import tasks
from moonbot.terrain import clear_cache, get_terrain, make_ground
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.location import DEM_CRATER_PIXELS, DemRelief, Location, curvature_drop, dem_site, location_axis

pytestmark = pytest.mark.integration

R = 1737400.0


def local_dem(heights, spacing=2.0, curvature=False, h0=0.0) -> LocalDem:
    return LocalDem(heights=heights, spacing_m=spacing, lat_deg=10.0, lon_deg=20.0, h0_m=h0, curvature=curvature)


def periodic_dem(nx: int, ny: int, period: int = 25) -> np.ndarray:
    """Rough heights (ny, nx) that repeat exactly every `period` columns counted from the centre
    column: the same float64 values, not merely the same formula."""
    rng = np.random.default_rng(7)
    tile = rng.normal(0.0, 0.15, size=(ny, period)) + 2.0 * np.sin(2 * np.pi * np.arange(period) / period)
    columns = (np.arange(nx) - (nx - 1) // 2) % period
    return tile[:, columns] + 1.5 * np.cos(2 * np.pi * np.arange(ny) / 40.0)[:, None]


def dem_config(path, **terrain):
    overrides = {
        "terrain.location": "dem",
        "terrain.dem_file": str(path),
        "terrain.extent_m": 60.0,
        "terrain.detail_m": 0.05,
        "terrain.detail_extent_m": 1.0,
        "terrain.growth": 1.1,
    }
    overrides.update({f"terrain.{k}": v for k, v in terrain.items()})
    return overrides


def test_grid_interpolation_equals_the_dem_at_nodes_and_quadratics_everywhere():
    n, s = 41, 0.5
    e = (np.arange(n) - 20) * s
    E, N = np.meshgrid(e, e)
    quadratic = lambda x, y: 3.0 + 0.2 * x - 0.1 * y + 0.03 * x * x - 0.02 * x * y + 0.01 * y * y  # noqa: E731
    relief = DemRelief(local_dem(quadratic(E, N), spacing=s), (1.0, -2.0))  # site on a node
    assert relief.site_m == (1.0, -2.0)
    rng = np.random.default_rng(1)
    u, v = rng.uniform(-7.0, 7.0, 500), rng.uniform(-7.0, 7.0, 500)
    np.testing.assert_allclose(relief.grid_height(u, v), quadratic(u + 1.0, v - 2.0), rtol=0, atol=1e-12)
    rough = rng.normal(size=(n, n))
    nodes = DemRelief(local_dem(rough, spacing=s), (0.0, 0.0))
    i = rng.integers(-18, 18, size=(2, 50))
    np.testing.assert_array_equal(nodes.grid_height(i[0] * s, i[1] * s), rough[i[1] + 20, i[0] + 20])


def test_relief_has_no_crease_at_pixel_edges():
    """Catmull-Rom is C1: the slope just west and just east of a DEM column agree (a bilinear
    read would jump by the DEM's second difference), and so does the world relief built on it."""
    rough = np.random.default_rng(2).normal(size=(31, 31))
    relief = DemRelief(local_dem(rough, spacing=1.0), (0.0, 0.0))
    x = np.arange(-10, 11, dtype=np.float64)
    y = np.full_like(x, 0.37)
    h = 1e-6
    for height in (relief.grid_height, relief.height):
        west = (height(x, y) - height(x - h, y)) / h
        east = (height(x + h, y) - height(x, y)) / h
        np.testing.assert_allclose(west, east, atol=1e-4)


def test_a_level_dem_is_the_sphere_about_any_site():
    """A constant-height surface, imported with curvature (its exact drop below the DEM origin's
    tangent plane) or flat, is the sphere through the site in the site's frame, wherever the site
    is: world up = −(R + h0) + √((R + h0)² − d²), to a nanometre at 2 km."""
    s, h0 = 5.0, 812.0
    n = 1601  # ±4 km
    e = (np.arange(n) - 800) * s
    E, N = np.meshgrid(e, e)
    d = np.hypot(E, N)
    for curvature, heights in ((True, np.sqrt((R + h0) ** 2 - d * d) - (R + h0)), (False, np.zeros_like(d))):
        dem = LocalDem(heights=heights, spacing_m=s, lat_deg=-62.0, lon_deg=20.0, h0_m=h0, curvature=curvature)
        relief = DemRelief(dem, (2000.0, 1000.0))
        assert relief.site.height_m == pytest.approx(h0, abs=1e-6)
        x, y = np.array([-1990.0, 0.0, 1990.0, 700.0]), np.array([0.0, 500.0, 0.0, -1800.0])
        np.testing.assert_allclose(relief.world_up(x, y), -curvature_drop(np.hypot(x, y), R + h0), rtol=0, atol=1e-9)


def dem_frame_point(relief: DemRelief, dem: LocalDem, x, y):
    """World points (x, y, world_up) → DEM frame (east, north, up from the DEM origin) by way of
    their selenographic coordinates, through GeographicLib (LunarFrame) point by point: the site's
    frame as gt.json records it, then the DEM origin's."""
    site = _core.LunarFrame(relief.site.lat_deg, relief.site.lon_deg, relief.site.height_m)
    origin = _core.LunarFrame(dem.lat_deg, dem.lon_deg, dem.h0_m)
    z = relief.world_up(x, y)
    return np.array([origin.to_enu(*site.to_geodetic(a, b, c)) for a, b, c in zip(x, y, z)]).T


@pytest.mark.parametrize("curvature", [True, False], ids=["curved", "flat"])
@pytest.mark.parametrize("lat0", [-89.9, 89.9, 10.0])
def test_world_points_lie_on_the_dem_surface(lat0, curvature):
    """Each world point (x, y, world_up(x, y)) of a site 5 km east of the DEM's origin, carried to
    the DEM's frame through selenographic coordinates (GeographicLib, independent of the site
    frame's own arithmetic), lies on the DEM surface: curved import, its up is the interpolated
    DEM under it; flat import, its height above the sphere is h0 + the DEM on its radial."""
    s, h0 = 4.0, -1500.0
    e = (np.arange(2 * 1300 + 1) - 1300) * s  # ±5.2 km east-west
    n = (np.arange(2 * 100 + 1) - 100) * s  # ±400 m north-south
    E, N = np.meshgrid(e, n)
    relief_m = 40.0 * np.sin(E / 90.0) * np.cos(N / 70.0) + 0.05 * E  # slopes up to ~0.5
    heights = relief_m - (curvature_drop(np.hypot(E, N), R + h0) if curvature else 0.0)
    dem = LocalDem(heights=heights, spacing_m=s, lat_deg=lat0, lon_deg=33.0, h0_m=h0, curvature=curvature)
    relief = DemRelief(dem, (5000.0, 0.0))
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-150.0, 150.0, 60), rng.uniform(-150.0, 150.0, 60)
    east, north, up = dem_frame_point(relief, dem, x, y)
    u, v = east - relief.site_m[0], north - relief.site_m[1]
    if curvature:
        np.testing.assert_allclose(up, relief.grid_height(u, v), rtol=0, atol=1e-6)
    else:
        scale = (R + h0) / (up + R + h0)  # the radial's foot on the DEM origin's tangent plane
        foot = relief.grid_height(east * scale - relief.site_m[0], north * scale - relief.site_m[1])
        radius = np.sqrt(east**2 + north**2 + (up + R + h0) ** 2)
        np.testing.assert_allclose(radius - (R + h0), foot, rtol=0, atol=1e-6)
    assert np.abs(relief.world_up(np.zeros(1), np.zeros(1))).max() < 1e-9  # the origin is on the ground


@pytest.mark.parametrize("lat0", [-89.9, 89.9])
def test_a_polar_site_5_km_out_has_its_own_true_north(lat0):
    """At 89.9° the pole is 3.03 km from the DEM's origin; a site 5 km east sees it 58.8° off the
    DEM's north (the reported case). The world's +y is the site's meridian toward the north pole,
    and the site's north in the DEM's grid is the bearing of the north pole from the site (89.9° N)
    or the bearing away from the south pole (89.9° S), both found with GeographicLib."""
    dem = LocalDem(
        heights=np.zeros((101, 2 * 1300 + 1)), spacing_m=4.0, lat_deg=lat0, lon_deg=-60.0, h0_m=0.0, curvature=False
    )
    relief = DemRelief(dem, (5000.0, 0.0))
    origin = _core.LunarFrame(lat0, -60.0, 0.0)
    pole = np.array(origin.to_enu(math.copysign(90.0, lat0), 0.0, 0.0))
    assert abs(pole[1]) == pytest.approx(R * math.sin(math.radians(0.1)), rel=1e-9)  # 3.03 km north or south
    ahead = math.copysign(1.0, lat0)  # north is toward the pole at 89.9° N, away from it at 89.9° S
    to_pole = math.degrees(math.atan2(ahead * (pole[0] - 5000.0), ahead * pole[1]))
    assert to_pole == pytest.approx(-58.76 if lat0 > 0 else 58.76, abs=0.01)
    # The site's meridian at ±δ: that chord is parallel to the meridian's tangent at the site.
    lat, lon, h = relief.site.lat_deg, relief.site.lon_deg, relief.site.height_m
    south, north = (np.array(origin.to_enu(lat + k * 1e-4, lon, h)) for k in (-1, 1))
    bearing = math.degrees(math.atan2(*(north - south)[:2]))
    assert relief.site.north_in_dem_deg == pytest.approx(bearing, abs=1e-6)
    assert relief.site.north_in_dem_deg == pytest.approx(to_pole, abs=0.001)  # the pole is 5.85 km off: nearly
    # The site itself: 5 km east of the DEM's origin on the sphere, where GeographicLib puts it.
    assert (relief.site.lat_deg, relief.site.lon_deg, relief.site.height_m) == origin.to_geodetic(*relief.origin)
    assert abs(relief.site.height_m) < 1e-6
    assert abs(math.sin(math.radians(relief.site.lat_deg))) == pytest.approx(
        R * math.sin(math.radians(89.9)) / math.hypot(R, 5000.0), rel=1e-12
    )
    # World +y 100 m out is due north of the site: on its meridian, at a higher latitude.
    site = _core.LunarFrame(relief.site.lat_deg, relief.site.lon_deg, relief.site.height_m)
    lat_n, lon_n, _ = site.to_geodetic(0.0, 100.0, float(relief.world_up(np.zeros(1), np.full(1, 100.0))[0]))
    assert lat_n > relief.site.lat_deg
    assert (lon_n - relief.site.lon_deg + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
    # And the Sun at azimuth 0 shines from the world's +y.
    np.testing.assert_allclose(
        _core.DirectionalLight(0.0, 20.0).direction,
        [0.0, math.cos(math.radians(20.0)), math.sin(math.radians(20.0))],
        atol=1e-12,
    )


@pytest.fixture
def periodic_file(tmp_path):
    """A 2 m DEM, 4.3 km east-west, 170 m north-south, repeating every 50 m east-west."""
    nx, ny = 2 * 1070 + 1, 85
    return local_dem(periodic_dem(nx, ny)).save(tmp_path / "periodic.npz")


def test_detail_is_only_below_the_dem_pixel(periodic_file):
    config = load_config(None, dem_config(periodic_file)).terrain
    location = Location(config, location_axis(config), LocalDem.load(periodic_file))
    assert location.roughness.longest_drawn_m == 4.0  # two DEM pixels
    assert location.craters.diameters.max() <= DEM_CRATER_PIXELS * 2.0
    assert location.main_crater is None and location.hills is None
    # Roughness off: the relief is the DEM itself about the site.
    bare = load_config(
        None, dem_config(periodic_file, **{"roughness.rms_slope_deg": 0.0, "craters.density": 0.0})
    ).terrain
    plain = Location(bare, location_axis(bare), LocalDem.load(periodic_file))
    x = np.linspace(-50, 50, 101)
    np.testing.assert_array_equal(plain.surface(x, x * 0.3, np.full_like(x, 0.05)), plain.dem.height(x, x * 0.3))


def test_a_site_2_km_from_the_dem_origin_renders_like_one_at_the_origin(tmp_path):
    """The DEM repeats every 50 m, so the sites (0, 0) and (2000, 0) stand on the same ground. On
    the equator a site due east keeps the DEM's north (no meridian convergence), and what is left
    between the two is the sphere: the site sees the DEM's tangent-plane grid stretched by
    (2 km / R)² = 1.3e-6, which moves the 60 m terrain's edge by 0.08 mm. So the meshes agree to
    5e-5 m (slopes up to ~0.5), 2e-6 m under the bags, and the renders to the last few pixels
    (a pixel or two where a crater's or a pebble's shadow edge crosses its samples).
    Without the shift to the site, float32 vertices 2 km out would be 0.12 mm apart under the
    bags, the 5 cm near grid would show it, and these bounds would fail."""
    nx, ny = 2 * 1070 + 1, 85
    path = LocalDem(
        heights=periodic_dem(nx, ny), spacing_m=2.0, lat_deg=0.0, lon_deg=20.0, h0_m=0.0, curvature=False
    ).save(tmp_path / "equator.npz")
    outputs = []
    for site in ([0.0, 0.0], [2000.0, 0.0]):
        clear_cache()
        overrides = dem_config(path, dem_site_m=site)
        # Settle on the rendered surface itself: a height field on the 5 cm mesh's own nodes.
        overrides.update({"camera.width": 96, "camera.height": 72, "bags.settle.ground_step_m": 0.05})
        config = load_config(None, overrides)
        terrain, _ = get_terrain(config.terrain)
        out = tmp_path / f"site_{int(site[0])}"
        run_views(config, [0, 9], out)
        outputs.append((out, terrain))
    (a, ta), (b, tb) = outputs
    assert tb.site.north_in_dem_deg == 0.0 and tb.site.lat_deg == 0.0
    assert tb.site.lon_deg == pytest.approx(20.0 + math.degrees(math.atan(2000.0 / R)), abs=1e-12)  # the radial
    va, vb = ta.mesh[0], tb.mesh[0]
    np.testing.assert_array_equal(va[:, :2], vb[:, :2])
    near = np.hypot(va[:, 0], va[:, 1]) <= 1.0
    dz = np.abs(va[:, 2].astype(np.float64) - vb[:, 2])
    assert dz.max() < 5e-5 and dz[near].max() < 2e-6
    for view in ("view_000", "view_009"):
        ga, gb = (json.loads((d / view / "gt.json").read_text()) for d in (a, b))
        for key in ("camera_height_m", "render_seed", "sun"):
            assert ga[key] == gb[key], key
        for ia, ib in zip(ga["instances"], gb["instances"]):
            np.testing.assert_allclose(ia["cam_t_m2c"], ib["cam_t_m2c"], rtol=0, atol=0.01)  # mm
            np.testing.assert_allclose(ia["cam_R_m2c"], ib["cam_R_m2c"], rtol=0, atol=1e-5)
        rgb = [np.asarray(Image.open(d / view / "rgb.png"), np.int16) for d in (a, b)]
        # A shadow edge of a 25 cm crater or of a pebble may still cross a pixel's samples.
        off = np.abs(rgb[0] - rgb[1]).max(axis=-1)
        assert np.count_nonzero(off > 1) <= 3 and (off > 0).mean() < 0.005
        masks = [np.asarray(Image.open(d / view / "mask.png")) for d in (a, b)]
        assert (masks[0] != masks[1]).mean() < 0.005
        da, db = (np.load(d / view / "depth.npy") for d in (a, b))
        both = (da > 0) & (db > 0)
        assert ((da > 0) != (db > 0)).mean() < 0.002  # a horizon pixel may see past the edge or not
        np.testing.assert_allclose(da[both], db[both], rtol=1e-4)
    depth = np.load(a / "view_000" / "depth.npy")
    assert (depth > 0).mean() > 0.5


def test_dem_errors_name_the_field(tmp_path, periodic_file):
    with pytest.raises(ConfigError, match="terrain.dem_file: required when location is dem"):
        load_config(None, {"terrain.location": "dem"})
    clear_cache()
    with pytest.raises(OSError, match="terrain.dem_file: .*missing.npz: cannot read"):
        get_terrain(load_config(None, dem_config(tmp_path / "missing.npz")).terrain)
    # 60 m around a site 2100 m east leaves the DEM, which reaches 2138 m east of its origin.
    with pytest.raises(ValueError, match=r"terrain.extent_m: .*reaches only 38.0 m east of it"):
        get_terrain(load_config(None, dem_config(periodic_file, dem_site_m=[2100.0, 0.0])).terrain)
    with pytest.raises(ValueError, match=r"north of it.*import a larger --size-m"):
        get_terrain(load_config(None, dem_config(periodic_file, extent_m=100.0)).terrain)


def test_render_one_dem(tmp_path, periodic_file):
    result = CliRunner().invoke(
        main,
        [
            "render-one",
            "--dem",
            str(periodic_file),
            "--out",
            str(tmp_path / "out"),
            "--no-sheet",
            "--set",
            "terrain.extent_m=60",
            "--set",
            "terrain.growth=1.1",
            "--set",
            "camera.width=96",
            "--set",
            "camera.height=72",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "dem terrain" in result.output
    depth = np.load(tmp_path / "out" / "view_000" / "depth.npy")
    assert np.isfinite(depth).all() and (depth > 0).mean() > 0.5


def test_flat_dem_site_is_the_sphere_about_the_site(tmp_path):
    """A level DEM, no detail: the mesh is the sphere's drop about the site, wherever it is."""
    path = local_dem(np.zeros((85, 2141))).save(tmp_path / "level.npz")
    for site in ([0.0, 0.0], [-2000.0, 20.0]):
        clear_cache()
        config = load_config(
            None, dem_config(path, dem_site_m=site, **{"roughness.rms_slope_deg": 0.0, "craters.density": 0.0})
        ).terrain
        v, _ = get_terrain(config)[0].mesh
        x, y, z = (v[:, k].astype(np.float64) for k in range(3))
        np.testing.assert_allclose(-z, curvature_drop(np.hypot(x, y)), rtol=1e-6, atol=1e-9)
        assert np.abs(z).max() == pytest.approx(curvature_drop(np.array([60.0 * math.sqrt(2)]))[0], rel=1e-3)


def raise_nodes(heights: np.ndarray, spacing: float, east: float, north: float, rise: float, half: int = 0):
    """Raises the (2·half + 1)² nodes around the node nearest (east, north) of a (ny, nx) DEM grid
    centred on its origin by `rise` metres, in place; returns that node's (east, north)."""
    ny, nx = heights.shape
    i, j = int(round(east / spacing + (nx - 1) / 2)), int(round(north / spacing + (ny - 1) / 2))
    heights[j - half : j + half + 1, i - half : i + half + 1] += rise
    return (i - (nx - 1) / 2) * spacing, (j - (ny - 1) / 2) * spacing


@pytest.mark.parametrize("lat0", [-89.9, 89.9])
def test_a_polar_site_shadow_falls_to_its_true_south(tmp_path, lat0):
    """A 25 m pillar at a site 5 km east of a DEM origin at ±89.9°, a 4 m post at the DEM node
    nearest the point 15 m geodetically due south of it (found with GeographicLib from the DEM
    origin alone) and a 6 m post 15 m south of it in the DEM's grid (58.8° away from true south
    there). Found in the built terrain by their heights, both posts stand where their
    selenographic positions put them in the frame gt.json records (the 4 m one near the world's
    (0, −15)); rendered from above with the Sun at azimuth 0, 30° up, the pillar's shadow covers
    the 4 m post and misses the 6 m one, and with the Sun at azimuth 180 the 4 m post is lit.
    Had the world kept the DEM's axes, the 6 m post would stand at (0, −15) in the shadow."""
    s = 1.0
    e = (np.arange(2 * 5100 + 1) - 5100) * s
    n = (np.arange(2 * 60 + 1) - 60) * s
    E, N = np.meshgrid(e, n)
    heights = -curvature_drop(np.hypot(E, N), R)  # the sphere, as a curved import stores it
    origin = _core.LunarFrame(lat0, -60.0, 0.0)
    lat_s, lon_s, _ = origin.to_geodetic(5000.0, 0.0, float(heights[60, 10100]))  # the pillar's foot
    true_south = origin.to_enu(lat_s - math.degrees(15.0 / R), lon_s, 0.0)  # 15 m down its meridian
    raise_nodes(heights, s, 5000.0, 0.0, 25.0, half=1)
    # Single-node posts: their interpolated tops peak at the node itself.
    nodes = {
        "4 m": raise_nodes(heights, s, true_south[0], true_south[1], 4.0),
        "6 m": raise_nodes(heights, s, 5000.0, -15.0, 6.0),
    }
    path = LocalDem(heights=heights, spacing_m=s, lat_deg=lat0, lon_deg=-60.0, h0_m=0.0, curvature=True).save(
        tmp_path / "pole.npz"
    )
    config = load_config(
        None,
        dem_config(
            path,
            dem_site_m=[5000.0, 0.0],
            extent_m=40.0,
            detail_m=0.2,
            detail_extent_m=40.0,
            **{"roughness.rms_slope_deg": 0.0, "craters.density": 0.0},
        ),
    ).terrain
    ground = make_ground(config)
    site = dem_site(config, LocalDem.load(path))
    assert abs(site.north_in_dem_deg) == pytest.approx(58.8, abs=0.05)
    # Where the posts' nodes are in the world frame gt.json describes (its origin is the pillar's top).
    world = _core.LunarFrame(site.lat_deg, site.lon_deg, site.height_m)
    expected = {
        name: world.to_enu(*origin.to_geodetic(e, n, -float(curvature_drop(np.hypot(e, n), R))))[:2]
        for name, (e, n) in nodes.items()
    }
    assert expected["4 m"] == pytest.approx((0.0, -15.0), abs=0.8)  # the node nearest true south

    # The posts as the terrain holds them: the highest points 8–22 m from the pillar.
    x, y = np.meshgrid(np.arange(-25.0, 25.0, 0.1), np.arange(-25.0, 25.0, 0.1))
    r = np.hypot(x, y)
    rise = np.where((r > 8.0) & (r < 22.0), ground.height(x, y) + curvature_drop(r), -np.inf)
    posts = {}
    for name in ("6 m", "4 m"):
        k = np.unravel_index(np.argmax(rise), rise.shape)
        posts[name] = (float(x[k]), float(y[k]))
        rise[np.hypot(x - x[k], y - y[k]) < 4.0] = -np.inf
    for name in posts:
        assert posts[name] == pytest.approx(expected[name], abs=0.3), name

    scene = _core.Scene()
    vertices, triangles = ground.mesh()
    scene.add_background(scene.add_mesh(vertices, triangles), np.eye(4), (0.3, 0.3, 0.3), _core.Photometry())
    scene.commit()
    size, f, centre = 160, 160.0, np.array([0.0, -10.0, 80.0])  # looking straight down: 80 m square
    R_w2c = np.diag([1.0, -1.0, -1.0])
    camera = _core.Camera(f, f, size / 2, size / 2, size, size, R_w2c, -R_w2c @ centre)

    def brightness(sun_azimuth: float, xy: tuple[float, float]) -> float:
        """Mean radiance of the 3 × 3 pixels over a post's top at world `xy`, over the image's median."""
        rgb = _core.render(
            scene, camera, _core.DirectionalLight(sun_azimuth, 30.0, 1361.0, 0.533), _core.RenderSettings(bounces=0)
        )["rgb"]
        top = float(ground.height(np.array([xy[0]]), np.array([xy[1]]))[0])
        u = size / 2 + f * (xy[0] - centre[0]) / (centre[2] - top)
        v = size / 2 - f * (xy[1] - centre[1]) / (centre[2] - top)
        return float(rgb[int(v) - 1 : int(v) + 2, int(u) - 1 : int(u) + 2].mean() / np.median(rgb))

    assert brightness(0.0, posts["4 m"]) < 0.05  # in the pillar's shadow
    assert brightness(0.0, posts["6 m"]) > 0.5
    assert brightness(180.0, posts["4 m"]) > 0.5


def test_polar_site_is_recorded_in_gt_json_and_the_bop_files(tmp_path):
    """A south-pole site 5 km out, rendered as a sweep task and merged: gt.json, the BOP scene's
    scene_camera.json (beside cam_R_w2c, whose world frame it locates) and scene_meta.json carry
    the site's latitude, longitude, height and the turn from the DEM's north to the site's."""
    dem = LocalDem(
        heights=np.zeros((61, 2 * 1300 + 1)), spacing_m=4.0, lat_deg=-89.9, lon_deg=-60.0, h0_m=0.0, curvature=False
    ).save(tmp_path / "pole.npz")
    (tmp_path / "sweep.yaml").write_text(f"""
seed: 4
camera: {{width: 48, height: 36}}
orbit: {{views: 1, radius_m: 0.8}}
render: {{spp: 1, bounces: 0, light_samples: 1}}
terrain: {{location: dem, dem_file: {dem}, dem_site_m: [5000.0, 0.0], extent_m: 40.0, detail_m: 0.1,
           detail_extent_m: 1.0, growth: 1.2}}
bags: {{settle: {{enabled: false}}}}  # the records are the point; a coarse bag on 10 cm relief may slide
meshes:
  sandbag_01: {{edge_length_m: 0.03, edge_steps: 2}}
sweep:
  splits:
    - name: train
      meshes: [sandbag-01]
      bag_counts: [1]
""")
    config = load_config(tmp_path / "sweep.yaml")
    for task in tasks(config):
        run_task(config, task, tmp_path / "out", threads=2)
    site = dem_site(config.terrain, LocalDem.load(dem)).as_json()
    assert site["north_in_dem_deg"] == pytest.approx(58.76, abs=0.01)
    assert site["lat_deg"] == pytest.approx(-89.8072, abs=1e-4) and site["height_m"] == pytest.approx(0.0, abs=1e-6)
    (gt_path,) = (tmp_path / "out").rglob("gt.json")
    assert json.loads(gt_path.read_text())["site"] == site
    report = merge_dataset(tmp_path / "out", config=config, workers=1, progress=None)
    scene = (
        report.dataset / "by_condition" / "train" / "sandbag-01" / "dem" / "scene_000000"
    )  # the view of train_pbr/000000
    assert json.loads((scene / "scene_camera.json").read_text())["0"]["site"] == site
    assert json.loads((scene / "scene_meta.json").read_text())["images"]["0"]["site"] == site
