// DEM import against closed forms: the sphere's curvature drop, ENU round trips far from the
// origin, harmonic void filling of a plane, georeference round trips and the errors a crop gives.
#include <cmath>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/dem.h"
#include "moonbot/geo.h"

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
