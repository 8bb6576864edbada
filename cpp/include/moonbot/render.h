// Rendering one view of a committed scene into caller-owned buffers: linear RGB radiance,
// z-depth and instance labels. Depth and labels come from the pixel-centre ray only, so they are
// exact and independent of the sample count.
#pragma once

#include <cstdint>
#include <vector>

#include "moonbot/camera.h"
#include "moonbot/light.h"
#include "moonbot/medium.h"
#include "moonbot/render_limits.h"
#include "moonbot/scene.h"

namespace moonbot {

class LightCache;

struct RenderSettings {
    int spp = 1;        ///< RGB samples per pixel, 1..65536; 1 = the pixel-centre ray, no jitter
    uint64_t seed = 0;  ///< keys the counter-based generator (with pixel and sample)
    int threads = 0;    ///< worker threads, 0 = all hardware threads, at most kMaxThreads
    /// Re-solve each hit's distance in double against the triangle's plane (depth exact to
    /// float32 rounding at any coordinates) instead of keeping Embree's float32 t, whose error
    /// grows with the distance of the scene from the origin. Costs ~15 ns a camera ray.
    bool exact_depth = true;
    /// Shadow rays per camera sample toward the Sun's disk (soft shadow edges); 1..1024. A point
    /// light, and the faint Earth, get one.
    int light_samples = 1;
    /// Diffuse inter-reflection: path vertices after the first hit, each lit by the lights
    /// through a shadow ray (next-event estimation); 0 = direct light only, at most kMaxBounces.
    int bounces = 0;
    /// Adaptive anti-aliasing; 0 = off (every pixel gets `spp` samples). Else the samples a pixel
    /// is brought up to, spp < adaptive_spp ≤ 65536, where samples disagree: the luminance of
    /// their direct light spreads (max − min) beyond `adaptive_threshold` times √(m·M), m their
    /// mean and M the frame's mean direct luminance over its base samples. The spread stands for
    /// the pixel's error, and √(m·M) weighs it as a display does, between relative to the pixel
    /// (a dim pixel's error shows more) and relative to the frame (where the image's error sits):
    /// an edge between two surfaces of one brightness is not refined, a lit sliver on a dark
    /// face is. With dust (and spp ≥ 2) all three are as the image shows them: the spread and m
    /// dimmed by the pixel's transmittance to the camera, m and M with the cloud's glow added, so
    /// an edge the cloud veils is refined less. With spp ≥ 2 the samples compared are a pixel's
    /// own `spp` base samples, and a pixel is refined where they or those of one of its eight
    /// neighbours disagree (the neighbours catch the slivers of an edge that all of a pixel's own
    /// base samples miss); the extra samples carry direct light only (a camera ray and its shadow
    /// rays), and the pixel's indirect light stays the mean of its base samples (render()'s split
    /// estimator). With spp = 1 the base sample is the pixel-centre ray the depth and labels
    /// already trace, and the samples compared are the centre samples of the pixel's 3×3
    /// neighbourhood; a refined pixel's radiance is then the mean of adaptive_spp jittered
    /// samples, indirect light included. The decisions follow from the base samples of every
    /// pixel, all taken before any refinement: images stay identical whatever the thread count.
    int adaptive_spp = 0;
    /// The spread of direct luminance over the samples compared, over √(their mean × the frame's
    /// mean), that refines a pixel (adaptive_spp); ≥ 0.
    double adaptive_threshold = 0.25;
    /// Width, in pixels, of the box each camera sample's textures (regolith grain, weave, dust
    /// cover) are prefiltered over, 0.25..8. At 1 a sample stands for its pixel's box, which the
    /// pixel's samples then integrate as a sensor's pixel does; wider blurs the textures, so fewer
    /// pixels disagree and refine, at the cost of detail a real camera would record.
    double texture_filter_px = 1.0;
    /// Shadow rays toward the Sun's disk per refinement sample (adaptive_spp) in a penumbra, where
    /// the base samples' Sun rays of the pixel or of a neighbour partly escape: there the disk's
    /// visibility is what varies. 1..1024. A refinement sample elsewhere casts one.
    int penumbra_light_samples = 1;
    /// With adaptive_spp and spp >= 2: 0 brings every refined pixel up to adaptive_spp samples;
    /// f > 0 gives it a share of the adaptive_spp − spp samples past its base in proportion to its
    /// (or a neighbour's) base samples' direct-luminance spread over f times the frame's mean
    /// direct luminance, all of them from f up, at least one; the count is then moved to a power
    /// of two (refined_sample_count). Finite, >= 0.
    double adaptive_full_spread = 0.0;
    /// With adaptive_spp and spp >= 2: a pixel whose 3×3 neighbourhood's base samples, taken
    /// together, spread beyond this times √(their mean × the frame's mean) (adaptive_threshold's
    /// measure, with a bar of its own) is refined, and its share (adaptive_full_spread) follows
    /// that spread rather than the largest of the nine pixels' own. Where a sunlit face meets
    /// ground lit at a grazing angle, or a lit ridge crosses a shadow, a pixel may hold a sliver of
    /// either, and a miss costs it that whole contrast; its own and its neighbours' spreads each
    /// see only part of it. 0 = off; finite, >= 0.
    double adaptive_contrast = 0.0;
    /// With adaptive_spp, spp >= 2 and adaptive_full_spread f₀ > 0: the share's f is chosen for
    /// each view, the largest of f₀·kErrorTargetStep^j (j = 0..kErrorTargetSteps) whose refined pixels'
    /// predicted error is at most this, relative to the image's mean luminance (f₀ where none
    /// is): a view whose edges are few spends fewer samples, a hard one more. The prediction is
    /// √(kRefinedErrorScale · Σ (T·s)²/N^1.5 / P) over the refined pixels (s its spread, N its
    /// samples, T the dust's transmittance to the camera, 1 without dust, P the frame's pixels),
    /// as the error of N points of a net across an edge falls; with dust the mean includes the
    /// cloud's glow. What the unrefined pixels and the light cache leave is not in it. 0 = off
    /// (f₀ always); finite, in [0, 1].
    double adaptive_error_target = 0.0;

    /// Throws std::invalid_argument naming the first field out of its range (render() calls it).
    void validate() const;
};

constexpr int kMaxLightSamples = 1024;

/// The samples a refined pixel is brought up to under RenderSettings::adaptive_full_spread:
/// base + ⌈share·(total − base)⌉ (at least base + 1), `share` in [0, 1] its spread's share, then
/// moved to the power of two nearest it in ratio (2^k for counts in [2^k/√2, 2^k·√2)), kept above
/// `base` and at most `total`. A pixel's samples are the first N points of its scrambled Sobol
/// sequence (sampler.h), and only the first 2^k of them form a (0, k, 2)-net, one point in every
/// elementary box: a soft transition across the pixel (a penumbra, light grazing its facets) is
/// integrated better by such a net than by the first ~1.4× as many points, whose extra points
/// unbalance the strata (test_sampler.cpp's a_net_beats_more_points_past_it; on a hard edge the
/// extra points still help). Requires 1 <= base < total.
int refined_sample_count(int base, int total, double share);

/// RenderSettings::adaptive_error_target's calibration: a refined pixel of spread s after N
/// samples is off by about √(k·s²/N^1.5). Fitted on the six bench_accuracy scenes at 640×480,
/// f from 5 to 30 (docs/performance.md): 0.030–0.040.
constexpr double kRefinedErrorScale = 0.034;
/// The error target's ladder above adaptive_full_spread: steps of 2^(1/8) (9 %, about 2.5 % in
/// the error), 40 of them (32×). A coarser ladder of 1.25× left a hard view's error 7 % apart
/// between two rungs.
constexpr double kErrorTargetStep = 1.0905077326652577;
constexpr int kErrorTargetSteps = 40;

/// Output buffers, row-major, owned by the caller; a null pointer means the pass is not wanted
/// and costs nothing. rgb: H×W×3 float32 W/(m²·sr); depth: H×W float32 metres (0 = no hit);
/// instance: H×W uint8 (0 = background or no hit).
struct FrameView {
    float* rgb = nullptr;
    float* depth = nullptr;
    uint8_t* instance = nullptr;
};

/// What a render did. Counts are exact and deterministic; `seconds` is wall time.
struct RenderStats {
    uint64_t camera_rays = 0;
    uint64_t second_look_rays = 0;    ///< camera rays traced again at a shared vertex (Accel::intersect_watertight)
    uint64_t shadow_rays = 0;         ///< toward the lights, from every path vertex
    uint64_t bounce_shadow_rays = 0;  ///< of shadow_rays, those from bounce vertices (scattered origins)
    uint64_t bounce_rays = 0;
    uint64_t medium_rays = 0;  ///< shadow rays toward the Sun from the dust's grid nodes
    uint64_t refined_pixels = 0;   ///< pixels given adaptive_spp samples (RenderSettings::adaptive_spp)
    uint64_t refinement_rays =
        0;  ///< of camera_rays, second_look_rays and shadow_rays, those of the refinement samples
    double seconds = 0.0;
};

/// Renders one view. Throws std::invalid_argument on bad settings or an uncommitted scene.
///
/// Shading: black sky; each light l of irradiance E_l (tinted by its colour) lights a hit
/// through the BRDF f = albedo/π · photometric_shape(μi, μo, g) of the hit's material:
/// L = Σ_l E_l · f(s_l) · max(0, n·s_l) · V_l, where s_l is the direction to the disk's centre
/// and V_l the fraction of `light_samples` shadow rays toward uniformly sampled points of the
/// disk that escape. (The cosine and the BRDF taken at the disk's centre rather than averaged
/// over it err by O(half-angle²) ≈ 2e-5 for the Sun; where the disk straddles a facet's own
/// horizon, the part below it counts as hidden.) With `bounces` > 0 each path continues in a
/// cosine-distributed direction, weighted by π·f, and is lit again at every vertex.
///
/// Adaptive anti-aliasing (`adaptive_spp` N > 0, over B = `spp` base samples): with B ≥ 2 a
/// refined pixel's radiance is the split estimator (1/N)·Σ_N L_direct + (1/B)·Σ_B L_indirect,
/// L_direct the lights at the camera ray's hit, L_indirect what the bounce paths add; with B = 1
/// it is (1/N)·Σ_N L over N jittered samples. A pixel not refined keeps (1/B)·Σ_B L, bit for bit
/// what adaptive_spp 0 gives.
///
/// Dust (`medium`, optional; null or puff-free costs nothing): baked per render on a grid of
/// spacing voxel_m (DustGrid: extinction k, optical depth toward the Sun, the geometry's shade
/// V at each node). Each pixel's radiance is attenuated by the transmittance T(s_hit) along its
/// centre ray, the Sun's light at each first hit by the dust's transmittance toward the Sun, and
/// the pixel gains the sunlight the dust scatters toward the camera,
/// ∫ k(s)·ω·p_HG(θ)·E_sun·T(s)·T_sun(s)·V(s) ds, both marched along the centre ray in steps of
/// voxel_m, sampled at each step's middle. Bounce paths do not see the dust, nor does the Earth's light;
/// depth and labels stay those of the geometry.
///
/// Light cache (`light_cache`, optional; light_cache.h): built for this scene in its present
/// static state, these lights and settings.bounces (else std::invalid_argument). A camera hit on
/// a surface it covers takes its indirect light from it, albedo/π · shape(mean direction) · E,
/// and traces no bounce; hits on moving geometry, or on a cached surface's back, bounce as
/// without it. The lights stay per pixel with their shadow rays.
RenderStats render(const Scene& scene, const Camera& camera, const Lights& lights, const RenderSettings& settings,
                   const FrameView& out, const Medium* medium = nullptr, const LightCache* light_cache = nullptr);
/// The same, lit by the Sun alone.
RenderStats render(const Scene& scene, const Camera& camera, const DirectionalLight& sun,
                   const RenderSettings& settings, const FrameView& out);
/// The geometric passes alone, depth and instance (`out.rgb` must be null, else
/// std::invalid_argument): nothing is shaded, so no light is given and no shadow ray is traced.
RenderStats render_geometry(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                            const FrameView& out);

/// The same, into owned buffers (for C++ callers and tests).
struct Frame {
    int width = 0, height = 0;
    std::vector<float> rgb, depth;
    std::vector<uint8_t> instance;
    RenderStats stats;
};
Frame render_frame(const Scene& scene, const Camera& camera, const Lights& lights, const RenderSettings& settings,
                   const Medium* medium = nullptr, const LightCache* light_cache = nullptr);
Frame render_frame(const Scene& scene, const Camera& camera, const DirectionalLight& sun,
                   const RenderSettings& settings);

}  // namespace moonbot
