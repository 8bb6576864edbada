#include "moonbot/render.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/light_cache.h"
#include "moonbot/rng.h"
#include "moonbot/sampler.h"
#include "rays.h"

namespace moonbot {

namespace {

using namespace detail;

constexpr int kMaxSpp = 65536;
// Dimension pairs of one camera sample (sampler.h): pair 0 jitters the pixel; kPairLight + l
// samples light l's disk at the camera hit (the sequence's index runs over the samples and, within
// each, its shadow rays, so all of a pixel's rays toward the Sun are stratified together); bounce b
// takes kPairBounce + kPairsPerBounce·(b − 1) for its direction and the pairs after it for its
// vertex's lights.
constexpr uint32_t kPairLight = 8, kPairBounce = 4096, kPairsPerBounce = 32;
// A march stops once the dust's optical depth passes this: nothing behind shows (e^-20 ≈ 2e-9).
constexpr double kOpaqueDepth = 20.0;
// A box's σ (its width/√12) in the textures' footprint units (σ = footprint/2): 2/√12 = 1/√3.
const double kBoxSigmaToFootprint = 1.0 / std::sqrt(3.0);

/// The end of one pixel's path: where it is, which way it left, what it carries.
struct PathVertex {
    glm::dvec3 point;       // world metres
    glm::dvec3 lifted;      // where its shadow and bounce rays start (lift_off)
    glm::dvec3 normal;      // unit geometric normal, on the side the path arrived from
    glm::dvec3 shading;     // unit shading normal (the weave's, on cloth; else `normal`)
    glm::dvec3 albedo;      // linear RGB here (the fabric's and the stain's, on cloth)
    glm::dvec3 wo;          // unit, toward the previous vertex (the camera for the first)
    glm::dvec3 throughput;  // product of the BRDF weights along the path so far
    uint32_t instance;
    double cos_light[2];    // normal · light dir, per light
    bool alive;
    bool shaded_apart;      // `shading` differs from `normal`
    // The RMS slope (tan) of relief over the pixel about `shading` (the grain's,
    // GrainSample::residual_slope_variance): the lights' cosines are averaged over it. 0 elsewhere.
    double residual_slope;
    // The cloth's glossy tapes (fabric.h "Sheen"), at camera hits on cloth with sheen only:
    double sheen;             // its weight s; 0 elsewhere, and then nothing below is read
    const FabricParams* fabric;
    FabricSample weave;       // the prefiltered weave at the hit
    glm::dvec3 warp, weft;    // unit, with `shading` the frame the lobes are oriented in
};

/// What a pixel's base samples say about whether they agree (adaptive anti-aliasing).
struct SampleAgreement {
    int sun_escaped = 0;  // Sun shadow rays from the camera hits that escaped
    int sun_hidden = 0;   // those blocked, or below the hit facet's horizon
    double luminance_min = INFINITY, luminance_max = 0.0, luminance_sum = 0.0;  // of direct light, W/(m²·sr)

    void add(int escaped, int hidden, double luminance) {
        sun_escaped += escaped;
        sun_hidden += hidden;
        luminance_min = std::min(luminance_min, luminance);
        luminance_max = std::max(luminance_max, luminance);
        luminance_sum += luminance;
    }

    /// Whether the `samples` added disagree enough for more (render.h): their direct luminance
    /// spreads beyond `threshold` × the geometric mean of their own mean and the frame's.
    bool disagree(int samples, double threshold, double frame_luminance) const {
        return disagree(luminance_max - luminance_min, luminance_sum / samples, threshold, frame_luminance);
    }
    static bool disagree(double spread, double mean, double threshold, double frame_luminance) {
        return spread > threshold * std::sqrt(mean * frame_luminance);
    }
    bool penumbra() const { return sun_escaped > 0 && sun_hidden > 0; }
};

/// Rec. 709 luminance of linear RGB.
double luminance(const glm::dvec3& rgb) { return 0.2126 * rgb.r + 0.7152 * rgb.g + 0.0722 * rgb.b; }

/// One marched ray of a strided dust march (Medium::march_stride_px): where it crosses the grid
/// and DustGrid::march_profile's sums along it.
struct DustProfile {
    bool crosses = false;
    double enter = 0.0, exit = 0.0;  // metres along the ray
    std::vector<double> tau, lit;

    /// The sums from the camera to `distance` (metres along the ray; +inf: all of it), linear
    /// within a step.
    void at(double distance, double step, double& tau_out, double& lit_out) const {
        tau_out = lit_out = 0.0;
        if (!crosses || !(distance > enter)) return;
        const double s = std::min(distance, exit) - enter;
        const size_t j = std::min(static_cast<size_t>(s / step), tau.size() - 2);
        const double start = static_cast<double>(j) * step;
        const double length = std::min(step, exit - enter - start);
        const double f = length > 0.0 ? std::clamp((s - start) / length, 0.0, 1.0) : 1.0;
        tau_out = tau[j] + f * (tau[j + 1] - tau[j]);
        lit_out = lit[j] + f * (lit[j + 1] - lit[j]);
    }
};

/// Per-thread scratch for one tile.
struct TileScratch {
    std::array<RayHit, kTilePixels> rays;
    std::array<RayHit, kTilePixels> shadow;
    std::array<glm::dvec3, kTilePixels> dirs;
    std::array<glm::dvec3, kTilePixels> centre_dirs;  // of each camera ray's pixel centre: where textures are read
    TileHits hits;
    std::array<int, kTilePixels> shadow_of;     // which pixel of the tile a shadow ray belongs to
    // pixel_stream of each camera ray's pixel, for random samples: the tile's pixels in order,
    // or those of a refinement batch's rays (TileRenderer::refine_tile).
    std::array<uint64_t, kTilePixels> streams;
    // Each camera ray's index in its pixel's sample sequence (sampler.h): its jitter, its Sun-disk
    // points and its bounces'. One for the whole tile in a base pass; a refinement batch holds
    // runs of consecutive samples of its pixels.
    std::array<uint32_t, kTilePixels> samples;
    std::array<glm::dvec3, kTilePixels> radiance;  // of one sample: direct, then indirect added
    std::array<PathVertex, kTilePixels> path;
    std::array<int, kTilePixels> visible;       // shadow rays of one light that escaped, per pixel
    // Adaptive anti-aliasing, used only when adaptive_spp > 0:
    std::array<glm::dvec3, kTilePixels> direct;  // of one sample: the lights at the camera hit
    std::array<int, kTilePixels> sun_escaped;    // of one sample: its Sun shadow rays that escaped
    std::array<int, kTilePixels> sun_hidden;     // ... and those blocked or below the facet's horizon
    std::array<SampleAgreement, kTilePixels> agreement;
    // Refinement (TileRenderer::refine_tile), per refined pixel:
    std::array<int, kTilePixels> refined;              // the tile's pixels that get more samples
    std::array<int, kTilePixels> totals;               // the samples each is brought up to
    std::array<int, kTilePixels> refined_sun_rays;     // Sun-disk rays of each of its samples
    std::array<uint64_t, kTilePixels> refined_streams;  // its pixel_stream
    // ... and per camera ray of a refinement batch:
    std::array<int, kTilePixels> ray_pixel;  // its tile pixel (refined[its refined pixel])
    std::array<int, kTilePixels> ray_refined;  // its refined pixel (an index into refined)
    std::array<int, kTilePixels> sun_rays;   // its Sun-disk rays
    // The regolith grain as each tile pixel's samples read it (TileRenderer::read_grain),
    // where its centre ray hits, once a pass over the tile.
    struct GrainRead {
        bool known = false;     // the centre ray hit an instance with grain
        uint32_t instance = 0;  // that instance
        glm::dvec3 point{0.0};  // where it hit, world metres
        GrainSample sample;
    };
    std::array<GrainRead, kTilePixels> grain_reads;
    // The light cache's indirect radiance toward the camera at a sample's hit, kept for the tile
    // pixel's later samples that hit the same triangle (TileRenderer::add_indirect), one pass over
    // the tile at a time.
    struct IndirectRead {
        bool known = false;
        uint32_t instance = 0, prim = 0;  // the triangle it was read on
        glm::dvec3 radiance{0.0};         // W/(m²·sr), linear RGB, for a path throughput of 1
    };
    std::array<IndirectRead, kTilePixels> indirect_reads;
    // The light cache's corners of the triangles the tile's pixels read (LightCache::corners),
    // tilted to the facet's normal, kept for its other pixels on the same triangle: the
    // triangles are mostly many pixels wide. A few slots, chosen by the triangle's index.
    struct CornerRead {
        bool known = false;
        uint32_t instance = 0, prim = 0;  // the triangle
        glm::dvec3 normal{0.0};           // the facet's normal the corners were tilted to
        LightCache::TriangleCorners corners;
    };
    static constexpr uint32_t kCornerSlots = 8;
    std::array<CornerRead, kCornerSlots> corner_reads;
    // Dust, used only when the render has a medium:
    std::array<double, kTilePixels> sun_dust;       // transmittance toward the Sun at each first hit
    std::array<double, kTilePixels> dust_through;   // transmittance from the camera to the hit
    std::array<glm::dvec3, kTilePixels> dust_glow;  // sunlight the dust scatters toward the camera
    std::array<DustProfile, (kTile + 1) * (kTile + 1)> lattice;  // the marched rays of a strided march
};

/// Adaptive anti-aliasing's record of every pixel's base samples, written by the first pass over
/// the tiles and read by the second, which refines a pixel where it or one of its eight
/// neighbours disagrees: a sliver of a pixel that all of its own base samples miss is mostly
/// caught by a neighbour's along the same edge. Complete before the second pass starts, so the
/// decisions are the same whatever tile a thread took. With one base sample (the pixel-centre
/// ray) a pixel has nothing of its own to compare: its 3×3 neighbourhood's centre samples are
/// compared instead, from the `centre` record.
struct AdaptiveFrame {
    /// One pixel's centre sample, as SampleAgreement::add takes it (spp 1 only).
    struct CentreSample {
        uint16_t sun_escaped;   // its Sun shadow rays that escaped ...
        uint16_t sun_hidden;    // ... and those blocked or below the facet's horizon
        double luminance;       // of its direct light, W/(m²·sr)
    };
    std::vector<glm::dvec3> sum, direct_sum;  // over the base samples (spp >= 2): radiance, and its direct part
    // spp >= 2: bit 0 SampleAgreement::disagree (set by decide(), once the frame's luminance is
    // known), bit 1 the pixel's Sun rays partly escape (set by the first pass), bit 2 its 3×3
    // neighbourhood's base samples together disagree by RenderSettings::adaptive_contrast (decide())
    std::vector<uint8_t> disagree;
    std::vector<float> spread;  // spp >= 2: max − min of the base samples' direct luminance, W/(m²·sr)
    // spp >= 2 with RenderSettings::adaptive_contrast: min of the base samples' direct luminance, W/(m²·sr)
    std::vector<float> lowest;
    // spp >= 2, where bit 2 is set: max − min over the 3×3 neighbourhood's base samples, W/(m²·sr)
    std::vector<float> across;
    double frame_luminance = 0.0;  // mean direct luminance of the base samples over the frame, W/(m²·sr)
    double full_spread = 0.0;      // the share's f for this view (RenderSettings::adaptive_full_spread, or chosen)
    std::vector<CentreSample> centre;  // spp 1 only
    std::vector<double> dust_through;  // with dust only: the pixel's transmittance ...
    std::vector<glm::dvec3> dust_glow;  // ... and glow (TileScratch), applied after refining

    AdaptiveFrame(size_t pixels, bool centre_only, bool dust, bool contrast)
        : sum(centre_only ? 0 : pixels),
          direct_sum(centre_only ? 0 : pixels),
          disagree(centre_only ? 0 : pixels),
          spread(centre_only ? 0 : pixels),
          lowest(centre_only || !contrast ? 0 : pixels),
          across(centre_only || !contrast ? 0 : pixels),
          centre(centre_only ? pixels : 0),
          dust_through(dust ? pixels : 0),
          dust_glow(dust ? pixels : 0) {}

    /// After the first pass: the frame's mean direct luminance, then (spp ≥ 2) each pixel's
    /// SampleAgreement::disagree against it (with dust, both as the image shows them: through(),
    /// shown()), and with `contrast` > 0 its 3×3 neighbourhood's (RenderSettings::adaptive_contrast;
    /// the frame is `width` pixels wide), then the view's share `full_spread`
    /// (RenderSettings::adaptive_error_target). Sums in pixel order, so the same for any threads.
    void decide(const RenderSettings& settings, int width) {
        const int spp = settings.spp;
        const double threshold = settings.adaptive_threshold, contrast = settings.adaptive_contrast;
        full_spread = settings.adaptive_full_spread;
        const bool centre_only = spp == 1;
        const size_t pixels = centre_only ? centre.size() : direct_sum.size();
        double total = 0.0, seen = 0.0;  // seen: as the image shows it, through the dust, its glow added
        for (size_t k = 0; k < pixels; ++k) {
            const double direct = centre_only ? centre[k].luminance : luminance(direct_sum[k]) / spp;
            total += direct;
            seen += shown(k, direct);
        }
        frame_luminance = pixels > 0 ? total / static_cast<double>(pixels) : 0.0;
        if (centre_only) return;
        seen /= static_cast<double>(pixels);
        for (size_t k = 0; k < pixels; ++k)
            if (SampleAgreement::disagree(through(k) * spread[k], shown(k, luminance(direct_sum[k]) / spp), threshold,
                                          seen))
                disagree[k] |= 1;
        if (contrast > 0.0) decide_contrast(spp, contrast, width);
        if (settings.adaptive_error_target > 0.0 && full_spread > 0.0)
            full_spread = targeted_full_spread(spp, settings.adaptive_spp, settings.adaptive_error_target, width);
    }

    /// Pixel k's transmittance to the camera through the dust, 1 without dust.
    double through(size_t k) const { return dust_through.empty() ? 1.0 : dust_through[k]; }
    /// The luminance the image shows at pixel k for a surface luminance L, both W/(m²·sr): L
    /// dimmed by the dust and the cloud's glow along its centre ray added; L without dust.
    double shown(size_t k, double L) const {
        return dust_glow.empty() ? L : L * dust_through[k] + luminance(dust_glow[k]);
    }

    /// Whether pixel (x, y) is refined (spp >= 2, after decide's bits) and, if so, the spread its
    /// share follows, else −1: the rule TileRenderer::refine_tile and targeted_full_spread both read.
    float refined_spread(int x, int y, int width, int height) const {
        bool refine = false;
        float largest = 0.0f;
        for (int ny = std::max(y - 1, 0); ny <= std::min(y + 1, height - 1); ++ny)
            for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, width - 1); ++nx) {
                const size_t j = static_cast<size_t>(ny) * width + nx;
                refine = refine || (disagree[j] & 1) != 0;
                largest = std::max(largest, spread[j]);
            }
        const size_t k = static_cast<size_t>(y) * width + x;
        if (disagree[k] & 4) {
            refine = true;
            largest = std::max(largest, across[k]);
        }
        return refine ? largest : -1.0f;
    }

    /// RenderSettings::adaptive_error_target: the largest f = full_spread·kErrorTargetStep^j whose refined
    /// pixels' predicted relative error is at most `target`. The error is the image's, as it
    /// leaves the render: with dust, each pixel's is dimmed by its transmittance and the mean it is
    /// relative to includes the cloud's glow. Sums in pixel order: the same for any threads.
    double targeted_full_spread(int spp, int total, double target, int width) const {
        const size_t pixels = direct_sum.size();
        const int height = static_cast<int>(pixels / static_cast<size_t>(width));
        double mean = 0.0;  // the image's mean luminance: all light, through the dust, its glow added
        for (size_t k = 0; k < pixels; ++k) mean += shown(k, luminance(sum[k]) / spp);
        mean /= static_cast<double>(pixels);
        struct Refined {
            float spread;    // the spread its share follows, W/(m²·sr)
            double through;  // the dust's transmittance to the camera, 1 without dust
        };
        std::vector<Refined> refined;
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x)
                if (const float s = refined_spread(x, y, width, height); s >= 0.0f)
                    refined.push_back({s, through(static_cast<size_t>(y) * width + x)});
        if (refined.empty() || !(mean > 0.0)) return full_spread;
        // The prediction √(k·Σ (T·s)²/N^1.5 / P) / mean ≤ target, squared and rearranged.
        const double budget = target * target * static_cast<double>(pixels) * mean * mean / kRefinedErrorScale;
        double chosen = full_spread, f = full_spread;
        for (int step = 0; step <= kErrorTargetSteps; ++step, f *= kErrorTargetStep) {
            double predicted = 0.0;  // Σ (T·s)²/N^1.5
            for (const Refined& r : refined) {
                const double n =
                    refined_sample_count(spp, total, std::min(1.0, double(r.spread) / (f * frame_luminance)));
                const double seen = double(r.spread) * r.through;
                predicted += seen * seen / (n * std::sqrt(n));
            }
            if (predicted > budget) break;
            chosen = f;
        }
        return chosen;
    }

    /// decide's neighbourhood contrast (RenderSettings::adaptive_contrast, bit 2 and `across`).
    void decide_contrast(int spp, double contrast, int width) {
        const size_t pixels = direct_sum.size();
        const int height = static_cast<int>(pixels / static_cast<size_t>(width));
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                double low = INFINITY, high = -INFINITY, mean = 0.0;
                int n = 0;
                for (int ny = std::max(y - 1, 0); ny <= std::min(y + 1, height - 1); ++ny)
                    for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, width - 1); ++nx, ++n) {
                        const size_t j = static_cast<size_t>(ny) * width + nx;
                        low = std::min(low, double(lowest[j]));
                        high = std::max(high, double(lowest[j]) + spread[j]);
                        mean += luminance(direct_sum[j]) / spp;
                    }
                const size_t k = static_cast<size_t>(y) * width + x;
                if (!SampleAgreement::disagree(high - low, mean / n, contrast, frame_luminance)) continue;
                disagree[k] |= 4;
                across[k] = static_cast<float>(high - low);
            }
    }
};

class TileRenderer {
public:
    TileRenderer(const Scene& scene, const Camera& camera, const Lights& lights, const RenderSettings& settings,
                 const FrameView& out, const DustGrid* medium, const LightCache* light_cache, AdaptiveFrame* adaptive)
        : m_scene(scene),
          m_camera(camera),
          m_settings(settings),
          m_out(out),
          m_instances(instance_table(scene)),
          m_lights(light_table(lights)),
          m_medium(medium),
          m_light_cache(light_cache),
          m_adaptive(adaptive) {
        for (const LightData& l : m_lights) m_random = m_random || !l.point;
        m_random = m_random || settings.bounces > 0;
        for (const InstanceData& inst : m_instances) m_grain = m_grain || inst.grain != nullptr;
        m_grain = m_grain && !m_lights.empty();
        // Light 0 is the Sun unless the Sun is dark (light_table leaves dark lights out).
        if (lights.sun.irradiance() > 0.0) m_sun = &m_lights[0];
    }

    void render_tile(int x0, int y0, int x1, int y1, TileScratch& s, RenderStats& stats) const {
        const int tw = x1 - x0;
        const int n = tw * (y1 - y0);
        const bool want_rgb = m_out.rgb != nullptr;
        // The dust is marched once per pixel along its centre ray (it varies over many pixels), and
        // the grain read once where it hits.
        const bool centre_pass =
            m_out.depth || m_out.instance || (want_rgb && (m_settings.spp == 1 || m_medium || m_grain));

        if (m_settings.spp > 1 || m_random) {
            // The (seed, pixel) part of the random numbers' key, once per pixel, not per number.
            for (int y = y0, i = 0; y < y1; ++y)
                for (int x = x0; x < x1; ++x, ++i) s.streams[i] = pixel_stream(m_settings.seed, index(x, y));
        }
        if (centre_pass) {
            trace(x0, y0, tw, n, s, stats, /*centre=*/true);
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

        if (m_grain) read_grain(n, s);
        if (m_medium) march_dust(x0, y0, tw, n, s);
        if (m_light_cache) std::fill_n(s.indirect_reads.begin(), n, TileScratch::IndirectRead{});
        if (m_settings.spp == 1) {
            std::fill_n(s.samples.begin(), n, 0u);
            shade(n, s, stats, /*indirect=*/true);
            if (m_adaptive) {
                AdaptiveFrame& a = *m_adaptive;
                for (int y = y0, i = 0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x, ++i) {
                        const size_t k = index(x, y);
                        a.centre[k] = {static_cast<uint16_t>(s.sun_escaped[i]), static_cast<uint16_t>(s.sun_hidden[i]),
                                       luminance(s.direct[i])};
                        if (!m_medium) continue;
                        a.dust_through[k] = s.dust_through[i];
                        a.dust_glow[k] = s.dust_glow[i];
                    }
            }
        } else {
            const bool adaptive = m_adaptive != nullptr;
            std::array<glm::dvec3, kTilePixels> sum, direct_sum;
            sum.fill(glm::dvec3(0.0));
            if (adaptive) {
                direct_sum.fill(glm::dvec3(0.0));
                std::fill_n(s.agreement.begin(), n, SampleAgreement{});
            }
            for (int sample = 0; sample < m_settings.spp; ++sample) {
                std::fill_n(s.samples.begin(), n, static_cast<uint32_t>(sample));
                trace(x0, y0, tw, n, s, stats, /*centre=*/false);
                shade(n, s, stats, /*indirect=*/true);
                for (int i = 0; i < n; ++i) sum[i] += s.radiance[i];
                if (!adaptive) continue;
                for (int i = 0; i < n; ++i) {
                    direct_sum[i] += s.direct[i];
                    s.agreement[i].add(s.sun_escaped[i], s.sun_hidden[i], luminance(s.direct[i]));
                }
            }
            for (int i = 0; i < n; ++i) s.radiance[i] = sum[i] / double(m_settings.spp);
            if (adaptive) {
                AdaptiveFrame& a = *m_adaptive;
                for (int y = y0, i = 0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x, ++i) {
                        const size_t k = index(x, y);
                        a.sum[k] = sum[i];
                        a.direct_sum[k] = direct_sum[i];
                        const SampleAgreement& agreement = s.agreement[i];
                        a.spread[k] = static_cast<float>(agreement.luminance_max - agreement.luminance_min);
                        if (!a.lowest.empty()) a.lowest[k] = static_cast<float>(agreement.luminance_min);
                        a.disagree[k] = agreement.penumbra() ? 2 : 0;
                        if (!m_medium) continue;
                        a.dust_through[k] = s.dust_through[i];
                        a.dust_glow[k] = s.dust_glow[i];
                    }
            }
        }
        if (m_medium)
            for (int i = 0; i < n; ++i) s.radiance[i] = s.radiance[i] * s.dust_through[i] + s.dust_glow[i];
        for (int y = y0, i = 0; y < y1; ++y) {
            float* px = m_out.rgb + 3 * index(x0, y);
            for (int x = 0; x < tw; ++x, ++i, px += 3)
                for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(s.radiance[i][c]);
        }
    }

    /// Adaptive anti-aliasing's second pass over the tile [x0, x1) × [y0, y1), once every tile's
    /// base samples are in (AdaptiveFrame). With spp ≥ 2 base samples, each pixel where it or a
    /// neighbour disagrees gets samples spp .. adaptive_spp − 1 of direct light alone, and its rgb
    /// becomes the split estimator (render.h). With one (the centre sample), each pixel whose 3×3
    /// neighbourhood's centre samples disagree gets adaptive_spp jittered samples of its whole
    /// radiance in place of the centre's. The other pixels keep what the first pass wrote.
    void refine_tile(int x0, int y0, int x1, int y1, TileScratch& s, RenderStats& stats) const {
        const AdaptiveFrame& a = *m_adaptive;
        const int tw = x1 - x0, w = m_camera.width(), h = m_camera.height();
        const int base = m_settings.spp;
        int count = 0;
        for (int y = y0, i = 0; y < y1; ++y)
            for (int x = x0; x < x1; ++x, ++i) {
                bool refine = false, penumbra = false;
                float spread = 0.0f;  // the spread its share follows (base >= 2)
                if (base >= 2) {
                    spread = a.refined_spread(x, y, w, h);
                    refine = spread >= 0.0f;
                    for (int ny = std::max(y - 1, 0); refine && ny <= std::min(y + 1, h - 1); ++ny)
                        for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, w - 1); ++nx)
                            penumbra = penumbra || (a.disagree[index(nx, ny)] & 2) != 0;
                } else {
                    SampleAgreement neighbourhood;
                    int samples = 0;
                    for (int ny = std::max(y - 1, 0); ny <= std::min(y + 1, h - 1); ++ny)
                        for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, w - 1); ++nx, ++samples) {
                            const AdaptiveFrame::CentreSample& c = a.centre[index(nx, ny)];
                            neighbourhood.add(c.sun_escaped, c.sun_hidden, c.luminance);
                        }
                    refine = neighbourhood.disagree(samples, m_settings.adaptive_threshold, a.frame_luminance);
                }
                if (!refine) continue;
                // In a penumbra (its own or a neighbour's base samples' Sun rays partly escape) a
                // refinement sample casts penumbra_light_samples rays: there the disk's visibility
                // is what varies. Elsewhere the many samples spread one ray each over the disk.
                s.refined_sun_rays[count] = penumbra ? m_settings.penumbra_light_samples : 1;
                s.totals[count] = refined_total(spread, a.frame_luminance);
                s.refined[count] = i;
                s.refined_streams[count++] = pixel_stream(m_settings.seed, index(x, y));
            }
        if (count == 0) return;
        const uint64_t rays_before = stats.camera_rays + stats.second_look_rays + stats.shadow_rays;
        if (m_grain) {
            // The refined pixels' centre rays again, for the grain's reads (the first pass's are gone).
            trace(x0, y0, tw, count, s, stats, /*centre=*/true, s.refined.data());
            read_grain(count, s, s.refined.data());
        }
        std::array<glm::dvec3, kTilePixels> extra;
        std::fill_n(extra.begin(), count, glm::dvec3(0.0));
        // Over one centre sample: all of the pixel's samples anew, indirect light included (the
        // cache's costs no ray); over more: the samples past them, direct light alone.
        const bool whole = base == 1;
        if (m_light_cache && whole)  // past spp >= 2 base samples the refinement reads no indirect light
            for (int j = 0; j < count; ++j) s.indirect_reads[s.refined[j]] = {};
        // The samples go in batches of up to a tile's rays, each pixel's consecutive: a pixel's
        // Sun rays leave from one footprint, so Embree's 8-wide shadow packets go full and
        // coherent. A pixel's sums run over its samples in order, whatever the batches, so the
        // image does not depend on them.
        const int first = whole ? 0 : base;
        int next = 0, sample = first;  // the next ray: refined pixel `next`'s sample `sample`
        while (next < count) {
            int m = 0;
            for (; m < kTilePixels && next < count; ++m) {
                s.ray_refined[m] = next;
                s.ray_pixel[m] = s.refined[next];
                s.streams[m] = s.refined_streams[next];
                s.sun_rays[m] = s.refined_sun_rays[next];
                s.samples[m] = static_cast<uint32_t>(sample);
                if (++sample == s.totals[next]) ++next, sample = first;
            }
            trace(x0, y0, tw, m, s, stats, /*centre=*/false, s.ray_pixel.data());
            shade(m, s, stats, /*indirect=*/whole, /*refining=*/!whole, s.ray_pixel.data());
            for (int r = 0; r < m; ++r) extra[s.ray_refined[r]] += whole ? s.radiance[r] : s.direct[r];
        }
        for (int j = 0; j < count; ++j) {
            const int i = s.refined[j];
            const size_t k = index(x0 + i % tw, y0 + i / tw);
            const double n = s.totals[j];
            glm::dvec3 radiance =
                whole ? extra[j] / n : (a.sum[k] - a.direct_sum[k]) / double(base) + (a.direct_sum[k] + extra[j]) / n;
            if (m_medium) radiance = radiance * a.dust_through[k] + a.dust_glow[k];
            for (int c = 0; c < 3; ++c) m_out.rgb[3 * k + c] = static_cast<float>(radiance[c]);
        }
        stats.refined_pixels += static_cast<uint64_t>(count);
        stats.refinement_rays += stats.camera_rays + stats.second_look_rays + stats.shadow_rays - rays_before;
    }

private:
    size_t index(int x, int y) const { return static_cast<size_t>(y) * m_camera.width() + x; }

    /// The samples a refined pixel is brought up to: adaptive_spp, or with adaptive_full_spread
    /// f > 0 (and spp >= 2 base samples) a share of the samples past the base in proportion to
    /// its neighbourhood's largest direct-luminance spread over f times the frame's mean
    /// (`frame_luminance`), moved to a power of two (refined_sample_count): a pixel's error after
    /// N samples is about its spread over √N, so for a given number of samples the image's RMS
    /// error is least where they follow the spread.
    int refined_total(float spread, double frame_luminance) const {
        const int base = m_settings.spp, total = m_settings.adaptive_spp;
        const double full = m_adaptive->full_spread * frame_luminance;
        if (base < 2 || !(full > 0.0)) return total;
        return refined_sample_count(base, total, std::min(1.0, double(spread) / full));
    }

    /// Traces n camera rays and resolves their hits: through the pixel's centre (`centre`), or
    /// jittered by sample TileScratch::samples[j] of its pixel's sequence; with `pixels`, ray j
    /// goes through the tile's pixel pixels[j] (row-major in the tile, tw wide), else through
    /// pixel j.
    void trace(int x0, int y0, int tw, int n, TileScratch& s, RenderStats& stats, bool centre,
               const int* pixels = nullptr) const {
        const glm::dvec3& origin = m_camera.center();
        if (centre && !pixels) {
            centre_rays(m_camera, x0, y0, x0 + tw, y0 + n / tw, s.dirs.data(), s.rays.data());
            std::copy_n(s.dirs.begin(), n, s.centre_dirs.begin());
        } else {
            for (int i = 0; i < n; ++i) {
                const int p = pixels ? pixels[i] : i;
                const SamplePair j = centre ? SamplePair{0.5f, 0.5f} : sample_pair(s.streams[i], s.samples[i], 0);
                const double x = x0 + p % tw, y = y0 + p / tw;
                s.dirs[i] = m_camera.direction(x + double(j.u), y + double(j.v));
                s.centre_dirs[i] = m_camera.direction(x + 0.5, y + 0.5);
                set_ray(s.rays[i], origin, s.dirs[i]);
            }
        }
        // Depth and masks are ground truth: no camera ray may slip through a shared vertex.
        stats.second_look_rays += m_scene.accel().intersect_watertight(s.rays.data(), n, m_scene.has_background());
        stats.camera_rays += n;
        s.hits.resolve(m_instances.data(), origin, s.dirs.data(), s.rays.data(), n, tw, m_settings.exact_depth);
    }

    /// The radiance of the n resolved camera hits, each for its own sample (TileScratch::samples):
    /// the lights at the hit (also kept apart in `direct` when adaptive_spp > 0), then, with
    /// `indirect`, the indirect light (add_indirect). `refining`: refinement samples past spp ≥ 2
    /// base samples, each casting its TileScratch::sun_rays Sun-disk rays (light_vertices).
    /// `pixels` as trace's.
    void shade(int n, TileScratch& s, RenderStats& stats, bool indirect, bool refining = false,
               const int* pixels = nullptr) const {
        std::fill_n(s.radiance.begin(), n, glm::dvec3(0.0));
        if (m_settings.adaptive_spp > 0) {
            // Where no light shines (or not the Sun), nothing below writes them.
            std::fill_n(s.direct.begin(), n, glm::dvec3(0.0));
            std::fill_n(s.sun_escaped.begin(), n, 0);
            std::fill_n(s.sun_hidden.begin(), n, 0);
        }
        if (m_lights.empty()) return;
        const glm::dvec3& origin = m_camera.center();
        for (int i = 0; i < n; ++i) {
            PathVertex& v = s.path[i];
            v.alive = s.hits.pixel(i).hit;
            if (!v.alive) continue;
            const glm::dvec3& dir = s.dirs[i];
            // The record caches the normal and its cosine to the first light (the Sun) per
            // triangle: neighbouring pixels mostly share them.
            const TriangleRecord& tri = s.hits.shaded(i, dir, m_lights[0].dir);
            const PixelHit& h = s.hits.pixel(i);
            v.point = origin + h.t * dir;
            v.normal = tri.normal[h.side];
            v.lifted = lift_off(v.point, v.normal, tri.reach);
            v.wo = -dir / glm::length(dir);
            v.throughput = glm::dvec3(1.0);
            v.instance = tri.instance;
            const InstanceData& inst = m_instances[tri.instance];
            v.albedo = albedo_at(inst, tri.prim, h.u, h.v);
            v.shading = v.normal;
            v.shaded_apart = inst.woven != nullptr || inst.vertex_normals != nullptr;
            v.residual_slope = 0.0;
            v.sheen = 0.0;
            if (inst.vertex_normals) v.shading = shading_normal_at(inst, tri.prim, h.u, h.v, v.normal);
            if (inst.woven) cloth(inst, tri, h, dir, s.centre_dirs[i], v);
            if (inst.grain)
                regolith_grain(inst, tri, h, dir, s.centre_dirs[i], v, s.grain_reads[pixels ? pixels[i] : i]);
            v.cos_light[0] = tri.cos_sun[h.side];
            for (size_t l = 1; l < m_lights.size(); ++l) v.cos_light[l] = glm::dot(v.normal, m_lights[l].dir);
            if (m_medium && m_sun) s.sun_dust[i] = m_medium->sun_transmittance(v.point);
        }
        light_vertices(n, s, stats, refining ? m_settings.penumbra_light_samples : m_settings.light_samples, kPairLight,
                       m_medium && m_sun ? s.sun_dust.data() : nullptr, /*camera_hits=*/true,
                       refining ? s.sun_rays.data() : nullptr);
        if (m_settings.adaptive_spp > 0) std::copy_n(s.radiance.begin(), n, s.direct.begin());
        if (indirect) add_indirect(n, s, stats, pixels);
    }

    /// Adds the indirect light at the camera hits (the paths set up by shade) to the radiance of
    /// their samples: the light cache's, where it serves the hit, else that of the diffuse bounces.
    /// A pixel reads the cache once per triangle its samples hit (TileScratch::indirect_reads):
    /// the cached light varies over the lattice's centimetres, not within a pixel's footprint on
    /// one facet, whose textures its samples already read at one point. `pixels` as trace's.
    void add_indirect(int n, TileScratch& s, RenderStats& stats, const int* pixels = nullptr) const {
        if (m_light_cache)
            for (int i = 0; i < n; ++i) {
                PathVertex& v = s.path[i];
                if (!v.alive) continue;
                const PixelHit& h = s.hits.pixel(i);
                const TriangleRecord& tri = s.hits.record(h);
                TileScratch::IndirectRead& read = s.indirect_reads[pixels ? pixels[i] : i];
                if (!(read.known && read.instance == tri.instance && read.prim == tri.prim)) {
                    const auto indirect = cached_indirect(v, tri.prim, h.u, h.v, s);
                    if (!indirect) continue;  // not served: the path bounces
                    read = {true, tri.instance, tri.prim, *indirect};
                }
                s.radiance[i] += read.radiance * v.throughput;
                v.alive = false;  // the cache stands for its bounces
            }
        for (int bounce = 1; bounce <= m_settings.bounces; ++bounce) {
            const uint32_t pair = kPairBounce + kPairsPerBounce * static_cast<uint32_t>(bounce - 1);
            if (!extend_paths(n, s, stats, pair)) break;
            light_vertices(n, s, stats, 1, pair + 1, nullptr, /*camera_hits=*/false);
        }
    }

    /// The dust between the camera and each pixel's first hit (or the sky), along the resolved
    /// pixel-centre rays: marched in steps of the grid's spacing, sampled at each step's middle
    /// (the midpoint rule: no noise, an error of second order in the step on the smooth puffs;
    /// a random offset per pixel was measured to leave grain 4–10× worse than the midpoint's
    /// error, bench_medium), it gives the transmittance to the hit and the sunlight scattered
    /// toward the camera (render.h). With Medium::march_stride_px S > 1 only every S-th pixel's
    /// ray marches, as far as the farthest hit among the pixels that read it, and the pixels
    /// between read the four around them at their own hit distances (the tile [x0, x0 + tw) ×
    /// rows, n pixels).
    void march_dust(int x0, int y0, int tw, int n, TileScratch& s) const {
        const glm::dvec3& origin = m_camera.center();
        const Medium& medium = m_medium->medium();
        const double step = medium.voxel_m;
        const int stride = medium.march_stride_px;
        // Strided: the rays through every stride-th pixel centre, from the tile's first pixel to
        // one stride past its last (the next tile marches the same ray as far as it needs it: the
        // sums along a ray do not depend on how far it goes). Each goes as far as the farthest
        // hit among the pixels that read it.
        const int columns = stride > 1 ? (tw - 1) / stride + 2 : 0;
        const int rows = stride > 1 ? (n / tw - 1) / stride + 2 : 0;
        std::array<double, (kTile + 1) * (kTile + 1)> reach;
        std::fill_n(reach.begin(), columns * rows, 0.0);
        for (int i = 0; i < n && stride > 1; ++i) {
            const PixelHit& h = s.hits.pixel(i);
            const double distance = h.hit ? h.t * glm::length(s.dirs[i]) : INFINITY;
            const int px = i % tw, py = i / tw, a = px / stride, b = py / stride;
            for (int dy = 0; dy <= (py % stride ? 1 : 0); ++dy)
                for (int dx = 0; dx <= (px % stride ? 1 : 0); ++dx) {
                    double& r = reach[static_cast<size_t>((b + dy) * columns + a + dx)];
                    r = std::max(r, distance);
                }
        }
        for (int b = 0; b < rows; ++b)
            for (int a = 0; a < columns; ++a) {
                const size_t k = static_cast<size_t>(b * columns + a);
                DustProfile& p = s.lattice[k];
                glm::dvec3 dir = m_camera.direction(x0 + a * stride + 0.5, y0 + b * stride + 0.5);
                dir /= glm::length(dir);
                p.crosses = reach[k] > 0.0 && m_medium->clip(origin, dir, reach[k], p.enter, p.exit);
                if (p.crosses) m_medium->march_profile(origin, dir, p.enter, p.exit, step, kOpaqueDepth, p.tau, p.lit);
            }
        for (int i = 0; i < n; ++i) {
            s.dust_through[i] = 1.0;
            s.dust_glow[i] = glm::dvec3(0.0);
            const PixelHit& h = s.hits.pixel(i);
            const double length = glm::length(s.dirs[i]);
            const glm::dvec3 dir = s.dirs[i] / length;
            const double distance = h.hit ? h.t * length : INFINITY;
            double depth = 0.0, lit = 0.0;
            if (stride == 1) {
                double enter, exit;
                if (!m_medium->clip(origin, dir, distance, enter, exit)) continue;
                depth = m_medium->march(origin, dir, enter, exit, step, kOpaqueDepth, lit);
            } else {
                // Bilinear between the four marched rays around the pixel, each read at the
                // pixel's own hit distance.
                const int px = i % tw, py = i / tw;
                const int a = px / stride, b = py / stride;
                const double fx = double(px % stride) / stride, fy = double(py % stride) / stride;
                const double weight[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
                const int corner[4] = {b * columns + a, b * columns + a + 1, (b + 1) * columns + a,
                                       (b + 1) * columns + a + 1};
                for (int c = 0; c < 4; ++c) {
                    if (weight[c] == 0.0) continue;
                    double t, l;
                    s.lattice[static_cast<size_t>(corner[c])].at(distance, step, t, l);
                    depth += weight[c] * t;
                    lit += weight[c] * l;
                }
            }
            s.dust_through[i] = std::exp(-depth);
            if (!m_sun || lit == 0.0) continue;
            // Irradiance E = π·scale; light travels along −sun.dir, then toward the camera, −dir.
            const double phase = henyey_greenstein(glm::dot(m_sun->dir, dir), medium.asymmetry);
            s.dust_glow[i] = medium.albedo * m_sun->color * (lit * phase * m_sun->scale * kPi);
        }
    }

    /// The footprint (metres) textures are prefiltered over at a camera hit `distance` metres
    /// along `dir`, in the textures' convention of a Gaussian of σ = footprint/2 (fabric.h). A
    /// pixel covers an ellipse on the surface, its angle 1/fx at that distance across and that
    /// over the obliquity to the unit normal `n` along the slope (capped so a grazing hit stays
    /// finite); the isotropic width of the same area (√obliquity) blurs neither axis far beyond
    /// the pixel. A box of width w has σ = w/√12, so a box of `texture_filter_px` such widths is
    /// a footprint of texture_filter_px·w/√3.
    double pixel_footprint(double distance, const glm::dvec3& dir, const glm::dvec3& n) const {
        const double obliquity = std::max(std::abs(glm::dot(n, dir)) / glm::length(dir), 0.1);
        const double width = distance / m_camera.intrinsics().fx / std::sqrt(obliquity);
        return width * m_settings.texture_filter_px * kBoxSigmaToFootprint;
    }

    /// Where a camera hit reads its textures: the point at which its pixel's centre ray
    /// (`centre_dir`) meets the plane of the hit's facet (`tri`'s plane, in double from its world
    /// vertices, so the same point for every sample of the pixel on that facet). A texture
    /// prefiltered over the pixel's box and read there is the same for all of them, so the
    /// samples integrate only what the geometry and the lights vary, as a sensor's pixel
    /// integrates the texture once over its box (read at each sample's own point, the box's
    /// spread would add to the samples' and blur the texture by a second box). Empty where that
    /// plane is edge-on to the centre ray or behind the camera, or where the crossing lies farther
    /// from the sample's hit `v` (at `distance` metres) than a pixel's extent on the facet (the
    /// facet cannot reach the pixel's centre): the sample then reads at its own point.
    std::optional<glm::dvec3> texture_point(const TriangleRecord& tri, const PathVertex& v, double distance,
                                            const glm::dvec3& centre_dir) const {
        const double facing_plane = glm::dot(tri.n_plane, centre_dir);
        if (facing_plane == 0.0) return std::nullopt;
        const double t = tri.offset / facing_plane;
        if (!(t > 0.0)) return std::nullopt;
        const glm::dvec3 crossing = m_camera.center() + t * centre_dir;
        if (!within_pixel(v, distance, centre_dir, crossing)) return std::nullopt;
        return crossing;
    }

    /// Whether `point` lies within a pixel's extent of the sample's hit `v` (at `distance`
    /// metres): a pixel's width on the hit's facet, stretched along its slope by the obliquity
    /// to the centre ray (capped as in pixel_footprint); a sample lies within √2/2 of it from
    /// its pixel's centre.
    bool within_pixel(const PathVertex& v, double distance, const glm::dvec3& centre_dir,
                      const glm::dvec3& point) const {
        const double obliquity = std::max(std::abs(glm::dot(centre_dir, v.normal)) / glm::length(centre_dir), 0.1);
        const double extent = distance / m_camera.intrinsics().fx / obliquity;
        const glm::dvec3 offset = point - v.point;
        return glm::dot(offset, offset) <= extent * extent;
    }

    /// The regolith grain where the centre rays just traced (n of them, ray j through tile pixel
    /// pixels[j], or j) hit an instance that has it, into those pixels' TileScratch::grain_reads:
    /// prefiltered over the centre ray's footprint on the facet it hits (pixel_footprint).
    void read_grain(int n, TileScratch& s, const int* pixels = nullptr) const {
        const glm::dvec3& origin = m_camera.center();
        for (int j = 0; j < n; ++j) {
            TileScratch::GrainRead& read = s.grain_reads[pixels ? pixels[j] : j];
            read = {};
            const PixelHit& h = s.hits.pixel(j);
            if (!h.hit) continue;
            const uint32_t instance = s.hits.record(h).instance;
            const RegolithGrain* grain = m_instances[instance].grain;
            if (!grain) continue;
            const glm::dvec3& dir = s.dirs[j];
            const TriangleRecord& tri = s.hits.shaded(j, dir, m_lights[0].dir);
            const double distance = h.t * glm::length(dir);
            const double footprint = pixel_footprint(distance, dir, tri.normal[h.side]);
            read.known = true;
            read.instance = instance;
            read.point = origin + h.t * dir;
            read.sample = texture_at(m_instances[instance], read.point, footprint);
        }
    }

    /// Regolith's granular micro-texture at a camera hit (regolith_texture.h), prefiltered over
    /// the pixel's footprint and read at the pixel's centre: it scales the albedo, tilts the
    /// shading normal, and gives the spread of the filtered slopes over the pixel as the
    /// vertex's residual_slope. Beyond the texture's flat footprint nothing changes. A tilt that
    /// would turn the shading normal away from the camera is dropped (a bump map cannot show a
    /// facet the geometry hides).
    ///
    /// A pixel reads it once, as a sensor's pixel integrates it once: where its centre ray hits
    /// (`read`, TileScratch::grain_reads), so every sample on that instance within a pixel's extent
    /// of that point takes it, whatever facet it hit. A sample elsewhere (on another instance, or
    /// past a ridge of the same one) reads where the centre ray meets its own facet's plane
    /// (texture_point), or failing that at its own point.
    void regolith_grain(const InstanceData& inst, const TriangleRecord& tri, const PixelHit& h, const glm::dvec3& dir,
                        const glm::dvec3& centre_dir, PathVertex& v, const TileScratch::GrainRead& read) const {
        const double distance = h.t * glm::length(dir);
        GrainSample g;
        if (read.known && read.instance == tri.instance && within_pixel(v, distance, centre_dir, read.point)) {
            g = read.sample;
        } else if (const std::optional<glm::dvec3> centre = texture_point(tri, v, distance, centre_dir)) {
            const glm::dvec3 to_centre = *centre - m_camera.center();
            g = texture_at(inst, *centre, pixel_footprint(glm::length(to_centre), to_centre, v.normal));
        } else {
            g = texture_at(inst, v.point, pixel_footprint(distance, dir, v.shading));
        }
        if (g.albedo_factor == 1.0 && g.residual_slope_variance == 0.0 && g.gradient == glm::dvec3(0.0)) return;
        v.residual_slope = std::sqrt(g.residual_slope_variance);
        v.shaded_apart = v.shaded_apart || v.residual_slope > 0.0;
        v.albedo *= g.albedo_factor;
        if (g.gradient == glm::dvec3(0.0)) return;
        const glm::dvec3 tilted = perturbed_normal(v.shading, g.gradient);
        if (!(glm::dot(tilted, v.wo) > 0.0)) return;
        v.shading = tilted;
        v.shaded_apart = true;
    }

    /// What instance `inst` (one with grain) shows over a pixel footprint of `footprint_m` metres at
    /// world `point`: its grain (nothing past the grain's flat footprint), with the slopes of the
    /// craters its mesh did not draw added to the grain's mean slope.
    static GrainSample texture_at(const InstanceData& inst, const glm::dvec3& point, double footprint_m) {
        GrainSample g;
        if (footprint_m < inst.grain->flat_footprint_m()) g = inst.grain->eval(point, footprint_m);
        if (inst.craters) g.gradient += inst.craters->gradient(point.x, point.y, footprint_m);
        return g;
    }

    /// The bag's cloth at a camera hit: where the hit lies in the UV atlas, the weave there
    /// prefiltered over the pixel's footprint, the stain mask's value, and the weave's normal in
    /// the world (the tangent frame follows the atlas: +u along the warp, +v along the weft).
    void cloth(const InstanceData& inst, const TriangleRecord& tri, const PixelHit& h, const glm::dvec3& dir,
               const glm::dvec3& centre_dir, PathVertex& v) const {
        const WovenSurface& w = *inst.woven;
        const float* uv = inst.corner_uvs + 6 * static_cast<size_t>(tri.prim);
        const glm::dvec2 uv0(uv[0], uv[1]), uv1(uv[2], uv[3]), uv2(uv[4], uv[5]);
        const double b1 = h.u, b2 = h.v;
        const glm::dvec2 st = (1.0 - b1 - b2) * uv0 + b1 * uv1 + b2 * uv2;
        const uint32_t* corner = inst.triangles + 3 * static_cast<size_t>(tri.prim);
        auto world = [&](uint32_t k) {
            const float* p = inst.vertices + 3 * static_cast<size_t>(corner[k]);
            return inst.linear * glm::dvec3(p[0], p[1], p[2]);  // edges only: no translation
        };
        const glm::dvec3 p0 = world(0), e1 = world(1) - p0, e2 = world(2) - p0;
        const glm::dvec2 d1 = uv1 - uv0, d2 = uv2 - uv0;
        const double det = d1.x * d2.y - d2.x * d1.y;
        const glm::dvec3 n = v.shading;  // the geometric normal, or the mesh's smooth one
        glm::dvec3 t, b;
        if (std::abs(det) > 1e-20) {
            t = (e1 * d2.y - e2 * d1.y) / det;  // ∂p/∂u
            t -= n * glm::dot(n, t);
            const double len = glm::length(t);
            if (len > 0.0) {
                t /= len;
                b = glm::cross(n, t);
                if (glm::dot(b, (e2 * d1.x - e1 * d2.x) / det) < 0.0) b = -b;  // along +v
            } else {
                orthonormal_basis(n, t, b);
            }
        } else {
            orthonormal_basis(n, t, b);  // a degenerate UV triangle: any frame (the weave is then arbitrary)
        }
        // The prefiltered textures (weave, dust cover) are read where the pixel's centre ray meets
        // the facet (texture_point): barycentrics (c1, c2) extended past the triangle's edges.
        double c1 = b1, c2 = b2;
        {
            const std::optional<glm::dvec3> centre = texture_point(tri, v, h.t * glm::length(dir), centre_dir);
            const glm::dvec3 offset = centre ? *centre - v.point : glm::dvec3(0.0);
            const double g11 = glm::dot(e1, e1), g12 = glm::dot(e1, e2), g22 = glm::dot(e2, e2);
            const double gram = g11 * g22 - g12 * g12;
            if (gram > 0.0) {
                const double r1 = glm::dot(offset, e1), r2 = glm::dot(offset, e2);
                c1 += (g22 * r1 - g12 * r2) / gram;
                c2 += (g11 * r2 - g12 * r1) / gram;
            }
        }
        const glm::dvec2 st_texture = st + (c1 - b1) * d1 + (c2 - b2) * d2;
        // The weave is periodic: read once a pixel through one box, threads a little over a pixel
        // apart beat with the pixels into moiré. It is read through two (√2 wider), as the
        // samples' own reads used to average it and as a camera's optical low-pass filter does.
        const double footprint = pixel_footprint(h.t * glm::length(dir), dir, n) * std::sqrt(2.0);
        const FabricSample f =
            fabric_eval(w.fabric, st_texture.x * w.metres_per_uv, st_texture.y * w.metres_per_uv, footprint);
        // The cloth's clean colour: the weave's, tinted by the mesh's own per-vertex colour (a
        // user mesh's texture; exactly the weave's without one).
        const glm::dvec3 clean = inst.vertex_albedo ? f.albedo * vertex_factor_at(inst, tri.prim, b1, b2) : f.albedo;
        double dirt = 0.0;  // the stain mask's value or the dust's cover
        if (w.dust) {
            const glm::dvec3 object_point = (1.0 - c1 - c2) * object_vertex(inst, corner[0]) +
                                            c1 * object_vertex(inst, corner[1]) + c2 * object_vertex(inst, corner[2]);
            dirt = w.dust->coverage(object_point, footprint);
            v.albedo = dusted_colour(clean, dirt, w.dirt_colour);
        } else if (inst.stain) {
            dirt = inst.stain->sample(st.x, st.y);
            v.albedo = stained_base_colour(clean, dirt, w.dirt_colour);
        } else {
            v.albedo = clean;
        }
        // Dust fills the weave's pits: under cover m the relief flattens toward the mean surface.
        const glm::dvec3 weave = w.dust ? glm::mix(f.normal, glm::dvec3(0.0, 0.0, 1.0), dirt) : f.normal;
        const glm::dvec3 shading = t * weave.x + b * weave.y + n * weave.z;
        v.shading = shading / glm::length(shading);
        if (w.fabric.sheen > 0.0) {
            v.sheen = w.fabric.sheen * (1.0 - std::min(dirt, 1.0));  // dirt is matte: it covers the gloss
            v.fabric = &w.fabric;
            v.weave = f;
            // The warp direction in the weave's own tangent plane.
            const glm::dvec3 warp = t - v.shading * glm::dot(v.shading, t);
            v.warp = warp / glm::length(warp);
            v.weft = glm::cross(v.shading, v.warp);
            if (glm::dot(v.weft, b) < 0.0) v.weft = -v.weft;
        }
    }

    /// Vertex `i` of instance `inst`'s mesh in its object frame, metres.
    static glm::dvec3 object_vertex(const InstanceData& inst, uint32_t i) {
        const float* p = inst.vertices + 3 * static_cast<size_t>(i);
        return {p[0], p[1], p[2]};
    }

    /// The cloth's sheen at vertex `v` for light arriving from `wi` (unit, world): π·f_sheen, in
    /// the units of the renderer's albedo·shape (a Lambertian's π·f).
    static double sheen_weight(const PathVertex& v, const glm::dvec3& wi) {
        return kPi * cloth_sheen(*v.fabric, v.weave, cloth_local(v, wi), cloth_local(v, v.wo));
    }

    /// The world direction `w` in vertex `v`'s (warp, weft, shading normal) frame.
    static glm::dvec3 cloth_local(const PathVertex& v, const glm::dvec3& w) {
        return glm::dvec3(glm::dot(w, v.warp), glm::dot(w, v.weft), glm::dot(w, v.shading));
    }

    /// Adds every light's contribution at the live path vertices to their pixels: `samples`
    /// shadow rays per light toward its disk (light l: dimension pair `pair` + l, points
    /// sample·R .. sample·R + R − 1 of its sequence, R its rays a vertex, `sample` its camera
    /// ray's TileScratch::samples entry), each
    /// vertex weighted by its path throughput (and the Sun's by `sun_dust`, the dust's
    /// transmittance toward it, per pixel, where given). `camera_hits`: the vertices are the
    /// camera rays' hits; else a bounce's, scattered over the scene, whose shadow rays are
    /// counted apart (bounce_shadow_rays). `sun_rays` (refinement samples past the spp base
    /// samples only): the Sun's rays per vertex, R_i ≤ `samples`, at points
    /// spp·light_samples + (sample − spp)·R_i + k of its sequence, past the base samples' (with
    /// R_i = light_samples the points sample·R_i + k as above).
    void light_vertices(int n, TileScratch& s, RenderStats& stats, int samples, uint32_t pair, const double* sun_dust,
                        bool camera_hits, const int* sun_rays = nullptr) const {
        const auto base = static_cast<uint32_t>(m_settings.spp);
        for (size_t l = 0; l < m_lights.size(); ++l) {
            const LightData& light = m_lights[l];
            // The Earth's light is ~1e-4 of the Sun's: one shadow ray toward its disk leaves noise
            // far below the Sun's, so only the Sun gets `samples`.
            const bool disk_sun = !light.point && l == 0;
            const int most = disk_sun ? samples : 1;
            const bool per_pixel = disk_sun && sun_rays != nullptr;
            auto rays_of = [&](int i) { return per_pixel ? sun_rays[i] : most; };
            std::fill_n(s.visible.begin(), n, 0);
            for (int k = 0; k < most; ++k) {
                int count = 0;
                for (int i = 0; i < n; ++i) {
                    const PathVertex& v = s.path[i];
                    if (!v.alive || v.cos_light[l] <= 0.0 || k >= rays_of(i)) continue;
                    glm::dvec3 to_light = light.dir;
                    if (!light.point) {
                        // Consecutive points of the light's sequence: stratified over all the pixel's rays to it.
                        const auto rays = static_cast<uint32_t>(rays_of(i));
                        const uint32_t sample = s.samples[i];
                        const uint32_t point = per_pixel ? base * static_cast<uint32_t>(m_settings.light_samples) +
                                                               (sample - base) * rays + static_cast<uint32_t>(k)
                                                         : sample * rays + static_cast<uint32_t>(k);
                        to_light = light.toward(sample_pair(s.streams[i], point, pair + static_cast<uint32_t>(l)));
                        if (glm::dot(v.normal, to_light) <= 0.0) continue;  // below the facet's horizon
                    }
                    // Behind the wall of a crater the mesh did not draw: hidden, and no ray to trace.
                    if (camera_hits) {
                        const SubgridCraters* craters = m_instances[v.instance].craters;
                        if (craters && craters->shadowed(v.point, to_light, v.normal)) continue;
                    }
                    set_ray(s.shadow[count], v.lifted, to_light);
                    s.shadow_of[count++] = i;
                }
                if (count == 0) continue;
                m_scene.accel().occluded(s.shadow.data(), count);
                stats.shadow_rays += count;
                if (!camera_hits) stats.bounce_shadow_rays += count;
                for (int j = 0; j < count; ++j)
                    if (s.shadow[j].tfar >= 0.0f) ++s.visible[s.shadow_of[j]];
            }
            if (camera_hits && &light == m_sun && m_settings.adaptive_spp > 0) {
                // What the Sun's visibility says to adaptive anti-aliasing: rays below the facet's
                // horizon count as hidden, as they do in the shading.
                for (int i = 0; i < n; ++i) {
                    const bool faces = s.path[i].alive && s.path[i].cos_light[l] > 0.0;
                    s.sun_escaped[i] = faces ? s.visible[i] : 0;
                    s.sun_hidden[i] = faces ? rays_of(i) - s.visible[i] : 0;
                }
            }
            for (int i = 0; i < n; ++i) {
                if (s.visible[i] == 0) continue;
                const PathVertex& v = s.path[i];
                const InstanceData& inst = m_instances[v.instance];
                // Visibility follows the geometry; brightness the shading normal.
                double mu_i, shape;
                if (v.residual_slope > 0.0) {
                    mu_i = spread_lit_cosine(inst, v, light.dir);  // μi·shape averaged as one
                    shape = 1.0;
                } else {
                    mu_i = v.shaded_apart ? std::max(0.0, glm::dot(v.shading, light.dir)) : v.cos_light[l];
                    shape = shape_at(inst, mu_i, glm::dot(v.shading, v.wo), glm::dot(light.dir, v.wo));
                }
                // Grouped so that a Lambertian surface under a point Sun, seen directly, gets
                // exactly albedo·(E/π·μi): every other factor is then 1.
                const double dust = sun_dust && &light == m_sun ? sun_dust[i] : 1.0;
                if (v.sheen > 0.0) {
                    // The cloth's (1 − s)·albedo/π·shape + s·f_sheen.
                    const glm::dvec3 brdf =
                        (1.0 - v.sheen) * v.albedo * shape + glm::dvec3(v.sheen * sheen_weight(v, light.dir));
                    s.radiance[i] += (brdf * (light.scale * mu_i)) * ((double(s.visible[i]) / rays_of(i)) * dust) *
                                     light.color * v.throughput;
                    continue;
                }
                s.radiance[i] += (v.albedo * (light.scale * mu_i)) *
                                 (shape * (double(s.visible[i]) / rays_of(i)) * dust) * light.color * v.throughput;
            }
        }
    }

    /// μi·shape of the light from `to` (unit) at camera hit `v`, averaged over the slopes within
    /// its footprint (PathVertex::residual_slope σ): a sensor's pixel sums the light of all the
    /// facets it covers, and the cosine's clamp at the terminator is far from linear in them. The
    /// slope along the light's direction in the surface changes μi to first order (the one across
    /// it by O(σ²), left out); it is integrated by 3-point Gauss–Hermite quadrature over a normal
    /// law of σ (nodes 0, ±√3·σ; weights 2/3, 1/6, 1/6), each node the shading normal tilted by
    /// that slope. A node turned from the light adds nothing; nodes turned from the camera are
    /// not seen, and the weights are shared among the others.
    double spread_lit_cosine(const InstanceData& inst, const PathVertex& v, const glm::dvec3& to) const {
        static constexpr double kNodes[3] = {0.0, 1.7320508075688772, -1.7320508075688772};
        static constexpr double kWeights[3] = {2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0};
        const double cos_g = glm::dot(to, v.wo);
        const PhaseTerms terms = phase_terms(inst.photometry, cos_g);  // the nodes share g
        glm::dvec3 along = to - glm::dot(to, v.shading) * v.shading;
        const double length = glm::length(along);
        along = length > 1e-12 ? along / length : glm::dvec3(0.0);
        double sum = 0.0, seen = 0.0;
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3 n = glm::normalize(v.shading + (kNodes[k] * v.residual_slope) * along);
            const double mu_o = glm::dot(n, v.wo);
            if (!(mu_o > 0.0)) continue;
            seen += kWeights[k];
            const double mu_i = glm::dot(n, to);
            if (mu_i > 0.0) sum += kWeights[k] * mu_i * shape_at(inst, terms, mu_i, mu_o, cos_g);
        }
        if (seen > 0.0) return sum / seen;
        const double mu_i = std::max(0.0, glm::dot(v.shading, to));
        return mu_i * shape_at(inst, terms, mu_i, glm::dot(v.shading, v.wo), cos_g);
    }

    /// The indirect radiance toward the camera at camera hit `v` (on triangle `prim`, at Embree's
    /// barycentrics u, w) from the light cache, W/(m²·sr): the cached irradiance E, tilted to the
    /// facet's normal (LightCache::at), shaded with the hit's BRDF, albedo/π · shape · E (on glossy
    /// cloth (1 − s)·albedo/π·shape + s·f_sheen, as light_vertices weighs it), the shape taken
    /// along the irradiance's mean incident
    /// direction (about the geometric normal, as a bounce's weight is) and the sheen averaged over
    /// a lobe about it as wide as the light spreads (sheen_over_lobe), for a path throughput of
    /// 1. None where the cache does not serve the hit (moving geometry, or its surface seen from
    /// the back): that path bounces.
    std::optional<glm::dvec3> cached_indirect(const PathVertex& v, uint32_t prim, double u, double w,
                                              TileScratch& s) const {
        if (!m_light_cache->covers(v.instance)) return std::nullopt;
        if (glm::dot(m_light_cache->normal_at(v.instance, prim, u, w), v.normal) <= 0.0) return std::nullopt;
        // The corners tilted to the facet's own normal, as the path tracer bounces about it
        // (extend_paths): LightCache::at, its corners kept for the tile's other pixels.
        TileScratch::CornerRead& slot = s.corner_reads[prim % TileScratch::kCornerSlots];
        if (!(slot.known && slot.instance == v.instance && slot.prim == prim && slot.normal == v.normal))
            slot = {true, v.instance, prim, v.normal, m_light_cache->corners(v.instance, prim, &v.normal)};
        const IndirectLight in = LightCache::interpolate(slot.corners, u, w);
        const double resultant = glm::length(in.mean_direction);
        const glm::dvec3 axis = resultant > 0.0 ? in.mean_direction / resultant : v.normal;
        const InstanceData& inst = m_instances[v.instance];
        double shape = 1.0;
        if (inst.photometry.model != Photometry::Model::Lambert) {
            // The mean direction may dip below a facet that leans from its vertices' normals.
            const double mu_i = std::max(glm::dot(v.normal, axis), 1e-3);
            shape = photometric_shape(inst.photometry, mu_i, glm::dot(v.normal, v.wo), glm::dot(axis, v.wo));
        }
        glm::dvec3 brdf = v.albedo * shape;  // π·f
        if (v.sheen > 0.0) brdf = brdf * (1.0 - v.sheen) + glm::dvec3(v.sheen * sheen_over_lobe(v, axis, resultant));
        return brdf * kInvPi * in.irradiance;
    }

    /// The cloth's π·f_sheen at vertex `v` averaged over incident light spread about the unit
    /// `axis` with mean resultant length `resultant` (IndirectLight::mean_direction): a von
    /// Mises–Fisher lobe of concentration κ = R̄(3 − R̄²)/(1 − R̄²) (Banerjee et al. 2005's
    /// estimate from R̄), read at 16 fixed points of it (a Fibonacci lattice through its inverse
    /// CDF, so the same for every pixel), those below the geometric horizon left out. The
    /// sheen's lobe is sharp: read along the mean direction alone, the light a shadowed face gets
    /// from the ground around it would gloss as if it all came from that one direction.
    static double sheen_over_lobe(const PathVertex& v, const glm::dvec3& axis, double resultant) {
        constexpr int kPoints = 16;
        // The points' turns about the axis, k·(golden ratio's fraction) mod 1: the same for every
        // lobe, so their cosines and sines are worked out once.
        static const std::array<std::array<double, 2>, kPoints> kTurns = [] {
            constexpr double kGoldenFraction = 0.6180339887498949;
            std::array<std::array<double, 2>, kPoints> turns{};
            for (int k = 0; k < kPoints; ++k)
                turn_cos_sin(std::fmod(k * kGoldenFraction, 1.0), turns[k][0], turns[k][1]);
            return turns;
        }();
        const double r = std::min(resultant, 0.999);
        const double kappa = std::max(r * (3.0 - r * r) / (1.0 - r * r), 1e-6);
        const double span = -std::expm1(-2.0 * kappa);  // 1 − e^(−2κ)
        glm::dvec3 t, b;
        orthonormal_basis(axis, t, b);
        const ClothSheen sheen(*v.fabric, v.weave, cloth_local(v, v.wo));
        double sum = 0.0;
        int used = 0;
        for (int k = 0; k < kPoints; ++k) {
            const double p = (k + 0.5) / kPoints;
            // Inverse CDF of cos θ under a vMF lobe: 1 + ln(1 − p·(1 − e^(−2κ)))/κ.
            const double cos_theta = std::clamp(1.0 + std::log1p(-p * span) / kappa, -1.0, 1.0);
            const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
            const glm::dvec3 wi = axis * cos_theta + (t * kTurns[k][0] + b * kTurns[k][1]) * sin_theta;
            if (glm::dot(wi, v.normal) <= 0.0) continue;
            sum += kPi * sheen(cloth_local(v, wi));  // sheen_weight, its wo-only factors shared
            ++used;
        }
        return used > 0 ? sum / used : 0.0;
    }

    /// Continues every live path by one bounce: a cosine-distributed direction about the normal
    /// (dimension pair `pair`), the throughput weighted by π·f·cos/pdf = albedo·shape,
    /// and the ray traced. Paths that leave the scene end. Returns whether any path lives on.
    bool extend_paths(int n, TileScratch& s, RenderStats& stats, uint32_t pair) const {
        int count = 0;
        for (int i = 0; i < n; ++i) {
            PathVertex& v = s.path[i];
            if (!v.alive) continue;
            double mu_i;
            const SamplePair q = sample_pair(s.streams[i], s.samples[i], pair);
            const glm::dvec3 wi = cosine_direction(v.normal, q.u, q.v, mu_i);
            const InstanceData& inst = m_instances[v.instance];
            const double shape = shape_at(inst, mu_i, glm::dot(v.normal, v.wo), glm::dot(wi, v.wo));
            // Cosine-distributed directions weigh any BRDF f by π·f: the cloth's sheen too (a
            // lobe this broad needs no sampling of its own).
            if (v.sheen > 0.0)
                v.throughput *= (1.0 - v.sheen) * v.albedo * shape + glm::dvec3(v.sheen * sheen_weight(v, wi));
            else v.throughput *= v.albedo * shape;
            if (!(mu_i > 0.0) || v.throughput == glm::dvec3(0.0)) {
                v.alive = false;
                continue;
            }
            v.point = v.lifted;  // the ray's origin, in double
            v.wo = wi;  // the ray's direction until it hits
            set_ray(s.rays[count], v.point, wi);
            s.shadow_of[count++] = i;
        }
        if (count == 0) return false;
        m_scene.accel().intersect(s.rays.data(), count);
        stats.bounce_rays += count;
        for (int j = 0; j < count; ++j) {
            PathVertex& v = s.path[s.shadow_of[j]];
            const RayHit& ray = s.rays[j];
            if (ray.geom_id == kInvalidId) {
                v.alive = false;  // to the black sky
                continue;
            }
            const InstanceData& inst = m_instances[ray.inst_id];
            const glm::dvec3 wi = v.wo;
            glm::dvec3 normal;
            if (!arrival_normal(inst, ray, wi, normal)) {
                v.alive = false;
                continue;
            }
            v.point += static_cast<double>(ray.tfar) * wi;
            v.normal = normal;
            v.lifted = lift_off(v.point, normal, triangle_reach(inst, ray.prim_id));
            v.shading = normal;
            v.shaded_apart = false;
            v.residual_slope = 0.0;  // the grain's slope spread belongs to the camera hit that read it
            v.sheen = 0.0;
            // Cloth met by a bounce shows its mean colour: neither weave nor stain is resolved
            // by the light it passes on.
            v.albedo = albedo_at(inst, ray.prim_id, ray.u, ray.v);
            v.wo = -wi;
            v.instance = ray.inst_id;
            for (size_t l = 0; l < m_lights.size(); ++l) v.cos_light[l] = glm::dot(normal, m_lights[l].dir);
        }
        return true;
    }

    const Scene& m_scene;
    const Camera& m_camera;
    const RenderSettings& m_settings;
    const FrameView& m_out;
    const std::vector<InstanceData> m_instances;
    const std::vector<LightData> m_lights;
    const DustGrid* m_medium;  // null: no dust, and none of its code runs
    const LightCache* m_light_cache;  // null: every path bounces
    AdaptiveFrame* m_adaptive;  // null: adaptive anti-aliasing is off (or no rgb)
    const LightData* m_sun = nullptr;  // the Sun's entry in m_lights, if it shines
    bool m_random = false;  // some shading draws random numbers (disk samples, bounces)
    bool m_grain = false;   // some instance has the regolith grain (and a light shines on it)
};

}  // namespace

RenderStats render(const Scene& scene, const Camera& camera, const DirectionalLight& sun,
                   const RenderSettings& settings, const FrameView& out) {
    return render(scene, camera, Lights{sun, std::nullopt}, settings, out);
}

int refined_sample_count(int base, int total, double share) {
    const int wanted = base + std::max(1, static_cast<int>(std::ceil((total - base) * share)));
    int low = 1;  // the largest power of two <= wanted
    while (low <= wanted / 2) low *= 2;
    // 2·low is nearer in ratio where wanted/low >= √2, i.e. wanted² >= 2·low² (exact in integers).
    int count = int64_t(wanted) * wanted >= 2 * int64_t(low) * low ? 2 * low : low;
    while (count <= base) count *= 2;
    return std::min(count, total);
}

void RenderSettings::validate() const {
    if (light_samples < 1 || light_samples > kMaxLightSamples)
        throw std::invalid_argument("light_samples: must be in 1.." + std::to_string(kMaxLightSamples) + ", got " +
                                    std::to_string(light_samples));
    if (!std::isfinite(adaptive_contrast) || adaptive_contrast < 0.0)
        throw std::invalid_argument("adaptive_contrast: must be a finite number >= 0, got " +
                                    std::to_string(adaptive_contrast));
    if (!std::isfinite(adaptive_error_target) || adaptive_error_target < 0.0 || adaptive_error_target > 1.0)
        throw std::invalid_argument("adaptive_error_target: must be a finite number in [0, 1], got " +
                                    std::to_string(adaptive_error_target));
    if (!std::isfinite(adaptive_full_spread) || adaptive_full_spread < 0.0)
        throw std::invalid_argument("adaptive_full_spread: must be a finite number >= 0, got " +
                                    std::to_string(adaptive_full_spread));
    if (penumbra_light_samples < 1 || penumbra_light_samples > kMaxLightSamples)
        throw std::invalid_argument("penumbra_light_samples: must be in 1.." + std::to_string(kMaxLightSamples) +
                                    ", got " + std::to_string(penumbra_light_samples));
    if (bounces < 0 || bounces > kMaxBounces)
        throw std::invalid_argument("bounces: must be in 0.." + std::to_string(kMaxBounces) + ", got " +
                                    std::to_string(bounces));
    if (spp < 1 || spp > kMaxSpp)
        throw std::invalid_argument("spp: must be in 1.." + std::to_string(kMaxSpp) + ", got " + std::to_string(spp));
    if (adaptive_spp != 0) {
        if (adaptive_spp <= spp || adaptive_spp > kMaxSpp)
            throw std::invalid_argument("adaptive_spp: must be 0 (off) or in spp + 1.." + std::to_string(kMaxSpp) +
                                        " = " + std::to_string(spp + 1) + ".." + std::to_string(kMaxSpp) + ", got " +
                                        std::to_string(adaptive_spp));
    }
    if (!(adaptive_threshold >= 0.0) || !std::isfinite(adaptive_threshold))
        throw std::invalid_argument("adaptive_threshold: must be a finite number >= 0, got " +
                                    std::to_string(adaptive_threshold));
    if (threads < 0 || threads > kMaxThreads)
        throw std::invalid_argument("threads: must be in 0.." + std::to_string(kMaxThreads) + " (0 = all), got " +
                                    std::to_string(threads));
    if (!(texture_filter_px >= 0.25 && texture_filter_px <= 8.0))
        throw std::invalid_argument("texture_filter_px: must be in [0.25, 8] pixels, got " +
                                    std::to_string(texture_filter_px));
}

RenderStats render_geometry(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                            const FrameView& out) {
    if (out.rgb) throw std::invalid_argument("rgb: render_geometry renders depth and instance only");
    // The renderer reads its lights only to shade rgb, which is not asked for here: any light will
    // do, and none of it is used.
    const DirectionalLight unused(0.0, 90.0, 0.0);
    return render(scene, camera, Lights{unused, std::nullopt}, settings, out);
}

namespace {

bool same_light(const DirectionalLight& a, const DirectionalLight& b) {
    return a.direction() == b.direction() && a.irradiance() == b.irradiance() && a.half_angle() == b.half_angle() &&
           a.color() == b.color();
}

/// Throws std::invalid_argument unless `cache` was built for this scene as it is, these lights
/// and `bounces`.
void check_light_cache(const LightCache& cache, const Scene& scene, const Lights& lights, int bounces) {
    if (&cache.scene() != &scene) throw std::invalid_argument("light_cache: built for another scene");
    if (cache.scene_revision() != scene.static_revision())
        throw std::invalid_argument("light_cache: the scene's static geometry changed since the cache was built");
    const Lights& built = cache.lights();
    if (!same_light(built.sun, lights.sun) || built.earth.has_value() != lights.earth.has_value() ||
        (lights.earth && !same_light(*built.earth, *lights.earth)))
        throw std::invalid_argument("light_cache: built for other lights");
    if (cache.settings().bounces != bounces)
        throw std::invalid_argument("light_cache: built for " + std::to_string(cache.settings().bounces) +
                                    " bounces, the render asks for " + std::to_string(bounces));
}

}  // namespace

RenderStats render(const Scene& scene, const Camera& camera, const Lights& lights, const RenderSettings& settings,
                   const FrameView& out, const Medium* medium, const LightCache* light_cache) {
    settings.validate();
    const Scene::ReadLock lock(scene);  // before the checks, so they stay true during the render
    if (!scene.committed()) throw std::invalid_argument("scene: not committed (call commit() after adding geometry)");
    if (scene.instance_count() == 0) throw std::invalid_argument("scene: has no instances");
    if (light_cache) check_light_cache(*light_cache, scene, lights, settings.bounces);

    const auto start = std::chrono::steady_clock::now();
    const int w = camera.width(), h = camera.height();
    const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
    if (medium) medium->validate();
    // A medium without puffs is no medium: nothing of the dust's runs.
    std::optional<DustGrid> dust;
    tbb::task_arena arena(settings.threads > 0 ? settings.threads : tbb::task_arena::automatic);
    if (medium && !medium->puffs.empty() && out.rgb)
        arena.execute([&] { dust.emplace(*medium, scene, lights.sun.direction()); });
    // Adaptive anti-aliasing (rgb only): a second pass refines.
    std::optional<AdaptiveFrame> adaptive;
    if (settings.adaptive_spp > 0 && out.rgb)
        adaptive.emplace(static_cast<size_t>(w) * h, settings.spp == 1, dust.has_value(),
                         settings.adaptive_contrast > 0.0);
    const TileRenderer tiles(scene, camera, lights, settings, out, dust ? &*dust : nullptr, light_cache,
                             adaptive ? &*adaptive : nullptr);
    std::atomic<uint64_t> camera_rays{0}, second_look_rays{0}, shadow_rays{0}, bounce_shadow_rays{0}, bounce_rays{0},
        refined_pixels{0}, refinement_rays{0};

    auto each_tile = [&](bool refining) {
        tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y), [&](const auto& range) {
            TileScratch scratch;
            RenderStats local;
            for (int t = range.begin(); t != range.end(); ++t) {
                const int x0 = (t % tiles_x) * kTile, y0 = (t / tiles_x) * kTile;
                const int x1 = std::min(x0 + kTile, w), y1 = std::min(y0 + kTile, h);
                if (refining) tiles.refine_tile(x0, y0, x1, y1, scratch, local);
                else tiles.render_tile(x0, y0, x1, y1, scratch, local);
            }
            camera_rays += local.camera_rays;
            second_look_rays += local.second_look_rays;
            shadow_rays += local.shadow_rays;
            bounce_shadow_rays += local.bounce_shadow_rays;
            bounce_rays += local.bounce_rays;
            refined_pixels += local.refined_pixels;
            refinement_rays += local.refinement_rays;
        });
    };
    arena.execute([&] {
        each_tile(false);
        if (adaptive) {
            adaptive->decide(settings, camera.width());
            each_tile(true);
        }
    });

    RenderStats stats;
    stats.camera_rays = camera_rays;
    stats.second_look_rays = second_look_rays;
    stats.shadow_rays = shadow_rays;
    stats.bounce_shadow_rays = bounce_shadow_rays;
    stats.bounce_rays = bounce_rays;
    stats.refined_pixels = refined_pixels;
    stats.refinement_rays = refinement_rays;
    stats.medium_rays = dust ? dust->shadow_rays() : 0;
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return stats;
}

Frame render_frame(const Scene& scene, const Camera& camera, const DirectionalLight& sun,
                   const RenderSettings& settings) {
    return render_frame(scene, camera, Lights{sun, std::nullopt}, settings);
}

Frame render_frame(const Scene& scene, const Camera& camera, const Lights& lights, const RenderSettings& settings,
                   const Medium* medium, const LightCache* light_cache) {
    Frame f;
    f.width = camera.width();
    f.height = camera.height();
    const size_t n = static_cast<size_t>(f.width) * f.height;
    f.rgb.assign(3 * n, 0.0f);
    f.depth.assign(n, 0.0f);
    f.instance.assign(n, 0);
    f.stats =
        render(scene, camera, lights, settings, {f.rgb.data(), f.depth.data(), f.instance.data()}, medium, light_cache);
    return f;
}

}  // namespace moonbot
