// The yardstick for the renderer's speed: Embree's own time for exactly the rays a render traces,
// with no ray setup, shading or writes. Our render time divided by this is our overhead.
#pragma once

#include <cstdint>

#include "moonbot/camera.h"
#include "moonbot/scene.h"
#include "moonbot/sun.h"

namespace moonbot {

/// Median seconds over the repeats for each way of tracing the rays of one spp = 1 render: the
/// pixel-centre camera rays and the Sun shadow rays from their hits, in the renderer's 8×8 tiles,
/// on `threads` threads (0 = all).
struct EmbreeLimit {
    uint64_t camera_rays = 0;
    uint64_t shadow_rays = 0;
    double intersect_single_s = 0;  ///< rtcIntersect1, one ray at a time
    double intersect_stream_s = 0;  ///< rtcIntersect1M, 64-ray coherent streams (what render uses)
    double occluded_single_s = 0;   ///< rtcOccluded1
    double occluded_stream_s = 0;   ///< rtcOccluded1M (what render uses)
};

/// Generates the rays once (untimed), then times only the Embree calls. `repeats` ≥ 1.
EmbreeLimit measure_embree_limit(const Scene& scene, const Camera& camera, const Sun& sun,
                                 int threads, int repeats);

}  // namespace moonbot
