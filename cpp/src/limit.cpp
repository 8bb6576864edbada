#include "moonbot/limit.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/render.h"
#include "moonbot/rng.h"
#include "rays.h"

namespace moonbot {

namespace {

using namespace detail;
using Clock = std::chrono::steady_clock;

/// Rays, or packets of rays, grouped by tile: tile t owns items[offset[t], offset[t + 1]),
/// which hold count[t] rays.
template <typename T>
struct Tiled {
    std::vector<T> items;
    std::vector<size_t> offset{0};
    std::vector<size_t> count;

    size_t tiles() const { return count.size(); }
    void end_tile(size_t rays) {
        offset.push_back(items.size());
        count.push_back(rays);
    }
};

/// Appends `n` rays to `out` as packets of W, taking them in the order `order` lists; the last
/// packet's spare lanes stay empty (the tracing call marks them inactive).
template <int W>
void pack(const RayHit* rays, const std::vector<int>& order, size_t n, std::vector<RayHitPacket<W>>& out) {
    for (size_t first = 0; first < n; first += W) {
        RayHitPacket<W> packet{};
        for (size_t lane = 0; lane < W && first + lane < n; ++lane)
            pack_lane(rays[order[first + lane]], packet, static_cast<int>(lane));
        out.push_back(packet);
    }
}

/// The order in which a tw×th tile's camera rays (row-major) fill packets: bw×bh pixel blocks,
/// the compact footprints a packet tracer would use (4×2 for 8 lanes, 4×4 for 16).
std::vector<int> block_order(int tw, int th, int bw, int bh) {
    std::vector<int> order;
    for (int by = 0; by < th; by += bh)
        for (int bx = 0; bx < tw; bx += bw)
            for (int y = by; y < std::min(by + bh, th); ++y)
                for (int x = bx; x < std::min(bx + bw, tw); ++x) order.push_back(y * tw + x);
    return order;
}

double median(std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
}

/// What one clock-to-clock interval costs when nothing runs inside it: the median, over
/// batches, of the mean of 1000 back-to-back intervals.
double timer_overhead() {
    std::vector<double> batches;
    for (int b = 0; b < 21; ++b) {
        double sum = 0.0;
        for (int i = 0; i < 1000; ++i) {
            const auto start = Clock::now();
            sum += std::chrono::duration<double>(Clock::now() - start).count();
        }
        batches.push_back(sum / 1000.0);
    }
    return median(batches);
}

/// Seconds spent inside `trace`, tile by tile from a per-thread copy, summed per thread; the
/// busiest thread's sum, median over the repeats.
template <typename T, typename Trace>
double embree_seconds(tbb::task_arena& arena, const Tiled<T>& pristine, int repeats, double overhead, Trace trace) {
    std::vector<double> seconds;
    tbb::enumerable_thread_specific<std::vector<T>> scratch;
    for (int r = 0; r < repeats; ++r) {
        tbb::enumerable_thread_specific<double> busy(0.0);
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, pristine.tiles()), [&](const auto& range) {
                std::vector<T>& work = scratch.local();
                double& sum = busy.local();
                for (size_t t = range.begin(); t != range.end(); ++t) {
                    if (pristine.count[t] == 0) continue;  // nothing to trace (no shadow rays)
                    // Fresh tfar and hit fields, copied into the cache outside the timed interval.
                    work.assign(pristine.items.begin() + static_cast<std::ptrdiff_t>(pristine.offset[t]),
                                pristine.items.begin() + static_cast<std::ptrdiff_t>(pristine.offset[t + 1]));
                    const auto start = Clock::now();
                    trace(work.data(), pristine.count[t]);
                    sum += std::chrono::duration<double>(Clock::now() - start).count() - overhead;
                }
            });
        });
        double busiest = 0.0;
        for (double s : busy) busiest = std::max(busiest, s);
        seconds.push_back(busiest);
    }
    return median(seconds);
}

/// Wall seconds of tracing every tile in place over the whole image's rays, median over repeats.
template <typename Trace>
double wall_seconds_from_memory(tbb::task_arena& arena, const Tiled<RayHit>& pristine, int repeats, Trace trace) {
    std::vector<double> seconds;
    std::vector<RayHit> work;
    for (int r = 0; r < repeats; ++r) {
        work = pristine.items;  // fresh tfar and hit fields; copied outside the timed region
        const auto start = Clock::now();
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, pristine.tiles()), [&](const auto& range) {
                for (size_t t = range.begin(); t != range.end(); ++t)
                    trace(work.data() + pristine.offset[t], pristine.count[t]);
            });
        });
        seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
    }
    return median(seconds);
}

/// The unit geometric normal at the hit of the traced `ray` (which left along `dir`), on the side
/// the ray arrived from, as the renderer's bounce vertices take it; false if it missed or the
/// normal is degenerate.
bool hit_normal(const InstanceData* instances, const RayHit& ray, const glm::dvec3& dir, glm::dvec3& normal) {
    return ray.geom_id != kInvalidId && arrival_normal(instances[ray.inst_id], ray, dir, normal);
}

/// Bounce rays for the `n` traced rays `from` (ray k leaving along dirs[k], of pixel pixel_of[k];
/// every hit is a path vertex): a cosine-distributed direction about the hit's unit geometric
/// normal on the arriving side, from the lifted hit point, its two uniforms keyed by the pixel and
/// `generation`. Into `out` (their directions into `out_dirs`, their pixels into `out_pixel`);
/// returns their number.
int bounce_rays(const InstanceData* instances, const RayHit* from, const glm::dvec3* origins, const glm::dvec3* dirs,
                const uint64_t* pixel_of, int n, uint32_t generation, RayHit* out, glm::dvec3* out_origins,
                glm::dvec3* out_dirs, uint64_t* out_pixel) {
    int count = 0;
    for (int k = 0; k < n; ++k) {
        const RayHit& ray = from[k];
        glm::dvec3 normal;
        if (!hit_normal(instances, ray, dirs[k], normal)) continue;
        const glm::dvec3 point = origins[k] + static_cast<double>(ray.tfar) * dirs[k];
        const uint64_t stream = pixel_stream(0, pixel_of[k]);
        double mu;
        const glm::dvec3 wi = cosine_direction(normal, stream_uniform01(stream, 0, 2 * generation),
                                               stream_uniform01(stream, 0, 2 * generation + 1), mu);
        out_origins[count] = lift_off(point, normal, triangle_reach(instances[ray.inst_id], ray.prim_id));
        out_dirs[count] = wi;
        out_pixel[count] = pixel_of[k];
        set_ray(out[count], out_origins[count], wi);
        ++count;
    }
    return count;
}

/// Shadow rays toward the Sun (unit `to_sun`) from the hits of the `n` traced rays `traced` (ray
/// k left origins[k] along dirs[k]) whose surface, on the side the ray arrived from, faces it:
/// as the renderer lights a bounce vertex. Into `out`; returns their number.
int sun_rays(const InstanceData* instances, const RayHit* traced, const glm::dvec3* origins, const glm::dvec3* dirs,
             int n, const glm::dvec3& to_sun, RayHit* out) {
    int count = 0;
    for (int k = 0; k < n; ++k) {
        glm::dvec3 normal;
        if (!hit_normal(instances, traced[k], dirs[k], normal) || glm::dot(normal, to_sun) <= 0.0) continue;
        const glm::dvec3 point = origins[k] + static_cast<double>(traced[k].tfar) * dirs[k];
        set_ray(out[count++], lift_off(point, normal, triangle_reach(instances[traced[k].inst_id], traced[k].prim_id)),
                to_sun);
    }
    return count;
}

}  // namespace

EmbreeLimit measure_embree_limit(const Scene& scene, const Camera& camera, const DirectionalLight& sun, int threads,
                                 int repeats, int bounces) {
    if (repeats < 1) throw std::invalid_argument("repeats: must be >= 1");
    if (bounces < 0 || bounces > kMaxBounces)
        throw std::invalid_argument("bounces: must be in 0.." + std::to_string(kMaxBounces));
    if (threads < 0 || threads > kMaxThreads)
        throw std::invalid_argument("threads: must be in 0.." + std::to_string(kMaxThreads) + " (0 = all)");
    const Scene::ReadLock lock(scene);
    if (!scene.committed()) throw std::invalid_argument("scene: not committed (call commit() after adding geometry)");
    if (scene.instance_count() == 0) throw std::invalid_argument("scene: has no instances");

    // The camera rays of the renderer's centre pass, tile by tile, and the shadow rays of their
    // hits, made by the renderer's own code (rays.h); then the same rays packed for packets.
    const int w = camera.width(), h = camera.height();
    const std::vector<InstanceData> instances = instance_table(scene);
    Tiled<RayHit> camera_rays, shadow_rays;
    Tiled<RayHitPacket<8>> camera_8, shadow_8;
    Tiled<RayHitPacket<16>> camera_16, shadow_16;
    camera_rays.items.reserve(static_cast<size_t>(w) * h);
    std::array<glm::dvec3, kTilePixels> dirs;
    std::array<RayHit, kTilePixels> traced, shadow;
    std::array<int, kTilePixels> shadow_of;
    std::vector<int> in_order(kTilePixels);
    for (int i = 0; i < kTilePixels; ++i) in_order[static_cast<size_t>(i)] = i;
    TileHits hits;
    // Bounce rays per generation, tile by tile, and one generation's rays, origins, directions
    // and pixels while the next is made from them.
    std::vector<Tiled<RayHit>> bounce(static_cast<size_t>(bounces)), bounce_shadow(static_cast<size_t>(bounces));
    std::array<RayHit, kTilePixels> gen, next;
    std::array<glm::dvec3, kTilePixels> gen_origin, gen_dir, next_origin, next_dir;
    std::array<uint64_t, kTilePixels> gen_pixel, next_pixel;
    for (int y0 = 0; y0 < h; y0 += kTile)
        for (int x0 = 0; x0 < w; x0 += kTile) {
            const int x1 = std::min(x0 + kTile, w), y1 = std::min(y0 + kTile, h);
            const int n = centre_rays(camera, x0, y0, x1, y1, dirs.data(), traced.data());
            const auto un = static_cast<size_t>(n);
            camera_rays.items.insert(camera_rays.items.end(), traced.begin(), traced.begin() + n);
            camera_rays.end_tile(un);
            pack<8>(traced.data(), block_order(x1 - x0, y1 - y0, 4, 2), un, camera_8.items);
            camera_8.end_tile(un);
            pack<16>(traced.data(), block_order(x1 - x0, y1 - y0, 4, 4), un, camera_16.items);
            camera_16.end_tile(un);

            scene.accel().intersect(traced.data(), un);
            hits.resolve(instances.data(), camera.center(), dirs.data(), traced.data(), n, x1 - x0, true);
            int n_shadow = 0;
            if (sun.irradiance() > 0.0)
                n_shadow =
                    hits.shadow_rays(camera.center(), dirs.data(), sun.direction(), shadow.data(), shadow_of.data());
            const auto us = static_cast<size_t>(n_shadow);
            shadow_rays.items.insert(shadow_rays.items.end(), shadow.begin(), shadow.begin() + n_shadow);
            shadow_rays.end_tile(us);
            pack<8>(shadow.data(), in_order, us, shadow_8.items);
            shadow_8.end_tile(us);
            pack<16>(shadow.data(), in_order, us, shadow_16.items);
            shadow_16.end_tile(us);

            // Generation 0 "leaves" the camera: the traced camera rays, then each bounce from the
            // previous generation's hits (traced here, untimed, to find them).
            int n_gen = n;
            for (int i = 0; i < n; ++i) {
                gen[i] = traced[i];
                gen_origin[i] = camera.center();
                gen_dir[i] = dirs[i];
                gen_pixel[i] =
                    static_cast<uint64_t>(y0 + i / (x1 - x0)) * w + static_cast<uint64_t>(x0 + i % (x1 - x0));
            }
            for (int g = 0; g < bounces; ++g) {
                const int made = bounce_rays(instances.data(), gen.data(), gen_origin.data(), gen_dir.data(),
                                             gen_pixel.data(), n_gen, static_cast<uint32_t>(g), next.data(),
                                             next_origin.data(), next_dir.data(), next_pixel.data());
                Tiled<RayHit>& out = bounce[static_cast<size_t>(g)];
                out.items.insert(out.items.end(), next.begin(), next.begin() + made);
                out.end_tile(static_cast<size_t>(made));
                if (made > 0) scene.accel().intersect(next.data(), static_cast<size_t>(made));
                const int lit = sun.irradiance() > 0.0 ? sun_rays(instances.data(), next.data(), next_origin.data(),
                                                                  next_dir.data(), made, sun.direction(), shadow.data())
                                                       : 0;
                Tiled<RayHit>& to_sun = bounce_shadow[static_cast<size_t>(g)];
                to_sun.items.insert(to_sun.items.end(), shadow.begin(), shadow.begin() + lit);
                to_sun.end_tile(static_cast<size_t>(lit));
                std::swap(gen, next);
                std::swap(gen_origin, next_origin);
                std::swap(gen_dir, next_dir);
                std::swap(gen_pixel, next_pixel);
                n_gen = made;
            }
        }

    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    const Accel& accel = scene.accel();
    const double overhead = timer_overhead();
    EmbreeLimit limit;
    limit.camera_rays = camera_rays.items.size();
    limit.shadow_rays = shadow_rays.items.size();
    limit.timer_overhead_s = overhead;
    limit.threads = arena.max_concurrency();
    // A query the four ways Embree takes rays, in this order: one at a time, in packets of 8 and
    // of 16 (`packets` serves both widths), and as one stream a tile.
    const auto four_ways = [&](const Tiled<RayHit>& rays, const Tiled<RayHitPacket<8>>& rays_8,
                               const Tiled<RayHitPacket<16>>& rays_16, auto single, auto packets, auto stream) {
        return std::tuple<double, double, double, double>{embree_seconds(arena, rays, repeats, overhead, single),
                                                          embree_seconds(arena, rays_8, repeats, overhead, packets),
                                                          embree_seconds(arena, rays_16, repeats, overhead, packets),
                                                          embree_seconds(arena, rays, repeats, overhead, stream)};
    };
    std::tie(limit.intersect_single_s, limit.intersect_packet8_s, limit.intersect_packet16_s,
             limit.intersect_stream_s) =
        four_ways(
            camera_rays, camera_8, camera_16, [&](RayHit* r, size_t n) { accel.intersect_single(r, n); },
            [&](auto* p, size_t n) { accel.intersect_packets(p, n); },
            [&](RayHit* r, size_t n) { accel.intersect(r, n); });
    std::tie(limit.occluded_single_s, limit.occluded_packet8_s, limit.occluded_packet16_s, limit.occluded_stream_s) =
        four_ways(
            shadow_rays, shadow_8, shadow_16, [&](RayHit* r, size_t n) { accel.occluded_single(r, n); },
            [&](auto* p, size_t n) { accel.occluded_packets(p, n); },
            [&](RayHit* r, size_t n) { accel.occluded(r, n); });
    for (size_t g = 0; g < bounce.size(); ++g) {
        limit.bounce_rays.push_back(bounce[g].items.size());
        limit.bounce_stream_s.push_back(
            embree_seconds(arena, bounce[g], repeats, overhead, [&](RayHit* r, size_t n) { accel.intersect(r, n); }));
        limit.bounce_single_s.push_back(embree_seconds(arena, bounce[g], repeats, overhead,
                                                       [&](RayHit* r, size_t n) { accel.intersect_single(r, n); }));
        limit.bounce_shadow_rays.push_back(bounce_shadow[g].items.size());
        limit.bounce_shadow_stream_s.push_back(embree_seconds(arena, bounce_shadow[g], repeats, overhead,
                                                              [&](RayHit* r, size_t n) { accel.occluded(r, n); }));
    }
    limit.intersect_stream_from_memory_s =
        wall_seconds_from_memory(arena, camera_rays, repeats, [&](RayHit* r, size_t n) { accel.intersect(r, n); });
    limit.occluded_stream_from_memory_s =
        wall_seconds_from_memory(arena, shadow_rays, repeats, [&](RayHit* r, size_t n) { accel.occluded(r, n); });
    return limit;
}

}  // namespace moonbot
