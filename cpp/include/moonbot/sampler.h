// The renderer's per-pixel sample points: low-discrepancy in pairs of dimensions, so that an
// estimate over a pixel's samples converges faster than with independent random numbers, yet a
// pure function of (stream, index, pair) like rng.h's: images stay bit-identical whatever the
// threads or the order tiles are rendered in.
//
// The method is Burley's (2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)): the first two
// dimensions of Sobol's sequence, Owen-scrambled with a hash (Laine & Karras's nested uniform
// permutation on bit-reversed values), a separate scramble for each pixel and pair of dimensions,
// and each pixel's sample order shuffled by Owen-scrambling the index. Any 2^k consecutive
// samples from index 0 of one (pixel, pair) then form a (0, k, 2)-net: each of the 2^k
// elementary rectangles of every shape 2^-a × 2^-(k-a) holds exactly one point. Different pixels
// and pairs are decorrelated by their hashes.
#pragma once

#include <cstdint>

#include "moonbot/rng.h"

namespace moonbot {

/// The 32 bits of `x` in reverse order.
inline uint32_t reverse_bits(uint32_t x) {
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00FF00FFu) << 8) | ((x & 0xFF00FF00u) >> 8);
    x = ((x & 0x0F0F0F0Fu) << 4) | ((x & 0xF0F0F0F0u) >> 4);
    x = ((x & 0x33333333u) << 2) | ((x & 0xCCCCCCCCu) >> 2);
    return ((x & 0x55555555u) << 1) | ((x & 0xAAAAAAAAu) >> 1);
}

/// Owen's nested uniform scramble of the binary fraction 0.b31 b30 … b0 held in `x`: each bit
/// flipped or not by a hash of `seed` and the bits above it. Laine & Karras's permutation (as
/// constants tuned by Burley 2020), applied to the reversed bits, where a bit depends on the ones
/// below it through additions and products by even constants.
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) {
    x = reverse_bits(x);
    x += seed;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return reverse_bits(x);
}

/// The second dimension of Sobol's sequence as a 32-bit fraction: the XOR of the direction numbers
/// of the index's set bits, v_0 = 2^31, v_k = v_(k-1) XOR (v_(k-1) >> 1) (primitive polynomial x + 1).
inline uint32_t sobol_second(uint32_t index) {
    uint32_t x = 0;
    for (uint32_t v = 1u << 31; index != 0; index >>= 1, v ^= v >> 1)
        if (index & 1u) x ^= v;
    return x;
}

/// A 2D sample point, both coordinates in [0, 1) (24-bit floats, exactly representable).
struct SamplePair {
    float u, v;
};

/// Point `index` of the low-discrepancy sequence of dimension pair `pair` for the pixel whose
/// pixel_stream is `stream` (rng.h).
inline SamplePair sample_pair(uint64_t stream, uint32_t index, uint32_t pair) {
    // One 64-bit hash per (pixel, pair) gives the index shuffle and the two scrambles.
    const uint64_t h = mix64(stream ^ (0xD1B54A32D192ED03ull * (static_cast<uint64_t>(pair) + 1)));
    const uint64_t h2 = mix64(h);
    const uint32_t shuffled = owen_scramble(index, static_cast<uint32_t>(h));
    const uint32_t x = owen_scramble(reverse_bits(shuffled), static_cast<uint32_t>(h >> 32));
    const uint32_t y = owen_scramble(sobol_second(shuffled), static_cast<uint32_t>(h2));
    return {static_cast<float>(x >> 8) * (1.0f / 16777216.0f), static_cast<float>(y >> 8) * (1.0f / 16777216.0f)};
}

}  // namespace moonbot
