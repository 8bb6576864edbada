#include "moonbot/regolith_texture.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "moonbot/rng.h"
#include "moonbot/subgrid_relief.h"

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
// An octave whose Gaussian gain falls below this is dropped; weights are rescaled so they stay
// continuous in the footprint (see the header).
constexpr double kGainCut = 0.01;
constexpr int kMaxOctaves = 16;
// Odd multipliers spreading the three lattice coordinates over the 64-bit key before the mixer
// (the first is SplitMix's golden-ratio increment; the others any large odd constants).
constexpr uint64_t kSpreadX = 0x9E3779B97F4A7C15ull, kSpreadY = 0xC2B2AE3D27D4EB4Full, kSpreadZ = 0x165667B19E3779F9ull;
constexpr uint64_t kGrainDomain = 0x67726169'6E2D7265ull;  // separates these lattices from other uses of a seed

void require(bool ok, const char* field, const std::string& what) {
    if (!ok) throw std::invalid_argument(std::string("grain.") + field + ": " + what);
}

int octave_count(const GrainParams& p) {
    int n = 0;
    for (double c = p.finest_cell_m; c <= p.coarsest_cell_m * (1.0 + 1e-9) && n <= kMaxOctaves; c *= 2.0) ++n;
    return n;
}

/// A uniform value on [−1, 1] from 24 bits: the bit patterns' midpoints, a set symmetric about 0.
inline double signed_unit(uint32_t bits) { return (static_cast<double>(bits >> 8) + 0.5) * (1.0 / 8388608.0) - 1.0; }

/// A rotation by `angle` radians about the unit `axis` (Rodrigues).
glm::dmat3 rotation(const glm::dvec3& axis, double angle) {
    const double c = std::cos(angle), s = std::sin(angle), t = 1.0 - c;
    const double x = axis.x, y = axis.y, z = axis.z;
    // glm is column-major: m[column][row].
    glm::dmat3 m;
    m[0] = {t * x * x + c, t * x * y + s * z, t * x * z - s * y};
    m[1] = {t * x * y - s * z, t * y * y + c, t * y * z + s * x};
    m[2] = {t * x * z + s * y, t * y * z - s * x, t * z * z + c};
    return m;
}

}  // namespace

void GrainParams::validate() const {
    require(std::isfinite(albedo_rms) && albedo_rms >= 0.0 && albedo_rms <= 0.5, "albedo_rms", "must be in [0, 0.5]");
    require(std::isfinite(slope_rms_deg) && slope_rms_deg >= 0.0 && slope_rms_deg <= 45.0, "slope_rms_deg",
            "must be in [0, 45] degrees");
    require(std::isfinite(finest_cell_m) && finest_cell_m > 0.0, "finest_cell_m", "must be a finite number > 0");
    require(std::isfinite(coarsest_cell_m) && coarsest_cell_m >= finest_cell_m && coarsest_cell_m <= 1.0,
            "coarsest_cell_m", "must be in [finest_cell_m, 1] metres");
    require(std::isfinite(hurst) && hurst >= 0.0 && hurst <= 1.0, "hurst", "must be in [0, 1]");
    const int n = octave_count(*this);
    require(n <= kMaxOctaves, "coarsest_cell_m",
            "at most " + std::to_string(kMaxOctaves) + " octaves (coarsest/finest <= 2^15)");
    // Value noise is bounded by 1, so the factor stays positive iff A·n < 1.
    const double bound = albedo_rms * std::sqrt(n / kValueNoiseVariance);
    require(bound < 1.0, "albedo_rms",
            "too large for " + std::to_string(n) + " octaves: the albedo factor could reach " +
                std::to_string(1.0 - bound) + " (needs albedo_rms < " +
                std::to_string(std::sqrt(kValueNoiseVariance / n)) + ")");
}

RegolithGrain::RegolithGrain(const GrainParams& params, std::shared_ptr<const SubgridRelief> subgrid)
    : m_params(params), m_subgrid(std::move(subgrid)) {
    params.validate();
    if (m_subgrid) m_flat_footprint = std::numeric_limits<double>::infinity();
    if (!params.enabled()) return;  // m_grain_flat_footprint 0: no grain octave is read
    const int n = octave_count(params);
    const double albedo_amplitude = params.albedo_rms / std::sqrt(n * kValueNoiseVariance);
    // Σ_k (c_k^H / c_k)²: each octave's slope variance per unit S², before kValueNoiseSlopeVariance.
    double slope_sum = 0.0;
    for (int k = 0; k < n; ++k)
        slope_sum += std::pow(params.finest_cell_m * std::ldexp(1.0, k), 2.0 * params.hurst - 2.0);
    const double height_scale =
        std::tan(params.slope_rms_deg * kPi / 180.0) / std::sqrt(kValueNoiseSlopeVariance * slope_sum);
    const uint64_t base = mix64(params.seed ^ kGrainDomain);
    for (int k = 0; k < n; ++k) {
        Octave o;
        o.cell = params.finest_cell_m * std::ldexp(1.0, k);
        // Fixed, arbitrary rotations, a different one per octave: only their differing matters
        // (aligned lattices would stack their grid lines).
        const double phi = 2.39996 * (k + 1);  // the golden angle spreads the axes
        const glm::dvec3 axis = glm::normalize(glm::dvec3(std::cos(phi), std::sin(phi), 0.7 - 0.1 * k));
        o.rotation = rotation(axis, 0.9 + 1.3 * k) * (1.0 / o.cell);
        o.to_world = glm::transpose(o.rotation);
        o.albedo_amplitude = albedo_amplitude;
        o.height_amplitude = height_scale * std::pow(o.cell, params.hurst);
        o.slope_variance = kValueNoiseSlopeVariance * (o.height_amplitude / o.cell) * (o.height_amplitude / o.cell);
        o.key = mix64(base + static_cast<uint64_t>(k));
        m_octaves.push_back(o);
    }
    m_grain_flat_footprint = m_octaves.back().cell * (2.0 / kPi) * std::sqrt(-2.0 * std::log(kGainCut));
    if (!m_subgrid) m_flat_footprint = m_grain_flat_footprint;
}

GrainSample RegolithGrain::eval(const glm::dvec3& p, double footprint_m) const {
    GrainSample out;
    if (!(footprint_m < m_flat_footprint)) return out;
    if (m_subgrid) {
        const ReliefSample relief = m_subgrid->eval(p, footprint_m);
        out.gradient = relief.gradient;
        out.residual_slope_variance = relief.residual_slope_variance;
    }
    if (!(footprint_m < m_grain_flat_footprint)) return out;
    double albedo = 0.0;
    glm::dvec3 gradient(0.0);
    for (const Octave& o : m_octaves) {
        const double x = kPi * footprint_m / (2.0 * o.cell);
        const double gain = std::exp(-0.5 * x * x);
        if (gain <= kGainCut) continue;
        const double w = (gain - kGainCut) * (1.0 / (1.0 - kGainCut));
        out.residual_slope_variance += w * w * (1.0 - w * w) * o.slope_variance;
        const glm::dvec3 q = o.rotation * p;
        const glm::dvec3 f = glm::floor(q);
        const glm::dvec3 t = q - f;
        const glm::dvec3 s = t * t * (3.0 - 2.0 * t);         // cubic fade
        const glm::dvec3 ds = 6.0 * t * (1.0 - t);            // its derivative
        const auto ix = static_cast<uint64_t>(static_cast<int64_t>(f.x));
        const auto iy = static_cast<uint64_t>(static_cast<int64_t>(f.y));
        const auto iz = static_cast<uint64_t>(static_cast<int64_t>(f.z));
        // Corner values: albedo lattice a[c], relief lattice h[c], c = bits (x, y, z).
        double a[8], h[8];
        for (int c = 0; c < 8; ++c) {
            const uint64_t key =
                o.key + (ix + (c & 1)) * kSpreadX + (iy + ((c >> 1) & 1)) * kSpreadY + (iz + ((c >> 2) & 1)) * kSpreadZ;
            const uint64_t bits = mix64(key);
            a[c] = signed_unit(static_cast<uint32_t>(bits >> 32));
            h[c] = signed_unit(static_cast<uint32_t>(bits));
        }
        // Trilinear in the faded coordinates.
        auto lerp = [](double u, double v, double k) { return u + k * (v - u); };
        const double a00 = lerp(a[0], a[1], s.x), a10 = lerp(a[2], a[3], s.x);
        const double a01 = lerp(a[4], a[5], s.x), a11 = lerp(a[6], a[7], s.x);
        albedo += w * o.albedo_amplitude * lerp(lerp(a00, a10, s.y), lerp(a01, a11, s.y), s.z);
        if (o.height_amplitude > 0.0) {
            const double h00 = lerp(h[0], h[1], s.x), h10 = lerp(h[2], h[3], s.x);
            const double h01 = lerp(h[4], h[5], s.x), h11 = lerp(h[6], h[7], s.x);
            const double hy0 = lerp(h00, h10, s.y), hy1 = lerp(h01, h11, s.y);
            // Partial derivatives in lattice units.
            const double dx =
                ds.x * lerp(lerp(h[1] - h[0], h[3] - h[2], s.y), lerp(h[5] - h[4], h[7] - h[6], s.y), s.z);
            const double dy = ds.y * lerp(h10 - h00, h11 - h01, s.z);
            const double dz = ds.z * (hy1 - hy0);
            gradient += (w * w * o.height_amplitude) * (o.to_world * glm::dvec3(dx, dy, dz));
        }
    }
    out.albedo_factor = 1.0 + albedo;
    out.gradient += gradient;
    return out;
}

glm::dvec3 perturbed_normal(const glm::dvec3& normal, const glm::dvec3& gradient) {
    const glm::dvec3 tangential = gradient - glm::dot(gradient, normal) * normal;
    return glm::normalize(normal - tangential);
}

}  // namespace moonbot
