#include <cmath>

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
