#include <cmath>
#include <cstring>

#include "check.h"
#include "moonbot/regolith_texture.h"
#include "moonbot/rng.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;

GrainParams textured() {
    GrainParams p;
    p.albedo_rms = 0.1;
    p.slope_rms_deg = 15.0;
    p.finest_cell_m = 1e-3;
    p.coarsest_cell_m = 16e-3;
    p.seed = 7;
    return p;
}

/// A deterministic scatter of n points over a square of side `side` metres on the plane z = h0
/// (so that the statistics cover many independent cells of every octave).
glm::dvec3 scatter(int i, double side, double h0 = 0.0) {
    return {side * (uniform01(11, static_cast<uint64_t>(i), 0, 0) - 0.5),
            side * (uniform01(11, static_cast<uint64_t>(i), 0, 1) - 0.5), h0};
}

}  // namespace

TEST_CASE(closed_form_value_noise_statistics) {
    // E[s'²] = 6/5 and E[s² + (1 − s)²] = 26/35 for s = 3t² − 2t³ (midpoint rule, 1e5 steps).
    double ds2 = 0.0, w2 = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        const double t = (i + 0.5) / n, s = t * t * (3 - 2 * t), d = 6 * t * (1 - t);
        ds2 += d * d / n;
        w2 += (s * s + (1 - s) * (1 - s)) / n;
    }
    CHECK_NEAR(ds2, 1.2, 1e-9);
    CHECK_NEAR(w2, 26.0 / 35.0, 1e-9);
}

TEST_CASE(unfiltered_statistics_match_the_parameters) {
    // Mean factor 1 (to 1e-3), relative RMS albedo_rms and 1-D RMS slope tan(slope_rms_deg)
    // along x and along a diagonal (the lattices are rotated; the slope variance is isotropic).
    const RegolithGrain g(textured());
    const int n = 400000;
    double sum = 0.0, sum2 = 0.0, sx2 = 0.0, sd2 = 0.0;
    const glm::dvec3 diagonal = glm::normalize(glm::dvec3(1, 1, 0));
    for (int i = 0; i < n; ++i) {
        const GrainSample s = g.eval(scatter(i, 20.0), 0.0);
        sum += s.albedo_factor;
        sum2 += (s.albedo_factor - 1) * (s.albedo_factor - 1);
        sx2 += s.gradient.x * s.gradient.x;
        const double d = glm::dot(s.gradient, diagonal);
        sd2 += d * d;
    }
    CHECK_NEAR(sum / n, 1.0, 1e-3);
    CHECK_NEAR(std::sqrt(sum2 / n), 0.1, 0.1 * 0.02);
    const double tan_rms = std::tan(15.0 * kPi / 180.0);
    CHECK_NEAR(std::sqrt(sx2 / n), tan_rms, tan_rms * 0.03);
    CHECK_NEAR(std::sqrt(sd2 / n), tan_rms, tan_rms * 0.03);
}

TEST_CASE(large_footprint_is_exactly_the_mean) {
    const RegolithGrain g(textured());
    // 1.93 × the coarsest cell: every octave's gain is under 1 %.
    CHECK_NEAR(g.flat_footprint_m(), 16e-3 * (2 / kPi) * std::sqrt(2 * std::log(100.0)), 1e-15);
    for (int i = 0; i < 1000; ++i) {
        const GrainSample s = g.eval(scatter(i, 5.0, 0.3), g.flat_footprint_m());
        CHECK(s.albedo_factor == 1.0);
        CHECK(s.gradient == glm::dvec3(0.0));
    }
    // Just under it the coarsest octave fades in continuously from 0.
    double largest = 0.0;
    for (int i = 0; i < 1000; ++i)
        largest = std::max(largest, std::abs(g.eval(scatter(i, 5.0), g.flat_footprint_m() * 0.999).albedo_factor - 1));
    CHECK(largest > 0.0);
    CHECK(largest < 1e-4);
}

TEST_CASE(filtered_texture_is_noise_free_at_coarse_footprints) {
    // Pixels of footprint F, each sampled at 16 jittered points by two different seeds (as the
    // renderer's spp 16 does): with the prefilter the two seeds' pixel values agree several
    // times better than with the unfiltered texture, whose octaves below F alias into noise;
    // from flat_footprint_m() on they agree exactly.
    const RegolithGrain g(textured());
    for (double footprint : {4e-3, 8e-3, 16e-3, g.flat_footprint_m()}) {
        double filtered = 0.0, unfiltered = 0.0;
        const int pixels = 2000;
        for (int p = 0; p < pixels; ++p) {
            const glm::dvec3 centre = scatter(p, 10.0);
            double mean[2][2] = {{0, 0}, {0, 0}};  // [seed][unfiltered, filtered]
            for (int seed = 0; seed < 2; ++seed)
                for (int k = 0; k < 16; ++k) {
                    const glm::dvec3 jitter(footprint * (uniform01(100 + seed, p, k, 0) - 0.5),
                                            footprint * (uniform01(100 + seed, p, k, 1) - 0.5), 0.0);
                    mean[seed][0] += (g.eval(centre + jitter, 0.0).albedo_factor - 1) / 16;
                    mean[seed][1] += (g.eval(centre + jitter, footprint).albedo_factor - 1) / 16;
                }
            unfiltered += (mean[0][0] - mean[1][0]) * (mean[0][0] - mean[1][0]) / pixels;
            filtered += (mean[0][1] - mean[1][1]) * (mean[0][1] - mean[1][1]) / pixels;
        }
        // RMS differences between the seeds' pixel values; the texture's own RMS is 0.1.
        CHECK(std::sqrt(unfiltered) > 0.02);
        CHECK(std::sqrt(filtered) < 0.25 * std::sqrt(unfiltered));
        if (footprint == g.flat_footprint_m()) CHECK(filtered == 0.0);
    }
}

TEST_CASE(relief_over_a_pixel_gives_its_mean_slope_and_its_spread) {
    // For a footprint F each octave k (slope variance V_k ∝ c_k^(2H−2), summing to tan²15°) has
    // weight w_k ≈ exp(−½(πF/2c_k)²): the gradient's variance over the plane is Σ w_k⁴·V_k (the
    // prefiltered relief averaged over the pixel's box once more), and residual_slope_variance
    // is Σ w_k²(1 − w_k²)·V_k at every point. That spread is what the prefiltered slopes show
    // over the box they stand for (width √3·F: a box of σ F/2), about the box's mean: measured
    // by jittering 64 reads over it, within 10 % (a box is not a Gaussian).
    const RegolithGrain g(textured());
    const double tan2 = std::pow(std::tan(15.0 * kPi / 180.0), 2.0);
    double norm = 0.0;
    for (int k = 0; k < 5; ++k) norm += std::pow(1e-3 * std::ldexp(1.0, k), 2 * 0.6 - 2);
    for (double footprint : {1.5e-3, 3e-3, 6e-3}) {
        double mean_slope = 0.0, spread = 0.0;
        for (int k = 0; k < 5; ++k) {
            const double c = 1e-3 * std::ldexp(1.0, k), x = kPi * footprint / (2 * c);
            const double gain = std::exp(-0.5 * x * x), w = gain > 0.01 ? (gain - 0.01) / 0.99 : 0.0;
            const double v = tan2 * std::pow(c, 2 * 0.6 - 2) / norm;
            mean_slope += w * w * w * w * v;
            spread += w * w * (1 - w * w) * v;
        }
        const int n = 100000;
        double gx2 = 0.0;
        for (int i = 0; i < n; ++i) {
            const GrainSample s = g.eval(scatter(i, 20.0), footprint);
            gx2 += s.gradient.x * s.gradient.x / n;
            CHECK_NEAR(s.residual_slope_variance, spread, 1e-12 * tan2);
        }
        CHECK_NEAR(gx2, mean_slope, 0.05 * mean_slope);
        const int pixels = 2000, reads = 64;
        const double box = std::sqrt(3.0) * footprint;
        double within = 0.0;
        for (int p = 0; p < pixels; ++p) {
            const glm::dvec3 centre = scatter(p, 10.0);
            double sum = 0.0, sum2 = 0.0;
            for (int k = 0; k < reads; ++k) {
                const glm::dvec3 jitter(box * (uniform01(300, p, k, 0) - 0.5), box * (uniform01(300, p, k, 1) - 0.5),
                                        0.0);
                // The prefiltered slope itself (weights w_k): eval's gradient weighs w², and the
                // gain at F·√½ squared is the gain at F.
                const double gx = g.eval(centre + jitter, footprint * std::sqrt(0.5)).gradient.x;
                sum += gx / reads;
                sum2 += gx * gx / reads;
            }
            within += (sum2 - sum * sum) / pixels;
        }
        CHECK_NEAR(within, spread, 0.1 * spread);
    }
    // No spread where the texture is unfiltered, nor where it is flat.
    CHECK(g.eval(scatter(1, 1.0), 0.0).residual_slope_variance == 0.0);
    CHECK(g.eval(scatter(1, 1.0), g.flat_footprint_m()).residual_slope_variance == 0.0);
}

TEST_CASE(deterministic_and_keyed_by_seed) {
    const RegolithGrain a(textured()), b(textured());
    GrainParams other = textured();
    other.seed = 8;
    const RegolithGrain c(other);
    int differ = 0;
    for (int i = 0; i < 200; ++i) {
        const glm::dvec3 p = scatter(i, 3.0, -1.2);
        const GrainSample sa = a.eval(p, 1e-3), sb = b.eval(p, 1e-3), sc = c.eval(p, 1e-3);
        CHECK(std::memcmp(&sa.albedo_factor, &sb.albedo_factor, sizeof(double)) == 0);
        CHECK(sa.gradient == sb.gradient);
        differ += sa.albedo_factor != sc.albedo_factor;
    }
    CHECK(differ == 200);
}

TEST_CASE(far_from_the_origin_it_stays_finite_and_bounded) {
    // The terrain reaches 2 km: the lattice indices are ~2e6 and the fractions still resolve.
    const RegolithGrain g(textured());
    const double bound = 0.1 * std::sqrt(5 / kValueNoiseVariance);  // A·octaves
    for (int i = 0; i < 1000; ++i) {
        const GrainSample s = g.eval(scatter(i, 1.0) + glm::dvec3(-1999.3, 1987.1, -3.2), 0.0);
        CHECK(std::isfinite(s.albedo_factor) && std::abs(s.albedo_factor - 1) <= bound);
        CHECK(std::isfinite(s.gradient.x) && std::isfinite(s.gradient.y) && std::isfinite(s.gradient.z));
    }
}

TEST_CASE(perturbed_normal_tilts_against_the_gradient) {
    // z = 0.2·x over the plane with normal +z: the normal of that height field is (−0.2, 0, 1)/|·|.
    const glm::dvec3 n = perturbed_normal({0, 0, 1}, {0.2, 0, 0});
    CHECK_NEAR(n.x, -0.2 / std::sqrt(1.04), 1e-15);
    CHECK_NEAR(n.z, 1 / std::sqrt(1.04), 1e-15);
    // The gradient's normal component does not tilt it.
    const glm::dvec3 m = perturbed_normal({0, 0, 1}, {0, 0, 5});
    CHECK(m == glm::dvec3(0, 0, 1));
}

TEST_CASE(bad_parameters_name_the_field) {
    auto message = [](const GrainParams& p) -> std::string {
        try {
            p.validate();
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    GrainParams p = textured();
    p.albedo_rms = 0.3;  // 5 octaves: the factor could reach 1 − 0.3·√(5/0.1366) < 0
    CHECK(message(p).find("grain.albedo_rms") == 0);
    p = textured();
    p.finest_cell_m = 0.0;
    CHECK(message(p).find("grain.finest_cell_m") == 0);
    p = textured();
    p.coarsest_cell_m = 1e-4;
    CHECK(message(p).find("grain.coarsest_cell_m") == 0);
    p = textured();
    p.slope_rms_deg = NAN;
    CHECK(message(p).find("grain.slope_rms_deg") == 0);
    CHECK(!GrainParams{}.enabled());
    CHECK(textured().enabled());
}
