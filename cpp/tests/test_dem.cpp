// DEM import against closed forms: the sphere's curvature drop, ENU round trips far from the
// origin, harmonic void filling of a plane, georeference round trips and the errors a crop gives;
// GeoTIFF decoding of hand-built files, cut short at every byte or holding random strips.
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/dem.h"
#include "moonbot/geo.h"
#include "moonbot/image.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;
double rad(double d) { return d * kPi / 180.0; }
double deg(double r) { return r * 180.0 / kPi; }

/// R − √(R² − d²) by its series R·(x/2 + x²/8 + x³/16 + 5x⁴/128), x = d²/R², which has no
/// cancellation; the next term is below 1e-18 relative for d ≤ 10 km.
double drop_series(double d, double R) {
    const double x = d * d / (R * R);
    return R * (x / 2 + x * x / 8 + x * x * x / 16 + 5 * x * x * x * x / 128);
}

/// A geographic raster of constant height `h` covering lat0 ± span_lat, lon0 ± span_lon.
DemRaster constant_geographic(double lat0, double lon0, double span_lat, double span_lon, double step_deg, double h) {
    DemGeoref g;
    g.kind = DemGeoref::Kind::Geographic;
    g.dx = g.dy = step_deg;
    const int w = static_cast<int>(2 * span_lon / step_deg) + 1, ht = static_cast<int>(2 * span_lat / step_deg) + 1;
    g.x0 = lon0 - span_lon;
    g.y0 = lat0 + span_lat;
    g.wrap_lon_deg = lon0;
    return DemRaster::from_heights("constant.tif", w, ht, std::vector<double>(static_cast<size_t>(w) * ht, h), g);
}

template <typename F>
std::string message_of(F f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_CASE(curvature_drop_matches_the_exact_sphere) {
    for (double d : {1.0, 100.0, 1000.0, 2000.0, 10000.0}) {
        const double exact = drop_series(d, kLunarRadius);
        CHECK_NEAR(curvature_drop(d), exact, 1e-6 * exact);
        // The same in extended precision straight from R − √(R² − d²), where it does not cancel.
        if (d >= 100.0) {
            const long double R = kLunarRadius, D = d;
            const double direct = static_cast<double>(R - std::sqrt(R * R - D * D));
            CHECK_NEAR(curvature_drop(d), direct, 1e-6 * exact);
        }
    }
}

TEST_CASE(constant_dem_with_curvature_falls_away_like_the_sphere) {
    // Mid-latitude and polar sites, ground on the reference sphere and 1.5 km above it.
    for (double lat0 : {30.0, -85.3})
        for (double h : {0.0, 1500.0}) {
            const double span_lon = lat0 < -80 ? 6.0 : 0.5;
            const DemRaster dem = constant_geographic(lat0, 20.0, 0.5, span_lon, 0.002, h);
            DemCrop crop;
            crop.lat_deg = lat0;
            crop.lon_deg = 20.0;
            crop.size_m = 10000.0;
            crop.spacing_m = 250.0;
            const LocalDemGrid on = import_dem(dem, crop);
            CHECK(on.nx == 41 && on.ny == 41);
            CHECK_NEAR(on.h0_m, h, 1e-9);
            CHECK(on.voids_filled == 0);
            // The ground is a sphere of radius R + h about the body's centre; the origin is on it.
            double worst = 0.0;
            for (int j = 0; j < on.ny; ++j)
                for (int i = 0; i < on.nx; ++i) {
                    const double e = (i - 20) * 250.0, n = (j - 20) * 250.0;
                    const double want = -curvature_drop(std::hypot(e, n), kLunarRadius + h);
                    const double got = on.heights[static_cast<size_t>(j) * on.nx + i];
                    // 1e-6 relative, and a nanometre floor: double rounding of ECEF at R = 1737 km.
                    CHECK_NEAR(got, want, 1e-6 * std::abs(want) + 1e-9);
                    worst = std::max(worst, std::abs(got - want));
                }
            CHECK(worst < 1e-5);
            crop.curvature = false;
            const LocalDemGrid off = import_dem(dem, crop);
            for (double z : off.heights) CHECK_NEAR(z, 0.0, 1e-9);
        }
}

TEST_CASE(enu_round_trip_at_10_km_all_bearings_and_heights) {
    const double R = kLunarRadius, s = 10000.0 / R;  // 10 km of arc
    for (double lat0 : {0.0, 45.0, -85.3, 89.9})
        for (double h0 : {-2000.0, 0.0, 1500.0}) {
            const LunarFrame frame(lat0, 137.0, h0);
            for (int b = 0; b < 8; ++b)
                for (double h : {-3000.0, 0.0, 8000.0}) {
                    // The point 10 km away along bearing b·45° (spherical destination formula).
                    const double bearing = rad(45.0 * b), p0 = rad(lat0);
                    const double p1 = std::asin(std::sin(p0) * std::cos(s) + std::cos(p0) * std::sin(s) * std::cos(bearing));
                    const double l1 = rad(137.0) + std::atan2(std::sin(bearing) * std::sin(s) * std::cos(p0),
                                                              std::cos(s) - std::sin(p0) * std::sin(p1));
                    const glm::dvec3 enu = frame.to_enu(deg(p1), deg(l1), h);
                    CHECK(std::hypot(enu.x, enu.y) > 9000.0);
                    const glm::dvec3 llh = frame.to_geodetic(enu);
                    double dlon = llh.y - deg(l1);
                    dlon -= 360.0 * std::round(dlon / 360.0);
                    CHECK_NEAR(rad(llh.x - deg(p1)) * R, 0.0, 1e-3);
                    CHECK_NEAR(rad(dlon) * R * std::cos(p1), 0.0, 1e-3);
                    CHECK_NEAR(llh.z, h, 1e-3);
                }
        }
}

TEST_CASE(void_fill_reproduces_a_plane) {
    const int w = 40, h = 30;
    auto plane = [](int x, int y) { return 0.3 * x - 0.2 * y + 5.0; };
    std::vector<double> z(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) z[static_cast<size_t>(y) * w + x] = plane(x, y);
    int holes = 0;
    for (int y = 8; y < 20; ++y)
        for (int x = 5; x < 17; ++x, ++holes) z[static_cast<size_t>(y) * w + x] = NAN;
    z[static_cast<size_t>(25) * w + 30] = INFINITY;  // a lone non-finite sample is a void too
    ++holes;
    CHECK(fill_voids(z, w, h) == holes);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) CHECK_NEAR(z[static_cast<size_t>(y) * w + x], plane(x, y), 1e-7);
}

TEST_CASE(void_fill_at_the_edge_stays_within_the_data) {
    const int w = 12, h = 9;
    std::vector<double> z(static_cast<size_t>(w) * h);
    for (size_t i = 0; i < z.size(); ++i) z[i] = static_cast<double>(i % w);
    for (int y = 0; y < h; ++y) z[static_cast<size_t>(y) * w + (w - 1)] = NAN;  // the east column
    z[0] = NAN;  // and a corner
    CHECK(fill_voids(z, w, h) == h + 1);
    for (double v : z) CHECK(std::isfinite(v) && v >= 0.0 && v <= w - 2.0);
    std::vector<double> none(6, NAN);
    CHECK_THROWS(std::invalid_argument, fill_voids(none, 3, 2));
}

TEST_CASE(georef_round_trips_and_wraps_longitude) {
    DemGeoref geo;  // a 0–360° E raster at 1/64°
    geo.dx = geo.dy = 1.0 / 64;
    geo.x0 = 0.5 / 64;
    geo.y0 = 60.0 - 0.5 / 64;
    geo.wrap_lon_deg = 180.0;
    const glm::dvec2 uv = geo.to_raster(10.0, -20.0);  // −20° E is 340° E
    CHECK_NEAR(uv.x, (340.0 - geo.x0) * 64, 1e-9);
    CHECK_NEAR(uv.y, (geo.y0 - 10.0) * 64, 1e-9);
    const glm::dvec2 ll = geo.to_latlon(uv.x, uv.y);
    CHECK_NEAR(ll.x, 10.0, 1e-12);
    CHECK_NEAR(ll.y, 340.0, 1e-12);

    DemGeoref eqc;
    eqc.kind = DemGeoref::Kind::Equirectangular;
    eqc.dx = 5.0;
    eqc.dy = 4.0;
    eqc.x0 = -12345.0;
    eqc.y0 = 98765.0;
    eqc.center_lon_deg = eqc.wrap_lon_deg = 180.0;
    eqc.origin_lat_deg = 2.0;
    eqc.std_parallel_deg = 30.0;
    eqc.false_easting_m = 1000.0;
    eqc.false_northing_m = -500.0;
    const glm::dvec2 back = eqc.to_raster(eqc.to_latlon(17.25, 31.5).x, eqc.to_latlon(17.25, 31.5).y);
    CHECK_NEAR(back.x, 17.25, 1e-9);
    CHECK_NEAR(back.y, 31.5, 1e-9);
    // True to scale along the standard parallel: 5 m model pixels are 5 m of ground at 30°.
    CHECK_NEAR(eqc.pixel_size_m(30.0, 0.0).x, 5.0, 1e-12);
    CHECK_NEAR(eqc.pixel_size_m(30.0, 0.0).y, 4.0, 1e-12);
}

TEST_CASE(orthographic_and_polar_stereographic_match_snyder) {
    const double R = kLunarRadius, pi = 3.14159265358979323846;
    DemGeoref ortho;  // about Kepler crater, 47.7 m pixels, pixel (0, 0) at model (0, 0)
    ortho.kind = DemGeoref::Kind::Orthographic;
    ortho.dx = ortho.dy = 47.7;
    ortho.origin_lat_deg = 8.12;
    ortho.center_lon_deg = ortho.wrap_lon_deg = -38.01;
    ortho.validate();
    CHECK_NEAR(ortho.to_raster(8.12, -38.01).x, 0.0, 1e-9);
    CHECK_NEAR(ortho.to_raster(8.12, 321.99).y, 0.0, 1e-9);  // the same meridian as 321.99° E
    // 90° of longitude east on the equator seen from the equator: X = R (Snyder eq. 20-3).
    ortho.origin_lat_deg = 0.0;
    CHECK_NEAR(ortho.to_raster(0.0, 51.99).x * ortho.dx, R, 1e-6);
    CHECK(std::isnan(ortho.to_raster(0.0, 141.99).x));  // the far side
    ortho.origin_lat_deg = 8.12;
    const glm::dvec2 ll = ortho.to_latlon(-321.5, 207.25);
    const glm::dvec2 back = ortho.to_raster(ll.x, ll.y);
    CHECK_NEAR(back.x, -321.5, 1e-9);
    CHECK_NEAR(back.y, 207.25, 1e-9);
    // True to scale at the centre; 10 km out radially a u step is foreshortened by cos c.
    CHECK_NEAR(ortho.pixel_size_m(8.12, -38.01).x, 47.7, 1e-6);
    const glm::dvec2 east = ortho.to_latlon(10000.0 / 47.7, 0.0);
    CHECK_NEAR(ortho.pixel_size_m(east.x, east.y).x, 47.7 / std::cos(std::asin(10000.0 / R)), 1e-6);

    DemGeoref ps;  // south polar, 20 m pixels, k0 = 1, pole at model (0, 0) = pixel (0, 0)
    ps.kind = DemGeoref::Kind::PolarStereographic;
    ps.dx = ps.dy = 20.0;
    ps.origin_lat_deg = -90.0;
    ps.validate();
    // −80° on the meridian 90° E: ρ = 2R·tan(π/4 − 80°/2) along +X (Snyder eqs. 21-8, 21-9).
    const glm::dvec2 p = ps.to_raster(-80.0, 90.0);
    CHECK_NEAR(p.x * 20.0, 2 * R * std::tan(pi / 4 - 40.0 * pi / 180), 1e-6);
    CHECK_NEAR(p.y, 0.0, 1e-9);
    const glm::dvec2 on0 = ps.to_raster(-89.0, 0.0);  // the 0° meridian runs along +Y at the south pole
    CHECK_NEAR(on0.x, 0.0, 1e-9);
    CHECK(on0.y < 0.0);
    const glm::dvec2 q = ps.to_latlon(123.25, -456.5);
    const glm::dvec2 qb = ps.to_raster(q.x, q.y);
    CHECK_NEAR(qb.x, 123.25, 1e-9);
    CHECK_NEAR(qb.y, -456.5, 1e-9);
    CHECK_NEAR(ps.pixel_size_m(-89.999, 0.0).x, 20.0, 1e-4);  // k = 1 at the pole
    // Variant B's k0 for a true-scale latitude of −71°: scale 1 there.
    ps.scale_k0 = (1 + std::sin(71.0 * pi / 180)) / 2;
    CHECK_NEAR(ps.pixel_size_m(-71.0, 30.0).x, 20.0, 1e-6);
}

TEST_CASE(constant_dem_looks_the_same_from_two_centres) {
    // After the shift to the local origin, a constant DEM is the same at any two sites.
    const DemRaster dem = constant_geographic(-20.0, 40.0, 0.3, 0.3, 0.001, -1234.5);
    DemCrop a;
    a.lat_deg = -20.0;
    a.lon_deg = 40.0;
    a.size_m = 2000.0;
    a.spacing_m = 50.0;
    DemCrop b = a;
    b.lat_deg = -20.0 + deg(2000.0 / kLunarRadius);  // 2 km north
    const LocalDemGrid ga = import_dem(dem, a), gb = import_dem(dem, b);
    CHECK(ga.heights.size() == gb.heights.size());
    for (size_t k = 0; k < ga.heights.size(); ++k) CHECK_NEAR(ga.heights[k], gb.heights[k], 1e-9);
    CHECK_NEAR(ga.heights.front(), -curvature_drop(std::sqrt(2.0) * 1000.0, kLunarRadius - 1234.5), 1e-8);
}

TEST_CASE(crop_errors_name_the_file_and_the_bound) {
    const DemRaster dem = constant_geographic(10.0, 10.0, 0.05, 0.05, 0.001, 0.0);
    DemCrop crop;
    crop.lat_deg = 10.0;
    crop.lon_deg = 10.04;
    crop.size_m = 4000.0;  // 0.066° across: past the east edge at 10.05°
    crop.spacing_m = 20.0;
    const std::string east = message_of([&] { import_dem(dem, crop); });
    CHECK(contains(east, "constant.tif: "));
    CHECK(contains(east, "east edge"));
    CHECK(!contains(east, "west edge"));
    crop.lon_deg = 10.0;
    crop.lat_deg = -10.0;  // the whole crop is south of the raster
    const std::string south = message_of([&] { import_dem(dem, crop); });
    CHECK(contains(south, "south edge") && contains(south, "lat"));
    CHECK_THROWS(std::invalid_argument, import_dem(dem, crop));

    crop.lat_deg = 10.0;
    crop.size_m = 0.0;
    CHECK(contains(message_of([&] { import_dem(dem, crop); }), "size_m"));
    crop.size_m = -5.0;
    CHECK_THROWS(std::invalid_argument, import_dem(dem, crop));
    crop.size_m = 30.0;  // less than two spacings
    CHECK(contains(message_of([&] { import_dem(dem, crop); }), "size_m"));
    crop.size_m = 1000.0;
    crop.spacing_m = -1.0;
    CHECK(contains(message_of([&] { import_dem(dem, crop); }), "spacing_m"));
    crop.spacing_m = NAN;
    CHECK_THROWS(std::invalid_argument, import_dem(dem, crop));
}

TEST_CASE(all_void_crop_is_an_error_and_voids_are_counted) {
    DemGeoref g;
    g.dx = g.dy = 0.001;
    g.x0 = 9.95;
    g.y0 = 10.05;
    g.wrap_lon_deg = 10.0;
    const int w = 101, h = 101;
    std::vector<double> z(static_cast<size_t>(w) * h, NAN);
    const DemRaster empty = DemRaster::from_heights("voids.tif", w, h, z, g);
    DemCrop crop;
    crop.lat_deg = 10.0;
    crop.lon_deg = 10.0;
    crop.size_m = 400.0;
    crop.spacing_m = 20.0;
    const std::string msg = message_of([&] { import_dem(empty, crop); });
    CHECK(contains(msg, "voids.tif: every source pixel under the crop is void"));

    // Data only beside the footprint (inside the margin read around it, so the fill succeeds):
    // the footprint itself is all void, which is still an error.
    for (int x = 36; x < 39; ++x) z[static_cast<size_t>(50) * w + x] = 1.0;
    const DemRaster far = DemRaster::from_heights("far.tif", w, h, z, g);
    CHECK(contains(message_of([&] { import_dem(far, crop); }), "far.tif: every source pixel under the crop is void"));

    // A plane with a void in the middle: filled, counted, and no NaN comes out.
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) z[static_cast<size_t>(y) * w + x] = 2.0 * x - 3.0 * y;
    for (int y = 48; y < 53; ++y)
        for (int x = 47; x < 54; ++x) z[static_cast<size_t>(y) * w + x] = NAN;
    const LocalDemGrid grid = import_dem(DemRaster::from_heights("hole.tif", w, h, z, g), crop);
    CHECK(grid.voids_filled == 35);
    for (double v : grid.heights) CHECK(std::isfinite(v));
}

// ---------------------------------------------------------------------------------------------
// GeoTIFF files built byte by byte (TIFF 6.0 §2; GeoTIFF 1.0 §2.6), so each field's place is known.

namespace {

void put16(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    b[at] = static_cast<uint8_t>(v), b[at + 1] = static_cast<uint8_t>(v >> 8);
}
void put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

/// A little-endian geographic GeoTIFF of `w` × `h` float32 samples in strips of `rows` rows,
/// each strip's stored bytes given (compressed with `compression` or not). Pixel (0, 0)'s
/// centre is at lat 10.05°, lon 9.95°, pixels 0.001° (PixelIsArea).
std::vector<uint8_t> geotiff_bytes(int w, int h, int rows, uint16_t compression,
                                   const std::vector<std::vector<uint8_t>>& strips) {
    struct Entry {
        uint16_t tag, type;
        uint32_t count;
        std::vector<uint8_t> value;  // little-endian bytes
    };
    auto shorts = [](std::vector<uint32_t> v) {
        std::vector<uint8_t> b(v.size() * 2);
        for (size_t i = 0; i < v.size(); ++i) put16(b, 2 * i, v[i]);
        return b;
    };
    auto longs = [](std::vector<uint32_t> v) {
        std::vector<uint8_t> b(v.size() * 4);
        for (size_t i = 0; i < v.size(); ++i) put32(b, 4 * i, v[i]);
        return b;
    };
    auto doubles = [](std::vector<double> v) {
        std::vector<uint8_t> b(v.size() * 8);
        std::memcpy(b.data(), v.data(), b.size());  // the test machine is little-endian (x86-64)
        return b;
    };
    const uint32_t n = static_cast<uint32_t>(strips.size());
    std::vector<Entry> entries = {
        {256, 4, 1, longs({static_cast<uint32_t>(w)})},
        {257, 4, 1, longs({static_cast<uint32_t>(h)})},
        {258, 3, 1, shorts({32})},
        {259, 3, 1, shorts({compression})},
        {262, 3, 1, shorts({1})},
        {273, 4, n, {}},  // StripOffsets: filled in once the layout is known
        {277, 3, 1, shorts({1})},
        {278, 4, 1, longs({static_cast<uint32_t>(rows)})},
        {279, 4, n, {}},
        {339, 3, 1, shorts({3})},
        {33550, 12, 3, doubles({0.001, 0.001, 0.0})},
        {33922, 12, 6, doubles({0.0, 0.0, 0.0, 9.9495, 10.0505, 0.0})},
        {34735, 3, 16, shorts({1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2054, 0, 1, 9102})},
    };
    const size_t ifd_size = 2 + 12 * entries.size() + 4;
    size_t values_at = 8 + ifd_size, data_at = values_at;
    for (const Entry& e : entries)
        if (e.tag == 273 || e.tag == 279) data_at += 4 * e.count;
        else if (e.value.size() > 4) data_at += e.value.size();
    std::vector<uint32_t> offsets, counts;
    for (const auto& s : strips) {
        offsets.push_back(static_cast<uint32_t>(data_at));
        counts.push_back(static_cast<uint32_t>(s.size()));
        data_at += s.size();
    }
    for (Entry& e : entries)
        if (e.tag == 273) e.value = longs(offsets);
        else if (e.tag == 279) e.value = longs(counts);
    std::vector<uint8_t> b(8 + ifd_size);
    b[0] = b[1] = 'I';
    put16(b, 2, 42);
    put32(b, 4, 8);
    put16(b, 8, static_cast<uint32_t>(entries.size()));
    for (size_t i = 0; i < entries.size(); ++i) {
        const Entry& e = entries[i];
        const size_t at = 10 + 12 * i;
        put16(b, at, e.tag);
        put16(b, at + 2, e.type);
        put32(b, at + 4, e.count);
        if (e.value.size() <= 4) {
            std::copy(e.value.begin(), e.value.end(), b.begin() + static_cast<std::ptrdiff_t>(at + 8));
        } else {
            put32(b, at + 8, static_cast<uint32_t>(values_at + (b.size() - 8 - ifd_size)));
            b.insert(b.end(), e.value.begin(), e.value.end());
        }
    }
    for (const auto& s : strips) b.insert(b.end(), s.begin(), s.end());
    return b;
}

/// Row-major float32 samples z = x − 2y as the bytes of strips of `rows` rows.
std::vector<std::vector<uint8_t>> plane_strips(int w, int h, int rows) {
    std::vector<std::vector<uint8_t>> strips;
    for (int y0 = 0; y0 < h; y0 += rows) {
        std::vector<uint8_t> s;
        for (int y = y0; y < std::min(h, y0 + rows); ++y)
            for (int x = 0; x < w; ++x) {
                const float z = static_cast<float>(x - 2 * y);
                uint8_t raw[4];
                std::memcpy(raw, &z, 4);
                s.insert(s.end(), raw, raw + 4);
            }
        strips.push_back(std::move(s));
    }
    return strips;
}

std::vector<uint8_t> deflate(const std::vector<uint8_t>& raw) {
    uLongf size = compressBound(static_cast<uLong>(raw.size()));
    std::vector<uint8_t> out(size);
    if (compress(out.data(), &size, raw.data(), static_cast<uLong>(raw.size())) != Z_OK)
        throw std::runtime_error("zlib compress failed");
    out.resize(size);
    return out;
}

/// A scratch folder of its own for this process (release and sanitizer builds may run at once).
std::filesystem::path scratch_dir(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes, size_t n) {
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
}

/// Opens a GeoTIFF and reads every pixel; "" if that worked, else the IoError's message (any
/// other exception fails the test).
std::string read_whole(const std::string& path) {
    try {
        const DemRaster dem = DemRaster::open_geotiff(path);
        const std::vector<double> z = dem.read(0, 0, dem.width(), dem.height());
        return "";
    } catch (const IoError& e) {
        return e.what();
    }
}

}  // namespace

TEST_CASE(geotiff_strips_decode_exactly_uncompressed_and_deflate) {
    const auto dir = scratch_dir("moonbot_test_dem_tiff");
    const int w = 37, h = 29, rows = 4;
    for (uint16_t compression : {1, 8}) {
        std::vector<std::vector<uint8_t>> strips = plane_strips(w, h, rows);
        if (compression == 8)
            for (auto& s : strips) s = deflate(s);
        const std::string path = (dir / "plane.tif").string();
        const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
        write_file(path, bytes, bytes.size());
        const DemRaster dem = DemRaster::open_geotiff(path);
        CHECK(dem.width() == w && dem.height() == h && dem.description() == "GeoTIFF float32, geographic");
        // A window starting and ending mid-strip and mid-row.
        const std::vector<double> z = dem.read(3, 5, 30, 27);
        bool exact = z.size() == 27u * 22u;
        for (int y = 5; y < 27 && exact; ++y)
            for (int x = 3; x < 30; ++x) exact &= z[static_cast<size_t>(y - 5) * 27 + (x - 3)] == x - 2.0 * y;
        CHECK(exact);
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE(geotiff_cut_at_every_byte_is_an_error_naming_the_file) {
    // Cut anywhere — header, directory, tag values, any strip — the file is refused with an
    // IoError naming it; cuts in the pixel data name the strip. Never a crash (this test runs
    // under ASan/UBSan too) and never zeros for the missing part.
    const auto dir = scratch_dir("moonbot_test_dem_cut");
    const std::string path = (dir / "cut.tif").string();
    const int w = 9, h = 7, rows = 2;
    for (uint16_t compression : {1, 8}) {
        std::vector<std::vector<uint8_t>> strips = plane_strips(w, h, rows);
        if (compression == 8)
            for (auto& s : strips) s = deflate(s);
        const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
        write_file(path, bytes, bytes.size());
        CHECK(read_whole(path).empty());
        size_t data_at = bytes.size();
        for (const auto& s : strips) data_at -= s.size();
        int wrong = 0;
        for (size_t n = 0; n < bytes.size(); ++n) {
            write_file(path, bytes, n);
            const std::string msg = read_whole(path);
            const bool named = contains(msg, path + ": ") && (n < data_at || contains(msg, "strip "));
            if (!named && ++wrong <= 3) std::printf("  cut at %zu of %zu bytes: '%s'\n", n, bytes.size(), msg.c_str());
        }
        CHECK(wrong == 0);
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE(garbage_strips_are_errors_not_crashes) {
    // Random bytes as LZW, Deflate and PackBits strips: each read either fails with an IoError
    // naming the file and the strip or (PackBits can) decodes to exactly the strip's size. Run
    // under ASan/UBSan, this is what shows the decoders never read or write out of bounds.
    const auto dir = scratch_dir("moonbot_test_dem_garbage");
    const std::string path = (dir / "garbage.tif").string();
    std::mt19937 rng(20240611);
    const int w = 5, h = 4, rows = 2;  // two strips of 40 bytes
    for (uint16_t compression : {5, 8, 32773}) {
        int errors = 0;
        for (int trial = 0; trial < 300; ++trial) {
            std::vector<std::vector<uint8_t>> strips(2);
            for (auto& s : strips) {
                s.resize(1 + rng() % 120);
                for (auto& byte : s) byte = static_cast<uint8_t>(rng());
            }
            if (compression == 5 && trial % 2 == 0) strips[0][0] = 0x80;  // a Clear code first, as writers do
            const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
            write_file(path, bytes, bytes.size());
            const std::string msg = read_whole(path);
            if (!msg.empty()) {
                ++errors;
                CHECK(contains(msg, path + ": strip "));
            }
        }
        CHECK(errors > 250);  // random bytes almost never decode to exactly 40 bytes
    }
    std::filesystem::remove_all(dir);
}
