"""DEM import end to end: synthetic GeoTIFFs (written with tifffile, GeoTIFF and GDAL tags set
by hand) and 16-bit PNGs (Pillow) holding known planes, imported and compared at every node with
closed forms computed here in numpy, independently of GeographicLib; voids, bad input, the
LocalDem file and the `terrain import` command."""

from __future__ import annotations

import math
import os
import re
import struct
import zlib

import numpy as np
import pytest
import tifffile
from click.testing import CliRunner
from PIL import Image, TiffImagePlugin

from moonbot import _core
from moonbot.cli import main
from moonbot.terrain.dem import LocalDem, import_dem

pytestmark = pytest.mark.unit

R = 1737400.0  # the lunar reference sphere, metres (SLDEM2015's datum)


# --- closed forms -------------------------------------------------------------------------------


def radial_latlon(east, north, lat0, lon0, h0):
    """Lat/lon (degrees) of the radial through the tangent-plane point (east, north, 0) of the
    ENU frame at (lat0, lon0, h0) on the sphere: the ground directly below a flat-grid node."""
    p, l = math.radians(lat0), math.radians(lon0)
    e_axis = np.array([-math.sin(l), math.cos(l), 0.0])
    n_axis = np.array([-math.sin(p) * math.cos(l), -math.sin(p) * math.sin(l), math.cos(p)])
    u_axis = np.array([math.cos(p) * math.cos(l), math.cos(p) * math.sin(l), math.sin(p)])
    v = np.multiply.outer(east, e_axis) + np.multiply.outer(north, n_axis) + (R + h0) * u_axis
    lat = np.degrees(np.arctan2(v[..., 2], np.hypot(v[..., 0], v[..., 1])))
    lon = np.degrees(np.arctan2(v[..., 1], v[..., 0]))
    return lat, lon


def node_grid(dem: LocalDem):
    """East and north of every node, (ny, nx) each."""
    return np.meshgrid(dem.east_m, dem.north_m)


def geotiff(
    path,
    data,
    *,
    model,
    pixel_scale,
    tiepoint,
    raster_type=1,
    proj=(),
    gdal_scale=None,
    gdal_offset=None,
    nodata=None,
    ct=17,
    **write,
):
    """Writes `data` (row 0 = north) as a GeoTIFF. model 2 = geographic (degrees), 1 = projected
    (metres, projection `ct`: 17 equirectangular, 21 orthographic, 15 polar stereographic;
    `proj` = ((GeoKey id, value), ...) stored in GeoDoubleParams).
    tiepoint = (i, j, x, y): raster point (i, j) is model point (x, y)."""
    keys = [(1024, 0, 1, model), (1025, 0, 1, raster_type)]
    doubles: list[float] = []
    if model == 2:
        keys.append((2054, 0, 1, 9102))  # degrees
    else:
        keys += [(3072, 0, 1, 32767), (3075, 0, 1, ct), (3076, 0, 1, 9001)]  # user-defined, metres
        for key, value in proj:
            keys.append((key, 34736, 1, len(doubles)))
            doubles.append(value)
    keys.sort()
    directory = [1, 1, 0, len(keys)] + [v for k in keys for v in k]
    i, j, x, y = tiepoint  # raster point (i, j) is model point (x, y)
    tags = [
        (33550, "d", 3, (*pixel_scale, 0.0), True),
        (33922, "d", 6, (i, j, 0.0, x, y, 0.0), True),
        (34735, "H", len(directory), directory, True),
    ]
    if doubles:
        tags.append((34736, "d", len(doubles), doubles, True))
    items = []
    if gdal_scale is not None:
        items.append(f'<Item name="SCALE" sample="0" role="scale">{gdal_scale!r}</Item>')
    if gdal_offset is not None:
        items.append(f'<Item name="OFFSET" sample="0" role="offset">{gdal_offset!r}</Item>')
    if items:
        tags.append((42112, "s", 0, "<GDALMetadata>\n  " + "\n  ".join(items) + "\n</GDALMetadata>", True))
    if nodata is not None:
        tags.append((42113, "s", 0, nodata, True))
    tifffile.imwrite(path, data, extratags=tags, photometric="minisblack", **write)
    return path


# A geographic raster around (LAT0, LON0): 1/4096° pixels (7.4 m north-south), 301 × 301.
LAT0, LON0 = 20.0, 10.0
STEP = 1.0 / 4096
N_PX = 301


def geographic_centres():
    """Lat/lon of the pixel centres of the geographic test raster, (N_PX,) each."""
    lon = LON0 - 150 * STEP + np.arange(N_PX) * STEP
    lat = LAT0 + 150 * STEP - np.arange(N_PX) * STEP
    return lat, lon


def geographic_tiepoint(raster_type):
    """The tiepoint that puts pixel (0, 0)'s centre at (LAT0 + 150 STEP, LON0 − 150 STEP)."""
    half = 0.5 * STEP if raster_type == 1 else 0.0  # PixelIsArea ties the pixel's outer corner
    return (0.0, 0.0, LON0 - 150 * STEP - half, LAT0 + 150 * STEP + half)


# --- planes import exactly ----------------------------------------------------------------------


@pytest.mark.parametrize("raster_type", [1, 2], ids=["pixel-is-area", "pixel-is-point"])
# 7-row strips put the crop's first and last rows mid-strip; 16 × 16 tiles put its edges mid-tile
# (OpenImageIO 2.4.7, which decoded these before, read both as zeros for float64).
@pytest.mark.parametrize(
    "layout",
    [
        {},
        {"byteorder": ">"},
        {"compression": "zlib"},
        {"rowsperstrip": 7},
        {"tile": (16, 16)},
        {"tile": (16, 16), "compression": "zlib", "bigtiff": True},
    ],
    ids=["one-strip", "big-endian", "deflate", "7-row-strips", "tiles", "bigtiff-deflate-tiles"],
)
def test_geographic_float64_plane_is_exact(tmp_path, raster_type, layout):
    """h = a·east + b·north + c with east/north the raster's local metres (linear in its
    degrees), imported flat: every node matches the plane at the ground below it to 1e-6 m."""
    a, b, c = 0.12, -0.07, -1234.5
    lat, lon = geographic_centres()
    east = R * math.cos(math.radians(LAT0)) * np.radians(lon - LON0)
    north = R * np.radians(lat - LAT0)
    heights = a * east[None, :] + b * north[:, None] + c
    path = geotiff(
        tmp_path / "plane.tif",
        heights,
        model=2,
        pixel_scale=(STEP, STEP),
        tiepoint=geographic_tiepoint(raster_type),
        raster_type=raster_type,
        **layout,
    )
    lat_c, lon_c = LAT0 + 0.003, LON0 - 0.002  # not on a pixel centre
    dem = import_dem(path, lat_c, lon_c, 600.0, spacing_m=10.0, curvature=False)
    h_c = a * R * math.cos(math.radians(LAT0)) * math.radians(lon_c - LON0) + b * R * math.radians(lat_c - LAT0) + c
    assert dem.h0_m == pytest.approx(h_c, abs=1e-9)
    e, n = node_grid(dem)
    nlat, nlon = radial_latlon(e, n, lat_c, lon_c, dem.h0_m)
    want = a * R * math.cos(math.radians(LAT0)) * np.radians(nlon - LON0) + b * R * np.radians(nlat - LAT0) + c - h_c
    assert dem.shape == (61, 61)
    np.testing.assert_allclose(dem.heights, want, rtol=0, atol=1e-6)
    assert dem.heights[30, 30] == pytest.approx(0.0, abs=1e-9)  # the origin node
    assert dem.source["voids_filled"] == 0
    assert dem.source["format"] == "GeoTIFF float64, geographic"


@pytest.mark.parametrize("tile", [None, (16, 16)], ids=["strips", "tiles"])
def test_equirectangular_float32_plane_is_exact(tmp_path, tile):
    """Simple cylindrical metres with a standard parallel, central meridian, latitude of origin
    and false easting/northing; the plane's samples are dyadic so float32 holds them exactly."""
    lat_s, lon_c0, lat_o, fe, fn = 15.0, 9.9, 19.5, 1000.0, -2000.0
    dx = 2.0
    x = 700.0 + dx * np.arange(N_PX)  # model X of the pixel centres
    y0 = fn + R * math.radians(LAT0 - lat_o) + 300.0
    y = y0 - dx * np.arange(N_PX)
    a, b, c = 1 / 32, -1 / 64, 100.0
    heights = (a * x[None, :] + b * (y[:, None] - y0) + c).astype(np.float32)
    assert np.array_equal(heights.astype(np.float64), a * x[None, :] + b * (y[:, None] - y0) + c)
    proj = ((3078, lat_s), (3082, fe), (3083, fn), (3088, lon_c0), (3089, lat_o))
    path = geotiff(
        tmp_path / "eqc.tif",
        heights,
        model=1,
        pixel_scale=(dx, dx),
        tiepoint=(0.0, 0.0, x[0] - dx / 2, y0 + dx / 2),
        proj=proj,
        tile=tile,
    )

    def model_xy(lat, lon):
        return (fe + R * np.radians(lon - lon_c0) * math.cos(math.radians(lat_s)), fn + R * np.radians(lat - lat_o))

    # The crop centre in the middle of the raster: model (1000 + 7, y0 − 300 + 5).
    lat_c = lat_o + math.degrees((y0 - 295.0 - fn) / R)
    lon_c = lon_c0 + math.degrees((1007.0 - fe) / (R * math.cos(math.radians(lat_s))))
    dem = import_dem(path, lat_c, lon_c, 400.0, spacing_m=5.0, curvature=False)
    e, n = node_grid(dem)
    X, Y = model_xy(*radial_latlon(e, n, lat_c, lon_c, dem.h0_m))
    np.testing.assert_allclose(dem.heights, a * (X - 1007.0) + b * (Y - (y0 - 295.0)), rtol=0, atol=1e-6)
    assert dem.h0_m == pytest.approx(a * 1007.0 - b * 295.0 + c, abs=1e-9)
    assert dem.source["format"] == "GeoTIFF float32, equirectangular"
    # The source pixel: 2 m model metres, true to scale at 15°, so narrower at ~20°.
    assert dem.source["pixel_north_m"] == pytest.approx(2.0, rel=1e-12)
    assert dem.source["pixel_east_m"] == pytest.approx(
        2.0 * math.cos(math.radians(lat_c)) / math.cos(math.radians(lat_s)), rel=1e-12
    )


def ortho_xy(lat, lon, lat0, lon0):
    """Snyder (1987) eqs. 20-3, 20-4 on the 1737.4 km sphere: orthographic model metres."""
    p, p0, dl = np.radians(lat), math.radians(lat0), np.radians(lon - lon0)
    return R * np.cos(p) * np.sin(dl), R * (math.cos(p0) * np.sin(p) - math.sin(p0) * np.cos(p) * np.cos(dl))


def polar_xy(lat, lon, lon0, k0, south=True):
    """Snyder (1987) eqs. 21-5 to 21-9 on the sphere: polar stereographic model metres."""
    s = -1.0 if south else 1.0
    rho = 2 * R * k0 * np.tan(math.pi / 4 - s * np.radians(lat) / 2)
    return rho * np.sin(np.radians(lon - lon0)), -s * rho * np.cos(np.radians(lon - lon0))


@pytest.mark.parametrize("projection", ["orthographic", "polar-a", "polar-b"])
def test_orthographic_and_polar_stereographic_planes_are_exact(tmp_path, projection):
    """A plane in model metres of an orthographic raster about Kepler crater (as LOLA crater
    cut-outs are) and of south polar stereographic rasters (as the LOLA polar DEMs are; variant A
    names k0 at the pole, variant B a latitude of true scale) imports exactly."""
    dx = 4.0
    if projection == "orthographic":
        lat0, lon0 = 8.12, -38.01
        proj = ((3088, lon0), (3089, lat0))
        ct, model_xy = 21, (lambda lat, lon: ortho_xy(lat, lon, lat0, lon0))
        lat_c, lon_c = 8.2, -37.9
    else:
        k0 = 1.0 if projection == "polar-a" else (1 + math.sin(math.radians(80.0))) / 2
        proj = ((3095, 0.0), (3081, -90.0)) if projection == "polar-a" else ((3095, 0.0), (3081, -80.0))
        ct, model_xy = 15, (lambda lat, lon: polar_xy(lat, lon, 0.0, k0))
        lat_c, lon_c = -89.4, 45.0  # near Shackleton, where the Artemis sites are
    xc, yc = model_xy(lat_c, lon_c)
    x = xc - 600.0 + dx * np.arange(N_PX)
    y = yc + 600.0 - dx * np.arange(N_PX)
    a, b, c = 1 / 32, -1 / 64, -2000.0
    heights = (a * (x[None, :] - x[0]) + b * (y[:, None] - y[0]) + c).astype(np.float32)
    assert np.array_equal(heights.astype(np.float64), a * (x[None, :] - x[0]) + b * (y[:, None] - y[0]) + c)
    path = geotiff(
        tmp_path / "proj.tif",
        heights,
        model=1,
        pixel_scale=(dx, dx),
        tiepoint=(0.0, 0.0, x[0] - dx / 2, y[0] + dx / 2),
        proj=proj,
        ct=ct,
    )
    dem = import_dem(path, lat_c, lon_c, 800.0, spacing_m=5.0, curvature=False)
    e, n = node_grid(dem)
    X, Y = model_xy(*radial_latlon(e, n, lat_c, lon_c, dem.h0_m))
    np.testing.assert_allclose(dem.heights, a * (X - xc) + b * (Y - yc), rtol=0, atol=1e-6)
    assert dem.source["format"] == "GeoTIFF float32, " + ("orthographic" if ct == 21 else "polar stereographic")


def test_int16_plane_with_gdal_scale_offset_is_exact(tmp_path):
    """LOLA-style int16 with GDAL scale 0.5 and an offset: raw = k + 3i − 2j, h = 0.5·raw + off,
    a plane in pixel coordinates, exact at every node."""
    i, j = np.meshgrid(np.arange(N_PX), np.arange(N_PX))
    raw = (-200 + 3 * i - 2 * j).astype(np.int16)
    offset = -1500.25
    path = geotiff(
        tmp_path / "lola.tif",
        raw,
        model=2,
        pixel_scale=(STEP, STEP),
        tiepoint=geographic_tiepoint(1),
        gdal_scale=0.5,
        gdal_offset=offset,
    )
    lat_c, lon_c = LAT0 - 0.001, LON0 + 0.0015
    dem = import_dem(path, lat_c, lon_c, 500.0, spacing_m=7.0, curvature=False)

    def uv(lat, lon):  # raster coordinates, integers at pixel centres
        return (lon - (LON0 - 150 * STEP)) / STEP, (LAT0 + 150 * STEP - lat) / STEP

    def relative(d: LocalDem, factor: float):  # the plane under each node, minus h0
        u, v = uv(*radial_latlon(*node_grid(d), lat_c, lon_c, d.h0_m))
        return factor * 0.5 * (3 * (u - uc) - 2 * (v - vc))

    uc, vc = uv(lat_c, lon_c)
    assert dem.h0_m == pytest.approx(0.5 * (-200 + 3 * uc - 2 * vc) + offset, abs=1e-9)
    np.testing.assert_allclose(dem.heights, relative(dem, 1.0), rtol=0, atol=1e-6)
    assert dem.source["height_scale"] == 0.5 and dem.source["height_offset_m"] == offset

    # The caller's scale and offset compose with the file's: h = (0.5·raw + off)·2 + 10. (The
    # nodes sit on the tangent plane at the new h0, so the ground under them moves a little too.)
    twice = import_dem(path, lat_c, lon_c, 500.0, spacing_m=7.0, curvature=False, scale=2.0, offset=10.0)
    assert twice.h0_m == pytest.approx(2 * dem.h0_m + 10.0, abs=1e-9)
    np.testing.assert_allclose(twice.heights, relative(twice, 2.0), rtol=0, atol=1e-6)
    assert twice.source["height_scale"] == 1.0 and twice.source["height_offset_m"] == 2 * offset + 10.0


def test_wide_raster_is_read_in_bands(tmp_path):
    """A wide raster (24000 float32 columns, one row per strip): the crop reads its own columns
    of each of its ~100 strips, and they join seamlessly."""
    w, h = 24000, 260
    i, j = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    data = (i / 8 - j / 16).astype(np.float32)  # dyadic: exact in float32
    step = 1.0 / 8192
    path = geotiff(
        tmp_path / "wide.tif", data, model=2, pixel_scale=(step, step), tiepoint=(0.0, 0.0, 100.0, 2.0), rowsperstrip=1
    )
    lat_c, lon_c = 2.0 - 130.5 * step, 100.0 + 12000.5 * step  # the centre of pixel (12000, 130)
    dem = import_dem(path, lat_c, lon_c, 800.0, spacing_m=8.0, curvature=False)
    fp = dem.source["footprint_px"]
    assert fp[3] - fp[1] > 100  # the crop spans more than one band of rows
    nlat, nlon = radial_latlon(*node_grid(dem), lat_c, lon_c, dem.h0_m)
    u, v = (nlon - 100.0) / step - 0.5, (2.0 - nlat) / step - 0.5
    np.testing.assert_allclose(dem.heights, (u - 12000) / 8 - (v - 130) / 16, rtol=0, atol=1e-6)


# --- voids --------------------------------------------------------------------------------------


@pytest.mark.parametrize("marker", ["gdal-nodata", "caller-nodata"])
def test_voids_are_filled_with_the_plane(tmp_path, marker):
    """A nodata block and a NaN block inside the crop come back as the plane (to 1e-4 m); no NaN
    reaches the output; the filled pixels are counted."""
    a, b = 0.25, 0.125
    i, j = np.meshgrid(np.arange(N_PX), np.arange(N_PX))
    plane = 50.0 + a * i + b * j
    data = plane.astype(np.float32)
    data[140:150, 135:147] = -9999.0
    data[155:160, 152:160] = np.nan
    data[151, 151] = np.inf
    voids = 10 * 12 + 5 * 8 + 1
    nodata = {"nodata": "-9999"} if marker == "gdal-nodata" else {}
    path = geotiff(
        tmp_path / "holes.tif", data, model=2, pixel_scale=(STEP, STEP), tiepoint=geographic_tiepoint(1), **nodata
    )
    caller = {} if marker == "gdal-nodata" else {"nodata": -9999.0}
    dem = import_dem(path, LAT0, LON0, 300.0, spacing_m=3.0, curvature=False, **caller)
    assert np.isfinite(dem.heights).all()
    assert dem.source["voids_filled"] == voids
    nlat, nlon = radial_latlon(*node_grid(dem), LAT0, LON0, dem.h0_m)
    u, v = (nlon - (LON0 - 150 * STEP)) / STEP, (LAT0 + 150 * STEP - nlat) / STEP
    assert dem.h0_m == pytest.approx(50.0 + a * 150 + b * 150, abs=1e-9)  # the centre pixel
    np.testing.assert_allclose(dem.heights, a * (u - 150) + b * (v - 150), rtol=0, atol=1e-4)
    # Without a nodata marker the −9999 block is data, and shows as a pit.
    if marker == "caller-nodata":
        pit = import_dem(path, LAT0, LON0, 300.0, spacing_m=3.0, curvature=False)
        assert pit.heights.min() < -9000 and pit.source["voids_filled"] == voids - 10 * 12


# --- 16-bit PNG ---------------------------------------------------------------------------------


def test_png_heightmap_imports_within_one_quantisation_step(tmp_path):
    """A plane in the PNG's local metres, quantised to 16 bits over [min, max]: the import
    matches the continuous plane within one step at every node, the crop off the image centre."""
    w, h, pixel = 241, 201, 1.5
    lo, hi = -120.0, 535.35
    step = (hi - lo) / 65535
    lat_c, lon_c = -45.0, 200.0  # image centre; lon beyond 180 on purpose
    east = (np.arange(w) - (w - 1) / 2) * pixel
    north = ((h - 1) / 2 - np.arange(h)) * pixel
    true = 200.0 + 0.4 * east[None, :] - 0.3 * north[:, None]
    raw = np.round((true - lo) / step).astype(np.uint16)
    path = tmp_path / "height.png"
    Image.fromarray(raw).save(path)
    with Image.open(path) as written:
        assert written.mode == "I;16"

    # The crop is centred 30 m east and 20 m south of the image centre.
    crop_lat = lat_c + math.degrees(-20.0 / R)
    crop_lon = lon_c - 360 + math.degrees(30.0 / (R * math.cos(math.radians(lat_c))))
    dem = import_dem(
        path,
        crop_lat,
        crop_lon,
        150.0,
        spacing_m=2.0,
        curvature=False,
        png_range=(lo, hi),
        png_pixel_m=pixel,
        png_center=(lat_c, lon_c),
    )
    nlat, nlon = radial_latlon(*node_grid(dem), crop_lat, crop_lon, dem.h0_m)
    e = R * np.radians((nlon - lon_c + 180) % 360 - 180) * math.cos(math.radians(lat_c))
    n = R * np.radians(nlat - lat_c)
    want = 0.4 * (e - 30.0) - 0.3 * (n + 20.0)
    assert np.abs(dem.heights - want).max() <= step
    assert dem.h0_m == pytest.approx(200.0 + 0.4 * 30.0 - 0.3 * -20.0, abs=step)
    assert dem.source["format"] == "PNG uint16, local equirectangular"
    assert dem.source["pixel_north_m"] == pytest.approx(pixel, rel=1e-12)
    assert dem.source["pixel_m"] == pytest.approx(pixel, rel=1e-4)  # east narrows off the centre


def test_png_needs_its_layout_and_16_bits(tmp_path):
    path = tmp_path / "h.png"
    Image.fromarray(np.zeros((8, 8), np.uint16)).save(path)
    with pytest.raises(ValueError, match=r"h\.png: a PNG heightmap needs png_range .* and png_pixel_m"):
        import_dem(path, 0.0, 0.0, 5.0)
    eight = tmp_path / "h8.png"
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(eight)
    with pytest.raises(OSError, match=r"h8\.png: uint8 samples; a PNG heightmap must be 16-bit"):
        import_dem(eight, 0.0, 0.0, 5.0, png_range=(0.0, 1.0), png_pixel_m=1.0)
    with pytest.raises(ValueError, match="png_range: max must exceed min"):
        import_dem(path, 0.0, 0.0, 5.0, png_range=(1.0, 1.0), png_pixel_m=1.0)


# --- kilometre scale ----------------------------------------------------------------------------


def test_constant_dem_is_the_same_from_two_centres_2_km_apart(tmp_path):
    """A constant-height DEM cropped around two centres 2 km apart gives the same heights after
    the local shift: the sphere's drop below each tangent plane, −(R+h) + √((R+h)² − d²)."""
    step = 1.0 / 1024  # 29.6 m
    height = 812.0
    data = np.full((513, 513), height, np.float32)
    path = geotiff(
        tmp_path / "flat.tif",
        data,
        model=2,
        pixel_scale=(step, step),
        tiepoint=(0.0, 0.0, 30.0 - 256.5 * step, 5.0 + 256.5 * step),
    )
    first = import_dem(path, 5.0, 30.0, 3000.0, spacing_m=25.0)
    shifted_lon = 30.0 + math.degrees(2000.0 / (R * math.cos(math.radians(5.0))))
    second = import_dem(path, 5.0, shifted_lon, 3000.0, spacing_m=25.0)
    assert first.shape == second.shape == (121, 121)
    assert first.h0_m == pytest.approx(height, abs=1e-9) and second.h0_m == pytest.approx(height, abs=1e-9)
    # Identical up to double rounding of ECEF coordinates at 1737 km (~1e-10 m).
    np.testing.assert_allclose(first.heights, second.heights, rtol=0, atol=1e-9)
    e, n = node_grid(first)
    drop = np.vectorize(_core.curvature_drop)(np.hypot(e, n), R + height)
    np.testing.assert_allclose(first.heights, -drop, rtol=1e-6, atol=1e-9)
    assert first.heights[0, 0] == pytest.approx(-((1500 * math.sqrt(2)) ** 2) / (2 * (R + height)), rel=1e-4)


# --- bad input ----------------------------------------------------------------------------------


def flat_geographic(tmp_path, name="ok.tif", data=None, **kw):
    if data is None:
        data = np.zeros((N_PX, N_PX), np.float32)
    return geotiff(tmp_path / name, data, model=2, pixel_scale=(STEP, STEP), tiepoint=geographic_tiepoint(1), **kw)


def test_missing_file_names_it(tmp_path):
    with pytest.raises(OSError, match=r"nope\.tif: no such file"):
        import_dem(tmp_path / "nope.tif", 0.0, 0.0, 10.0)


def test_not_a_geotiff_names_the_file_and_tag(tmp_path):
    plain = tmp_path / "plain.tif"
    tifffile.imwrite(plain, np.zeros((4, 4), np.float32))
    with pytest.raises(OSError, match=r"plain\.tif: no ModelPixelScale tag \(33550\); not a GeoTIFF\?"):
        import_dem(plain, 0.0, 0.0, 10.0)
    text = tmp_path / "text.tif"
    text.write_text("hello, not a tiff")
    with pytest.raises(OSError, match=r"text\.tif: not a TIFF file"):
        import_dem(text, 0.0, 0.0, 10.0)
    truncated = tmp_path / "cut.tif"
    truncated.write_bytes(flat_geographic(tmp_path).read_bytes()[:12])
    with pytest.raises(OSError, match=r"cut\.tif: TIFF .* past the end of the file"):
        import_dem(truncated, 0.0, 0.0, 10.0)


def test_unsupported_georeferences_name_the_key(tmp_path):
    def projected(name: str, ct: int, **keys):
        """An 8 × 8 projected GeoTIFF (model 1) of 5 m pixels in coordinate transformation `ct`."""
        zeros = np.zeros((8, 8), np.float32)
        return geotiff(tmp_path / name, zeros, model=1, pixel_scale=(5.0, 5.0), tiepoint=(0, 0, 0, 0), ct=ct, **keys)

    albers = projected("albers.tif", 11)  # CT_AlbersEqualArea
    with pytest.raises(
        OSError,
        match=r"albers\.tif: ProjCoordTransGeoKey \(3075\) = 11; only 17 \(equirectangular\), "
        r"21 \(orthographic\) or 15",
    ):
        import_dem(albers, 0.0, 0.0, 10.0)
    both = projected("both.tif", 15, proj=((3081, -80.0), (3092, 0.99)))
    with pytest.raises(OSError, match=r"both\.tif: both a latitude of true scale \(3081 = -80\) and a scale"):
        import_dem(both, -89.0, 0.0, 10.0)
    lzma = geotiff(
        tmp_path / "lzma.tif",
        np.zeros((32, 32), np.float32),
        model=2,
        pixel_scale=(STEP, STEP),
        tiepoint=(0, 0, 0, 0),
        compression="lzma",
    )
    with pytest.raises(
        OSError,
        match=r"lzma\.tif: Compression \(259\) = 34925 \(LZMA\) is not supported; use none, "
        r"LZW, Deflate or PackBits",
    ):
        import_dem(lzma, 0.0, 0.0, 10.0)
    rgb = tmp_path / "rgb.tif"
    tifffile.imwrite(
        rgb,
        np.zeros((8, 8, 3), np.uint8),
        extratags=[(33550, "d", 3, (1.0, 1.0, 0.0), True), (33922, "d", 6, (0,) * 6, True)],
    )
    with pytest.raises(OSError, match=r"rgb\.tif: 3 channels"):
        import_dem(rgb, 0.0, 0.0, 10.0)


def test_crop_outside_the_raster_names_the_file_and_bound(tmp_path):
    path = flat_geographic(tmp_path)
    # The raster spans ±150/4096° ≈ ±1.1 km north-south; a 3 km crop leaves it north and south.
    with pytest.raises(
        ValueError,
        match=r"ok\.tif: a 3000 m crop .* leaves the raster .* north edge"
        r" .*row 0, is at lat 20\.03",
    ):
        import_dem(path, LAT0, LON0, 3000.0)
    with pytest.raises(ValueError, match=r"ok\.tif: .* past its west edge"):
        import_dem(path, LAT0, LON0 - 0.1, 100.0)


def test_all_void_crop_names_the_file(tmp_path):
    data = np.full((N_PX, N_PX), -32768.0, np.float32)
    data[:, :20] = 1.0  # data far west of the crop
    path = flat_geographic(tmp_path, "void.tif", data, nodata="-32768")
    with pytest.raises(ValueError, match=r"void\.tif: every source pixel under the crop is void .*nodata -32768"):
        import_dem(path, LAT0, LON0, 200.0)


@pytest.mark.parametrize("size_m", [0.0, -10.0, math.nan, math.inf])
def test_bad_size_names_the_field(tmp_path, size_m):
    with pytest.raises(ValueError, match="^size_m: "):
        import_dem(flat_geographic(tmp_path), LAT0, LON0, size_m)


def test_bad_arguments_name_the_field(tmp_path):
    path = flat_geographic(tmp_path)
    with pytest.raises(ValueError, match="^spacing_m: "):
        import_dem(path, LAT0, LON0, 100.0, spacing_m=0.0)
    with pytest.raises(ValueError, match="^lat_deg: "):
        import_dem(path, 95.0, LON0, 100.0)
    with pytest.raises(ValueError, match="^height_scale: "):
        import_dem(path, LAT0, LON0, 100.0, scale=0.0)
    with pytest.raises(ValueError, match="^png_range/png_pixel_m: given for a GeoTIFF"):
        import_dem(path, LAT0, LON0, 100.0, png_range=(0.0, 1.0), png_pixel_m=1.0)


# --- every codec, and damaged files -------------------------------------------------------------


def block_table(path):
    """The first image's block table as tifffile reads it: (offsets, byte counts, 'strip' or 'tile',
    the offsets tag, the byte counts tag)."""
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        kind = "tile" if page.is_tiled else "strip"
        offsets_tag = page.tags["TileOffsets" if page.is_tiled else "StripOffsets"]
        counts_tag = page.tags["TileByteCounts" if page.is_tiled else "StripByteCounts"]
        return list(page.dataoffsets), list(page.databytecounts), kind, offsets_tag, counts_tag


def block_rows(path, k):
    """The message's "strip k (rows a–b)" or "tile k (rows a–b, columns c–d)" for block k."""
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        height, width = page.shape
        if page.is_tiled:
            th, tw = page.tilelength, page.tilewidth
            by, bx = divmod(k, -(-width // tw))
            return (
                f"tile {k} (rows {by * th}–{min(height, (by + 1) * th) - 1}, "
                f"columns {bx * tw}–{min(width, (bx + 1) * tw) - 1})"
            )
        rows = page.rowsperstrip
        return f"strip {k} (rows {k * rows}–{min(height, (k + 1) * rows) - 1})"


def patch_value(path, tag, index, value):
    """Overwrites value `index` of a TIFF tag in place, in the tag's own type and byte order."""
    with tifffile.TiffFile(path) as tif:
        byteorder = tif.byteorder
        at, dtype = tag.valueoffset, tag.dtype
    fmt = byteorder + {1: "B", 3: "H", 4: "I", 16: "Q"}[int(dtype)]
    data = bytearray(path.read_bytes())
    struct.pack_into(fmt, data, at + index * struct.calcsize(fmt), value)
    path.write_bytes(bytes(data))


def rewrite_block(path, k, stored: bytes):
    """Replaces block k's stored bytes with `stored`: in place when they fit, else appended to the
    file; its offset and byte count are patched to match. The file is not truncated."""
    offsets, counts, _, offsets_tag, counts_tag = block_table(path)
    data = bytearray(path.read_bytes())
    if len(stored) <= counts[k]:
        data[offsets[k] : offsets[k] + len(stored)] = stored
        at = offsets[k]
    else:
        at = len(data)
        data += stored
    path.write_bytes(bytes(data))
    patch_value(path, offsets_tag, k, at)
    patch_value(path, counts_tag, k, len(stored))


def rough(shape=(N_PX, N_PX), dtype=np.float32, seed=5):
    """Heights that deflate cannot shrink to nothing, so every block holds real bytes."""
    return (np.random.default_rng(seed).normal(0.0, 30.0, size=shape) + 500.0).astype(dtype)


def pillow_geotiff(path, data, compression, predictor=None, rows_per_strip=16):
    """`data` (row 0 = north) as a GeoTIFF written by Pillow through libtiff, the reference TIFF
    codec library (LZW, PackBits, Deflate, predictors), with the geographic raster's tags."""
    info = TiffImagePlugin.ImageFileDirectory_v2()
    for tag, values, kind in (
        (33550, (STEP, STEP, 0.0), 12),
        (33922, (0.0, 0.0, 0.0, *geographic_tiepoint(1)[2:], 0.0), 12),
        (34735, (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2054, 0, 1, 9102), 3),
    ):
        info[tag] = values
        info.tagtype[tag] = kind
    info[278] = rows_per_strip
    if predictor is not None:
        info[317] = predictor
    Image.fromarray(data).save(path, compression=compression, tiffinfo=info)
    return path


CROP = dict(lat_deg=LAT0 + 0.003, lon_deg=LON0 - 0.002, size_m=1200.0, spacing_m=10.0, curvature=False)


def crop(path):
    c = CROP
    return import_dem(path, c["lat_deg"], c["lon_deg"], c["size_m"], spacing_m=c["spacing_m"], curvature=False)


@pytest.mark.parametrize(
    "dtype,compression,predictor",
    [
        (np.float32, "tiff_lzw", None),
        (np.float32, "tiff_lzw", 3),
        (np.float32, "tiff_adobe_deflate", 3),
        (np.float32, "packbits", None),
        (np.int32, "tiff_lzw", 2),
        (np.int32, "tiff_adobe_deflate", 2),
        (np.uint16, "tiff_lzw", 2),
        (np.uint16, "packbits", None),
    ],
)
def test_libtiff_codecs_decode_like_the_uncompressed_file(tmp_path, dtype, compression, predictor):
    """Files libtiff wrote with LZW, PackBits or Deflate and the horizontal or floating-point
    predictor give, node for node, the same bytes as the same samples stored uncompressed."""
    data = rough(dtype=dtype)
    if dtype == np.uint16:
        data = (data.astype(np.float64) * 40).astype(np.uint16)  # the whole 16-bit range in use
    path = pillow_geotiff(tmp_path / "codec.tif", data, compression, predictor)
    assert np.array_equal(np.asarray(Image.open(path)), data)  # libtiff reads its own file back
    if compression == "tiff_adobe_deflate":  # the predictor really changed the stored bytes
        offsets, counts, *_ = block_table(path)
        assert zlib.decompress(path.read_bytes()[offsets[0] : offsets[0] + counts[0]]) != data[:16].tobytes()
    plain = flat_geographic(tmp_path, "plain.tif", data)
    got, want = crop(path), crop(plain)
    assert got.heights.tobytes() == want.heights.tobytes() and got.h0_m == want.h0_m


LAYOUTS = {
    "strips": {"rowsperstrip": 16},
    "deflate-strips": {"rowsperstrip": 16, "compression": "zlib"},
    "tiles": {"tile": (64, 64)},
    "deflate-tiles": {"tile": (64, 64), "compression": "zlib"},
}


@pytest.mark.parametrize("layout", LAYOUTS.values(), ids=LAYOUTS.keys())
def test_truncated_geotiff_names_the_file_and_the_block(tmp_path, layout):
    """A file cut short anywhere fails on opening: in the header, in the directory or its tag
    values, or in any strip or tile (the first, one in the middle, the last by one byte), naming
    the file, the block, the bytes it needs and the file's size; never zeros for the lost part."""
    whole = flat_geographic(tmp_path, "whole.tif", rough(), **layout).read_bytes()
    offsets, counts, kind, *_ = block_table(tmp_path / "whole.tif")
    assert len(offsets) >= 19 and sorted(offsets) == offsets  # blocks in file order, data last
    with tifffile.TiffFile(tmp_path / "whole.tif") as tif:
        keys = tif.pages[0].tags[34735]  # GeoKeyDirectory: stored after the IFD, before the pixels
        keys_at, keys_end = keys.valueoffset, keys.valueoffset + keys.valuebytecount
    cut = tmp_path / "cut.tif"
    for size, expect in (
        (5, r"the TIFF header is cut short: the file has 5 bytes, the header needs 8"),
        (20, r"TIFF first IFD lies past the end of the file"),
        (
            keys_at + 4,
            rf"TIFF GeoKeyDirectory \(34735\) lies past the end of the file: it needs bytes "
            rf"{keys_at}–{keys_end - 1}, the file has {keys_at + 4} \(truncated\?\)",
        ),
    ):
        cut.write_bytes(whole[:size])
        with pytest.raises(OSError, match=rf"cut\.tif: {expect}"):
            crop(cut)
    for size in (offsets[0] + counts[0] // 2, len(whole) * 6 // 10, len(whole) - 1):
        k = next(i for i, (o, c) in enumerate(zip(offsets, counts)) if o + c > size)
        cut.write_bytes(whole[:size])
        message = (
            rf"cut\.tif: {re.escape(block_rows(tmp_path / 'whole.tif', k))} lies past the end of the file: "
            rf"it needs bytes {offsets[k]}–{offsets[k] + counts[k] - 1} \(.*\), the file has {size} bytes "
            r"\(truncated\?\)"
        )
        with pytest.raises(OSError, match=message):
            crop(cut)
    assert kind in message


def test_damaged_blocks_name_the_file_and_the_block(tmp_path):
    """Blocks that lie inside the file but decode wrong: a Deflate stream of half the strip, a
    corrupt one, one that decodes past its strip; LZW and PackBits data cut short by their byte
    count; an uncompressed strip shorter than its rows; a short Deflate tile."""
    data = rough()
    raw = data.tobytes()
    strip = 16 * N_PX * 4  # bytes in a 16-row float32 strip
    k = 5  # rows 80–95, inside the crop
    rows = rf"strip {k} \(rows 80–95\)"

    def deflate_file(name):
        return flat_geographic(tmp_path, name, data, rowsperstrip=16, compression="zlib")

    short = deflate_file("short.tif")
    rewrite_block(short, k, zlib.compress(raw[k * strip : k * strip + strip // 2]))
    with pytest.raises(
        OSError,
        match=rf"short\.tif: {rows}: Deflate data decode to {strip // 2} bytes; the strip "
        rf"needs {strip} \(16 rows × {N_PX * 4} bytes\)",
    ):
        crop(short)
    corrupt = deflate_file("corrupt.tif")
    stored = bytearray(zlib.compress(raw[k * strip : (k + 1) * strip]))
    stored[0] = 0  # the zlib header's method: not deflate
    rewrite_block(corrupt, k, bytes(stored))
    with pytest.raises(OSError, match=rf"corrupt\.tif: {rows}: the Deflate stream is corrupt after 0 bytes \(zlib: "):
        crop(corrupt)
    long = deflate_file("long.tif")
    rewrite_block(long, k, zlib.compress(raw[k * strip : (k + 2) * strip]))
    with pytest.raises(
        OSError,
        match=rf"long\.tif: {rows}: the Deflate stream decodes to more than the {strip} "
        "bytes expected",
    ):
        crop(long)

    lzw = pillow_geotiff(tmp_path / "lzw.tif", data, "tiff_lzw")
    _, counts, _, _, counts_tag = block_table(lzw)
    patch_value(lzw, counts_tag, k, counts[k] // 2)
    with pytest.raises(OSError, match=rf"lzw\.tif: {rows}: LZW data decode to \d+ bytes; the strip needs {strip} "):
        crop(lzw)
    packbits = pillow_geotiff(tmp_path / "packbits.tif", data, "packbits")
    _, counts, _, _, counts_tag = block_table(packbits)
    patch_value(packbits, counts_tag, k, counts[k] // 2)
    with pytest.raises(
        OSError,
        match=rf"packbits\.tif: {rows}: (the PackBits data are cut short in a literal run|"
        rf"PackBits data decode to \d+ bytes; the strip needs {strip} )",
    ):
        crop(packbits)

    thin = flat_geographic(tmp_path, "thin.tif", data, rowsperstrip=16)
    _, _, _, _, counts_tag = block_table(thin)
    patch_value(thin, counts_tag, k, strip - 4)
    with pytest.raises(
        OSError,
        match=rf"thin\.tif: {rows} holds {strip - 4} bytes \(StripByteCounts \(279\)\); "
        rf"uncompressed it needs {strip} \(16 rows × {N_PX * 4} bytes\)",
    ):
        crop(thin)

    tiles = flat_geographic(tmp_path, "tiles.tif", data, tile=(64, 64), compression="zlib")
    tile = 64 * 64 * 4
    rewrite_block(tiles, 12, zlib.compress(b"\0" * (tile - 8)))  # the middle of 5 × 5 tiles
    with pytest.raises(
        OSError,
        match=rf"tiles\.tif: tile 12 \(rows 128–191, columns 128–191\): Deflate data decode "
        rf"to {tile - 8} bytes; the tile needs {tile} \(64 rows × 256 bytes\)",
    ):
        crop(tiles)


def test_absurd_layouts_name_the_tag(tmp_path):
    """Sizes and offsets that cannot be right: an image 2³² − 1 rows tall, a strip table shorter
    than the image, an offset past the end (no 64-bit overflow in BigTIFF), zero rows per strip."""

    def fresh(name, **kw):
        return flat_geographic(tmp_path, name, rough(), rowsperstrip=16, **kw)

    def tag(path, name):
        with tifffile.TiffFile(path) as tif:
            return tif.pages[0].tags[name]

    tall = fresh("tall.tif")
    patch_value(tall, tag(tall, "ImageLength"), 0, 2**32 - 1)
    with pytest.raises(
        OSError,
        match=rf"tall\.tif: ImageWidth × ImageLength = {N_PX} × 4294967295 pixels is "
        "implausibly large",
    ):
        crop(tall)
    taller = fresh("taller.tif")
    patch_value(taller, tag(taller, "ImageLength"), 0, 1000)
    with pytest.raises(
        OSError,
        match=rf"taller\.tif: StripOffsets \(273\) lists 19 strips; {N_PX} × 1000 pixels in "
        rf"{N_PX} × 16 blocks need 63",
    ):
        crop(taller)
    far = fresh("far.tif", bigtiff=True)
    _, _, _, offsets_tag, _ = block_table(far)
    patch_value(far, offsets_tag, 3, 2**64 - 8)
    with pytest.raises(
        OSError,
        match=r"far\.tif: strip 3 \(rows 48–63\) lies past the end of the file: it needs bytes "
        r"18446744073709551608–",
    ):
        crop(far)
    none = fresh("none.tif")
    patch_value(none, tag(none, "RowsPerStrip"), 0, 0)
    with pytest.raises(OSError, match=r"none\.tif: RowsPerStrip \(278\) = 0"):
        crop(none)


# --- the LocalDem file --------------------------------------------------------------------------


def test_save_load_is_bit_identical_and_deterministic(tmp_path):
    dem = import_dem(
        flat_geographic(tmp_path, data=np.random.default_rng(3).normal(size=(N_PX, N_PX)).astype(np.float32)),
        LAT0,
        LON0,
        300.0,
    )
    first, second = dem.save(tmp_path / "a.npz"), dem.save(tmp_path / "b.npz")
    assert first.read_bytes() == second.read_bytes()
    back = LocalDem.load(first)
    assert back.heights.tobytes() == dem.heights.tobytes() and back.heights.dtype == np.float64
    assert (back.spacing_m, back.lat_deg, back.lon_deg, back.h0_m, back.curvature) == (
        dem.spacing_m,
        dem.lat_deg,
        dem.lon_deg,
        dem.h0_m,
        dem.curvature,
    )
    assert back.source == dem.source
    assert not back.heights.flags.writeable
    with np.load(first) as npz:  # a plain .npz for anyone else
        assert npz["heights"].shape == dem.shape


def test_failed_save_keeps_the_previous_file(tmp_path, monkeypatch):
    dem = import_dem(flat_geographic(tmp_path), LAT0, LON0, 100.0)
    target = tmp_path / "dem.npz"
    dem.save(target)
    before = target.read_bytes()

    def refuse(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(OSError, match=r"dem\.npz: cannot write \(No space left on device\)"):
        dem.save(target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dem.npz", "ok.tif"]  # no temporary left


def test_load_errors_name_the_file(tmp_path):
    with pytest.raises(OSError, match=r"absent\.npz: cannot read"):
        LocalDem.load(tmp_path / "absent.npz")
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ValueError, match=r"other\.npz: not a LocalDem file"):
        LocalDem.load(other)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"PK\x03\x04 not really")
    with pytest.raises(ValueError, match=r"junk\.npz: not a LocalDem file"):
        LocalDem.load(junk)


def test_local_dem_rejects_nan_and_bad_fields():
    good = dict(heights=np.zeros((3, 3)), spacing_m=1.0, lat_deg=0.0, lon_deg=0.0, h0_m=0.0, curvature=True)
    LocalDem(**good)
    with pytest.raises(ValueError, match="^heights: must be finite"):
        LocalDem(**{**good, "heights": np.full((3, 3), np.nan)})
    with pytest.raises(ValueError, match="^spacing_m: must be > 0"):
        LocalDem(**{**good, "spacing_m": 0.0})
    with pytest.raises(ValueError, match="^source: must hold JSON values"):
        LocalDem(**{**good, "source": {"x": object()}})


# --- the command --------------------------------------------------------------------------------


def test_terrain_import_command_writes_what_load_reads(tmp_path):
    data = (np.arange(N_PX * N_PX, dtype=np.float32).reshape(N_PX, N_PX) % 97) * 0.01
    data[150, 150] = -9999.0
    path = flat_geographic(tmp_path, "site.tif", data, nodata="-9999", gdal_scale=1000.0)
    runner = CliRunner()
    args = [
        "terrain",
        "import",
        str(path),
        "--lat",
        str(LAT0),
        "--lon",
        str(LON0),
        "--size-m",
        "400",
        "--spacing-m",
        "4",
    ]
    first = runner.invoke(main, [*args, "--out", str(tmp_path / "out" / "a.npz")])
    assert first.exit_code == 0, first.output
    assert "101 × 101 grid at 4 m spacing" in first.output
    assert "1 void pixels filled" in first.output
    drop = _core.curvature_drop(200 * math.sqrt(2), R + LocalDem.load(tmp_path / "out" / "a.npz").h0_m)
    assert (
        f"Curvature on: the sphere falls {drop * 1000:.1f} mm below the tangent plane at the crop corner (282.8 m out)"
    ) in first.output
    second = runner.invoke(main, [*args, "--out", str(tmp_path / "out" / "b.npz")])
    assert second.exit_code == 0, second.output
    assert (tmp_path / "out" / "a.npz").read_bytes() == (tmp_path / "out" / "b.npz").read_bytes()
    loaded = LocalDem.load(tmp_path / "out" / "a.npz")
    direct = import_dem(path, LAT0, LON0, 400.0, spacing_m=4.0)
    assert loaded.heights.tobytes() == direct.heights.tobytes()
    assert loaded.source == direct.source and loaded.h0_m == direct.h0_m

    flat = runner.invoke(main, [*args, "--no-curvature", "--out", str(tmp_path / "c.npz")])
    assert flat.exit_code == 0 and "Curvature off" in flat.output
    assert not LocalDem.load(tmp_path / "c.npz").curvature


def test_terrain_import_command_reports_errors(tmp_path):
    result = CliRunner().invoke(
        main,
        [
            "terrain",
            "import",
            str(tmp_path / "missing.tif"),
            "--lat",
            "0",
            "--lon",
            "0",
            "--size-m",
            "10",
            "--out",
            str(tmp_path / "x.npz"),
        ],
    )
    assert result.exit_code == 1
    assert "missing.tif: no such file" in result.output
    assert not (tmp_path / "x.npz").exists()


def test_terrain_import_of_a_truncated_file_fails_and_writes_nothing(tmp_path):
    """The reported case: a GeoTIFF cut to its first part. The command exits 1 naming the file and
    the strip, writes no output, and leaves an earlier output in place byte for byte."""
    whole = flat_geographic(tmp_path, "whole.tif", rough(), rowsperstrip=16, compression="zlib").read_bytes()
    cut = tmp_path / "cut.tif"
    cut.write_bytes(whole[: len(whole) // 2])
    args = ["terrain", "import", str(cut), "--lat", str(LAT0), "--lon", str(LON0), "--size-m", "400"]
    runner = CliRunner()
    result = runner.invoke(main, [*args, "--out", str(tmp_path / "new.npz")])
    assert result.exit_code == 1
    assert re.search(
        r"cut\.tif: strip \d+ \(rows \d+–\d+\) lies past the end of the file: it needs bytes \d+–\d+ "
        rf"\(.*\), the file has {len(whole) // 2} bytes \(truncated\?\)",
        result.output,
    ), result.output
    assert not (tmp_path / "new.npz").exists()
    earlier = tmp_path / "earlier.npz"
    flat = runner.invoke(main, ["terrain", "import", str(tmp_path / "whole.tif"), *args[3:], "--out", str(earlier)])
    assert flat.exit_code == 0, flat.output
    before = earlier.read_bytes()
    assert runner.invoke(main, [*args, "--out", str(earlier)]).exit_code == 1
    assert earlier.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.tif", "earlier.npz", "whole.tif"]
