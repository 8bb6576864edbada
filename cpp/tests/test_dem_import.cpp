// DEM import against closed forms: a constant DEM falls away like the sphere and looks the same
// from two centres; a crop names the file and the bound it leaves, and an all-void footprint is an
// error while filled voids are counted.
#include <cmath>
#include <exception>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/dem_import.h"
#include "moonbot/geo.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;
double deg(double r) { return r * 180.0 / kPi; }

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
