// Counter-based random numbers: a value is a pure function of (seed, pixel, sample, dimension),
// so images are bit-identical whatever the number of threads or the order tiles are rendered in.
#pragma once

#include <cstdint>

namespace moonbot {

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer whose output bits
/// each depend on every input bit.
inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/// The part of uniform01's key that depends on (seed, pixel) only: a renderer drawing many
/// samples for one pixel computes it once per pixel instead of once per number.
inline uint64_t pixel_stream(uint64_t seed, uint64_t pixel) {
    return mix64(mix64(seed + 0x9E3779B97F4A7C15ull) ^ pixel);
}

/// uniform01 for the pixel whose pixel_stream is `stream`.
inline float stream_uniform01(uint64_t stream, uint32_t sample, uint32_t dimension) {
    const uint64_t h = mix64(stream ^ ((static_cast<uint64_t>(sample) << 32) | dimension));
    // The top 24 bits make an exactly representable float strictly below 1.
    return static_cast<float>(h >> 40) * (1.0f / 16777216.0f);
}

/// A uniform float in [0, 1) keyed by (seed, pixel, sample, dimension). Each key component is
/// folded in through the mixer, so neighbouring keys give independent-looking values.
inline float uniform01(uint64_t seed, uint64_t pixel, uint32_t sample, uint32_t dimension) {
    return stream_uniform01(pixel_stream(seed, pixel), sample, dimension);
}

}  // namespace moonbot
