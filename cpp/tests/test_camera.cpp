#include "check.h"
#include "fixtures.h"

using namespace moonbot;

TEST_CASE(direction_projects_back_to_its_pixel) {
    const Camera cam = fixtures::look_at({1.0, -2.0, 0.7}, {0.1, 0.2, 0.0}, 64, 48, 50.0);
    for (double x : {0.5, 10.25, 63.5})
        for (double y : {0.5, 23.0, 47.5}) {
            const glm::dvec3 d = cam.direction(x, y);
            CHECK_NEAR(glm::dot(d, cam.forward()), 1.0, 1e-12);  // z-depth scaling
            const glm::dvec3 p = cam.project(cam.center() + 3.0 * d);
            CHECK_NEAR(p.x, x, 1e-9);
            CHECK_NEAR(p.y, y, 1e-9);
            CHECK_NEAR(p.z, 3.0, 1e-12);
        }
}

TEST_CASE(straight_down_camera_is_valid) {
    const Camera cam = fixtures::look_at({0, 0, 1}, {0, 0, 0}, 8, 8, 10.0);
    CHECK_NEAR(cam.forward().z, -1.0, 1e-12);
    CHECK_NEAR(cam.center().z, 1.0, 1e-12);
}

TEST_CASE(bad_intrinsics_throw) {
    const glm::dmat3 I(1.0);
    const glm::dvec3 t(0.0);
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{0, 1, 0, 0, 8, 8}, I, t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, -1, 0, 0, 8, 8}, I, t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, 1, 0, 0, 0, 8}, I, t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, 1, 0, 0, 8, 0}, I, t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, 1, NAN, 0, 8, 8}, I, t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, 1, 0, 0, 8, 8}, glm::dmat3(2.0), t));
    CHECK_THROWS(std::invalid_argument, Camera(Intrinsics{1, 1, 0, 0, 8, 8}, glm::dmat3(-1.0), t));
}

TEST_CASE(direction_parts_sum_to_direction_bit_for_bit) {
    // The renderer builds a tile's rays from per-column and per-row parts (rays.h, centre_rays);
    // any difference from direction() would move rays.
    const Camera cam = fixtures::look_at({1.0, -2.0, 0.7}, {0.1, 0.2, 0.0}, 640, 480, 554.3);
    for (double x : {0.5, 1.5, 77.5, 319.5, 320.5, 639.5, -3.25, 1e4})
        for (double y : {0.5, 2.5, 239.5, 240.5, 479.5, 13.125}) {
            const glm::dvec3 d = cam.direction(x, y);
            const glm::dvec3 parts = (cam.x_part(x) + cam.y_part(y)) + cam.forward();
            CHECK(d.x == parts.x && d.y == parts.y && d.z == parts.z);
        }
}
