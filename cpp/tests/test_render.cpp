#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.h"
#include "fixtures.h"
#include "moonbot/render.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;

glm::dmat4 identity() { return glm::dmat4(1.0); }

/// A ray from `origin` along `dir` (both narrowed to float32), unbounded, seeing every instance.
RayHit unbounded_ray(const glm::dvec3& origin, const glm::dvec3& dir) {
    RayHit r{};
    r.org_x = float(origin.x), r.org_y = float(origin.y), r.org_z = float(origin.z);
    r.dir_x = float(dir.x), r.dir_y = float(dir.y), r.dir_z = float(dir.z);
    r.tfar = INFINITY, r.mask = 0xFFFFFFFFu;
    return r;
}

}  // namespace

TEST_CASE(plane_depth_matches_analytic_z_depth) {
    Scene scene;
    const uint32_t plane = fixtures::add_plane_mesh(scene, 200.0f);
    scene.add_background(plane, identity(), Material{glm::vec3(0.12f)});
    scene.commit();
    // Tilted view: depth varies across the image.
    const Camera cam = fixtures::look_at({0.3, -1.1, 0.9}, {0.0, 0.5, 0.0}, 80, 60, 60.0);
    RenderSettings settings;
    const Frame f = render_frame(scene, cam, DirectionalLight(120, 30, 1361), settings);
    int checked = 0;
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
            const glm::dvec3 d = cam.direction(x + 0.5, y + 0.5);
            if (d.z >= 0) continue;  // above the horizon
            const double t = -cam.center().z / d.z;
            if (t > 150.0) continue;  // beyond the plane's edge
            CHECK_NEAR(f.depth[y * f.width + x], t, 1e-5 * t);
            ++checked;
        }
    CHECK(checked > 1000);
}

TEST_CASE(lit_plane_radiance_is_albedo_over_pi_times_e_sin_el) {
    for (double el : {1.0, 5.0, 12.0, 60.0}) {
        Scene scene;
        scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(),
                             Material{glm::vec3(0.12f, 0.2f, 0.3f)});
        scene.commit();
        const Camera cam = fixtures::look_at({0, 0, 1.0}, {0, 0, 0}, 32, 32, 20.0);
        const Frame f = render_frame(scene, cam, DirectionalLight(77, el, 1361), RenderSettings{});
        const double e = 1361 * std::sin(el * kPi / 180);
        for (size_t i = 0; i < f.depth.size(); ++i) {
            CHECK_NEAR(f.rgb[3 * i + 0], 0.12 / kPi * e, 1e-5 * e);
            CHECK_NEAR(f.rgb[3 * i + 2], 0.30 / kPi * e, 1e-5 * e);
        }
    }
}

TEST_CASE(sun_below_horizon_is_black_and_traces_no_shadow_rays) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    scene.commit();
    const Camera cam = fixtures::look_at({0, 0, 1.0}, {0, 0, 0}, 16, 16, 20.0);
    const Frame f = render_frame(scene, cam, DirectionalLight(0, -3, 1361), RenderSettings{});
    for (float v : f.rgb) CHECK(v == 0.0f);
    CHECK(f.stats.shadow_rays == 0);
}

TEST_CASE(box_casts_a_shadow_and_is_labelled) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    const uint32_t box = fixtures::add_box_mesh(scene, 0.4f, 0.4f, 0.4f);
    scene.add_instance(box, identity(), 7, Material{glm::vec3(0.45f)});
    scene.commit();
    // Looking straight down from 3 m; Sun from the east at 45°: the shadow falls to the west.
    const Camera cam = fixtures::look_at({0, 0, 3.0}, {0, 0, 0}, 101, 101, 50.0);
    const Frame f = render_frame(scene, cam, DirectionalLight(90, 45, 1000), RenderSettings{});
    auto at = [&](double wx, double wy) {
        const glm::dvec3 p = cam.project({wx, wy, 0.0});
        return static_cast<size_t>(int(p.y)) * f.width + static_cast<size_t>(int(p.x));
    };
    CHECK(f.instance[at(0, 0)] == 7);
    CHECK_NEAR(f.depth[at(0, 0)], 3.0 - 0.4, 1e-5);
    CHECK(f.instance[at(-0.4, 0)] == 0);
    CHECK(f.rgb[3 * at(-0.4, 0)] == 0.0f);                       // in the shadow
    CHECK_NEAR(f.rgb[3 * at(0.6, 0)], 0.5 / kPi * 1000 * std::sin(kPi / 4), 1e-3);  // lit ground
}

TEST_CASE(bytes_identical_for_one_and_two_threads) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    scene.add_instance(fixtures::add_box_mesh(scene, 0.3f, 0.2f, 0.1f), identity(), 1, Material{});
    scene.commit();
    const Camera cam = fixtures::look_at({0.8, 0.5, 0.6}, {0, 0, 0.05}, 67, 45, 40.0);
    RenderSettings one{4, 11, 1}, two{4, 11, 2};
    const Frame a = render_frame(scene, cam, DirectionalLight(200, 12, 1361), one);
    const Frame b = render_frame(scene, cam, DirectionalLight(200, 12, 1361), two);
    CHECK(std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(a.depth.data(), b.depth.data(), a.depth.size() * sizeof(float)) == 0);
    CHECK(a.instance == b.instance);
}

TEST_CASE(only_requested_passes_cost_rays) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    scene.commit();
    const uint64_t builds = scene.bvh_builds();
    const Camera cam = fixtures::look_at({0, 0, 1.0}, {0, 0, 0}, 24, 16, 20.0);
    const DirectionalLight sun(0, 30, 1361);
    std::vector<float> depth(24 * 16);
    const RenderStats geometry_only = render(scene, cam, sun, RenderSettings{}, {nullptr, depth.data(), nullptr});
    CHECK(geometry_only.camera_rays == 24 * 16);
    CHECK(geometry_only.shadow_rays == 0);
    const Frame f = render_frame(scene, cam, sun, RenderSettings{4, 0, 0});
    CHECK(f.stats.camera_rays == 24 * 16 * (1 + 4));  // centre ray for depth/labels + 4 samples
    CHECK(f.stats.shadow_rays == 24 * 16 * 4);
    CHECK(scene.bvh_builds() == builds);  // rendering never rebuilds
}

TEST_CASE(bad_scene_input_throws) {
    Scene scene;
    const float v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float nan_v[] = {0, 0, 0, NAN, 0, 0, 0, 1, 0};
    const uint32_t t[] = {0, 1, 2}, bad_t[] = {0, 1, 3};
    CHECK_THROWS(std::invalid_argument, scene.add_mesh(v, 0, t, 1));
    CHECK_THROWS(std::invalid_argument, scene.add_mesh(v, 3, t, 0));
    CHECK_THROWS(std::invalid_argument, scene.add_mesh(nan_v, 3, t, 1));
    CHECK_THROWS(std::invalid_argument, scene.add_mesh(v, 3, bad_t, 1));
    const uint32_t m = scene.add_mesh(v, 3, t, 1);
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m, identity(), 0, Material{}));
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m, identity(), 256, Material{}));
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m + 1, identity(), 1, Material{}));
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m, glm::dmat4(0.0), 1, Material{}));
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m, identity(), 1, Material{glm::vec3(1.5f)}));
    scene.add_instance(m, identity(), 1, Material{});
    CHECK_THROWS(std::invalid_argument, scene.add_instance(m, identity(), 1, Material{}));  // duplicate
    const Camera cam = fixtures::look_at({0, 0, 1.0}, {0, 0, 0}, 4, 4, 2.0);
    // Not committed:
    CHECK_THROWS(std::invalid_argument, render_frame(scene, cam, DirectionalLight(0, 30, 1), RenderSettings{}));
    scene.commit();
    CHECK_THROWS(std::invalid_argument, render_frame(scene, cam, DirectionalLight(0, 30, 1), RenderSettings{0, 0, 0}));
    CHECK_THROWS(std::invalid_argument, render_frame(scene, cam, DirectionalLight(0, 30, 1), RenderSettings{1, 0, -1}));
}

TEST_CASE(scene_refuses_changes_while_a_render_holds_it) {
    Scene scene;
    const uint32_t plane = fixtures::add_plane_mesh(scene, 5.0f);
    scene.add_background(plane, identity(), Material{});
    scene.commit();
    {
        const Scene::ReadLock lock(scene);
        CHECK_THROWS(std::logic_error, fixtures::add_plane_mesh(scene, 1.0f));
        CHECK_THROWS(std::logic_error, scene.add_instance(plane, identity(), 1, Material{}));
        CHECK_THROWS(std::logic_error, scene.commit());
    }
    fixtures::add_plane_mesh(scene, 1.0f);  // released: allowed again
    CHECK(scene.mesh_count() == 2);
}

TEST_CASE(tile_records_change_no_bit_against_a_per_pixel_reference) {
    // The renderer resolves and shades once per distinct triangle in a tile (rays.h, TileHits).
    // This is the per-pixel formulation it replaced, written out as the reference: the same
    // 8×8-tile ray streams, then every hit resolved and shaded on its own. Depth, labels and
    // radiance must match bit for bit.
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 40.0f), identity(), Material{glm::vec3(0.12f)});
    const uint32_t box = fixtures::add_box_mesh(scene, 0.5f, 0.3f, 0.25f);
    glm::dmat4 turned =
        glm::rotate(glm::translate(identity(), glm::dvec3(0.1, -0.05, 0.0)), 0.6, glm::dvec3(0.2, 0.1, 1.0));
    scene.add_instance(box, turned, 3, Material{glm::vec3(0.55f, 0.45f, 0.32f)});
    scene.add_instance(box, glm::translate(identity(), glm::dvec3(-0.7, 0.4, 0.0)), 9, Material{glm::vec3(0.3f)});
    scene.commit();
    const Camera cam = fixtures::look_at({1.1, -0.9, 0.7}, {0.0, 0.0, 0.1}, 83, 61, 70.0);
    const DirectionalLight sun(120, 12, 1361);
    const int w = cam.width(), h = cam.height();
    const glm::dvec3 o = cam.center(), l = sun.direction();
    constexpr double kInvPi = 0.31830988618379067154, kShadowBias = 2e-5;

    for (bool exact : {true, false}) {
        std::vector<float> depth(static_cast<size_t>(w) * h), rgb(3 * depth.size());
        std::vector<uint8_t> label(depth.size());
        for (int y0 = 0; y0 < h; y0 += 8)
            for (int x0 = 0; x0 < w; x0 += 8) {
                std::vector<RayHit> rays, shadows;
                std::vector<glm::dvec3> dirs, normals;
                std::vector<size_t> pixels, shadow_pixel;
                for (int y = y0; y < std::min(y0 + 8, h); ++y)
                    for (int x = x0; x < std::min(x0 + 8, w); ++x) {
                        const glm::dvec3 d = cam.direction(x + 0.5, y + 0.5);
                        rays.push_back(unbounded_ray(o, d));
                        dirs.push_back(d);
                        pixels.push_back(static_cast<size_t>(y) * w + x);
                    }
                scene.accel().intersect_watertight(rays.data(), rays.size(), scene.has_background());
                normals.resize(rays.size());
                for (size_t i = 0; i < rays.size(); ++i) {
                    const RayHit& r = rays[i];
                    const size_t px = pixels[i];
                    if (r.geom_id == kInvalidId) continue;
                    const Instance& inst = scene.instance(r.inst_id);
                    const glm::dvec3 n_raw = inst.normal_to_world * glm::dvec3(r.ng_x, r.ng_y, r.ng_z);
                    double t = r.tfar;
                    const Mesh& mesh = scene.mesh(inst.mesh);
                    glm::dvec3 v[3];
                    double reach = 0.0;
                    for (int k = 0; k < 3; ++k) {
                        v[k] = inst.linear * mesh.vertex(mesh.triangles[3 * size_t(r.prim_id) + k]) + inst.translation;
                        reach = std::max({reach, std::abs(v[k].x), std::abs(v[k].y), std::abs(v[k].z)});
                    }
                    if (exact) {
                        const glm::dvec3 n_plane = glm::cross(v[1] - v[0], v[2] - v[0]);
                        const double along = glm::dot(n_plane, dirs[i]);
                        if (along * along > 1e-24 * glm::dot(n_plane, n_plane) * glm::dot(dirs[i], dirs[i])) {
                            const double solved = glm::dot(n_plane, v[0] - o) / along;
                            if (solved > 0.0) t = solved;
                        }
                    }
                    depth[px] = static_cast<float>(t);
                    label[px] = inst.label;
                    glm::dvec3 n = n_raw / glm::length(n_raw);
                    if (glm::dot(n, dirs[i]) > 0.0) n = -n;
                    normals[i] = n;
                    if (glm::dot(n, l) <= 0.0) continue;
                    const glm::dvec3 p = o + t * dirs[i];
                    const double scale = std::max({1.0, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
                    const glm::dvec3 s = p + n * std::max(kShadowBias * scale, 1e-6 * reach);
                    shadows.push_back(unbounded_ray(s, l));
                    shadow_pixel.push_back(i);
                }
                if (!shadows.empty()) scene.accel().occluded(shadows.data(), shadows.size());
                for (size_t k = 0; k < shadows.size(); ++k) {
                    if (shadows[k].tfar < 0.0f) continue;
                    const size_t i = shadow_pixel[k];
                    const glm::dvec3 albedo(scene.instance(rays[i].inst_id).material.albedo);
                    const glm::dvec3 radiance = albedo * (kInvPi * sun.irradiance() * glm::dot(normals[i], l));
                    for (int c = 0; c < 3; ++c) rgb[3 * pixels[i] + c] = static_cast<float>(radiance[c]);
                }
            }
        RenderSettings settings;
        settings.exact_depth = exact;
        const Frame f = render_frame(scene, cam, sun, settings);
        CHECK(std::memcmp(f.depth.data(), depth.data(), depth.size() * sizeof(float)) == 0);
        CHECK(std::memcmp(f.rgb.data(), rgb.data(), rgb.size() * sizeof(float)) == 0);
        CHECK(f.instance == label);
        size_t boxes = 0, lit = 0;
        for (size_t i = 0; i < label.size(); ++i) boxes += label[i] != 0, lit += rgb[3 * i] > 0.0f;
        CHECK(boxes > 200 && lit > 1000 && lit < label.size());  // the boxes show; some shade
    }
}

TEST_CASE(adaptive_refines_edges_only_and_leaves_other_pixels_bit_identical) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    scene.add_instance(fixtures::add_box_mesh(scene, 0.3f, 0.2f, 0.1f), identity(), 1, Material{glm::vec3(0.5f)});
    scene.commit();
    const Camera cam = fixtures::look_at({0.8, 0.5, 0.6}, {0, 0, 0.05}, 67, 45, 40.0);
    const DirectionalLight sun(200, 12, 1361, 0.533);
    RenderSettings off{4, 11, 1};
    off.light_samples = 2;
    off.bounces = 1;
    RenderSettings on = off;
    on.adaptive_spp = 16;
    const Frame a = render_frame(scene, cam, sun, off);
    const Frame b = render_frame(scene, cam, sun, on);
    on.threads = 2;
    const Frame c = render_frame(scene, cam, sun, on);
    CHECK(a.stats.refined_pixels == 0 && a.stats.refinement_rays == 0);
    CHECK(b.stats.refined_pixels > 0 && b.stats.refined_pixels < a.depth.size() / 4);
    CHECK(b.stats.refined_pixels == c.stats.refined_pixels);
    CHECK(std::memcmp(b.rgb.data(), c.rgb.data(), b.rgb.size() * sizeof(float)) == 0);
    CHECK(b.stats.bounce_rays == a.stats.bounce_rays);  // refinement samples carry direct light only
    // Every refined pixel traces 12 more camera rays (and a second look now and then).
    CHECK(b.stats.camera_rays - a.stats.camera_rays == 12 * b.stats.refined_pixels);
    size_t changed = 0;
    for (size_t i = 0; i < a.depth.size(); ++i)
        changed += std::memcmp(&a.rgb[3 * i], &b.rgb[3 * i], 3 * sizeof(float)) != 0;
    CHECK(changed > 0 && changed <= b.stats.refined_pixels);
    CHECK(a.depth == b.depth && a.instance == b.instance);
}

TEST_CASE(adaptive_settings_are_checked) {
    Scene scene;
    scene.add_background(fixtures::add_plane_mesh(scene, 50.0f), identity(), Material{});
    scene.commit();
    const Camera cam = fixtures::look_at({0, 0, 1.0}, {0, 0, 0}, 8, 8, 20.0);
    auto message = [&](int spp, int adaptive_spp, double threshold) {
        RenderSettings s{spp};
        s.adaptive_spp = adaptive_spp;
        s.adaptive_threshold = threshold;
        try {
            render_frame(scene, cam, DirectionalLight(0, 30, 1361), s);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    CHECK(message(4, 4, 0.25).rfind("adaptive_spp: must be 0 (off) or in spp + 1..65536", 0) == 0);
    CHECK(message(1, 1, 0.25).rfind("adaptive_spp: must be 0 (off) or in spp + 1..65536", 0) == 0);
    CHECK(message(1, 8, 0.25).empty());  // over the pixel-centre sample
    CHECK(message(4, 8, -1.0).rfind("adaptive_threshold:", 0) == 0);
    CHECK(message(4, 8, 0.0).empty());
    CHECK(message(4, 0, 0.25).empty());
}

TEST_CASE(render_geometry_needs_no_light_and_matches_a_lit_render) {
    Scene scene;
    const uint32_t plane = fixtures::add_plane_mesh(scene, 200.0f);
    scene.add_background(plane, identity(), Material{glm::vec3(0.12f)});
    scene.commit();
    const Camera cam = fixtures::look_at({0.3, -1.1, 0.9}, {0.0, 0.5, 0.0}, 40, 30, 60.0);
    const Frame lit = render_frame(scene, cam, DirectionalLight(120, 30, 1361), RenderSettings{});
    const size_t n = static_cast<size_t>(cam.width()) * cam.height();
    std::vector<float> depth(n);
    std::vector<uint8_t> instance(n);
    const RenderStats stats = render_geometry(scene, cam, RenderSettings{}, {nullptr, depth.data(), instance.data()});
    CHECK(depth == lit.depth && instance == lit.instance);
    CHECK(stats.shadow_rays == 0 && stats.camera_rays == lit.stats.camera_rays);
    std::vector<float> rgb(3 * n);
    CHECK_THROWS(std::invalid_argument, render_geometry(scene, cam, RenderSettings{}, {rgb.data(), nullptr, nullptr}));
}

TEST_CASE(render_settings_validate_names_the_field) {
    RenderSettings{}.validate();  // the defaults are valid
    auto rejection = [](const RenderSettings& s) -> std::string {
        try {
            s.validate();
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    RenderSettings s;
    s.spp = 0;
    CHECK(rejection(s).rfind("spp: must be in 1..", 0) == 0);
    s = RenderSettings{};
    s.adaptive_spp = 1;  // not above spp
    CHECK(rejection(s).rfind("adaptive_spp: ", 0) == 0);
    s = RenderSettings{};
    s.adaptive_threshold = NAN;
    CHECK(rejection(s).rfind("adaptive_threshold: ", 0) == 0);
    s = RenderSettings{};
    s.threads = kMaxThreads + 1;
    CHECK(rejection(s).rfind("threads: ", 0) == 0);
}

TEST_CASE(a_refined_pixel_gets_the_power_of_two_nearest_its_share) {
    // 4 base samples, up to 128: the share's count base + ⌈124·share⌉, moved to 2^k where it lies
    // in [2^k/√2, 2^k·√2), at least the first power of two past the base, at most the total.
    CHECK(refined_sample_count(4, 128, 0.0) == 8);     // 5 → 4, which is the base: 8
    CHECK(refined_sample_count(4, 128, 0.05) == 8);    // 11 < 8·√2 = 11.3
    CHECK(refined_sample_count(4, 128, 0.06) == 16);   // 12 >= 11.3
    CHECK(refined_sample_count(4, 128, 0.14) == 16);   // 22 < 16·√2 = 22.6
    CHECK(refined_sample_count(4, 128, 0.15) == 32);   // 23 >= 22.6
    CHECK(refined_sample_count(4, 128, 0.5) == 64);    // 66
    CHECK(refined_sample_count(4, 128, 1.0) == 128);
    CHECK(refined_sample_count(2, 64, 0.0) == 4);      // the draft's base 2: 3 → 4
    CHECK(refined_sample_count(4, 100, 1.0) == 100);   // a total that is no power of two caps it
    CHECK(refined_sample_count(3, 64, 0.0) == 4);      // a base that is none: 4 is past it
    for (int base : {2, 4, 8})
        for (double share = 0.0; share <= 1.0; share += 1.0 / 64) {
            const int n = refined_sample_count(base, 256, share);
            CHECK(n > base && n <= 256 && (n & (n - 1)) == 0);
        }
}
