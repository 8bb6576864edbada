// DEM georeferences against closed forms: round trips, longitude wrapping, and the orthographic
// and polar stereographic maps against Snyder's formulas.
#include <cmath>

#include "check.h"
#include "moonbot/dem_georef.h"
#include "moonbot/geo.h"

using namespace moonbot;

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
