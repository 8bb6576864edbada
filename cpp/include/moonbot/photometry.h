// Photometric functions: how bright a surface looks for given incidence, emission and phase
// angles. Regolith is not Lambertian: it is a dark, porous powder whose single scattering gives
// the Lommel-Seeliger law, and its shadow hiding brightens it sharply toward zero phase (the
// opposition surge). Numbers and sources: ../shared/reference/lunar-physics.md §1.
//
// Every model here is a BRDF f = (albedo/π)·shape(μi, μo, g) in sr⁻¹, reciprocal (shape is
// symmetric in μi and μo and depends on the directions only through them and g), so the same
// function serves direct light and inter-reflection. Radiance under a distant source of
// irradiance E is L = E·f·μi.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace moonbot {

struct Photometry {
    enum class Model : uint8_t {
        Lambert,       ///< shape = 1
        LunarLambert,  ///< McEwen (1991): shape = [2L(g)/(μi + μo) + 1 − L(g)]·B(g)
    };
    /// The Lunar-Lambert phase weight L(g): how much of the Lommel-Seeliger law is mixed in.
    enum class Phase : uint8_t {
        Exponential,  ///< L(g) = exp(−g/60°): positive at every phase (lunar-physics.md §1.4)
        McEwen,       ///< McEwen's cubic in g (degrees), clamped to [0, 1] (it turns negative past ~105°)
    };
    Model model = Model::Lambert;
    Phase phase = Phase::Exponential;
    /// Shadow-hiding opposition surge B(g) = 1 + B0 / (1 + tan(g/2)/h) (Hapke's SHOE form;
    /// B0 = 1.8, h = 0.07 for the Moon per Sato et al. 2014). B0 = 0 turns it off.
    double surge_amplitude = 0.0;
    double surge_width = 0.07;
};

namespace photometry_detail {
constexpr double kDegPerRad = 57.295779513082320877;
}

/// The Lunar-Lambert phase weight L(g) for cos g (the cosine of the phase angle: between the
/// directions to the light and to the viewer).
inline double lunar_lambert_phase(Photometry::Phase phase, double cos_g) {
    const double g_deg = std::acos(std::clamp(cos_g, -1.0, 1.0)) * photometry_detail::kDegPerRad;
    if (phase == Photometry::Phase::Exponential) return std::exp(-g_deg / 60.0);
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

/// shape(μi, μo, g): the BRDF divided by albedo/π, for cosines of incidence μi and emission μo
/// (both > 0; 0 is returned otherwise) and cos g. Dimensionless, ≥ 0.
inline double photometric_shape(const Photometry& p, double mu_i, double mu_o, double cos_g) {
    if (!(mu_i > 0.0 && mu_o > 0.0)) return 0.0;
    if (p.model == Photometry::Model::Lambert) return 1.0;
    const double l = lunar_lambert_phase(p.phase, cos_g);
    return (2.0 * l / (mu_i + mu_o) + (1.0 - l)) * opposition_surge(p, cos_g);
}

}  // namespace moonbot
