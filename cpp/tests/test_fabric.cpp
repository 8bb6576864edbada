#include <cmath>
#include <stdexcept>
#include <string>

#include "check.h"
#include "moonbot/fabric.h"
#include "moonbot/scene.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Mean of fabric_eval over one weave period (2p × 2p) on an n × n grid offset by (x0, y0). The
/// weave is a trigonometric polynomial of degree 3 per axis, so n ≥ 7 samples make the grid
/// mean its exact period mean.
struct PeriodMean {
    glm::dvec3 albedo{0.0}, normal{0.0};
};
PeriodMean period_mean(const FabricParams& p, double footprint, double x0, double y0, int n = 64) {
    PeriodMean m;
    const double step = 2 * p.pitch_m / n;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const FabricSample s = fabric_eval(p, x0 + i * step, y0 + j * step, footprint);
            m.albedo += s.albedo;
            m.normal += s.normal;
        }
    m.albedo /= double(n * n);
    m.normal /= double(n * n);
    return m;
}

}  // namespace

TEST_CASE(weave_height_closed_form) {
    // 1 at every cell centre (warp-up and weft-up alike), 0 where four cells meet.
    CHECK_NEAR(weave_height(kPi / 2, kPi / 2), 1.0, 1e-15);
    CHECK_NEAR(weave_height(kPi / 2, 3 * kPi / 2), 1.0, 1e-15);
    CHECK_NEAR(weave_height(0.0, 0.0), 0.0, 1e-15);
    CHECK_NEAR(weave_height(kPi, kPi), 0.0, 1e-15);
    // A warp-up cell (sin a sin b > 0) is a float along x: flat along a (1 − O(δ⁴)), curved
    // across it (1 − δ²); a weft-up cell the other way round.
    const double d = 0.2;
    CHECK_NEAR(weave_height(kPi / 2 + d, kPi / 2), 1.0, d * d * d * d);
    CHECK_NEAR(weave_height(kPi / 2, kPi / 2 + d), 1.0 - d * d, 2 * d * d * d * d);
    CHECK(weave_height(kPi / 2, 3 * kPi / 2 + d) > weave_height(kPi / 2 + d, 3 * kPi / 2));
    // Its range over a period is exactly [0, 1].
    double lo = 1e9, hi = -1e9;
    for (int j = 0; j < 400; ++j)
        for (int i = 0; i < 400; ++i) {
            const double h = weave_height(i * kPi / 200, j * kPi / 200);
            lo = std::min(lo, h);
            hi = std::max(hi, h);
        }
    CHECK_NEAR(lo, 0.0, 1e-12);
    CHECK_NEAR(hi, 1.0, 1e-12);
}

TEST_CASE(albedo_mean_over_a_period_is_the_configured_mean) {
    FabricParams p;
    for (double footprint : {0.0, 0.3e-3, 1.0e-3}) {
        const PeriodMean m = period_mean(p, footprint, 0.0123, -0.4567);
        for (int c = 0; c < 3; ++c) CHECK_NEAR(m.albedo[c], p.albedo[c], 1e-12);
    }
    p.contrast = 1.0;  // even at full contrast
    p.albedo = {0.2, 0.5, 0.9};
    const PeriodMean m = period_mean(p, 0.0, 3.0, 7.0);
    for (int c = 0; c < 3; ++c) CHECK_NEAR(m.albedo[c], p.albedo[c], 1e-12);
}

TEST_CASE(albedo_contrast_is_a_few_percent) {
    const FabricParams p;
    double lo = 1e9, hi = -1e9;
    for (int j = 0; j < 200; ++j)
        for (int i = 0; i < 200; ++i) {
            const double g = fabric_eval(p, i * 1.5e-5, j * 1.5e-5, 0.0).albedo.y / p.albedo.y;
            lo = std::min(lo, g);
            hi = std::max(hi, g);
        }
    CHECK_NEAR(lo, 1.0 - p.contrast, 1e-9);
    CHECK_NEAR(hi, 1.0 + p.contrast, 1e-9);
}

TEST_CASE(normal_is_unit_and_averages_to_the_flat_normal) {
    FabricParams p;
    p.relief_m = 4e-4;  // a coarse, steep weave makes the check harder
    for (double footprint : {0.0, 0.5e-3}) {
        const PeriodMean m = period_mean(p, footprint, 0.0, 0.0);
        // The mean of unit vectors is shorter than 1 (its length is the mean cosine); its
        // tangential part vanishes, so it points along the flat normal.
        CHECK_NEAR(m.normal.x, 0.0, 1e-12);
        CHECK_NEAR(m.normal.y, 0.0, 1e-12);
        CHECK(m.normal.z > 0.9 && m.normal.z <= 1.0);
        // An offset grid samples different points: the mean is still exactly the flat normal.
        const PeriodMean shifted = period_mean(p, footprint, 0.37e-3, -1.91e-3, 96);
        CHECK_NEAR(shifted.normal.x, 0.0, 1e-6);
        CHECK_NEAR(shifted.normal.y, 0.0, 1e-6);
    }
    for (int i = 0; i < 1000; ++i) {
        const FabricSample s = fabric_eval(p, i * 1.7e-5, i * 2.9e-5, 0.0);
        CHECK_NEAR(glm::length(s.normal), 1.0, 1e-14);
        CHECK(s.normal.z > 0);
    }
}

TEST_CASE(normal_is_the_height_fields_normal) {
    // Against central differences of the unfiltered height field.
    const FabricParams p;
    const double k = kPi / p.pitch_m, e = 1e-6;
    for (int i = 0; i < 50; ++i) {
        const double a = 0.37 * i, b = 1.3 - 0.21 * i;
        const double dzdx = p.relief_m * k * (weave_height(a + e, b) - weave_height(a - e, b)) / (2 * e);
        const double dzdy = p.relief_m * k * (weave_height(a, b + e) - weave_height(a, b - e)) / (2 * e);
        const glm::dvec3 want = glm::normalize(glm::dvec3(-dzdx, -dzdy, 1.0));
        const glm::dvec3 got = fabric_eval(p, a / k, b / k, 0.0).normal;
        CHECK(glm::length(got - want) < 1e-8);
    }
}

TEST_CASE(prefilter_is_the_gaussian_average) {
    // fabric_eval with footprint w equals the unfiltered albedo convolved with a Gaussian of
    // σ = w/2, here by quadrature over ±8σ.
    const FabricParams p;
    for (double w : {0.4e-3, 1.0e-3, 2.0e-3}) {
        const double sigma = w / 2, x0 = 0.81e-3, y0 = -0.23e-3;
        const int n = 161;
        const double step = 16 * sigma / (n - 1);
        double sum = 0, weights = 0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double dx = -8 * sigma + i * step, dy = -8 * sigma + j * step;
                const double g = std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
                sum += g * fabric_eval(p, x0 + dx, y0 + dy, 0.0).albedo.x;
                weights += g;
            }
        CHECK_NEAR(fabric_eval(p, x0, y0, w).albedo.x, sum / weights, 1e-9);
    }
}

TEST_CASE(wide_footprint_gives_mean_albedo_and_flat_normal) {
    const FabricParams p;
    double previous = 1e9;
    for (double periods : {0.25, 0.5, 1.0, 2.0}) {
        // The largest deviation from the mean over a period shrinks as the footprint grows.
        double worst = 0;
        for (int i = 0; i < 64; ++i) {
            const FabricSample s = fabric_eval(p, i * p.pitch_m / 32, i * p.pitch_m / 47, periods * 2 * p.pitch_m);
            worst = std::max(worst, std::abs(s.albedo.x - p.albedo.x) + glm::length(s.normal - glm::dvec3(0, 0, 1)));
        }
        CHECK(worst < previous);
        previous = worst;
    }
    CHECK(previous < 1e-6);  // two periods: gone
    for (int i = 0; i < 64; ++i) {
        const FabricSample s = fabric_eval(p, 0.1 + i * 1e-4, 0.2 - i * 3e-4, 20 * 2 * p.pitch_m);
        CHECK(s.albedo == p.albedo);
        CHECK(s.normal == glm::dvec3(0, 0, 1));
    }
}

TEST_CASE(periodic_over_two_threads_and_warp_weft_symmetric) {
    const FabricParams p;
    const double period = 2 * p.pitch_m;
    for (int i = 0; i < 100; ++i) {
        const double x = 0.013 * i, y = 0.5 - 0.007 * i, w = (i % 3) * 0.3e-3;
        const FabricSample s = fabric_eval(p, x, y, w);
        const FabricSample sx = fabric_eval(p, x + 3 * period, y, w);
        const FabricSample sy = fabric_eval(p, x, y - 5 * period, w);
        CHECK(glm::length(s.albedo - sx.albedo) < 1e-12 && glm::length(s.normal - sx.normal) < 1e-10);
        CHECK(glm::length(s.albedo - sy.albedo) < 1e-12 && glm::length(s.normal - sy.normal) < 1e-10);
        // Swapping warp and weft is a shift by one thread: f(y, x) = f(x + p, y), with the
        // normal's tangent and bitangent components swapped.
        const FabricSample swapped = fabric_eval(p, y, x, w);
        const FabricSample shifted = fabric_eval(p, x + p.pitch_m, y, w);
        CHECK(glm::length(swapped.albedo - shifted.albedo) < 1e-12);
        CHECK(glm::length(glm::dvec3(swapped.normal.y, swapped.normal.x, swapped.normal.z) - shifted.normal) < 1e-10);
    }
    // One thread is not a period: the over-under checkerboard needs two.
    CHECK(std::abs(weave_height(kPi / 2 + 0.3, kPi / 2) - weave_height(3 * kPi / 2 + 0.3, kPi / 2)) > 0.01);
}

TEST_CASE(params_are_validated) {
    FabricParams p;
    p.validate();
    p.pitch_m = 0;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = FabricParams{};
    p.relief_m = -1e-4;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = FabricParams{};
    p.contrast = 1.5;
    CHECK_THROWS(std::invalid_argument, p.validate());
    p = FabricParams{};
    p.albedo.z = NAN;
    CHECK_THROWS(std::invalid_argument, p.validate());
}

// --- sheen ---------------------------------------------------------------------------------------

namespace {

/// ∫ f_tape(ωi, ωo)·μi dωi over the hemisphere: the lobe's directional albedo at ωo, by the
/// midpoint rule in (t, φ) with μi = t² (dω·μi = 2t³ dt dφ; cells crowd toward the horizon, where
/// a grazing view's reflection lies), n × 2n cells.
double tape_albedo(const glm::dvec3& wo, double ax, double ay, int n) {
    double sum = 0.0;
    for (int j = 0; j < n; ++j) {
        const double t = (j + 0.5) / n, mu = t * t, sin_t = std::sqrt(1 - mu * mu);
        double ring = 0.0;
        for (int k = 0; k < 2 * n; ++k) {
            const double phi = (k + 0.5) * kPi / n;
            ring += tape_lobe({sin_t * std::cos(phi), sin_t * std::sin(phi), mu}, wo, ax, ay);
        }
        sum += 2 * t * t * t * ring;
    }
    return sum * (1.0 / n) * (kPi / n);
}

}  // namespace

TEST_CASE(tape_lobe_white_furnace_reflects_at_most_everything) {
    // Heitz 2014: with height-correlated Smith masking the single-scattering albedo is ≤ 1, close
    // to 1 for a smooth lobe seen from above, and lower for rough lobes and grazing views (the
    // energy of light that would scatter twice is lost, never created).
    const double roughness[][2] = {{0.35, 0.12}, {0.12, 0.35}, {0.1, 0.1}, {1.0, 1.0}, {1.0, 0.05}};
    double smooth_from_above = 0.0;
    for (const auto& a : roughness)
        for (double theta_deg : {0.0, 30.0, 60.0, 80.0, 88.0})
            for (double phi_deg : {0.0, 40.0, 90.0}) {
                const double t = theta_deg * kPi / 180, p = phi_deg * kPi / 180;
                const glm::dvec3 wo(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
                const double albedo = tape_albedo(wo, a[0], a[1], 600);
                CHECK(albedo <= 1.0 + 2e-3);
                CHECK(albedo > 0.0);
                if (a[0] == 0.1 && theta_deg == 0.0) smooth_from_above = albedo;
            }
    CHECK(smooth_from_above > 0.97);
    // Closed form: α = 1 seen from straight above, D = 1/π and G2 = 1/(1 + Λ(ωi)) with
    // Λ = (1/μi − 1)/2, so the albedo is ½∫₀¹ 2μ/(1 + μ) dμ = 1 − ln 2.
    CHECK_NEAR(tape_albedo({0, 0, 1}, 1.0, 1.0, 600), 1 - std::log(2.0), 1e-4);
    // Below the surface: nothing.
    CHECK(tape_lobe({0, 0, -1}, {0, 0, 1}, 0.3, 0.3) == 0.0);
    CHECK(tape_lobe({0, 0, 1}, {0.6, 0, -0.8}, 0.3, 0.3) == 0.0);
}

TEST_CASE(tape_lobe_is_reciprocal_and_anisotropic) {
    const glm::dvec3 a = glm::normalize(glm::dvec3(0.3, -0.2, 0.9)), b = glm::normalize(glm::dvec3(-0.5, 0.4, 0.6));
    CHECK_NEAR(tape_lobe(a, b, 0.35, 0.12), tape_lobe(b, a, 0.35, 0.12), 1e-12 * tape_lobe(a, b, 0.35, 0.12));
    // A lobe rough along x spreads its highlight along x: off-specular by 20° in the x-z plane it
    // keeps more than off-specular by 20° in the y-z plane; swapping the roughnesses swaps that.
    const double d = 20 * kPi / 180;
    const glm::dvec3 wi(0, 0, 1), off_x(std::sin(d), 0, std::cos(d)), off_y(0, std::sin(d), std::cos(d));
    CHECK(tape_lobe(wi, off_x, 0.35, 0.12) > 3 * tape_lobe(wi, off_y, 0.35, 0.12));
    CHECK_NEAR(tape_lobe(wi, off_x, 0.35, 0.12), tape_lobe(wi, off_y, 0.12, 0.35), 1e-12);
    // The GGX peak at normal incidence and mirror view: D(n)·G2/4 with D(n) = 1/(π ax ay), G2 = 1.
    CHECK_NEAR(tape_lobe(wi, wi, 0.35, 0.12), 1.0 / (kPi * 0.35 * 0.12) / 4.0, 1e-12);
}

TEST_CASE(sheen_prefilter_averages_the_weave_exactly) {
    FabricParams p;
    p.sheen = 0.1;
    const double scale = p.relief_m * kPi / p.pitch_m;
    // Far away (1 cm footprint over 1.5 mm threads) the warp share is the checkerboard's mean ½
    // and the whole relief's slope variance has moved into the lobe.
    const FabricSample far = fabric_eval(p, 0.0123, -0.0456, 1e-2);
    CHECK_NEAR(far.warp_share, 0.5, 1e-15);
    CHECK_NEAR(far.lost_slope2_x, scale * scale * (0.125 + 0.0390625), 1e-15);
    CHECK_NEAR(far.lost_slope2_y, far.lost_slope2_x, 0.0);
    // Up close nothing is lost, the share spans [0, 1] over a period and averages ½ (the
    // far value is the period mean: the sheen averages without aliasing).
    double lo = 1, hi = 0, mean = 0;
    const int n = 64;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const FabricSample s = fabric_eval(p, 2 * p.pitch_m * i / n, 2 * p.pitch_m * j / n, 0.0);
            CHECK(s.lost_slope2_x == 0.0);
            lo = std::min(lo, s.warp_share);
            hi = std::max(hi, s.warp_share);
            mean += s.warp_share / (n * n);
        }
    CHECK_NEAR(lo, 0.0, 1e-12);
    CHECK_NEAR(hi, 1.0, 1e-12);
    CHECK_NEAR(mean, 0.5, 1e-12);
    // The ⟨(∂h/∂a)²⟩ closed form behind lost_slope2: the unfiltered mean square of the normal's
    // slope over a period is scale²·(1/8 + 5/128).
    double slope2 = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const glm::dvec3 nn = fabric_eval(p, 2 * p.pitch_m * i / n, 2 * p.pitch_m * j / n, 0.0).normal;
            slope2 += (nn.x / nn.z) * (nn.x / nn.z) / (n * n);
        }
    CHECK_NEAR(slope2, scale * scale * (0.125 + 0.0390625), 1e-12);
    // Sheen off: the sample is the matte weave's, warp share and losses untouched.
    p.sheen = 0.0;
    const FabricSample matte = fabric_eval(p, 0.0123, -0.0456, 1e-2);
    CHECK(matte.warp_share == 0.5 && matte.lost_slope2_x == 0.0);
}

TEST_CASE(cloth_sheen_mixes_the_two_tape_directions) {
    FabricParams p;
    p.sheen = 0.2;
    FabricSample s;
    s.warp_share = 0.25;
    const glm::dvec3 wi = glm::normalize(glm::dvec3(0.4, 0.1, 0.9)), wo = glm::normalize(glm::dvec3(-0.3, 0.2, 0.8));
    CHECK_NEAR(cloth_sheen(p, s, wi, wo),
               0.25 * tape_lobe(wi, wo, p.sheen_along, p.sheen_across) +
                   0.75 * tape_lobe(wi, wo, p.sheen_across, p.sheen_along),
               1e-12);
    FabricParams bad = p;
    bad.sheen = 1.5;
    CHECK_THROWS(std::invalid_argument, bad.validate());
    bad = p;
    bad.sheen_along = 0.0;
    CHECK_THROWS(std::invalid_argument, bad.validate());
}

TEST_CASE(cloth_sheen_object_reused_over_many_directions_is_the_function) {
    // ClothSheen keeps what depends on wo alone; read at many wi in turn (as a lobe of incident
    // light is), each value must be the function's to the bit, below the surface (0) included.
    FabricParams p;
    p.sheen = 0.3;
    FabricSample s;
    s.warp_share = 0.6;
    s.lost_slope2_x = 0.004;
    s.lost_slope2_y = 0.001;
    for (const glm::dvec3& wo : {glm::dvec3(-0.3, 0.2, 0.8), glm::dvec3(0.05, -0.9, 0.1), glm::dvec3(0.3, 0.1, -0.4)}) {
        const glm::dvec3 o = glm::normalize(wo);
        const ClothSheen sheen(p, s, o);
        for (int k = 0; k < 64; ++k) {
            const double z = -0.3 + 1.3 * (k + 0.5) / 64, phi = 2.399963 * k;
            const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            const glm::dvec3 wi(r * std::cos(phi), r * std::sin(phi), z);
            const double once = sheen(wi), fresh = cloth_sheen(p, s, wi, o);
            CHECK(once == fresh);
            CHECK((wi.z > 0.0 && o.z > 0.0) ? once > 0.0 : once == 0.0);
        }
    }
}

TEST_CASE(woven_surface_validate_names_the_field) {
    WovenSurface w;
    w.validate();  // the defaults are valid
    auto rejection = [](const WovenSurface& s) -> std::string {
        try {
            s.validate();
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    w.metres_per_uv = 0.0;
    CHECK(rejection(w).rfind("metres_per_uv: ", 0) == 0);
    w = WovenSurface{};
    w.fabric.sheen_across = 0.0;
    CHECK(rejection(w).rfind("sheen_across: ", 0) == 0);
    w = WovenSurface{};
    w.dirt_colour.y = 1.5;
    CHECK(rejection(w).rfind("dirt_colour: ", 0) == 0);
    w = WovenSurface{};
    w.stain.opacity = 2.0;
    CHECK(rejection(w).find("opacity") != std::string::npos);
}
