// Rendering one view of a committed scene into caller-owned buffers: linear RGB radiance,
// z-depth and instance labels. Depth and labels come from the pixel-centre ray only, so they are
// exact and independent of the sample count.
#pragma once

#include <cstdint>
#include <vector>

#include "moonbot/camera.h"
#include "moonbot/scene.h"
#include "moonbot/sun.h"

namespace moonbot {

/// The most threads a render may ask for: far above any node, far below what breaks TBB.
constexpr int kMaxThreads = 1024;

struct RenderSettings {
    int spp = 1;        ///< RGB samples per pixel, 1..65536; 1 = the pixel-centre ray, no jitter
    uint64_t seed = 0;  ///< keys the counter-based generator (with pixel and sample)
    int threads = 0;    ///< worker threads, 0 = all hardware threads, at most kMaxThreads
    /// Re-solve each hit's distance in double against the triangle's plane (depth exact to
    /// float32 rounding at any coordinates) instead of keeping Embree's float32 t, whose error
    /// grows with the distance of the scene from the origin. Costs ~15 ns a camera ray.
    bool exact_depth = true;
};

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
    uint64_t shadow_rays = 0;
    double seconds = 0.0;
};

/// Renders one view. Throws std::invalid_argument on bad settings or an uncommitted scene.
/// Lambertian shading: L = albedo/π · E · max(0, n·s) · V(s), black sky, no inter-reflection.
RenderStats render(const Scene& scene, const Camera& camera, const Sun& sun,
                   const RenderSettings& settings, const FrameView& out);

/// The same, into owned buffers (for C++ callers and tests).
struct Frame {
    int width = 0, height = 0;
    std::vector<float> rgb, depth;
    std::vector<uint8_t> instance;
    RenderStats stats;
};
Frame render_frame(const Scene& scene, const Camera& camera, const Sun& sun,
                   const RenderSettings& settings);

}  // namespace moonbot
