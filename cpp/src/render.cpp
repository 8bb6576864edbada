#include "moonbot/render.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/rng.h"
#include "rays.h"

namespace moonbot {

namespace {

using namespace detail;

constexpr int kMaxSpp = 65536;
constexpr double kInvPi = 0.31830988618379067154;

/// Per-thread scratch for one tile.
struct TileScratch {
    std::array<RayHit, kTilePixels> rays;
    std::array<RayHit, kTilePixels> shadow;
    std::array<glm::dvec3, kTilePixels> dirs;
    TileHits hits;
    std::array<int, kTilePixels> shadow_of;     // which pixel of the tile a shadow ray belongs to
    std::array<uint64_t, kTilePixels> streams;  // pixel_stream of each pixel, for jittered samples
    std::array<glm::dvec3, kTilePixels> radiance;
};

class TileRenderer {
public:
    TileRenderer(const Scene& scene, const Camera& camera, const Sun& sun,
                 const RenderSettings& settings, const FrameView& out)
        : m_scene(scene), m_camera(camera), m_sun(sun), m_settings(settings), m_out(out),
          m_instances(instance_table(scene)), m_sun_scale(kInvPi * sun.irradiance()) {}

    void render_tile(int x0, int y0, int x1, int y1, TileScratch& s, RenderStats& stats) const {
        const int tw = x1 - x0;
        const int n = tw * (y1 - y0);
        const bool want_rgb = m_out.rgb != nullptr;
        const bool centre_pass = m_out.depth || m_out.instance || (want_rgb && m_settings.spp == 1);

        if (centre_pass) {
            trace(x0, y0, tw, n, s, stats, /*sample=*/-1);
            // Locals, not members: a uint8_t store may alias anything, so the compiler would
            // reload every member pointer after each label written.
            float* const depth = m_out.depth;
            uint8_t* const instance = m_out.instance;
            const InstanceData* const instances = m_instances.data();
            for (int y = y0, i = 0; y < y1; ++y) {
                const size_t row = index(x0, y);
                for (int x = 0; x < tw; ++x, ++i) {
                    const PixelHit& h = s.hits.pixel(i);
                    if (depth) depth[row + x] = h.hit ? static_cast<float>(h.t) : 0.0f;
                    if (instance) instance[row + x] = h.hit ? instances[s.hits.record(h).instance].label : 0;
                }
            }
        }
        if (!want_rgb) return;

        if (m_settings.spp == 1) {
            shade(n, s, stats);
        } else {
            std::array<glm::dvec3, kTilePixels> sum;
            sum.fill(glm::dvec3(0.0));
            // The (seed, pixel) part of the jitter's key, once per pixel rather than per sample.
            for (int y = y0, i = 0; y < y1; ++y)
                for (int x = x0; x < x1; ++x, ++i) s.streams[i] = pixel_stream(m_settings.seed, index(x, y));
            for (int sample = 0; sample < m_settings.spp; ++sample) {
                trace(x0, y0, tw, n, s, stats, sample);
                shade(n, s, stats);
                for (int i = 0; i < n; ++i) sum[i] += s.radiance[i];
            }
            for (int i = 0; i < n; ++i) s.radiance[i] = sum[i] / double(m_settings.spp);
        }
        for (int y = y0, i = 0; y < y1; ++y) {
            float* px = m_out.rgb + 3 * index(x0, y);
            for (int x = 0; x < tw; ++x, ++i, px += 3)
                for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(s.radiance[i][c]);
        }
    }

private:
    size_t index(int x, int y) const { return static_cast<size_t>(y) * m_camera.width() + x; }

    /// Traces one camera ray per tile pixel: through the centre (sample < 0) or jittered by the
    /// counter-based generator, and resolves the hits.
    void trace(int x0, int y0, int tw, int n, TileScratch& s, RenderStats& stats, int sample) const {
        const glm::dvec3& origin = m_camera.center();
        if (sample < 0) {
            centre_rays(m_camera, x0, y0, x0 + tw, y0 + n / tw, s.dirs.data(), s.rays.data());
        } else {
            const auto k = static_cast<uint32_t>(sample);
            for (int y = y0, i = 0; y < y0 + n / tw; ++y)
                for (int x = x0; x < x0 + tw; ++x, ++i) {
                    const double jx = stream_uniform01(s.streams[i], k, 0);
                    const double jy = stream_uniform01(s.streams[i], k, 1);
                    s.dirs[i] = m_camera.direction(x + jx, y + jy);
                    set_ray(s.rays[i], origin, s.dirs[i]);
                }
        }
        m_scene.accel().intersect(s.rays.data(), n, /*coherent=*/true);
        stats.camera_rays += n;
        s.hits.resolve(m_instances.data(), origin, s.dirs.data(), s.rays.data(), n, tw,
                       m_settings.exact_depth);
    }

    /// Direct sunlight on the resolved hits, with one shadow ray per hit facing the Sun.
    void shade(int n, TileScratch& s, RenderStats& stats) const {
        std::fill_n(s.radiance.begin(), n, glm::dvec3(0.0));
        if (m_sun.irradiance() <= 0.0) return;
        const int n_shadow = s.hits.shadow_rays(m_camera.center(), s.dirs.data(), m_sun.direction(),
                                                s.shadow.data(), s.shadow_of.data());
        if (n_shadow == 0) return;
        m_scene.accel().occluded(s.shadow.data(), n_shadow, /*coherent=*/true);
        stats.shadow_rays += n_shadow;
        for (int k = 0; k < n_shadow; ++k) {
            if (s.shadow[k].tfar < 0.0f) continue;  // occluded
            const PixelHit& h = s.hits.pixel(s.shadow_of[k]);
            const TriangleRecord& tri = s.hits.record(h);
            s.radiance[s.shadow_of[k]] =
                m_instances[tri.instance].albedo * (m_sun_scale * tri.cos_sun[h.side]);
        }
    }

    const Scene& m_scene;
    const Camera& m_camera;
    const Sun& m_sun;
    const RenderSettings& m_settings;
    const FrameView& m_out;
    const std::vector<InstanceData> m_instances;
    const double m_sun_scale;  // E/π: radiance of a white surface facing the Sun, W/(m²·sr)
};

}  // namespace

RenderStats render(const Scene& scene, const Camera& camera, const Sun& sun,
                   const RenderSettings& settings, const FrameView& out) {
    if (settings.spp < 1 || settings.spp > kMaxSpp)
        throw std::invalid_argument("spp: must be in 1.." + std::to_string(kMaxSpp) + ", got " +
                                    std::to_string(settings.spp));
    if (settings.threads < 0 || settings.threads > kMaxThreads)
        throw std::invalid_argument("threads: must be in 0.." + std::to_string(kMaxThreads) +
                                    " (0 = all), got " + std::to_string(settings.threads));
    const Scene::ReadLock lock(scene);  // before the checks, so they stay true during the render
    if (!scene.committed())
        throw std::invalid_argument("scene: not committed (call commit() after adding geometry)");
    if (scene.instance_count() == 0) throw std::invalid_argument("scene: has no instances");

    const auto start = std::chrono::steady_clock::now();
    const int w = camera.width(), h = camera.height();
    const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
    const TileRenderer tiles(scene, camera, sun, settings, out);
    std::atomic<uint64_t> camera_rays{0}, shadow_rays{0};

    tbb::task_arena arena(settings.threads > 0 ? settings.threads : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const auto& range) {
            TileScratch scratch;
            RenderStats local;
            for (int t = range.begin(); t != range.end(); ++t) {
                const int x0 = (t % tiles_x) * kTile, y0 = (t / tiles_x) * kTile;
                tiles.render_tile(x0, y0, std::min(x0 + kTile, w), std::min(y0 + kTile, h), scratch,
                                  local);
            }
            camera_rays += local.camera_rays;
            shadow_rays += local.shadow_rays;
        });
    });

    RenderStats stats;
    stats.camera_rays = camera_rays;
    stats.shadow_rays = shadow_rays;
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return stats;
}

Frame render_frame(const Scene& scene, const Camera& camera, const Sun& sun,
                   const RenderSettings& settings) {
    Frame f;
    f.width = camera.width();
    f.height = camera.height();
    const size_t n = static_cast<size_t>(f.width) * f.height;
    f.rgb.assign(3 * n, 0.0f);
    f.depth.assign(n, 0.0f);
    f.instance.assign(n, 0);
    f.stats = render(scene, camera, sun, settings, {f.rgb.data(), f.depth.data(), f.instance.data()});
    return f;
}

}  // namespace moonbot
