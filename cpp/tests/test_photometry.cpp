// Photometric functions (moonbot/photometry.h): Lambert and Lunar-Lambert unchanged, and Hapke's
// model against closed forms, Chandrasekhar's H-function, reciprocity, energy and its limits.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/photometry.h"

using namespace moonbot;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// The lunar set of Sato et al. 2014 (docs/physics.md): w 0.32, b 0.24, c 0.30,
/// B_S0 1.8, h_S 0.07, B_C0 0, θ̄ 23.4°, φ 0.3.
Photometry lunar_hapke(double w = 0.32, double roughness_deg = 23.4, double filling = 0.3, double shoe = 1.8,
                       double b = 0.24, double c = 0.30, double cboe = 0.0, double cboe_width = 1.0) {
    Photometry::HapkeParams h;
    h.w = w;
    h.b = b;
    h.c = c;
    h.cboe_amplitude = cboe;
    h.cboe_width = cboe_width;
    h.filling_factor = filling;
    h.roughness_rad = roughness_deg * kDeg;
    return make_hapke(h, shoe, 0.07);
}

/// A deterministic uniform in [0, 1) (splitmix64), so every run draws the same geometries.
struct Rng {
    uint64_t s;
    double next() {
        uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        z ^= z >> 31;
        return double(z >> 11) * 0x1.0p-53;
    }
};

/// A random pair of upper-hemisphere directions: (μi, μo, cos g), with the azimuth difference
/// uniform, so cos g is consistent with the two cosines.
struct Geometry {
    double mu_i, mu_o, cos_g;
};
Geometry random_geometry(Rng& rng) {
    const double mi = std::max(rng.next(), 1e-6), mo = std::max(rng.next(), 1e-6);
    const double psi = 2.0 * kPi * rng.next();
    const double cg = mi * mo + std::sqrt((1 - mi * mi) * (1 - mo * mo)) * std::cos(psi);
    return {mi, mo, cg};
}

/// The H approximation written out again here, straight from Hapke 2002 eq. 13, so the closed
/// form test does not reuse the code under test.
double H_2002(double w, double x) {
    const double gamma = std::sqrt(1.0 - w);
    const double r0 = (1.0 - gamma) / (1.0 + gamma);
    return 1.0 / (1.0 - w * x * (r0 + (1.0 - 2.0 * r0 * x) / 2.0 * std::log((1.0 + x) / x)));
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton on P_n from the Chebyshev guess).
void gauss_legendre01(int n, std::vector<double>& x, std::vector<double>& a) {
    x.assign(n, 0.0);
    a.assign(n, 0.0);
    for (int k = 0; k < n; ++k) {
        double z = std::cos(kPi * (k + 0.75) / (n + 0.5)), dp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = z;
            for (int j = 2; j <= n; ++j) {
                const double p2 = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p0) / j;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1.0);
            const double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) break;
        }
        x[k] = 0.5 * (1.0 - z);
        a[k] = 1.0 / ((1.0 - z * z) * dp * dp);  // 2/((1 − z²)P'²) on [−1, 1], halved for [0, 1]
    }
}

/// Chandrasekhar's H-function for isotropic scattering with albedo w, "exactly": the nonlinear
/// integral equation in its alternative form (Chandrasekhar 1960, Radiative Transfer, ch. V)
///   1/H(μ) = √(1 − w) + (w/2)·∫₀¹ μ'·H(μ')/(μ + μ') dμ'
/// iterated on Gauss-Legendre nodes, then evaluated at μ by the same equation (Nyström).
struct ExactH {
    double w;
    std::vector<double> x, a, h;
    explicit ExactH(double w_, int n = 400) : w(w_) {
        gauss_legendre01(n, x, a);
        h.assign(n, 1.0);
        for (int it = 0; it < 20000; ++it) {
            double change = 0.0;
            std::vector<double> next(n);
            // Geometric-mean damping: at w = 1 the equation is homogeneous (H → λH maps to H/λ),
            // and the plain iteration flips between the two; the mean cancels that mode.
            for (int j = 0; j < n; ++j) next[j] = std::sqrt(h[j] * (*this)(x[j]));
            for (int j = 0; j < n; ++j) change = std::max(change, std::abs(next[j] - h[j]));
            h = next;
            if (change < 1e-14) break;
        }
    }
    double operator()(double mu) const {
        double s = 0.0;
        for (size_t k = 0; k < x.size(); ++k) s += a[k] * x[k] * h[k] / (mu + x[k]);
        return 1.0 / (std::sqrt(1.0 - w) + 0.5 * w * s);
    }
    /// The zeroth moment ∫₀¹ H dμ.
    double moment0() const {
        double s = 0.0;
        for (size_t k = 0; k < x.size(); ++k) s += a[k] * h[k];
        return s;
    }
};

/// Directional-hemispherical reflectance over A_N, ∫ f·μo dΩo / A_N, for incidence cos μi: Gauss-Legendre in μo,
/// midpoint in the azimuth (folded to [0, π] by symmetry).
double hemispherical(const Photometry& p, double mu_i, int n_mu = 96, int n_phi = 720) {
    std::vector<double> x, a;
    gauss_legendre01(n_mu, x, a);
    const double si = std::sqrt(1 - mu_i * mu_i);
    double sum = 0.0;
    for (int k = 0; k < n_mu; ++k) {
        const double mo = x[k], so = std::sqrt(1 - mo * mo);
        double ring = 0.0;
        for (int j = 0; j < n_phi; ++j) {
            const double psi = kPi * (j + 0.5) / n_phi;
            ring += photometric_shape(p, mu_i, mo, mu_i * mo + si * so * std::cos(psi));
        }
        sum += a[k] * mo * ring * (2.0 * kPi / n_phi);
    }
    // shape = π·f/A_N (A_N = 1 for Lambert), so this is A_dh/A_N.
    return sum / kPi;
}

}  // namespace

TEST_CASE(phase_angle_within_2e_8_of_arccos) {
    double worst = 0.0;
    bool decreasing = true;
    double previous = 4.0;
    for (int i = -1000000; i <= 1000000; ++i) {
        const double c = i / 1e6;
        const double g = phase_angle(c);
        worst = std::max(worst, std::abs(g - std::acos(c)));
        decreasing = decreasing && g <= previous;
        previous = g;
    }
    CHECK(worst < 2.2e-8);
    CHECK(decreasing);
    CHECK(phase_angle(1.0) == 0.0 && phase_angle(-1.0) == kPi);
    CHECK(phase_angle(1.5) == 0.0 && phase_angle(-7.0) == kPi);  // clamped, as acos's argument was
    CHECK(std::isnan(phase_angle(std::nan(""))));
}

TEST_CASE(lambert_and_lunar_lambert_match_their_formulas) {
    Photometry lam;
    CHECK(photometric_shape(lam, 0.3, 0.7, 0.1) == 1.0);
    CHECK(photometric_shape(lam, 0.0, 0.7, 0.1) == 0.0);
    Photometry ll;
    ll.model = Photometry::Model::LunarLambert;
    ll.surge_amplitude = 1.8;
    ll.surge_width = 0.07;
    Rng rng{1};
    for (int n = 0; n < 1000; ++n) {
        const Geometry g = random_geometry(rng);
        const double deg = std::acos(std::clamp(g.cos_g, -1.0, 1.0)) * photometry_detail::kDegPerRad;
        const double l = std::exp(-deg / 60.0);
        const double c = std::clamp(g.cos_g, -1.0, 1.0);
        const double b = 1.0 + 1.8 / (1.0 + std::sqrt((1.0 - c) / (1.0 + c)) / 0.07);
        // The phase angle to 2.2e-8 rad and the exponential in single precision: 2e-7 relative.
        const double want = (2.0 * l / (g.mu_i + g.mu_o) + (1.0 - l)) * b;
        CHECK_NEAR(photometric_shape(ll, g.mu_i, g.mu_o, g.cos_g), want, 2e-7 * want);
    }
    CHECK_NEAR(photometric_shape(ll, 1.0, 1.0, 1.0), 2.8, 1e-15);
}

TEST_CASE(hapke_reciprocity) {
    // Bit-for-bit on 20 000 random geometries per parameter set, smooth and rough, with CBOE.
    const Photometry sets[] = {lunar_hapke(), lunar_hapke(0.32, 0.0), lunar_hapke(0.9, 45.0, 0.5),
                               lunar_hapke(0.6, 10.0, 0.1, 1.0, 0.5, -0.4, 0.5, 0.05), lunar_hapke(0.99, 60.0)};
    Rng rng{7};
    int mismatches = 0;
    for (const Photometry& p : sets)
        for (int n = 0; n < 20000; ++n) {
            const Geometry g = random_geometry(rng);
            const double a = photometric_shape(p, g.mu_i, g.mu_o, g.cos_g);
            const double b = photometric_shape(p, g.mu_o, g.mu_i, g.cos_g);
            mismatches += !(a == b);
            CHECK(std::isfinite(a) && a >= 0.0);
        }
    CHECK(mismatches == 0);
}

TEST_CASE(hapke_smooth_isotropic_closed_form) {
    // θ̄ = 0, no surges, b = 0 (isotropic p = 1 whatever c), φ = 0 (K = 1): Hapke's r reduces to
    // the Chandrasekhar-Hapke form r = w/(4π)·μ0/(μ0 + μ)·H(μ0)·H(μ) (Hapke 2002, IMSA).
    for (double w : {0.05, 0.32, 0.7, 0.99, 1.0}) {
        const Photometry p = lunar_hapke(w, 0.0, 0.0, 0.0, 0.0, 0.3);
        CHECK(p.hapke.K == 1.0 && p.hapke.chi == 1.0);
        Rng rng{11};
        for (int n = 0; n < 2000; ++n) {
            const Geometry g = random_geometry(rng);
            const double r = g.mu_i * hapke_brdf(p, g.mu_i, g.mu_o, g.cos_g);
            const double want = w / (4.0 * kPi) * g.mu_i / (g.mu_i + g.mu_o) * H_2002(w, g.mu_i) * H_2002(w, g.mu_o);
            CHECK_NEAR(r / want, 1.0, 1e-12);
        }
    }
}

TEST_CASE(h_function_against_chandrasekhar) {
    // The exact solver is itself checked: Chandrasekhar's moment identity ∫₀¹H dμ = (2/w)(1 − √(1 − w))
    // and his tabulated conservative value H(1) = 2.90781 (w = 1; Chandrasekhar 1960, ch. V tables).
    double worst = 0.0, worst_w = 0.0, worst_mu = 0.0;
    for (double w : {0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.99, 1.0}) {
        const ExactH exact(w);
        CHECK_NEAR(exact.moment0(), 2.0 / w * (1.0 - std::sqrt(1.0 - w)), 2e-6);
        if (w == 1.0) CHECK_NEAR(exact(1.0), 2.90781, 2e-5);
        std::printf("  w = %.2f: exact H(0.5) = %.5f, H(1) = %.5f; Hapke 2002: %.5f, %.5f\n", w, exact(0.5), exact(1.0),
                    hapke_H(w, 0.5), hapke_H(w, 1.0));
        for (int k = 1; k <= 100; ++k) {
            const double mu = k / 100.0;
            const double err = std::abs(hapke_H(w, mu) / exact(mu) - 1.0);
            if (err > worst) worst = err, worst_w = w, worst_mu = mu;
        }
    }
    std::printf("  worst relative error of Hapke 2002's H: %.4f %% (w = %.2f, mu = %.2f)\n", 100 * worst, worst_w,
                worst_mu);
    CHECK(worst < 0.01);  // Hapke 2002 states < 1 %
    CHECK(hapke_H(0.5, 0.0) == 1.0 && hapke_H(0.0, 0.7) == 1.0);
}

TEST_CASE(hapke_phase_function) {
    // Normalised: (1/4π)∫p dΩ = ½∫₋₁¹ p d(cos g) = 1 (Gauss-Legendre on each half).
    std::vector<double> x, a;
    gauss_legendre01(200, x, a);
    for (double b : {0.0, 0.24, 0.6}) {
        double s = 0.0;
        for (size_t k = 0; k < x.size(); ++k) s += a[k] * (hapke_phase(b, 0.3, x[k]) + hapke_phase(b, 0.3, -x[k]));
        CHECK_NEAR(0.5 * s, 1.0, 1e-9);
    }
    // c > 0: back-scattering (brighter at g = 0 than at g = 180°); b = 0 isotropic.
    CHECK(hapke_phase(0.24, 0.3, 1.0) > hapke_phase(0.24, 0.3, -1.0));
    CHECK(hapke_phase(0.0, 0.9, 0.3) == 1.0);
}

TEST_CASE(hapke_porosity_factor_values) {
    CHECK(hapke_porosity_factor(0.0) == 1.0);
    const double a = 1.209 * std::pow(0.3, 2.0 / 3.0);
    CHECK_NEAR(hapke_porosity_factor(0.3), -std::log(1.0 - a) / a, 1e-14);
    CHECK_NEAR(hapke_porosity_factor(0.3), 1.4404, 1e-4);
    CHECK(hapke_porosity_factor(1e-9) > 1.0 && hapke_porosity_factor(1e-9) < 1.0 + 1e-5);
    CHECK(std::isfinite(hapke_porosity_factor(0.75)));
}

TEST_CASE(hapke_roughness_limits) {
    Rng rng{3};
    // θ̄ = 0: S = 1 and the true cosines.
    for (int n = 0; n < 1000; ++n) {
        const Geometry g = random_geometry(rng);
        const HapkeRoughness r = hapke_roughness(0.0, 1.0, g.mu_i, g.mu_o, hapke_cos_psi(g.mu_i, g.mu_o, g.cos_g));
        CHECK(r.S == 1.0 && r.mu0e == g.mu_i && r.mue == g.mu_o);
    }
    // θ̄ > 0: μ0e, μe ≥ 0, S finite; S = 1 at i = e = 0.
    for (double deg : {5.0, 23.4, 45.0, 60.0}) {
        const double t = std::tan(deg * kDeg), chi = 1.0 / std::sqrt(1.0 + kPi * t * t);
        double smax = 0.0, worst[3] = {0, 0, 0};
        for (int n = 0; n < 20000; ++n) {
            const Geometry g = random_geometry(rng);
            const HapkeRoughness r = hapke_roughness(t, chi, g.mu_i, g.mu_o, hapke_cos_psi(g.mu_i, g.mu_o, g.cos_g));
            CHECK(std::isfinite(r.S) && r.S >= 0.0 && r.mu0e >= 0.0 && r.mue >= 0.0);
            if (r.S > smax) {
                smax = r.S;
                worst[0] = std::acos(g.mu_i) / kDeg, worst[1] = std::acos(g.mu_o) / kDeg;
                worst[2] = std::acos(hapke_cos_psi(g.mu_i, g.mu_o, g.cos_g)) / kDeg;
            }
        }
        std::printf(
            "  theta_bar = %4.1f deg: max S over 20000 geometries = %.6f at i = %.1f, e = %.1f, psi = %.1f deg\n", deg,
            smax, worst[0], worst[1], worst[2]);
        // Hapke's S is NOT bounded by 1: with e near grazing and ψ near π, μe/η(e) ≈
        // (1 − sin²(ψ/2)·E2(i))/(1 − (ψ/π)·E1(i)) > 1 because E1(i) ≫ E2(i) for moderate i. The
        // overshoot peaks at 1.0987 (0.5° grid over i, e, ψ at θ̄ = 5–60°: e = 90°, ψ = 180°).
        CHECK(smax <= 1.1);
        // At ψ = 0 (f = 1) the equations give S = 1 for i ≤ e and S = (1 + tan e·X)/(1 + tan i·X)
        // ≤ 1 for e < i, X = tan θ̄·E2(i)/(2 − E1(i)).
        for (int n = 0; n < 2000; ++n) {
            const double mi = std::max(rng.next(), 1e-6), mo = std::max(rng.next(), 1e-6);
            const double s0 = hapke_roughness(t, chi, mi, mo, 1.0).S;
            CHECK(s0 <= 1.0 + 1e-12);
            if (mi >= mo) CHECK_NEAR(s0, 1.0, 1e-12);
        }
        CHECK_NEAR(hapke_roughness(t, chi, 1.0, 1.0, 1.0).S, 1.0, 1e-15);
    }
}

TEST_CASE(hapke_finite_everywhere) {
    const Photometry sets[] = {lunar_hapke(), lunar_hapke(1.0, 60.0, 0.75, 10.0, 0.9, 1.0, 1.0, 0.01), lunar_hapke(0.0),
                               lunar_hapke(0.5, 0.0, 0.0, 0.0)};
    const double mus[] = {1e-300, 1e-12, 1e-6, 0.01, 0.5, 0.999999, 1.0, 1.0 + 1e-15};
    const double cgs[] = {-1.0, -1.0 + 1e-15, -0.5, 0.0, 0.5, 1.0 - 1e-15, 1.0, -2.0, 2.0};
    for (const Photometry& p : sets)
        for (double mi : mus)
            for (double mo : mus)
                for (double cg : cgs) {
                    const double s = photometric_shape(p, mi, mo, cg);
                    CHECK(std::isfinite(s) && s >= 0.0);
                }
    const Photometry p = lunar_hapke();
    for (double bad : {0.0, -0.5, std::nan("")}) {
        CHECK(photometric_shape(p, bad, 0.5, 0.2) == 0.0);
        CHECK(photometric_shape(p, 0.5, bad, 0.2) == 0.0);
    }
}

TEST_CASE(hapke_opposition_and_normalisation) {
    const Photometry p = lunar_hapke();
    CHECK_NEAR(opposition_surge(p, 1.0), 2.8, 1e-15);  // 1 + B_S0 at g = 0
    CHECK(hapke_cboe(0.05, 1.0) == 1.0 && hapke_cboe(0.05, -1.0) == 0.0);
    // At i = e = g = 0 the roughness gives μ0e = μe = χ and S = 1, so the normal albedo is
    // A_N = K·w/8·[p(0)·(1 + B_S0) + H(χ/K)² − 1]·(1 + B_C0).
    const Photometry::HapkeParams& h = p.hapke;
    const double hh = H_2002(h.w, h.chi / h.K);
    const double want = h.K * h.w / 8.0 * (hapke_phase(h.b, h.c, 1.0) * 2.8 + hh * hh - 1.0);
    CHECK_NEAR(h.normal_albedo, want, 1e-15);
    std::printf("  lunar set: K = %.4f, chi = %.4f, p(0) = %.4f, normal albedo A_N = %.4f\n", h.K, h.chi,
                hapke_phase(h.b, h.c, 1.0), h.normal_albedo);
    CHECK_NEAR(photometric_shape(p, 1.0, 1.0, 1.0), 1.0, 1e-15);
    // The surge part at g = 0 is exactly B_S0·p(0) on top of the no-surge model (same geometry).
    const Photometry q = lunar_hapke(0.32, 23.4, 0.3, 0.0);
    const HapkeRoughness r = hapke_roughness(h.tan_roughness, h.chi, 0.8, 0.8, 1.0);
    const double added = hapke_brdf(p, 0.8, 0.8, 1.0) - hapke_brdf(q, 0.8, 0.8, 1.0);
    CHECK_NEAR(added, h.K * h.w / (4 * kPi) * r.q * hapke_phase(h.b, h.c, 1.0) * 1.8, 1e-15);
    // CBOE multiplies by 1 + B_C0 at g = 0.
    const Photometry c = lunar_hapke(0.32, 23.4, 0.3, 1.8, 0.24, 0.3, 0.6, 0.05);
    CHECK_NEAR(hapke_brdf(c, 0.8, 0.8, 1.0) / hapke_brdf(p, 0.8, 0.8, 1.0), 1.6, 1e-14);
}

TEST_CASE(hapke_energy) {
    // Directional-hemispherical reflectance ≤ 1 for w ≤ 0.99 at several incidences.
    struct Case {
        const char* name;
        Photometry p;
    };
    const Case cases[] = {
        {"smooth isotropic K=1 w=0.99", lunar_hapke(0.99, 0.0, 0.0, 0.0, 0.0)},
        {"lunar b,c, theta 23.4, K=1.44, no SHOE, w=0.99", lunar_hapke(0.99, 23.4, 0.3, 0.0)},
        {"lunar set, w=0.99", lunar_hapke(0.99)},
        {"lunar set, w=0.32", lunar_hapke(0.32)},
    };
    for (const Case& c : cases) {
        std::printf("  %s: A_dh at i = 0, 30, 60, 80, 89 deg =", c.name);
        for (double i_deg : {0.0, 30.0, 60.0, 80.0, 89.0}) {
            const double a = hemispherical(c.p, std::cos(i_deg * kDeg)) * c.p.hapke.normal_albedo;
            std::printf(" %.4f", a);
            CHECK(a <= 1.0);
        }
        std::printf("\n");
    }
    // The quadrature itself: a white Lambertian surface gives 1.
    Photometry lam;
    CHECK_NEAR(hemispherical(lam, 0.6), 1.0, 1e-12);
}

TEST_CASE(phase_curves_report) {
    // No asserts: the lunar Hapke set against Lunar-Lambert (exp phase, same surge), normalised
    // to g = 0, in the mirror geometry i = e = g/2 (ψ = π) and with the camera at nadir (e = 0,
    // i = g), both on a flat surface.
    const Photometry h = lunar_hapke();
    Photometry ll;
    ll.model = Photometry::Model::LunarLambert;
    ll.surge_amplitude = 1.8;
    ll.surge_width = 0.07;
    std::printf(
        "  g[deg]   mirror i=e=g/2: Hapke  LunarLambert | nadir e=0, i=g: Hapke  LunarLambert  (radiance "
        "factor mu_i*shape, /g=0)\n");
    const double h0 = photometric_shape(h, 1, 1, 1), l0 = photometric_shape(ll, 1, 1, 1);
    for (double g : {0.0, 2.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0, 120.0}) {
        const double mi = std::cos(g / 2 * kDeg), cg = std::cos(g * kDeg);
        const double hm = mi * photometric_shape(h, mi, mi, cg) / h0, lm = mi * photometric_shape(ll, mi, mi, cg) / l0;
        double hn = 0, ln = 0;
        if (g < 90.0) {
            hn = cg * photometric_shape(h, cg, 1.0, cg) / h0;
            ln = cg * photometric_shape(ll, cg, 1.0, cg) / l0;
        }
        std::printf("  %6.1f   %21.4f %13.4f | %23.4f %13.4f\n", g, hm, lm, hn, ln);
    }
}

namespace {

/// The message validate() throws for `p`, or "" when it accepts it.
std::string rejection(const Photometry& p) {
    try {
        p.validate();
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

/// `p` with field `name` (a kPhotometryRanges name, in its units) set to `value`.
Photometry with_field(Photometry p, const std::string& name, double value) {
    if (name == "surge_amplitude") p.surge_amplitude = value;
    else if (name == "surge_width") p.surge_width = value;
    else if (name == "w") p.hapke.w = value;
    else if (name == "b") p.hapke.b = value;
    else if (name == "c") p.hapke.c = value;
    else if (name == "roughness_deg") p.hapke.roughness_rad = value * kRadPerDeg;
    else if (name == "filling_factor") p.hapke.filling_factor = value;
    else if (name == "cboe_amplitude") p.hapke.cboe_amplitude = value;
    else if (name == "cboe_width") p.hapke.cboe_width = value;
    else throw std::logic_error("no field " + name);
    return p;
}

}  // namespace

TEST_CASE(photometry_validate_checks_every_range_at_its_bounds) {
    CHECK(rejection(Photometry{}).empty());
    CHECK(rejection(lunar_hapke()).empty());
    for (const ParamRange& r : kPhotometryRanges) {
        const std::string prefix = std::string(r.field) + ": must be in ";
        for (Photometry::Model model : {Photometry::Model::Lambert, Photometry::Model::Hapke}) {
            Photometry base;
            base.model = model;  // the Hapke fields are checked whatever the model
            // A closed bound is accepted exactly (roughness too, through degrees → radians);
            // an open one, and anything beyond either, is refused with the field named.
            CHECK(rejection(with_field(base, r.field, r.lo)).empty() != r.lo_open);
            CHECK(rejection(with_field(base, r.field, r.hi)).empty() != r.hi_open);
            for (double bad : {r.lo - 1e-9, r.hi + 1e-9, std::nan("")}) {
                const std::string message = rejection(with_field(base, r.field, bad));
                CHECK(message.rfind(prefix, 0) == 0);
            }
        }
    }
    CHECK(rejection(with_field(Photometry{}, "w", 1.5)) == "w: must be in [0, 1], got 1.5");
    CHECK(rejection(with_field(Photometry{}, "b", 1.0)) == "b: must be in [0, 1), got 1");
    CHECK(rejection(with_field(Photometry{}, "cboe_width", 0.0)) == "cboe_width: must be in (0, 10], got 0");
}

TEST_CASE(validated_derives_hapke_fields_as_make_hapke_does) {
    Photometry p;
    p.model = Photometry::Model::Hapke;
    p.surge_amplitude = 1.8;
    const Photometry v = validated(p);
    const Photometry m = make_hapke(Photometry::HapkeParams{}, 1.8, 0.07);
    CHECK(v.hapke.K == m.hapke.K && v.hapke.chi == m.hapke.chi && v.hapke.normal_albedo == m.hapke.normal_albedo);
    CHECK(v.hapke.normal_albedo > 0.0);
    p.hapke.w = 2.0;
    CHECK_THROWS(std::invalid_argument, validated(p));
}
