// The renderer's sample points (sampler.h): the (0, k, 2)-net property that Owen scrambling keeps,
// decorrelation across pixels and pairs, purity, and the gain over independent random numbers on
// an integral with a known value.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

#include "check.h"
#include "moonbot/rng.h"
#include "moonbot/sampler.h"

using namespace moonbot;

namespace {

/// Whether the first 2^k points of (stream, pair) put exactly one point in each elementary
/// rectangle 2^-a × 2^-(k-a), for every a in 0..k.
bool is_net(uint64_t stream, uint32_t pair, int k) {
    const uint32_t n = 1u << k;
    for (int a = 0; a <= k; ++a) {
        std::vector<int> count(n, 0);
        for (uint32_t i = 0; i < n; ++i) {
            const SamplePair p = sample_pair(stream, i, pair);
            const uint32_t cx = static_cast<uint32_t>(p.u * double(1u << a));
            const uint32_t cy = static_cast<uint32_t>(p.v * double(1u << (k - a)));
            ++count[(cx << (k - a)) | cy];
        }
        for (int c : count)
            if (c != 1) return false;
    }
    return true;
}

}  // namespace

TEST_CASE(reverse_bits_and_sobol_second_dimension) {
    CHECK(reverse_bits(1u) == 0x80000000u);
    CHECK(reverse_bits(0x0000FFFFu) == 0xFFFF0000u);
    CHECK(reverse_bits(reverse_bits(0x12345678u)) == 0x12345678u);
    // Sobol's second dimension: 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8 for indices 1..7.
    const double expected[] = {0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875};
    for (uint32_t i = 0; i < 8; ++i) CHECK(sobol_second(i) / 4294967296.0 == expected[i]);
}

TEST_CASE(points_lie_in_the_unit_square_and_are_pure) {
    for (uint32_t pixel = 0; pixel < 50; ++pixel)
        for (uint32_t i = 0; i < 64; ++i) {
            const SamplePair p = sample_pair(pixel_stream(7, pixel), i, 3);
            CHECK(p.u >= 0.0f && p.u < 1.0f && p.v >= 0.0f && p.v < 1.0f);
            const SamplePair q = sample_pair(pixel_stream(7, pixel), i, 3);
            CHECK(p.u == q.u && p.v == q.v);
        }
}

TEST_CASE(every_power_of_two_prefix_is_a_net) {
    // For many pixels and pairs, the first 1, 2, 4, … 256 points are (0, k, 2)-nets: the
    // stratification the index shuffle and the scrambles must keep.
    for (uint32_t pixel = 0; pixel < 40; ++pixel)
        for (uint32_t pair : {0u, 1u, 8u, 4096u, 4129u})
            for (int k = 0; k <= 8; ++k) CHECK(is_net(pixel_stream(3, pixel), pair, k));
}

TEST_CASE(pixels_and_pairs_get_different_points) {
    std::set<std::pair<float, float>> first;
    for (uint32_t pixel = 0; pixel < 200; ++pixel) {
        const SamplePair p = sample_pair(pixel_stream(1, pixel), 0, 0);
        first.insert({p.u, p.v});
    }
    CHECK(first.size() == 200);  // index 0 is scrambled differently in every pixel
    int same = 0;
    for (uint32_t i = 0; i < 256; ++i) {
        const SamplePair a = sample_pair(pixel_stream(1, 9), i, 0), b = sample_pair(pixel_stream(1, 9), i, 1);
        same += a.u == b.u || a.v == b.v;
    }
    CHECK(same == 0);
    // Across pixels the points are uncorrelated: the mean product of centred coordinates of the
    // same index in neighbouring pixels is near 0 (1/12 would be full correlation).
    double product = 0.0;
    for (uint32_t pixel = 0; pixel < 4000; ++pixel) {
        const SamplePair a = sample_pair(pixel_stream(5, pixel), 3, 2),
                         b = sample_pair(pixel_stream(5, pixel + 1), 3, 2);
        product += (a.u - 0.5) * (b.u - 0.5);
    }
    CHECK(std::abs(product / 4000) < 0.005);
}

TEST_CASE(converges_faster_than_independent_numbers) {
    // The fraction of the unit square under the line y = 0.3 + 0.4·x (a pixel cut by an edge)
    // is 0.5 exactly. Over 2000 pixels, the RMS error of its 16- and 64-sample estimates is
    // 1/sqrt(N)-like with independent numbers and falls faster with the nets.
    for (uint32_t n : {16u, 64u}) {
        double err_net = 0.0, err_random = 0.0;
        for (uint32_t pixel = 0; pixel < 2000; ++pixel) {
            const uint64_t stream = pixel_stream(11, pixel);
            double net = 0.0, random = 0.0;
            for (uint32_t i = 0; i < n; ++i) {
                const SamplePair p = sample_pair(stream, i, 0);
                net += p.v < 0.3 + 0.4 * p.u;
                random += stream_uniform01(stream, i, 1) < 0.3 + 0.4 * stream_uniform01(stream, i, 0);
            }
            err_net += std::pow(net / n - 0.5, 2);
            err_random += std::pow(random / n - 0.5, 2);
        }
        err_net = std::sqrt(err_net / 2000);
        err_random = std::sqrt(err_random / 2000);
        std::printf("  edge coverage, %u samples: RMS error %.4f (nets) against %.4f (independent)\n", n, err_net,
                    err_random);
        CHECK(err_random > 0.8 * 0.5 / std::sqrt(double(n)));  // the independent baseline is what it should be
        CHECK(err_net < 0.5 * err_random);
    }
}

TEST_CASE(a_net_beats_more_points_past_it) {
    // Why a refined pixel's sample count is a power of two (render.h, refined_sample_count). A
    // penumbra 0.6 pixel wide crossing the pixel obliquely: the lit fraction
    // clamp((v − 0.4·u)/0.6, 0, 1), whose mean over the pixel is 0.5 exactly. Over 4000 pixels its
    // RMS error with the first 32 points (a net) is below that with the first 44 (a count
    // refined_sample_count moves to 32), and with 64 below that with 88: past the last net the
    // extra points unbalance the strata. On the hard edge of converges_faster_than_independent_numbers
    // the extra points still help (printed); the renders' refined pixels are mostly soft: long
    // penumbrae, light grazing the facets.
    const auto rms_error = [](uint32_t n, bool soft) {
        double sum = 0.0;
        for (uint32_t pixel = 0; pixel < 4000; ++pixel) {
            const uint64_t stream = pixel_stream(13, pixel);
            double lit = 0.0;
            for (uint32_t i = 0; i < n; ++i) {
                const SamplePair p = sample_pair(stream, i, 0);
                lit += soft ? std::clamp((p.v - 0.4 * p.u) / 0.6, 0.0, 1.0) : double(p.v < 0.3 + 0.4 * p.u);
            }
            sum += std::pow(lit / n - 0.5, 2);
        }
        return std::sqrt(sum / 4000);
    };
    for (const auto& [net, more] : {std::pair<uint32_t, uint32_t>{32, 44}, {64, 88}}) {
        const double at_net = rms_error(net, true), past = rms_error(more, true);
        std::printf("  penumbra: RMS error %.5f with %u points (a net), %.5f with %u; hard edge %.4f and %.4f\n",
                    at_net, net, past, more, rms_error(net, false), rms_error(more, false));
        CHECK(at_net < 0.9 * past);
    }
}

TEST_CASE(turn_cos_sin_matches_the_exact_angle_to_1e_11) {
    // Every 2^-16 turn (the quadrant boundaries and both ends included), and random 24-bit
    // fractions like the sampler's, against long-double cos and sin.
    std::vector<double> turns;
    for (uint32_t i = 0; i <= (1u << 16); ++i) turns.push_back(i / 65536.0);
    for (uint32_t i = 0; i < 200000; ++i) turns.push_back(static_cast<double>(mix64(i) >> 40) / 16777216.0);
    double worst = 0.0, worst_norm = 0.0;
    for (double t : turns) {
        double c, s;
        turn_cos_sin(t, c, s);
        const long double phi = 6.283185307179586476925286766559L * t;
        worst = std::max({worst, double(std::fabs(c - std::cos(phi))), double(std::fabs(s - std::sin(phi)))});
        worst_norm = std::max(worst_norm, std::fabs(c * c + s * s - 1.0));
    }
    CHECK(worst < 1e-11);
    CHECK(worst_norm < 2e-11);
    double c, s;
    turn_cos_sin(0.0, c, s);
    CHECK(c == 1.0 && s == 0.0);
    turn_cos_sin(0.25, c, s);
    CHECK(c == 0.0 && s == 1.0);
    turn_cos_sin(0.5, c, s);
    CHECK(c == -1.0 && s == 0.0);
}
