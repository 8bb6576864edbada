#include <cmath>

#include "check.h"
#include "moonbot/geo.h"
#include "moonbot/light.h"

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

}  // namespace

TEST_CASE(enu_round_trip_at_10_km) {
    const LunarFrame frame(-85.3, 31.2, 1200.0);
    const glm::dvec3 enu = frame.to_enu(-85.3 + 0.25, 31.2 + 1.5, 1450.0);
    const glm::dvec3 llh = frame.to_geodetic(enu);
    const glm::dvec3 back = frame.to_enu(llh.x, llh.y, llh.z);
    CHECK(glm::length(enu) > 5000.0);
    CHECK(glm::length(back - enu) < 1e-3);
    CHECK_NEAR(llh.z, 1450.0, 1e-3);
}

TEST_CASE(enu_drop_matches_sphere) {
    // A point on the reference sphere 1 km north of the origin lies d²/2R below the tangent plane.
    const LunarFrame frame(0.0, 0.0, 0.0);
    const double d_rad = 1000.0 / kLunarRadius;
    const glm::dvec3 enu = frame.to_enu(glm::degrees(d_rad), 0.0, 0.0);
    const double exact = kLunarRadius * (1.0 - std::cos(d_rad));
    CHECK_NEAR(-enu.z, exact, 1e-6 * exact);
    CHECK_NEAR(curvature_drop(kLunarRadius * std::sin(d_rad)), exact, 1e-6 * exact);
}

TEST_CASE(curvature_drop_small_distance_is_exact) {
    const double d = 1900.0;
    CHECK_NEAR(curvature_drop(d), d * d / (2 * kLunarRadius), 1e-6 * d * d / (2 * kLunarRadius));
    CHECK(curvature_drop(0.0) == 0.0);
    CHECK_THROWS(std::invalid_argument, curvature_drop(2 * kLunarRadius));
}

TEST_CASE(sun_direction_convention) {
    const DirectionalLight north(0.0, 0.0, 1361.0), east(90.0, 0.0, 1361.0), up(0.0, 90.0, 1361.0);
    CHECK_NEAR(north.direction().y, 1.0, 1e-15);
    CHECK_NEAR(east.direction().x, 1.0, 1e-15);
    CHECK_NEAR(up.direction().z, 1.0, 1e-15);
    CHECK_THROWS(std::invalid_argument, DirectionalLight(0.0, 91.0, 1.0));
    CHECK_THROWS(std::invalid_argument, DirectionalLight(0.0, 10.0, -1.0));
    CHECK_THROWS(std::invalid_argument, DirectionalLight(NAN, 10.0, 1.0));
}

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

TEST_CASE(enu_round_trip_at_10_km_all_bearings_and_heights) {
    const double R = kLunarRadius, s = 10000.0 / R;  // 10 km of arc
    for (double lat0 : {0.0, 45.0, -85.3, 89.9})
        for (double h0 : {-2000.0, 0.0, 1500.0}) {
            const LunarFrame frame(lat0, 137.0, h0);
            for (int b = 0; b < 8; ++b)
                for (double h : {-3000.0, 0.0, 8000.0}) {
                    // The point 10 km away along bearing b·45° (spherical destination formula).
                    const double bearing = rad(45.0 * b), p0 = rad(lat0);
                    const double p1 =
                        std::asin(std::sin(p0) * std::cos(s) + std::cos(p0) * std::sin(s) * std::cos(bearing));
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
