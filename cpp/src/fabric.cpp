#include "moonbot/fabric.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

void require(bool ok, const char* field, const std::string& what) {
    if (!ok) throw std::invalid_argument(std::string(field) + ": " + what);
}

constexpr double kPi = 3.14159265358979323846;

}  // namespace

void FabricParams::validate() const {
    require(std::isfinite(pitch_m) && pitch_m > 0, "pitch_m", "must be a finite number > 0");
    require(std::isfinite(relief_m) && relief_m >= 0, "relief_m", "must be a finite number >= 0");
    require(std::isfinite(contrast) && contrast >= 0 && contrast <= 1, "contrast", "must be in [0, 1]");
    for (int c = 0; c < 3; ++c)
        require(std::isfinite(albedo[c]) && albedo[c] >= 0 && albedo[c] <= 1, "albedo",
                "every channel must be in [0, 1]");
    require(std::isfinite(sheen) && sheen >= 0 && sheen <= 1, "sheen", "must be in [0, 1]");
    require(std::isfinite(sheen_along) && sheen_along >= 0.01 && sheen_along <= 1, "sheen_along",
            "must be in [0.01, 1]");
    require(std::isfinite(sheen_across) && sheen_across >= 0.01 && sheen_across <= 1, "sheen_across",
            "must be in [0.01, 1]");
}

namespace {

/// Smith's Λ for the anisotropic GGX distribution (Heitz 2014 eq. 86 with the anisotropic
/// projected roughness), direction w in the local frame, w.z > 0.
double ggx_lambda(const glm::dvec3& w, double ax2, double ay2) {
    const double z2 = w.z * w.z;
    return 0.5 * (-1.0 + std::sqrt(1.0 + (ax2 * w.x * w.x + ay2 * w.y * w.y) / z2));
}

/// The tape lobe of roughness (ax2, ay2) = (αx², αy²) with its wo-only factors given: pi_alpha =
/// π·√(ax2·ay2), lambda_wo = Λ(wo), and h the unit half vector of (wi, wo); wi.z, wo.z > 0.
double tape_lobe_at(const glm::dvec3& wi, const glm::dvec3& wo, const glm::dvec3& h, double ax2, double ay2,
                    double pi_alpha, double lambda_wo) {
    const double e = h.x * h.x / ax2 + h.y * h.y / ay2 + h.z * h.z;
    const double d = 1.0 / (pi_alpha * e * e);
    const double g2 = 1.0 / (1.0 + ggx_lambda(wi, ax2, ay2) + lambda_wo);
    return d * g2 / (4.0 * wi.z * wo.z);
}

double tape_lobe2(const glm::dvec3& wi, const glm::dvec3& wo, double ax2, double ay2) {
    if (!(wi.z > 0.0 && wo.z > 0.0)) return 0.0;
    return tape_lobe_at(wi, wo, glm::normalize(wi + wo), ax2, ay2, kPi * std::sqrt(ax2 * ay2),
                        ggx_lambda(wo, ax2, ay2));
}

}  // namespace

double tape_lobe(const glm::dvec3& wi, const glm::dvec3& wo, double ax, double ay) {
    return tape_lobe2(wi, wo, ax * ax, ay * ay);
}

double cloth_sheen(const FabricParams& params, const FabricSample& sample, const glm::dvec3& wi, const glm::dvec3& wo) {
    return ClothSheen(params, sample, wo)(wi);
}

ClothSheen::ClothSheen(const FabricParams& params, const FabricSample& sample, const glm::dvec3& wo)
    : m_wo(wo), m_warp_share(sample.warp_share) {
    const double along2 = params.sheen_along * params.sheen_along, across2 = params.sheen_across * params.sheen_across;
    // α² = 2σ² relates a Beckmann lobe to its per-axis slope variance σ² (Walter et al. 2007); we
    // widen the GGX lobe by the same amount.
    const double wx = 2.0 * sample.lost_slope2_x, wy = 2.0 * sample.lost_slope2_y;
    const auto make = [&](double ax2, double ay2) {
        // Λ(wo) only where the lobe can be nonzero (wo above the surface), as tape_lobe2 reads it.
        return Lobe{ax2, ay2, kPi * std::sqrt(ax2 * ay2), wo.z > 0.0 ? ggx_lambda(wo, ax2, ay2) : 0.0};
    };
    m_warp = make(along2 + wx, across2 + wy);
    m_weft = make(across2 + wx, along2 + wy);
}

double ClothSheen::lobe(const Lobe& l, const glm::dvec3& wi, const glm::dvec3& h) const {
    return tape_lobe_at(wi, m_wo, h, l.ax2, l.ay2, l.pi_alpha, l.lambda_wo);
}

double ClothSheen::operator()(const glm::dvec3& wi) const {
    double warp = 0.0, weft = 0.0;
    if (wi.z > 0.0 && m_wo.z > 0.0) {
        const glm::dvec3 h = glm::normalize(wi + m_wo);
        warp = lobe(m_warp, wi, h);
        weft = lobe(m_weft, wi, h);
    }
    return m_warp_share * warp + (1.0 - m_warp_share) * weft;
}

double weave_height(double a, double b) {
    return 0.5 - 0.25 * (std::cos(2 * a) + std::cos(2 * b)) +
           0.125 * (std::sin(3 * a) * std::sin(b) - std::sin(a) * std::sin(3 * b));
}

FabricSample fabric_eval(const FabricParams& params, double x, double y, double footprint_m) {
    const double k = kPi / params.pitch_m;  // rad per metre: a = kx
    const double a = k * x, b = k * y;
    // One sin/cos per axis; the 2× and 3× angles by the multiple-angle formulas.
    const double sa = std::sin(a), ca = std::cos(a), sb = std::sin(b), cb = std::cos(b);
    const double s2a = 2 * sa * ca, c2a = 1 - 2 * sa * sa, s2b = 2 * sb * cb, c2b = 1 - 2 * sb * sb;
    const double s3a = sa * (3 - 4 * sa * sa), c3a = ca * (4 * ca * ca - 3);
    const double s3b = sb * (3 - 4 * sb * sb), c3b = cb * (4 * cb * cb - 3);

    // Gaussian prefilter of σ = footprint/2: a sinusoid of angular frequency m·k keeps
    // g_m = exp(−½(mkσ)²) = g1^(m²); the cross terms (3, 1) keep g3·g1 = g1^10.
    const double ks = k * 0.5 * footprint_m;
    const double g1 = std::exp(-0.5 * ks * ks);
    const double g1_2 = g1 * g1, g2 = g1_2 * g1_2, g31 = g2 * g2 * g1_2;

    const double h = 0.5 - 0.25 * g2 * (c2a + c2b) + 0.125 * g31 * (s3a * sb - sa * s3b);
    const double dh_da = 0.5 * g2 * s2a + 0.125 * g31 * (3 * c3a * sb - ca * s3b);
    const double dh_db = 0.5 * g2 * s2b + 0.125 * g31 * (s3a * cb - 3 * sa * c3b);

    FabricSample out;
    out.albedo = params.albedo * (1.0 + params.contrast * (2.0 * h - 1.0));
    // n ∝ (−∂z/∂x, −∂z/∂y, 1) for the surface z = relief·h(kx, ky).
    const double scale = params.relief_m * k;
    out.normal = glm::normalize(glm::dvec3(-scale * dh_da, -scale * dh_db, 1.0));
    if (params.sheen > 0.0) {
        // sin a·sin b is the (1, 1) harmonic: filtered by g1·g1.
        out.warp_share = 0.5 * (1.0 + g1_2 * sa * sb);
        // Over a period ⟨(∂h/∂a)²⟩ = ⅛g2² + (1/64)·(5/2)·g31² (the harmonics are orthogonal), the
        // same for b; unfiltered (g = 1) minus filtered is what the footprint hides.
        const double lost = scale * scale * (0.125 * (1.0 - g2 * g2) + 0.0390625 * (1.0 - g31 * g31));
        out.lost_slope2_x = out.lost_slope2_y = lost;
    }
    return out;
}

}  // namespace moonbot
