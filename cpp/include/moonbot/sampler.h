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

#include <cmath>
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

/// Laine & Karras's nested uniform permutation (constants tuned by Burley 2020) of a bit-reversed
/// fraction: each bit flipped or not by a hash of `seed` and the bits below it (additions and
/// products by even constants carry only upward).
inline uint32_t laine_karras(uint32_t x, uint32_t seed) {
    x += seed;
    x ^= x * 0x6C50B47Cu;
    x ^= x * 0xB82F1E52u;
    x ^= x * 0xC7AFE638u;
    x ^= x * 0x8D22F6E6u;
    return x;
}

/// Owen's nested uniform scramble of the binary fraction 0.b31 b30 … b0 held in `x`: each bit
/// flipped or not by a hash of `seed` and the bits above it.
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) { return reverse_bits(laine_karras(reverse_bits(x), seed)); }

namespace detail {

/// Sobol's second dimension by bytes: entry [b][v] is the XOR of the direction numbers of the
/// bits of v placed at byte b of the index (v_0 = 2^31, v_k = v_(k-1) XOR (v_(k-1) >> 1),
/// primitive polynomial x + 1). Four lookups instead of a loop over 32 bits.
struct SobolSecondTable {
    uint32_t entry[4][256];
    constexpr SobolSecondTable() : entry{} {
        uint32_t direction[32] = {};
        direction[0] = 1u << 31;
        for (int k = 1; k < 32; ++k) direction[k] = direction[k - 1] ^ (direction[k - 1] >> 1);
        for (int b = 0; b < 4; ++b)
            for (uint32_t v = 0; v < 256; ++v) {
                uint32_t x = 0;
                for (int bit = 0; bit < 8; ++bit)
                    if (v & (1u << bit)) x ^= direction[8 * b + bit];
                entry[b][v] = x;
            }
    }
};
inline constexpr SobolSecondTable kSobolSecond{};

}  // namespace detail

/// The second dimension of Sobol's sequence as a 32-bit fraction: the XOR of the direction numbers
/// of the index's set bits.
inline uint32_t sobol_second(uint32_t index) {
    const auto& t = detail::kSobolSecond.entry;
    return t[0][index & 0xFFu] ^ t[1][(index >> 8) & 0xFFu] ^ t[2][(index >> 16) & 0xFFu] ^ t[3][index >> 24];
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
    // The first dimension is the van der Corput fraction reverse_bits(shuffled): its scramble
    // reverse_bits(laine_karras(reverse_bits(·))) needs no reversal going in.
    const uint32_t x = reverse_bits(laine_karras(shuffled, static_cast<uint32_t>(h >> 32)));
    const uint32_t y = owen_scramble(sobol_second(shuffled), static_cast<uint32_t>(h2));
    return {static_cast<float>(x >> 8) * (1.0f / 16777216.0f), static_cast<float>(y >> 8) * (1.0f / 16777216.0f)};
}

/// cos and sin of the angle 2π·`turn` (radians), `turn` in [0, 1]: a sample point's angle about
/// an axis (the renderer's bounce directions and Sun-disk points). To within 1e-11 of the exact
/// values (test_sampler.cpp), inline and without a branch: libm's sincos, a call per use, was 6 %
/// of the render stage at default quality and sincosf 3 % (profiled on the benchmark's scenes).
/// The quarter turn q nearest to `turn` is split off exactly (4·turn − q is exact in doubles), the
/// rest a ∈ [−π/4, π/4] goes through Taylor's series to a¹¹ and a¹² (truncation below 7e-12),
/// and (cos a, sin a) is rotated by q quarter turns.
inline void turn_cos_sin(double turn, double& c, double& s) {
    constexpr double kHalfPi = 1.57079632679489661923;
    constexpr double kQuarterCos[4] = {1.0, 0.0, -1.0, 0.0}, kQuarterSin[4] = {0.0, 1.0, 0.0, -1.0};
    const double quarters = 4.0 * turn;
    const double q = std::floor(quarters + 0.5);
    const double a = (quarters - q) * kHalfPi;
    const double a2 = a * a;
    const double sin_a =
        a * (1.0 + a2 * (-1.0 / 6 + a2 * (1.0 / 120 + a2 * (-1.0 / 5040 + a2 * (1.0 / 362880 - a2 / 39916800.0)))));
    const double cos_a =
        1.0 + a2 * (-0.5 + a2 * (1.0 / 24 +
                                 a2 * (-1.0 / 720 + a2 * (1.0 / 40320 + a2 * (-1.0 / 3628800 + a2 / 479001600.0)))));
    const int k = static_cast<int>(q) & 3;
    c = kQuarterCos[k] * cos_a - kQuarterSin[k] * sin_a;
    s = kQuarterSin[k] * cos_a + kQuarterCos[k] * sin_a;
}

}  // namespace moonbot
