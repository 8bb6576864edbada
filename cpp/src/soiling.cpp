#include "moonbot/soiling.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "moonbot/rng.h"

namespace moonbot {

namespace {

constexpr uint64_t kSoilingDomain = 0x736F696C'696E6721ull;  // separates these draws from other uses of a seed
// The contact band's strength b = 1 − exp(−N/kBandDeposits).
constexpr double kBandDeposits = 30.0;
// The speckle texture: albedo_rms is the largest 4 octaves allow (regolith_texture.h), the
// coverage code divides it back out to unit RMS.
constexpr double kSpeckleFinest = 0.5e-3, kSpeckleCoarsest = 4e-3;

void require(bool ok, const char* field, const std::string& what) {
    if (!ok) throw std::invalid_argument(std::string("stain.") + field + ": " + what);
}

GrainParams speckle_params(uint64_t seed) {
    GrainParams g;
    g.finest_cell_m = kSpeckleFinest;
    g.coarsest_cell_m = kSpeckleCoarsest;
    g.albedo_rms = 0.15;  // 4 octaves: < √(Var/4) = 0.185
    g.seed = mix64(seed ^ kSoilingDomain);
    return g;
}

}  // namespace

void SoilingParams::validate() const {
    require(deposits >= 0, "seeds", "must be >= 0");
    require(std::isfinite(opacity) && opacity >= 0 && opacity <= 1, "opacity", "must be in [0, 1]");
    require(std::isfinite(contact_height_m) && contact_height_m > 0 && contact_height_m <= 1, "contact_height_m",
            "must be in (0, 1] metres");
    require(std::isfinite(deposit_radius_m) && deposit_radius_m > 0 && deposit_radius_m <= 1, "deposit_radius_m",
            "must be in (0, 1] metres");
    require(std::isfinite(handled_share) && handled_share >= 0 && handled_share <= 1, "handled_share",
            "must be in [0, 1]");
    require(std::isfinite(speckle) && speckle >= 0 && speckle <= 2, "speckle", "must be in [0, 2]");
}

Soiling::Soiling(const SoilingParams& params, uint64_t seed, const float* vertices, size_t n_vertices,
                 const uint32_t* triangles, size_t n_triangles)
    : m_params(params), m_speckle(speckle_params(seed)) {
    params.validate();
    if (n_vertices == 0 || n_triangles == 0) throw std::invalid_argument("stain: the bag's mesh is empty");
    auto vertex = [&](uint32_t i) {
        return glm::dvec3(vertices[3 * size_t(i)], vertices[3 * size_t(i) + 1], vertices[3 * size_t(i) + 2]);
    };
    m_zmin = INFINITY;
    m_zmax = -INFINITY;
    for (size_t i = 0; i < n_vertices; ++i) {
        m_zmin = std::min(m_zmin, double(vertices[3 * i + 2]));
        m_zmax = std::max(m_zmax, double(vertices[3 * i + 2]));
    }
    m_band = 1.0 - std::exp(-params.deposits / kBandDeposits);
    if (params.deposits == 0) return;

    // Deposits are placed with density ∝ weight(z) over the surface, exactly, by rejection: a
    // triangle drawn by area × its largest weight (at its lowest or highest vertex; the weights
    // are monotone in z), a uniform point in it, kept with probability weight(z)/that largest.
    const double h = params.contact_height_m;
    auto low_weight = [&](double z) { return std::exp(-(z - m_zmin) / (2.0 * h)); };
    auto high_weight = [&](double z) { return std::exp(-(m_zmax - z) / h); };
    std::vector<double> low(n_triangles), high(n_triangles);
    double sum_low = 0.0, sum_high = 0.0;
    for (size_t t = 0; t < n_triangles; ++t) {
        const glm::dvec3 a = vertex(triangles[3 * t]), b = vertex(triangles[3 * t + 1]),
                         c = vertex(triangles[3 * t + 2]);
        const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
        sum_low += area * low_weight(std::min({a.z, b.z, c.z}));
        sum_high += area * high_weight(std::max({a.z, b.z, c.z}));
        low[t] = sum_low;
        high[t] = sum_high;
    }
    const uint64_t key = mix64(seed ^ kSoilingDomain);
    // Enough tries that a rejection run out is rarer than 1e-9 for any mesh whose triangles span
    // less than ~6h in z (the last try is kept then).
    constexpr int kTries = 64;
    for (int k = 0; k < params.deposits; ++k) {
        auto draw = [&](uint32_t dimension) { return double(uniform01(key, uint64_t(k), 0, dimension)); };
        const bool handled = draw(0) < params.handled_share;
        const std::vector<double>& cumulative = handled ? high : low;
        Deposit d;
        for (int attempt = 0; attempt < kTries; ++attempt) {
            const uint32_t dim = 4 * static_cast<uint32_t>(attempt) + 1;
            const double target = draw(dim) * cumulative.back();
            const size_t t = std::min<size_t>(
                std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin(), n_triangles - 1);
            // Uniform over the triangle (the square-root map of two uniforms).
            const double r1 = std::sqrt(draw(dim + 1)), r2 = draw(dim + 2);
            const glm::dvec3 a = vertex(triangles[3 * t]), b = vertex(triangles[3 * t + 1]),
                             c = vertex(triangles[3 * t + 2]);
            d.centre = (1.0 - r1) * a + r1 * (1.0 - r2) * b + r1 * r2 * c;
            const double accept = handled ? high_weight(d.centre.z) / high_weight(std::max({a.z, b.z, c.z}))
                                          : low_weight(d.centre.z) / low_weight(std::min({a.z, b.z, c.z}));
            if (draw(dim + 3) < accept) break;
        }
        d.radius = params.deposit_radius_m * (0.6 + 0.8 * draw(0xFFFF));
        m_deposits.push_back(d);
    }
}

double Soiling::smooth_coverage(const glm::dvec3& p) const {
    double c = m_band * std::exp(-(p.z - m_zmin) / m_params.contact_height_m);
    for (const Deposit& d : m_deposits) {
        const glm::dvec3 e = p - d.centre;
        const double q = glm::dot(e, e) / (d.radius * d.radius);
        if (q < 1.0) c += m_params.opacity * (1.0 - q) * (1.0 - q);
    }
    return std::min(c, 1.0);
}

double Soiling::coverage(const glm::dvec3& p, double footprint_m) const {
    const double c = smooth_coverage(p);
    if (c <= 0.0 || c >= 1.0 || m_params.speckle == 0.0) return c;
    const double xi = (m_speckle.eval(p, footprint_m).albedo_factor - 1.0) / m_speckle.params().albedo_rms;
    return std::clamp(c + 2.0 * m_params.speckle * xi * c * (1.0 - c), 0.0, 1.0);
}

glm::dvec3 dusted_colour(const glm::dvec3& clean, double m, const glm::dvec3& dust) {
    if (!(m > 0.0)) return clean;
    m = std::min(m, 1.0);
    return (1.0 - m) * clean + m * dust;  // exactly `dust` at m = 1
}

}  // namespace moonbot
