// The yardstick for the renderer's speed: Embree's own time for exactly the rays a render traces,
// with no ray setup, shading or writes. Our render time divided by this is our overhead.
#pragma once

#include <cstdint>
#include <vector>

#include "moonbot/camera.h"
#include "moonbot/light.h"
#include "moonbot/scene.h"

namespace moonbot {

/// Seconds Embree takes, median over the repeats, for the rays of one spp = 1 render traced
/// each way: the pixel-centre camera rays, the Sun shadow rays from their hits and `bounces`
/// generations of diffuse bounce rays, made by the renderer's own code, in the renderer's 8×8
/// tiles, on `threads` threads (0 = all).
///
/// Bounce rays: from every camera hit a cosine-distributed direction about the geometric normal
/// on the camera's side, leaving from the lifted hit point (rays.h: cosine_direction, lift_off);
/// generation g + 1 leaves from generation g's hits the same way, as the renderer's paths do;
/// and from every generation's hits that face the Sun, a shadow ray toward its centre. Both are
/// incoherent (origins spread over the scene), traced as the renderer traces them: 64-ray streams,
/// one stream per tile, generation and kind. Every stream, packet and single-ray query runs in
/// Embree's incoherent mode, as all of the renderer's do (accel.h).
///
/// Each tile's rays are copied into a per-thread buffer first, untimed, and only the Embree
/// calls are timed, tile by tile: the renderer also traces rays it has just written, from the
/// L1 cache, and Embree reading them from memory (a whole image of rays is 25 MB) was 20 % slower
/// on the default scene. A tile's time is clock-to-clock minus the clock's own cost (measured,
/// `timer_overhead_s`). Each thread sums its tiles; the figure is the busiest thread's sum, the
/// wall time of the same rays with no other work in between.
struct EmbreeLimit {
    uint64_t camera_rays = 0;
    uint64_t shadow_rays = 0;
    double intersect_single_s = 0;    ///< rtcIntersect1, one ray at a time
    double intersect_packet8_s = 0;   ///< rtcIntersect8, 4×2-pixel packets
    double intersect_packet16_s = 0;  ///< rtcIntersect16, 4×4-pixel packets
    double intersect_stream_s = 0;    ///< rtcIntersect1M, the tile as one 64-ray stream
                                      ///< (what render uses)
    double occluded_single_s = 0;     ///< rtcOccluded1
    double occluded_packet8_s = 0;    ///< rtcOccluded8, a tile's shadow rays in order, 8 a packet
    double occluded_packet16_s = 0;   ///< rtcOccluded16
    double occluded_stream_s = 0;     ///< rtcOccluded1M (what render uses)
    /// The two streams again, traced in place over the whole image's rays held in memory and
    /// timed as one wall-clock interval (how this probe measured before).
    double intersect_stream_from_memory_s = 0;
    double occluded_stream_from_memory_s = 0;
    /// Per bounce generation (index 0 = the first bounce): rays, and seconds as the renderer's
    /// incoherent 64-ray streams (rtcIntersect1M) and one ray at a time (rtcIntersect1); then the
    /// Sun shadow rays from that generation's hits, as incoherent streams (rtcOccluded1M).
    std::vector<uint64_t> bounce_rays;
    std::vector<double> bounce_stream_s;
    std::vector<double> bounce_single_s;
    std::vector<uint64_t> bounce_shadow_rays;
    std::vector<double> bounce_shadow_stream_s;
    double timer_overhead_s = 0;  ///< cost of one clock-to-clock interval, subtracted per tile
    int threads = 0;              ///< threads the arena ran
};

/// Generates the rays once (untimed), then times only the Embree calls. `repeats` ≥ 1,
/// `bounces` in 0..kMaxBounces.
EmbreeLimit measure_embree_limit(const Scene& scene, const Camera& camera, const DirectionalLight& sun, int threads,
                                 int repeats, int bounces = 0);

}  // namespace moonbot
