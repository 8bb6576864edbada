#include <cstring>
#include <stdexcept>
#include <string>

#include "../src/rays.h"
#include "check.h"
#include "fixtures.h"
#include "moonbot/light_cache.h"
#include "moonbot/render.h"

using namespace moonbot;

namespace {

glm::dmat4 identity() { return glm::dmat4(1.0); }

}  // namespace

TEST_CASE(static_rays_pass_through_moving_instances) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 10.0f), identity(), Material{});
    const uint32_t box = fixtures::add_box_mesh(scene, 1.0f, 1.0f, 1.0f);
    const uint32_t moving = scene.add_background(box, glm::translate(identity(), glm::dvec3(0, 0, 1)), Material{},
                                                 /*moving=*/true);
    scene.commit();
    CHECK(scene.instance(moving).moving);
    RayHit rays[2];
    for (RayHit& r : rays) detail::set_ray(r, {0.0, 0.0, 5.0}, {0.0, 0.0, -1.0});
    rays[1].mask = kStaticGeometry;
    scene.accel().intersect(rays, 2);
    CHECK(rays[0].inst_id == moving);  // every other ray sees it
    CHECK(rays[1].inst_id == 0);       // the cache's ray meets the plane under it
    CHECK_NEAR(rays[1].tfar, 5.0f, 1e-5);
}

TEST_CASE(moving_a_static_mesh_makes_it_moving_and_bumps_the_revision) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 10.0f), identity(), Material{});
    const uint32_t box = fixtures::add_box_mesh(scene, 1.0f, 1.0f, 1.0f);
    const uint32_t b = scene.add_instance(box, identity(), 1, Material{});
    scene.commit();
    const uint64_t before = scene.static_revision();
    std::vector<float> v(scene.mesh(box).vertices.begin(), scene.mesh(box).vertices.end() - 1);
    for (size_t i = 2; i < v.size(); i += 3) v[i] += 0.5f;
    scene.update_mesh(box, v.data(), v.size() / 3);
    scene.commit();
    CHECK(scene.instance(b).moving);
    CHECK(scene.static_revision() == before + 1);
    const LightCache cache(scene, Lights{DirectionalLight(0, 30, 1361), std::nullopt}, LightCacheSettings{});
    CHECK(cache.covers(0) && !cache.covers(b));
}

TEST_CASE(cache_values_do_not_depend_on_threads_or_fill_order) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 5.0f), identity(), Material{glm::vec3(0.3f)});
    scene.add_instance(fixtures::add_box_mesh(scene, 0.6f, 0.4f, 0.3f), identity(), 1, Material{glm::vec3(0.6f)});
    scene.commit();
    const Lights lights{DirectionalLight(120, 20, 1361, 0.53), std::nullopt};
    LightCacheSettings one;
    one.threads = 1;
    one.rays_objects = one.rays_background = 64;
    LightCacheSettings two = one;
    two.threads = 2;
    const LightCache a(scene, lights, one), b(scene, lights, two);
    b.fill_all();  // in parallel, in whatever order the threads take
    for (uint32_t inst = 0; inst < 2; ++inst)
        for (uint32_t v = static_cast<uint32_t>(scene.mesh(scene.instance(inst).mesh).vertex_count()); v-- > 0;) {
            const IndirectLight x = a.vertex(inst, v), y = b.vertex(inst, v);  // a: one by one, backwards
            CHECK(std::memcmp(&x, &y, sizeof x) == 0);
        }
    CHECK(a.stats().gather_rays == b.stats().gather_rays && a.stats().vertices == 12);
    // And a render with the cache: the same bytes on one thread and two.
    const Camera cam = fixtures::look_at({1.2, 0.9, 0.8}, {0, 0, 0.1}, 40, 30, 30.0);
    RenderSettings r1{4, 3, 1, true, 1, 2}, r2{4, 3, 2, true, 1, 2};
    const Frame f1 = render_frame(scene, cam, lights, r1, nullptr, &a);
    const Frame f2 = render_frame(scene, cam, lights, r2, nullptr, &b);
    CHECK(std::memcmp(f1.rgb.data(), f2.rgb.data(), f1.rgb.size() * sizeof(float)) == 0);
    CHECK(f1.stats.bounce_rays == 0);
}

TEST_CASE(light_cache_settings_validate_names_the_field) {
    LightCacheSettings{}.validate();  // the defaults are valid
    auto rejection = [](const LightCacheSettings& s) -> std::string {
        try {
            s.validate();
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    LightCacheSettings s;
    s.bounces = 0;
    CHECK(rejection(s).rfind("bounces: a light cache needs 1..", 0) == 0);
    s = LightCacheSettings{};
    s.rays_background = 0;
    CHECK(rejection(s).rfind("rays_background: ", 0) == 0);
    s = LightCacheSettings{};
    s.object_cell_m = -1.0;
    CHECK(rejection(s).rfind("object_cell_m: ", 0) == 0);
}
