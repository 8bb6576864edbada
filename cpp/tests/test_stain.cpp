#include <cmath>
#include <cstring>

#include "check.h"
#include "moonbot/stain.h"

using namespace moonbot;

namespace {

/// Σ_k α·B over the stamps, for texel (i, j), straight from the definition in stain.h: the
/// u offset wrapped into [−½, ½), v unwrapped (clipped), the local coordinate clamped.
double reference_sum(const StainParams& p, uint64_t seed, int i, int j) {
    const double u = (i + 0.5) / p.resolution, v = (j + 0.5) / p.resolution;
    double sum = 0;
    for (int k = 0; k < p.stamps; ++k) {
        const glm::dvec2 c = stamp_centre(seed, static_cast<uint32_t>(k));
        double du = u - c.x;
        du -= std::floor(du + 0.5);
        const double lu = std::clamp(du / p.brush_size + 0.5, 0.0, 1.0);
        const double lv = std::clamp((v - c.y) / p.brush_size + 0.5, 0.0, 1.0);
        sum += p.opacity * splat(lu, lv);
    }
    return sum;
}

bool same_bytes(const StainMask& a, const StainMask& b) {
    return a.resolution() == b.resolution() &&
           std::memcmp(a.data(), b.data(), sizeof(float) * a.resolution() * a.resolution()) == 0;
}

}  // namespace

TEST_CASE(splat_shape) {
    CHECK_NEAR(splat(0.5, 0.5), 1.0, 0.0);
    // Zero on the border of the local square (and anything clamped onto it), so clamping the
    // local coordinate smears nothing.
    for (int i = 0; i <= 100; ++i) {
        const double t = i / 100.0;
        CHECK(splat(t, 0.0) == 0.0 && splat(t, 1.0) == 0.0 && splat(0.0, t) == 0.0 && splat(1.0, t) == 0.0);
        CHECK(splat(t, -3.0) == 0.0 && splat(7.0, t) == 0.0);
    }
    // Values in [0, 1]; the support's area by quadrature matches the closed form.
    const int n = 2000;
    long inside = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double b = splat((i + 0.5) / n, (j + 0.5) / n);
            CHECK(b >= 0.0 && b <= 1.0);
            inside += b > 0.0;
        }
    CHECK_NEAR(double(inside) / (double(n) * n), splat_support_area(), 2e-4);
    CHECK_NEAR(splat_support_area(), 0.2515, 1e-4);
}

TEST_CASE(no_stamps_allocate_nothing) {
    const uint64_t bytes = stain_mask_bytes(), ever = stain_masks_allocated();
    StainParams p;
    p.stamps = 0;
    CHECK(paint_stain(p, 42) == nullptr);
    CHECK(stain_mask_bytes() == bytes && stain_masks_allocated() == ever);
    // A clean bag's base colour is the clean colour, exactly.
    const glm::dvec3 clean(0.55, 0.45, 0.32), dirt(0.12, 0.11, 0.10);
    CHECK(stained_base_colour(clean, 0.0, dirt) == clean);
    // And a painted mask is counted while it lives.
    p.stamps = 3;
    p.resolution = 64;
    {
        const auto mask = paint_stain(p, 42);
        CHECK(stain_mask_bytes() == bytes + 64 * 64 * sizeof(float));
        CHECK(stain_masks_allocated() == ever + 1);
    }
    CHECK(stain_mask_bytes() == bytes && stain_masks_allocated() == ever + 1);
}

TEST_CASE(one_stamp_is_alpha_times_the_splat) {
    StainParams p;
    p.stamps = 1;
    p.resolution = 256;
    p.opacity = 0.35;
    for (uint64_t seed : {1u, 2u, 3u, 99u}) {
        const auto mask = paint_stain(p, seed);
        const glm::dvec2 c = stamp_centre(seed, 0);
        double peak = 0;
        for (int j = 0; j < p.resolution; ++j)
            for (int i = 0; i < p.resolution; ++i) {
                const double want = reference_sum(p, seed, i, j);
                CHECK_NEAR(mask->texel(i, j), want, 1e-7);
                peak = std::max(peak, double(mask->texel(i, j)));
            }
        // The texel nearest the centre is within half a texel of it: B there is ≥ B's value at
        // that distance, close to 1, so the mask peaks at nearly α.
        const int ic = std::min(int(c.x * p.resolution), p.resolution - 1);
        const int jc = std::min(int(c.y * p.resolution), p.resolution - 1);
        const double lu = ((ic + 0.5) / p.resolution - c.x) / p.brush_size + 0.5;
        const double lv = ((jc + 0.5) / p.resolution - c.y) / p.brush_size + 0.5;
        CHECK_NEAR(mask->texel(ic, jc), p.opacity * splat(lu, lv), 1e-7);
        CHECK(peak <= p.opacity + 1e-7 && peak > 0.99 * p.opacity);
    }
}

TEST_CASE(stamps_add_then_clamp) {
    StainParams p;
    p.stamps = 90;
    p.resolution = 128;
    p.opacity = 0.6;
    const auto mask = paint_stain(p, 7);
    int saturated = 0, overlapped_below_one = 0;
    for (int j = 0; j < p.resolution; ++j)
        for (int i = 0; i < p.resolution; ++i) {
            const double sum = reference_sum(p, 7, i, j);
            CHECK_NEAR(mask->texel(i, j), std::min(sum, 1.0), 1e-6);
            saturated += sum > 1.0;
            overlapped_below_one += sum > p.opacity && sum < 1.0;  // two stamps, not clamped
        }
    CHECK(saturated > 100);
    CHECK(overlapped_below_one > 10);
}

TEST_CASE(edges_wrap_in_u_and_clip_in_v) {
    // Find stamps that straddle u = 0 and v = 0; the parts beyond u = 0 reappear at u → 1, the
    // parts below v = 0 are lost (reference_sum checks every texel of both).
    StainParams p;
    p.stamps = 1;
    p.resolution = 128;
    bool wrapped = false, clipped = false;
    for (uint64_t seed = 0; seed < 400 && !(wrapped && clipped); ++seed) {
        const glm::dvec2 c = stamp_centre(seed, 0);
        const bool straddles_u = c.x < 0.05, straddles_v = c.y < 0.05;
        if (!straddles_u && !straddles_v) continue;
        const auto mask = paint_stain(p, seed);
        for (int j = 0; j < p.resolution; ++j)
            for (int i = 0; i < p.resolution; ++i) CHECK_NEAR(mask->texel(i, j), reference_sum(p, seed, i, j), 1e-7);
        if (straddles_u) {
            const int jc = std::min(int(c.y * p.resolution), p.resolution - 1);
            wrapped |= mask->texel(p.resolution - 1, jc) > 0.4f;  // the blob continues past u = 1
        }
        clipped |= straddles_v;
    }
    CHECK(wrapped && clipped);
}

TEST_CASE(deterministic_and_thread_independent) {
    StainParams p;
    p.stamps = 90;
    p.resolution = 512;
    const auto a = paint_stain(p, 12345, 1), b = paint_stain(p, 12345, 2), c = paint_stain(p, 12345, 0);
    const auto d = paint_stain(p, 12345, 1), other = paint_stain(p, 12346, 0);
    CHECK(same_bytes(*a, *b) && same_bytes(*a, *c) && same_bytes(*a, *d));
    CHECK(!same_bytes(*a, *other));
}

TEST_CASE(coverage_matches_the_boolean_model) {
    // A texel at least s/2 from v = 0 and v = 1 is stained (M > 0) by stamp k with probability
    // s²·A (A = splat_support_area()), independently over k: expected coverage 1 − (1 − s²A)^N.
    // Averaged over 40 seeds the standard error is under 0.01.
    StainParams p;
    p.resolution = 128;
    for (int n : {15, 30, 90}) {
        p.stamps = n;
        const double expected = 1.0 - std::pow(1.0 - p.brush_size * p.brush_size * splat_support_area(), n);
        double covered = 0, texels = 0;
        for (uint64_t seed = 0; seed < 40; ++seed) {
            const auto mask = paint_stain(p, 1000 + seed);
            for (int j = 0; j < p.resolution; ++j) {
                const double v = (j + 0.5) / p.resolution;
                if (v < p.brush_size / 2 || v > 1 - p.brush_size / 2) continue;
                for (int i = 0; i < p.resolution; ++i) {
                    covered += mask->texel(i, j) > 0.0f;
                    texels += 1;
                }
            }
        }
        CHECK_NEAR(covered / texels, expected, 0.03);
    }
}

TEST_CASE(stamp_centres_are_uniform) {
    // 10000 centres: per axis mean ½ (σ = 0.0029) and a quarter of them in each quadrant
    // (σ = 43 of 2500).
    double mu = 0, mv = 0;
    int quadrant = 0;
    for (uint32_t k = 0; k < 10000; ++k) {
        const glm::dvec2 c = stamp_centre(5, k);
        CHECK(c.x >= 0 && c.x < 1 && c.y >= 0 && c.y < 1);
        mu += c.x;
        mv += c.y;
        quadrant += c.x < 0.5 && c.y < 0.5;
    }
    CHECK_NEAR(mu / 10000, 0.5, 0.012);
    CHECK_NEAR(mv / 10000, 0.5, 0.012);
    CHECK_NEAR(quadrant, 2500, 175);
    CHECK(stamp_centre(5, 0) != stamp_centre(6, 0));
}

TEST_CASE(bilinear_sampling) {
    StainParams p;
    p.stamps = 60;
    p.resolution = 32;
    const auto m = paint_stain(p, 3);
    const int n = p.resolution;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double u = (i + 0.5) / n, v = (j + 0.5) / n;
            CHECK_NEAR(m->sample(u, v), m->texel(i, j), 1e-7);
            // Halfway between texel centres: the average; across u = 1 to texel 0 (wrap).
            const int i1 = (i + 1) % n;
            CHECK_NEAR(m->sample(u + 0.5 / n, v), 0.5 * (m->texel(i, j) + m->texel(i1, j)), 1e-6);
            CHECK_NEAR(m->sample(u + 3.0, v), m->texel(i, j), 1e-6);
            CHECK_NEAR(m->sample(u - 2.0, v), m->texel(i, j), 1e-6);
        }
    // v clamps to the outermost texel centres.
    for (int i = 0; i < n; ++i) {
        const double u = (i + 0.5) / n;
        CHECK_NEAR(m->sample(u, -0.4), m->texel(i, 0), 1e-7);
        CHECK_NEAR(m->sample(u, 0.1 / n), m->texel(i, 0), 1e-7);
        CHECK_NEAR(m->sample(u, 1.3), m->texel(i, n - 1), 1e-7);
    }
}

TEST_CASE(base_colour_is_the_papers_lerp) {
    const glm::dvec3 clean(0.55, 0.45, 0.32), dirt(0.12, 0.11, 0.10);
    CHECK(stained_base_colour(clean, 1.0, dirt) == dirt);
    const glm::dvec3 half = stained_base_colour(clean, 0.5, dirt);
    CHECK(glm::length(half - (0.5 * clean + 0.25 * dirt)) < 1e-15);
    CHECK(stained_base_colour(clean, 1.7, dirt) == dirt);
    CHECK(stained_base_colour(clean, -0.2, dirt) == clean);
}

TEST_CASE(params_are_validated) {
    StainParams p;
    p.validate();
    p.stamps = -1;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = StainParams{};
    p.brush_size = 0.6;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = StainParams{};
    p.opacity = 1.01;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = StainParams{};
    p.resolution = 0;
    CHECK_THROWS(std::invalid_argument, paint_stain(p, 0));
    CHECK_THROWS(std::invalid_argument, paint_stain(StainParams{}, 0, -1));
}
