// Photometric functions: how bright a surface looks for given incidence, emission and phase
// angles. Regolith is not Lambertian: it is a dark, porous powder whose single scattering gives
// the Lommel-Seeliger law, and its shadow hiding brightens it sharply toward zero phase (the
// opposition surge). Numbers and sources: docs/physics.md.
//
// Every model here is a BRDF f = (albedo/π)·shape(μi, μo, g) in sr⁻¹, reciprocal (shape is
// symmetric in μi and μo and depends on the directions only through them and g), so the same
// function serves direct light and inter-reflection. Radiance under a distant source of
// irradiance E is L = E·f·μi.
//
// Hapke's full model (Model::Hapke) is the reference: the isotropic-multiple-scattering
// approximation (IMSA) of Hapke 2012 ("Theory of Reflectance and Emittance Spectroscopy",
// 2nd ed., ch. 12) with porosity K (Hapke 2008), shadow-hiding and coherent-backscatter
// opposition effects and Hapke's 1984 macroscopic roughness. It costs ~10 transcendental
// calls per evaluation (Lunar-Lambert: 2), so it is meant for validation renders; see
// hapke_brdf() for the equations and photometric_shape() for how it is normalised.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace moonbot {

/// The values a parameter may take: [lo, hi], either end open where said.
struct ParamRange {
    const char* field;
    double lo, hi;
    bool lo_open, hi_open;

    constexpr bool contains(double value) const {
        return (lo_open ? value > lo : value >= lo) && (hi_open ? value < hi : value <= hi);
    }
};

/// Photometry's ranges, checked by Photometry::validate() whatever the model, so a bad Hapke value
/// never waits silently for the day someone switches to Hapke. Units as Python sets them:
/// roughness_deg in degrees (stored as HapkeParams::roughness_rad).
inline constexpr ParamRange kPhotometryRanges[] = {
    {"surge_amplitude", 0.0, 10.0, false, false},
    {"surge_width", 0.0, 10.0, true, false},
    {"w", 0.0, 1.0, false, false},
    {"b", 0.0, 1.0, false, true},
    {"c", -1.0, 1.0, false, false},
    {"roughness_deg", 0.0, 60.0, false, false},
    {"filling_factor", 0.0, 0.75, false, false},
    {"cboe_amplitude", 0.0, 1.0, false, false},
    {"cboe_width", 0.0, 10.0, true, false},
};

/// Degrees to radians, the one factor by which roughness_deg becomes HapkeParams::roughness_rad
/// (validate() compares in radians with the same factor, so a value at a bound stays in range).
constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;

struct Photometry {
    enum class Model : uint8_t {
        Lambert,       ///< shape = 1
        LunarLambert,  ///< McEwen (1991): shape = [2L(g)/(μi + μo) + 1 − L(g)]·B(g)
        Hapke,         ///< Hapke 2012 IMSA + K + SHOE + CBOE + roughness: shape = π·f_Hapke / A_N
    };
    /// The Lunar-Lambert phase weight L(g): how much of the Lommel-Seeliger law is mixed in.
    enum class Phase : uint8_t {
        Exponential,  ///< L(g) = exp(−g/60°): positive at every phase (docs/physics.md)
        McEwen,       ///< McEwen's cubic in g (degrees), clamped to [0, 1] (it turns negative past ~105°)
    };
    Model model = Model::Lambert;
    Phase phase = Phase::Exponential;
    /// Shadow-hiding opposition surge B(g) = 1 + B0 / (1 + tan(g/2)/h) (Hapke's SHOE form;
    /// B0 = 1.8, h = 0.07 for the Moon per Sato et al. 2014). B0 = 0 turns it off. Hapke's
    /// model uses the same pair as its B_S0 and h_S.
    double surge_amplitude = 0.0;
    double surge_width = 0.07;

    /// Hapke's parameters (read only when model == Hapke). Build them with make_hapke(): the
    /// last four fields are derived from the others and must stay consistent with them.
    struct HapkeParams {
        double w = 0.32;  ///< single-scattering albedo of a grain, [0, 1]
        /// Double Henyey-Greenstein phase function p(g) (see hapke_phase()): b ∈ [0, 1) is the
        /// lobe width, c ∈ [−1, 1] the weight; c > 0 favours BACK-scattering (toward g = 0),
        /// the convention of Hapke 2012 and Sato et al. 2014 (Moon: b = 0.24, c = 0.30).
        double b = 0.24;
        double c = 0.30;
        double cboe_amplitude = 0.0;  ///< coherent-backscatter surge B_C0, [0, 1] (Sato 2014 set: 0)
        double cboe_width = 1.0;      ///< coherent-backscatter width h_C, > 0
        double filling_factor = 0.3;  ///< φ = 1 − porosity, [0, 0.75]; 0 means K = 1 (no porosity term)
        double roughness_rad = 0.408407044966673;  ///< mean slope θ̄, radians (23.4°), [0, 60°]
        // Derived by make_hapke():
        double K = 1.0;              ///< porosity factor K(φ) (hapke_porosity_factor)
        double tan_roughness = 0.0;  ///< tan θ̄
        double chi = 1.0;            ///< χ(θ̄) = 1/√(1 + π tan²θ̄)
        double normal_albedo = 0.0;  ///< A_N = π·f_Hapke(i = e = g = 0): the normaliser of shape
    } hapke;

    /// Throws std::invalid_argument naming the first field outside its kPhotometryRanges range
    /// ("w: must be in [0, 1], got 1.2"). Checks the Hapke fields whatever the model.
    void validate() const;
};

namespace photometry_detail {
constexpr double kDegPerRad = 57.295779513082320877;
}

/// The phase angle g (radians, [0, π]) whose cosine is `cos_g` (clamped to [−1, 1]): arccos by
/// Abramowitz & Stegun's 4.4.46 (Hastings), √(1 − x)·P7(x) on [0, 1] and π minus it for x < 0,
/// within 2.2e-8 rad of the exact angle (test_photometry.cpp), inline: libm's acos was 3 % of the
/// render stage at default quality (profiled), and Lunar-Lambert evaluates it at every path vertex.
inline double phase_angle(double cos_g) {
    const double x = std::abs(std::clamp(cos_g, -1.0, 1.0));
    const double p = 1.5707963050 +
                     x * (-0.2145988016 +
                          x * (0.0889789874 +
                               x * (-0.0501743046 +
                                    x * (0.0308918810 + x * (-0.0170881256 + x * (0.0066700901 - x * 0.0012624911))))));
    const double angle = std::sqrt(1.0 - x) * p;
    return cos_g < 0.0 ? 3.14159265358979323846 - angle : angle;
}

/// The Lunar-Lambert phase weight L(g) for cos g (the cosine of the phase angle: between the
/// directions to the light and to the viewer). The exponential is taken in single precision
/// (relative error near 1e-7, against the model's percent-level fit to the Moon): expf costs half
/// of exp.
inline double lunar_lambert_phase(Photometry::Phase phase, double cos_g) {
    const double g_deg = phase_angle(cos_g) * photometry_detail::kDegPerRad;
    if (phase == Photometry::Phase::Exponential) return std::exp(static_cast<float>(g_deg * (-1.0 / 60.0)));
    // McEwen's polynomial (ISIS3 LunarLambertMcEwen; g in degrees).
    const double l = 1.0 + g_deg * (-0.019 + g_deg * (2.42e-4 - g_deg * 1.46e-6));
    return std::clamp(l, 0.0, 1.0);
}

/// The opposition surge factor B(g) ≥ 1 for cos g; 1 when the surge is off.
inline double opposition_surge(const Photometry& p, double cos_g) {
    if (p.surge_amplitude == 0.0) return 1.0;
    // tan(g/2) = √((1 − cos g)/(1 + cos g)); at g = 180° the surge term is 0.
    const double c = std::clamp(cos_g, -1.0, 1.0);
    if (c <= -1.0) return 1.0;
    const double tan_half = std::sqrt((1.0 - c) / (1.0 + c));
    return 1.0 + p.surge_amplitude / (1.0 + tan_half / p.surge_width);
}

// ---------------------------------------------------------------------------------------------
// Hapke's model. Notation (Hapke 2012): i, e incidence and emission angles, μ0 = cos i,
// μ = cos e, g the phase angle, ψ the azimuth between the planes of incidence and emission
// (ψ = 0: Sun and viewer on the same side, g = |i − e|; ψ = π: opposite sides, g = i + e).
// Written from the published equations; sources per function. Equation numbers are given only
// where cited widely (Hapke 2002 eq. 13); the rest are cited by paper and, for the 2012 book,
// by chapter — not checked against the texts while writing this.

/// Chandrasekhar's H-function for isotropic scatterers of single-scattering albedo w, in
/// Hapke's 2002 approximation (Hapke 2002, Icarus 157:523, eq. 13; restated in Hapke 2012):
///   H(x) ≈ 1 / (1 − w·x·[r0 + (1 − 2·r0·x)/2 · ln((1 + x)/x)]),
///   r0 = (1 − γ)/(1 + γ), γ = √(1 − w)  (r0: the diffusive reflectance).
/// Hapke states a relative error below 1 %; cpp/tests/test_photometry.cpp finds at most 0.97 %
/// (w = 0.99, x = 1) against a numerical solution of Chandrasekhar's integral equation. x ≤ 0 gives 1 (the
/// limit: x·ln(1/x) → 0). Finite for w ∈ [0, 1], x ≥ 0.
inline double hapke_H(double w, double x) {
    if (!(x > 0.0)) return 1.0;
    const double gamma = std::sqrt(std::max(0.0, 1.0 - w));
    const double r0 = (1.0 - gamma) / (1.0 + gamma);
    // log1p(1/x) = ln((1 + x)/x), accurate for large x too.
    return 1.0 / (1.0 - w * x * (r0 + 0.5 * (1.0 - 2.0 * r0 * x) * std::log1p(1.0 / x)));
}

/// The double Henyey-Greenstein single-particle phase function p(g) for cos g (the two-parameter
/// form of Hapke 2012 fitted by Sato et al. 2014):
///   p(g) = (1 + c)/2 · (1 − b²)/(1 − 2b·cos g + b²)^{3/2} + (1 − c)/2 · (1 − b²)/(1 + 2b·cos g + b²)^{3/2}.
/// The first lobe peaks at g = 0 (light going back toward the source), so c > 0 means
/// back-scattering. Normalised: (1/4π)∫p dΩ = 1. b = 0 (or the b → 0 limit) is isotropic, p = 1,
/// whatever c is.
inline double hapke_phase(double b, double c, double cos_g) {
    const double cg = std::clamp(cos_g, -1.0, 1.0);
    const double one_b2 = 1.0 - b * b;
    const double back = one_b2 / std::pow(1.0 - 2.0 * b * cg + b * b, 1.5);
    const double forward = one_b2 / std::pow(1.0 + 2.0 * b * cg + b * b, 1.5);
    return 0.5 * (1.0 + c) * back + 0.5 * (1.0 - c) * forward;
}

/// The coherent-backscatter opposition function B_C(g) ∈ [0, 1], B_C(0) = 1 (Hapke 2002; Hapke
/// 2012): with y = tan(g/2)/h_C,
///   B_C = [1 + (1 − e^{−y})/y] / [2·(1 + y)²].
inline double hapke_cboe(double width, double cos_g) {
    const double c = std::clamp(cos_g, -1.0, 1.0);
    if (c <= -1.0) return 0.0;  // g = 180°: y = ∞
    const double y = std::sqrt((1.0 - c) / (1.0 + c)) / width;
    // (1 − e^{−y})/y = −expm1(−y)/y → 1 as y → 0 (no cancellation near opposition).
    const double ratio = y > 0.0 ? -std::expm1(-y) / y : 1.0;
    return (1.0 + ratio) / (2.0 * (1.0 + y) * (1.0 + y));
}

/// Hapke's porosity factor K(φ) for filling factor φ = 1 − porosity (Hapke 2008, Icarus
/// 195:918; Hapke 2012): K = −ln(1 − 1.209·φ^{2/3}) / (1.209·φ^{2/3}). K(0) = 1 (the
/// limit), K(0.3) ≈ 1.440, K grows without bound as φ → 1.209^{−3/2} ≈ 0.752.
inline double hapke_porosity_factor(double filling_factor) {
    if (!(filling_factor > 0.0)) return 1.0;
    const double a = 1.209 * std::pow(filling_factor, 2.0 / 3.0);
    return -std::log1p(-a) / a;
}

/// Hapke's 1984 macroscopic-roughness correction (Icarus 59:41; restated in Hapke 2012 ch. 12)
/// for a surface whose facet slopes have mean θ̄: the effective cosines μ0e, μe seen by the
/// smooth-surface model and the shadowing function S(i, e, ψ).
struct HapkeRoughness {
    double mu0e;  ///< effective cos i
    double mue;   ///< effective cos e
    /// Shadowing function: 1 for θ̄ = 0 or i = e = 0, ≤ 1 at ψ = 0 and ψ = π. In between the
    /// published equations let it exceed 1 slightly (up to ~1.09 found numerically, at small ψ
    /// with one direction near grazing): μe/η(e) > 1 there.
    double S;
    /// S/(μ0·μe)·μ0e·μe/(μ0e + μe) rearranged so the BRDF needs no division by μ0: the factor
    /// that replaces 1/(μ0 + μ) of the smooth model, i.e. f = K·w/(4π)·q·[…]. Symmetric in i, e.
    double q;
};

/// The roughness correction for cos i = mu_i, cos e = mu_o (both in (0, 1]) and cos ψ, with
/// tan θ̄ and χ(θ̄) = 1/√(1 + π·tan²θ̄) precomputed. Equations (Hapke 2012 ch. 12, from Hapke
/// 1984), with E1(x) = exp(−(2/π)·cot θ̄·cot x), E2(x) = exp(−(1/π)·cot²θ̄·cot²x),
/// η(x) = χ·[cos x + sin x·tan θ̄·E2(x)/(2 − E1(x))], f(ψ) = exp(−2·tan(ψ/2)) and, for i ≤ e
/// (swap the roles of i and e — and of μ0e and μe — for e < i):
///   μ0e = χ·[cos i + sin i·tan θ̄·(cos ψ·E2(e) + sin²(ψ/2)·E2(i)) / (2 − E1(e) − (ψ/π)·E1(i))]
///   μe  = χ·[cos e + sin e·tan θ̄·(E2(e) − sin²(ψ/2)·E2(i))       / (2 − E1(e) − (ψ/π)·E1(i))]
///   S   = μe/η(e) · μ0/η(i) · χ / (1 − f(ψ) + f(ψ)·χ·μ0/η(i)),
/// where in the last line μe is the effective cosine and μ0 the true one, and μ0/η(i) belongs
/// to the SMALLER of the two angles (for e < i it is μ/η(e)).
/// Reciprocity: swapping i and e swaps μ0e and μe and leaves η(i)·η(e) and the smaller angle's
/// term alone, so S/μ0·μ0e/(μ0e + μe) — the part of the BRDF that roughness changes — is
/// symmetric: Hapke's rough model is reciprocal, and q is computed so that it is bit-for-bit.
inline HapkeRoughness hapke_roughness(double tan_tb, double chi, double mu_i, double mu_o, double cos_psi) {
    constexpr double kPi = 3.14159265358979323846;
    if (tan_tb == 0.0) return {mu_i, mu_o, 1.0, 1.0 / (mu_i + mu_o)};  // smooth: the model unchanged
    const double cot_tb = 1.0 / tan_tb;
    // s: the smaller angle (larger cosine), l: the larger. Ties take either branch: both give
    // the same numbers when i = e (cos ψ + sin²(ψ/2) = 1 − sin²(ψ/2)).
    const bool i_small = mu_i >= mu_o;
    const double mu_s = i_small ? mu_i : mu_o, mu_l = i_small ? mu_o : mu_i;
    const double sin_s = std::sqrt(std::max(0.0, 1.0 - mu_s * mu_s));
    const double sin_l = std::sqrt(std::max(0.0, 1.0 - mu_l * mu_l));
    // cot x = cos x / sin x; at x = 0 (sin x = 0) E1 = E2 = 0 (the limit cot x → ∞).
    auto e1 = [&](double mu, double sn) { return sn > 0.0 ? std::exp(-2.0 / kPi * cot_tb * mu / sn) : 0.0; };
    auto e2 = [&](double mu, double sn) {
        if (!(sn > 0.0)) return 0.0;
        const double t = cot_tb * mu / sn;
        return std::exp(-t * t / kPi);
    };
    const double e1s = e1(mu_s, sin_s), e1l = e1(mu_l, sin_l);
    const double e2s = e2(mu_s, sin_s), e2l = e2(mu_l, sin_l);
    const double cp = std::clamp(cos_psi, -1.0, 1.0);
    const double psi = std::acos(cp);
    const double sin2_half = 0.5 * (1.0 - cp);  // sin²(ψ/2)
    // f(ψ) = exp(−2 tan(ψ/2)), tan(ψ/2) = √((1 − cos ψ)/(1 + cos ψ)); 0 at ψ = π.
    const double f_psi = cp <= -1.0 ? 0.0 : std::exp(-2.0 * std::sqrt((1.0 - cp) / (1.0 + cp)));
    // The denominator is > 0 unless both directions graze and ψ = π (then E1 → 1 for both);
    // the floor keeps the result finite there.
    const double den = std::max(2.0 - e1l - psi / kPi * e1s, 1e-300);
    double mu_se = chi * (mu_s + sin_s * tan_tb * (cp * e2l + sin2_half * e2s) / den);
    double mu_le = chi * (mu_l + sin_l * tan_tb * (e2l - sin2_half * e2s) / den);
    // μ_se can dip below 0 for grazing, back-lit geometries at large θ̄ (cos ψ < 0 makes its
    // correction negative): no facet is then both lit and seen, so treat it as 0.
    mu_se = std::max(mu_se, 0.0);
    mu_le = std::max(mu_le, 0.0);
    const double eta_s = chi * (mu_s + sin_s * tan_tb * e2s / (2.0 - e1s));
    const double eta_l = chi * (mu_l + sin_l * tan_tb * e2l / (2.0 - e1l));
    const double shadow = chi / (1.0 - f_psi + f_psi * chi * mu_s / eta_s);
    HapkeRoughness r;
    r.mu0e = i_small ? mu_se : mu_le;
    r.mue = i_small ? mu_le : mu_se;
    // S = μe_eff/η(e)·μ0/η(i)·shadow, with (e, i) the true roles.
    r.S = (i_small ? mu_le * mu_i : mu_se * mu_i) / (eta_s * eta_l) * shadow;
    const double sum = mu_se + mu_le;
    // q = μ0e·μe/(μ0e + μe) · χ/(η(i)·η(e)·(1 − f + f·χ·μs/ηs)) — written in s/l order so
    // swapping i and e gives the identical floating-point operations.
    r.q = sum > 0.0 ? (mu_se * mu_le / sum) * shadow / (eta_s * eta_l) : 0.0;
    return r;
}

/// cos ψ from μ0, μ and cos g, inverting cos g = μ0·μ + sin i·sin e·cos ψ (the spherical law of
/// cosines), clamped to [−1, 1] against rounding. When i or e is 0 the azimuth is undefined and
/// irrelevant (every term that uses it is multiplied by sin of that angle or by E(0) = 0):
/// 1 is returned.
inline double hapke_cos_psi(double mu_i, double mu_o, double cos_g) {
    const double sin_prod = std::sqrt(std::max(0.0, 1.0 - mu_i * mu_i) * std::max(0.0, 1.0 - mu_o * mu_o));
    if (!(sin_prod > 1e-300)) return 1.0;
    return std::clamp((cos_g - mu_i * mu_o) / sin_prod, -1.0, 1.0);
}

/// Hapke's BRDF f = r/μ0 in sr⁻¹ (r: Hapke's bidirectional reflectance, radiance over
/// collimated irradiance) for cosines μi = cos i, μo = cos e and cos g; 0 unless μi, μo > 0.
/// The form is Hapke 2012's IMSA model with porosity, both opposition effects and roughness
/// (Hapke 2012 ch. 12, the full expression; with K = 1 it is Hapke 2002's model with the
/// isotropic multiple-scattering term M = H·H − 1):
///   r(i, e, g) = K·(w/4π)·μ0e/(μ0e + μe)·[p(g)·(1 + B_S0·B_S(g)) + H(μ0e/K)·H(μe/K) − 1]
///                ·[1 + B_C0·B_C(g)]·S(i, e, g),
/// B_S(g) = 1/(1 + tan(g/2)/h_S) (SHOE, opposition_surge()), H = hapke_H, p = hapke_phase,
/// B_C = hapke_cboe, S, μ0e, μe = hapke_roughness. With θ̄ = 0 (χ = 1, S = 1, μ0e = μ0):
///   f = K·w/(4π)/(μ0 + μ)·[…]·[…].
inline double hapke_brdf(const Photometry& p, double mu_i, double mu_o, double cos_g) {
    constexpr double kInv4Pi = 0.0795774715459476678844;  // 1/(4π)
    if (!(mu_i > 0.0 && mu_o > 0.0)) return 0.0;
    const Photometry::HapkeParams& h = p.hapke;
    const double mi = std::min(mu_i, 1.0), mo = std::min(mu_o, 1.0);
    const HapkeRoughness rough = hapke_roughness(h.tan_roughness, h.chi, mi, mo, hapke_cos_psi(mi, mo, cos_g));
    const double single = hapke_phase(h.b, h.c, cos_g) * opposition_surge(p, cos_g);
    const double multiple = hapke_H(h.w, rough.mu0e / h.K) * hapke_H(h.w, rough.mue / h.K) - 1.0;
    const double cboe = h.cboe_amplitude == 0.0 ? 1.0 : 1.0 + h.cboe_amplitude * hapke_cboe(h.cboe_width, cos_g);
    return h.K * h.w * kInv4Pi * rough.q * (single + multiple) * cboe;
}

/// A Hapke Photometry with its derived fields set. Angles in radians; ranges as documented on
/// Photometry::HapkeParams (checked by Photometry::validate(), not here). The SHOE pair is the
/// Photometry's surge_amplitude (B_S0) and surge_width (h_S).
inline Photometry make_hapke(Photometry::HapkeParams h, double shoe_amplitude, double shoe_width) {
    Photometry p;
    p.model = Photometry::Model::Hapke;
    p.surge_amplitude = shoe_amplitude;
    p.surge_width = shoe_width;
    h.K = hapke_porosity_factor(h.filling_factor);
    h.tan_roughness = std::tan(h.roughness_rad);
    h.chi = 1.0 / std::sqrt(1.0 + 3.14159265358979323846 * h.tan_roughness * h.tan_roughness);
    p.hapke = h;
    // Normal albedo: the radiance factor π·r/μ0 at i = e = g = 0, where S = 1 and μ0e = μe = χ.
    p.hapke.normal_albedo = 3.14159265358979323846 * hapke_brdf(p, 1.0, 1.0, 1.0);
    return p;
}

/// `p` validated (Photometry::validate()) and, for Hapke, with its derived fields computed from the
/// others (make_hapke): what a Material holds.
inline Photometry validated(const Photometry& p) {
    p.validate();
    return p.model == Photometry::Model::Hapke ? make_hapke(p.hapke, p.surge_amplitude, p.surge_width) : p;
}

/// What Lunar-Lambert's shape takes from the phase angle alone: L(g) and the surge B(g), for one
/// cos g. Several (μi, μo) pairs at the same g (the slopes of one footprint) then share them.
/// Unset (and unused) for the other models.
struct PhaseTerms {
    double lunar_lambert = 0.0;  // L(g)
    double surge = 1.0;          // B(g)
};

/// The PhaseTerms of `p` at cos g.
inline PhaseTerms phase_terms(const Photometry& p, double cos_g) {
    if (p.model != Photometry::Model::LunarLambert) return {};
    return {lunar_lambert_phase(p.phase, cos_g), opposition_surge(p, cos_g)};
}

/// photometric_shape(p, μi, μo, cos g) (below) with Lunar-Lambert's phase terms given (`terms`, from
/// phase_terms(p, cos g)): the same number, to the bit.
inline double photometric_shape(const Photometry& p, const PhaseTerms& terms, double mu_i, double mu_o, double cos_g) {
    if (!(mu_i > 0.0 && mu_o > 0.0)) return 0.0;
    if (p.model == Photometry::Model::Lambert) return 1.0;
    if (p.model == Photometry::Model::Hapke) {
        constexpr double kPi = 3.14159265358979323846;
        if (!(p.hapke.normal_albedo > 0.0)) return 0.0;  // w = 0: a black surface
        return kPi * hapke_brdf(p, mu_i, mu_o, cos_g) / p.hapke.normal_albedo;
    }
    const double l = terms.lunar_lambert;
    return (2.0 * l / (mu_i + mu_o) + (1.0 - l)) * terms.surge;
}

/// shape(μi, μo, g): the BRDF divided by albedo/π, for cosines of incidence μi and emission μo
/// (both > 0; 0 is returned otherwise) and cos g. Dimensionless, ≥ 0.
///
/// Hapke: shape = π·f_Hapke(μi, μo, g) / A_N with A_N = π·f_Hapke(1, 1, 1), Hapke's normal
/// albedo for these parameters (surges included). So shape(1, 1, 1) = 1 and `albedo` keeps
/// meaning the normal albedo, as for Lunar-Lambert after dividing by shape(1, 1, 1) = 1 + B0:
/// Hapke's w, b, c, … fix the angular shape, `albedo` the brightness (and colour). A_N itself
/// (0.266 for the Sato et al. 2014 lunar set) is in p.hapke.normal_albedo.
inline double photometric_shape(const Photometry& p, double mu_i, double mu_o, double cos_g) {
    if (!(mu_i > 0.0 && mu_o > 0.0)) return 0.0;
    return photometric_shape(p, phase_terms(p, cos_g), mu_i, mu_o, cos_g);
}

}  // namespace moonbot
