#include "moonbot/limit.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <stdexcept>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/render.h"
#include "rays.h"

namespace moonbot {

namespace {

using namespace detail;

/// Rays grouped by tile: tile t owns rays[offset[t], offset[t + 1]).
struct TiledRays {
    std::vector<RayHit> rays;
    std::vector<size_t> offset{0};
    size_t tiles() const { return offset.size() - 1; }
};

template <typename Trace>
double median_seconds(tbb::task_arena& arena, const TiledRays& pristine, int repeats, Trace trace) {
    std::vector<double> seconds;
    std::vector<RayHit> work;
    for (int r = 0; r < repeats; ++r) {
        work = pristine.rays;  // fresh tfar and hit fields; copied outside the timed region
        const auto start = std::chrono::steady_clock::now();
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, pristine.tiles()), [&](const auto& range) {
                for (size_t t = range.begin(); t != range.end(); ++t)
                    trace(work.data() + pristine.offset[t], pristine.offset[t + 1] - pristine.offset[t]);
            });
        });
        seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    std::nth_element(seconds.begin(), seconds.begin() + seconds.size() / 2, seconds.end());
    return seconds[seconds.size() / 2];
}

}  // namespace

EmbreeLimit measure_embree_limit(const Scene& scene, const Camera& camera, const Sun& sun,
                                 int threads, int repeats) {
    if (repeats < 1) throw std::invalid_argument("repeats: must be >= 1");
    if (threads < 0 || threads > kMaxThreads)
        throw std::invalid_argument("threads: must be in 0.." + std::to_string(kMaxThreads) + " (0 = all)");
    const Scene::ReadLock lock(scene);
    if (!scene.committed())
        throw std::invalid_argument("scene: not committed (call commit() after adding geometry)");
    if (scene.instance_count() == 0) throw std::invalid_argument("scene: has no instances");

    // The camera rays of the renderer's centre pass, tile by tile, and the shadow rays of their
    // hits, made by the renderer's own code (rays.h).
    const int w = camera.width(), h = camera.height();
    const std::vector<InstanceData> instances = instance_table(scene);
    TiledRays camera_rays, shadow_rays;
    camera_rays.rays.reserve(static_cast<size_t>(w) * h);
    std::array<glm::dvec3, kTilePixels> dirs;
    std::array<RayHit, kTilePixels> traced, shadow;
    std::array<int, kTilePixels> shadow_of;
    TileHits hits;
    for (int y0 = 0; y0 < h; y0 += kTile)
        for (int x0 = 0; x0 < w; x0 += kTile) {
            const int x1 = std::min(x0 + kTile, w), y1 = std::min(y0 + kTile, h);
            const int n = centre_rays(camera, x0, y0, x1, y1, dirs.data(), traced.data());
            camera_rays.rays.insert(camera_rays.rays.end(), traced.begin(), traced.begin() + n);
            camera_rays.offset.push_back(camera_rays.rays.size());
            scene.accel().intersect(traced.data(), static_cast<size_t>(n), true);
            hits.resolve(instances.data(), camera.center(), dirs.data(), traced.data(), n, x1 - x0, true);
            if (sun.irradiance() > 0.0) {
                const int n_shadow = hits.shadow_rays(camera.center(), dirs.data(), sun.direction(),
                                                      shadow.data(), shadow_of.data());
                shadow_rays.rays.insert(shadow_rays.rays.end(), shadow.begin(), shadow.begin() + n_shadow);
            }
            shadow_rays.offset.push_back(shadow_rays.rays.size());
        }

    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    const Accel& accel = scene.accel();
    EmbreeLimit limit;
    limit.camera_rays = camera_rays.rays.size();
    limit.shadow_rays = shadow_rays.rays.size();
    limit.intersect_single_s = median_seconds(arena, camera_rays, repeats,
        [&](RayHit* r, size_t n) { accel.intersect_single(r, n); });
    limit.intersect_stream_s = median_seconds(arena, camera_rays, repeats,
        [&](RayHit* r, size_t n) { accel.intersect(r, n, true); });
    limit.occluded_single_s = median_seconds(arena, shadow_rays, repeats,
        [&](RayHit* r, size_t n) { accel.occluded_single(r, n); });
    limit.occluded_stream_s = median_seconds(arena, shadow_rays, repeats,
        [&](RayHit* r, size_t n) { accel.occluded(r, n, true); });
    return limit;
}

}  // namespace moonbot
