#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include "check.h"
#include "fixtures.h"
#include "moonbot/dust.h"

using namespace moonbot;

TEST_CASE(ejecta_fly_bounce_and_rest_above_a_thin_plane) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), glm::dmat4(1.0), Material{});
    scene.commit();
    EjectaParams p;
    p.count = 64;
    for (double t : {0.0, 0.3, 0.9, 1.99}) {
        const std::vector<Fragment> a = simulate_ejecta(scene, p, 3, t, kMaxDustStep, 1);
        const std::vector<Fragment> b = simulate_ejecta(scene, p, 3, t, kMaxDustStep, 2);
        CHECK(a.size() == 64u);
        for (size_t i = 0; i < a.size(); ++i) {
            CHECK(a[i].position.z >= a[i].diameter_m / 2 - 1e-6);  // never below the surface
            CHECK(a[i].position == b[i].position && a[i].velocity == b[i].velocity);
        }
    }
    // Free flight is exact: half a second up from launch, no ground in reach.
    const Fragment f0 = simulate_ejecta(scene, p, 7, 0.0, 0.01)[0];
    const Fragment f1 = simulate_ejecta(scene, p, 7, 0.2, 0.01)[0];
    CHECK(f1.bounces == 0);
    CHECK_NEAR(f1.position.z, f0.position.z + f0.velocity.z * 0.2 - 0.5 * 1.62 * 0.04, 1e-12);
}

TEST_CASE(ejecta_arguments_are_checked) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 1.0f), glm::dmat4(1.0), Material{});
    scene.commit();
    EjectaParams p;
    CHECK_THROWS(std::invalid_argument, simulate_ejecta(scene, p, 0, 1.0, 0.0));
    CHECK_THROWS(std::invalid_argument, simulate_ejecta(scene, p, 0, -1.0, 0.01));
    p.restitution = 1.0;
    CHECK_THROWS(std::invalid_argument, simulate_ejecta(scene, p, 0, 1.0, 0.01));
}

TEST_CASE(a_fragment_behind_a_surface_is_put_back_in_front_not_bounced_down) {
    // A fragment whose lowest point starts 1 mm under a plane, rising: its first chord meets the
    // plane from behind. Bounced off the back of the plane it would fall forever; instead it is
    // put back on top, flies on and comes to rest on the plane.
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), glm::dmat4(1.0), Material{});
    scene.commit();
    EjectaParams p;
    Fragment f{};
    f.diameter_m = 0.02;
    f.position = glm::dvec3(0.0, 0.0, 0.01 - 0.001);
    f.velocity = glm::dvec3(0.1, 0.0, 0.5);
    Fragment start = f;
    fly_fragment(scene, p, start, 0.01, 0.01);  // one step: put back out and flown
    CHECK(start.corrections == 1);
    CHECK(start.position.z - 0.01 > 0.0 && start.velocity.z > 0.0);
    CHECK_NEAR(start.velocity.z, 0.5 - 1.62 * 0.01, 1e-12);  // the velocity is kept
    fly_fragment(scene, p, f, 1.99, 0.01);
    CHECK(f.corrections == 1 && f.resting && f.bounces > 0);
    CHECK_NEAR(f.position.z, 0.01, 1e-5);  // resting on the plane, not under it
    // Bad arguments name the field.
    Fragment bad{};
    CHECK_THROWS(std::invalid_argument, fly_fragment(scene, p, bad, 1.0, 0.01));  // no diameter
    CHECK_THROWS(std::invalid_argument, fly_fragment(scene, p, f, 1.0, 0.5));
}

TEST_CASE(ejecta_never_enter_a_box_nor_the_ground_however_fast) {
    // A 0.3 × 0.3 × 0.2 m box on a plane, the emitter's disc half under it; fragments at 1.25–
    // 3.75 m/s in an 80° cone stepping 0.1 s (up to 0.4 m a step, the box's width). Neither end
    // of a fragment's collision segment (its centre, its lowest point) is ever inside the box or
    // under the plane; at launch the lowest point is kSpawnClearance above whatever is under it.
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), glm::dmat4(1.0), Material{});
    scene.add_background(fixtures::add_box_mesh(scene, 0.3f, 0.3f, 0.2f), glm::dmat4(1.0), Material{});
    scene.commit();
    EjectaParams p;
    p.origin = glm::dvec3(0.2, 0.0, 0.0);
    p.count = 300;
    p.cone_half_angle_deg = 80.0;
    p.mean_speed_m_s = 2.5;
    auto in_box = [](const glm::dvec3& q) {
        return std::abs(q.x) < 0.15 && std::abs(q.y) < 0.15 && q.z > 0.0 && q.z < 0.2;
    };
    int on_box = 0, bounced = 0;
    for (const Fragment& f : simulate_ejecta(scene, p, 11, 0.0, kMaxDustStep)) {
        const double low = f.position.z - f.diameter_m / 2;
        const bool over_box = std::abs(f.position.x) < 0.15 && std::abs(f.position.y) < 0.15;
        // Embree's float32 distances: the surface's height is known to a few 1e-8 m.
        CHECK(low >= (over_box ? 0.2 : 0.0) + kSpawnClearance - 1e-7);
        on_box += low > 0.2;
    }
    CHECK(on_box > 0);  // some start on the box's top
    for (int k = 0; k < 100; ++k) {
        for (const Fragment& f : simulate_ejecta(scene, p, 11, 0.02 * k, kMaxDustStep)) {
            const glm::dvec3 low = f.position - glm::dvec3(0.0, 0.0, f.diameter_m / 2);
            CHECK(!in_box(f.position) && !in_box(low));
            CHECK(low.z > 0.0 || std::abs(f.position.x) > 50.0 || std::abs(f.position.y) > 50.0);
            CHECK(f.corrections == 0);
            bounced += f.bounces > 0;
        }
    }
    CHECK(bounced > 1000);
}

namespace {

std::string rejection(const std::function<void()>& validate) {
    try {
        validate();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE(dust_params_validate_names_the_field) {
    CHECK(rejection([] { EjectaParams{}.validate(); }).empty());
    CHECK(rejection([] { CloudParams{}.validate(); }).empty());
    CHECK(rejection([] { Medium{}.validate(); }).empty());
    EjectaParams e;
    e.restitution = 0.96;
    CHECK(rejection([&] { e.validate(); }).rfind("restitution: must be in [0, 0.95]", 0) == 0);
    e = EjectaParams{};
    e.min_diameter_m = 0.03;  // above max_diameter_m
    CHECK(rejection([&] { e.validate(); }).rfind("min_diameter_m: ", 0) == 0);
    CloudParams c;
    c.axis = glm::dvec3(0.0);
    CHECK(rejection([&] { c.validate(); }).rfind("axis: ", 0) == 0);
    c = CloudParams{};
    c.rise_fraction = 1.0;
    CHECK(rejection([&] { c.validate(); }).rfind("rise_fraction: must be in (0, 1)", 0) == 0);
    Medium m;
    m.march_stride_px = 3;
    CHECK(rejection([&] { m.validate(); }).rfind("march_stride_px: ", 0) == 0);
    m = Medium{};
    m.puffs.push_back(Puff{glm::dvec3(0.0), -1.0, 1.0});
    CHECK(rejection([&] { m.validate(); }).rfind("puffs: sigma_m", 0) == 0);
}
