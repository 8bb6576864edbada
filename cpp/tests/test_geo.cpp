#include "check.h"
#include "moonbot/geo.h"
#include "moonbot/light.h"

using namespace moonbot;

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
