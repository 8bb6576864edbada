"""The `dem` location: a LocalDem interpolated smoothly (equal to the DEM at its nodes, exact for
quadratics, C1 across pixel edges), its import curvature taken out and the location's own put
back about the site, fractal detail only below the DEM's pixel, clear errors for a DEM that does
not cover the terrain, and a bag 2 km from the DEM's origin rendering byte for byte like one at
the origin."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from moonbot.cli import main
from moonbot.config.load import ConfigError, load_config
from moonbot.pipeline import run_views
from moonbot.terrain import clear_cache, get_terrain
from moonbot.terrain.dem import LocalDem
from moonbot.terrain.location import DEM_CRATER_PIXELS, DemRelief, Location, curvature_drop, location_axis

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
    overrides = {"terrain.location": "dem", "terrain.dem_file": str(path), "terrain.extent_m": 60.0,
                 "terrain.detail_m": 0.05, "terrain.detail_extent_m": 1.0, "terrain.growth": 1.1}
    overrides.update({f"terrain.{k}": v for k, v in terrain.items()})
    return overrides


def test_relief_equals_the_dem_at_nodes_and_quadratics_everywhere():
    n, s = 41, 0.5
    e = (np.arange(n) - 20) * s
    E, N = np.meshgrid(e, e)
    quadratic = lambda x, y: 3.0 + 0.2 * x - 0.1 * y + 0.03 * x * x - 0.02 * x * y + 0.01 * y * y  # noqa: E731
    relief = DemRelief(local_dem(quadratic(E, N), spacing=s), (1.0, -2.0))  # site on a node
    assert relief.site_m == (1.0, -2.0)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-7.0, 7.0, 500), rng.uniform(-7.0, 7.0, 500)
    np.testing.assert_allclose(relief.height(x, y), quadratic(x + 1.0, y - 2.0), rtol=0, atol=1e-12)
    rough = rng.normal(size=(n, n))
    nodes = DemRelief(local_dem(rough, spacing=s), (0.0, 0.0))
    i = rng.integers(-18, 18, size=(2, 50))
    np.testing.assert_array_equal(nodes.height(i[0] * s, i[1] * s), rough[i[1] + 20, i[0] + 20])


def test_relief_has_no_crease_at_pixel_edges():
    """Catmull-Rom is C1: the slope just west and just east of a DEM column agree (a bilinear
    read would jump by the DEM's second difference)."""
    rough = np.random.default_rng(2).normal(size=(31, 31))
    relief = DemRelief(local_dem(rough, spacing=1.0), (0.0, 0.0))
    x = np.arange(-10, 11, dtype=np.float64)
    y = np.full_like(x, 0.37)
    h = 1e-6
    west = (relief.height(x, y) - relief.height(x - h, y)) / h
    east = (relief.height(x + h, y) - relief.height(x, y)) / h
    np.testing.assert_allclose(west, east, atol=1e-4)


def test_import_curvature_is_taken_out_and_put_back_about_the_site():
    """A constant-height surface imported with curvature (the sphere's drop below the DEM origin's
    tangent plane, exact) is level again; the location then drops by d²/2R about the site."""
    s, h0 = 5.0, 812.0
    n = 1601  # ±4 km
    e = (np.arange(n) - 800) * s
    E, N = np.meshgrid(e, e)
    d = np.hypot(E, N)
    curved = np.sqrt((R + h0) ** 2 - d * d) - (R + h0)
    relief = DemRelief(local_dem(curved, spacing=s, curvature=True, h0=h0), (2000.0, 1000.0))
    np.testing.assert_allclose(relief.heights, 0.0, atol=1e-9)
    assert relief.height(np.array([-1990.0, 0.0, 1990.0]), np.array([0.0, 500.0, 0.0])) == pytest.approx(0.0, abs=1e-9)


@pytest.fixture
def periodic_file(tmp_path):
    """A 2 m DEM, 4.3 km east-west, 170 m north-south, repeating every 50 m east-west."""
    nx, ny = 2 * 1070 + 1, 85
    return local_dem(periodic_dem(nx, ny)).save(tmp_path / "periodic.npz")


def test_detail_is_only_below_the_dem_pixel(periodic_file):
    config = load_config(None, dem_config(periodic_file)).terrain
    location = Location(config, location_axis(config), LocalDem.load(periodic_file))
    assert location.roughness.max_wavelength_m == 4.0  # two DEM pixels
    assert location.craters.diameters.max() <= DEM_CRATER_PIXELS * 2.0
    assert location.main_crater is None and location.hills is None
    # Roughness off: the relief is the DEM itself about the site.
    bare = load_config(None, dem_config(periodic_file, **{"roughness.rms_slope_deg": 0.0,
                                                          "craters.density": 0.0})).terrain
    plain = Location(bare, location_axis(bare), LocalDem.load(periodic_file))
    x = np.linspace(-50, 50, 101)
    np.testing.assert_array_equal(plain.surface(x, x * 0.3, np.full_like(x, 0.05)), plain.dem.height(x, x * 0.3))


def test_a_site_2_km_from_the_dem_origin_renders_like_one_at_the_origin(tmp_path, periodic_file):
    """The DEM repeats every 50 m, so the sites (0, 0) and (2000, 0) stand on the same ground:
    after the shift to the site, images, depth, masks and poses must be the same bytes. Without
    the shift, float32 vertices 2 km out are 0.12 mm apart and the 5 cm near grid would show it."""
    outputs = []
    for site in ([0.0, 0.0], [2000.0, 0.0]):
        clear_cache()
        overrides = dem_config(periodic_file, dem_site_m=site)
        # Settle on the rendered surface itself: a height field on the 5 cm mesh's own nodes.
        overrides.update({"camera.width": 96, "camera.height": 72, "bags.settle.ground_step_m": 0.05})
        config = load_config(None, overrides)
        terrain, _ = get_terrain(config.terrain)
        out = tmp_path / f"site_{int(site[0])}"
        run_views(config, [0, 9], out)
        outputs.append((out, terrain))
    (a, ta), (b, tb) = outputs
    np.testing.assert_array_equal(ta.mesh[0], tb.mesh[0])
    for view in ("view_000", "view_009"):
        for name in ("rgb.png", "depth.npy", "mask.png"):
            assert (a / view / name).read_bytes() == (b / view / name).read_bytes(), f"{view}/{name}"
        ga, gb = (json.loads((d / view / "gt.json").read_text()) for d in (a, b))
        for key in ("instances", "cam_R_w2c", "cam_t_w2c", "camera_height_m", "render_seed"):
            assert ga[key] == gb[key], key
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
    result = CliRunner().invoke(main, [
        "render-one", "--dem", str(periodic_file), "--out", str(tmp_path / "out"), "--no-sheet",
        "--set", "terrain.extent_m=60", "--set", "terrain.growth=1.1", "--set", "camera.width=96",
        "--set", "camera.height=72"])
    assert result.exit_code == 0, result.output
    assert "dem terrain" in result.output
    depth = np.load(tmp_path / "out" / "view_000" / "depth.npy")
    assert np.isfinite(depth).all() and (depth > 0).mean() > 0.5


def test_flat_dem_site_is_the_sphere_about_the_site(tmp_path):
    """A level DEM, no detail: the mesh is the sphere's drop about the site, wherever it is."""
    path = local_dem(np.zeros((85, 2141))).save(tmp_path / "level.npz")
    for site in ([0.0, 0.0], [-2000.0, 20.0]):
        clear_cache()
        config = load_config(None, dem_config(path, dem_site_m=site, **{"roughness.rms_slope_deg": 0.0,
                                                                        "craters.density": 0.0})).terrain
        v, _ = get_terrain(config)[0].mesh
        x, y, z = (v[:, k].astype(np.float64) for k in range(3))
        np.testing.assert_allclose(-z, curvature_drop(np.hypot(x, y)), rtol=1e-6, atol=1e-9)
        assert np.abs(z).max() == pytest.approx(curvature_drop(np.array([60.0 * math.sqrt(2)]))[0], rel=1e-3)
