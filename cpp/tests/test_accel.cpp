#include <algorithm>
#include <cmath>
#include <vector>

#include "check.h"
#include "fixtures.h"
#include "moonbot/accel.h"

using namespace moonbot;

namespace {

/// Camera rays over a small view of a plane and a box, and Sun-ward rays from the plane, some of
/// them blocked by the box.
struct Rays {
    std::vector<RayHit> camera, shadow;
};

Rays make_rays(const Camera& cam) {
    Rays r;
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) {
            const glm::dvec3 o = cam.center(), d = cam.direction(x + 0.5, y + 0.5);
            RayHit ray{};
            ray.org_x = float(o.x), ray.org_y = float(o.y), ray.org_z = float(o.z);
            ray.dir_x = float(d.x), ray.dir_y = float(d.y), ray.dir_z = float(d.z);
            ray.tfar = INFINITY, ray.mask = 0xFFFFFFFFu;
            r.camera.push_back(ray);
            RayHit up = ray;  // from the ground below the camera ray's hit point, toward a low Sun
            up.org_x = float(-0.8 + 1.6 * x / cam.width()), up.org_y = float(-0.8 + 1.6 * y / cam.height());
            up.org_z = 1e-4f, up.dir_x = 0.9f, up.dir_y = 0.0f, up.dir_z = 0.25f;
            r.shadow.push_back(up);
        }
    return r;
}

template <int W>
void packets_agree_with_streams(const Scene& scene, const Rays& rays, size_t n) {
    std::vector<RayHit> camera(rays.camera.begin(), rays.camera.begin() + n);
    std::vector<RayHit> shadow(rays.shadow.begin(), rays.shadow.begin() + n);
    std::vector<RayHitPacket<W>> camera_p((n + W - 1) / W), shadow_p((n + W - 1) / W);
    for (size_t i = 0; i < n; ++i) {
        pack_lane(camera[i], camera_p[i / W], int(i % W));
        pack_lane(shadow[i], shadow_p[i / W], int(i % W));
    }
    scene.accel().intersect(camera.data(), n);
    scene.accel().occluded(shadow.data(), n);
    scene.accel().intersect_packets(camera_p.data(), n);
    scene.accel().occluded_packets(shadow_p.data(), n);
    size_t hits = 0, blocked = 0;
    for (size_t i = 0; i < n; ++i) {
        const RayHitPacket<W>& c = camera_p[i / W];
        const int lane = int(i % W);
        CHECK(c.geom_id[lane] == camera[i].geom_id);
        CHECK(c.inst_id[lane] == camera[i].inst_id);
        if (camera[i].geom_id == kInvalidId) continue;
        ++hits;
        CHECK(c.prim_id[lane] == camera[i].prim_id);
        CHECK_NEAR(c.tfar[lane], camera[i].tfar, 1e-5 * camera[i].tfar);
        const bool occluded = shadow[i].tfar < 0.0f;
        CHECK((shadow_p[i / W].tfar[lane] < 0.0f) == occluded);
        blocked += occluded;
    }
    if (n == rays.camera.size()) CHECK(hits > n / 2 && blocked > 0 && blocked < n);
    // Lanes past the n-th are inactive: their (zeroed) hit ids are reset but never traced.
    if (n % W != 0) CHECK(camera_p.back().geom_id[W - 1] == kInvalidId);
}

}  // namespace

TEST_CASE(packets_of_8_and_16_hit_what_the_streams_hit) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 20.0f), glm::dmat4(1.0), Material{});
    scene.add_instance(fixtures::add_box_mesh(scene, 0.4f, 0.6f, 0.3f),
                       glm::translate(glm::dmat4(1.0), glm::dvec3(0.3, 0.0, 0.0)), 1, Material{});
    scene.commit();
    const Camera cam = fixtures::look_at({-1.0, -1.2, 1.1}, {0.2, 0.0, 0.1}, 40, 29, 30.0);
    const Rays rays = make_rays(cam);
    for (size_t n : {rays.camera.size(), size_t(64), size_t(61), size_t(13)}) {
        packets_agree_with_streams<8>(scene, rays, n);
        packets_agree_with_streams<16>(scene, rays, n);
    }
}
