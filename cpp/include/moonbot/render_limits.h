// Limits shared by the renderer and the passes that follow its conventions (the light cache, the
// dust simulation, the Embree limit benchmark), in a header of their own so that those passes
// need not include the renderer, which includes them.
#pragma once

namespace moonbot {

/// The most threads a render may ask for: far above any node, far below what breaks TBB.
constexpr int kMaxThreads = 1024;

/// The most path bounces after the first hit (RenderSettings::bounces, LightCacheSettings::bounces).
constexpr int kMaxBounces = 16;

}  // namespace moonbot
