#include "moonbot/medium.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
const double kSqrtHalfPi = std::sqrt(kPi / 2.0);
// The Sun grid has at most this many cells a side: a cloud spread far wider than its puffs gets
// coarser cells (more puffs a cell) rather than an unbounded grid.
constexpr int kMaxCellsPerSide = 256;

/// ∫ from a to b of exp(−x²) dx·2/√π = erf(b) − erf(a), b ≥ a, computed from the side of
/// the origin where the difference of two values near ±1 would not cancel.
double erf_span(double a, double b) {
    if (a > 0.0) return std::erfc(a) - std::erfc(b);
    if (b < 0.0) return std::erfc(-b) - std::erfc(-a);
    return std::erf(b) - std::erf(a);
}

}  // namespace

double optical_depth(const Puff& puff, const glm::dvec3& origin, const glm::dvec3& dir, double t_max) {
    if (!(t_max > 0.0) || puff.peak_extinction == 0.0) return 0.0;
    const glm::dvec3 p = origin - puff.centre;
    const double b = glm::dot(p, dir);
    const double q2 = std::max(0.0, glm::dot(p, p) - b * b);
    const double s = puff.sigma_m * std::sqrt(2.0);
    const double upper = std::isinf(t_max) ? INFINITY : (t_max + b) / s;
    return puff.peak_extinction * std::exp(-q2 / (2.0 * puff.sigma_m * puff.sigma_m)) * puff.sigma_m *
           kSqrtHalfPi * erf_span(b / s, upper);
}

double henyey_greenstein(double cos_theta, double g) {
    const double d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * kPi * d * std::sqrt(d));
}

void Medium::validate() const {
    for (const Puff& p : puffs) {
        if (!(std::isfinite(p.centre.x) && std::isfinite(p.centre.y) && std::isfinite(p.centre.z)))
            throw std::invalid_argument("puffs: centre must be finite");
        if (!(p.sigma_m > 0.0 && std::isfinite(p.sigma_m)))
            throw std::invalid_argument("puffs: sigma_m must be positive and finite");
        if (!(p.peak_extinction >= 0.0 && std::isfinite(p.peak_extinction)))
            throw std::invalid_argument("puffs: peak_extinction must be >= 0 and finite");
    }
    for (int c = 0; c < 3; ++c)
        if (!(albedo[c] >= 0.0 && albedo[c] <= 1.0))
            throw std::invalid_argument("albedo: each channel must be in [0, 1]");
    if (!(asymmetry > -1.0 && asymmetry < 1.0)) throw std::invalid_argument("asymmetry: must be in (-1, 1)");
    if (scatter_samples < 1 || scatter_samples > kMaxScatterSamples)
        throw std::invalid_argument("scatter_samples: must be in 1.." + std::to_string(kMaxScatterSamples) + ", got " +
                                    std::to_string(scatter_samples));
}

MediumIndex::MediumIndex(const Medium& medium, const glm::dvec3& sun_dir) : m_medium(medium), m_sun(sun_dir) {
    // A basis across the Sun's direction (Duff et al.'s, as the renderer's).
    const double sign = std::copysign(1.0, m_sun.z);
    const double k = -1.0 / (sign + m_sun.z);
    const double xy = m_sun.x * m_sun.y * k;
    m_a = {1.0 + sign * m_sun.x * m_sun.x * k, sign * xy, -sign * m_sun.x};
    m_b = {xy, sign + m_sun.y * m_sun.y * k, -m_sun.y};
    const std::vector<Puff>& puffs = medium.puffs;
    if (puffs.empty()) return;
    double a_lo = INFINITY, a_hi = -INFINITY, b_lo = INFINITY, b_hi = -INFINITY, reach = 0.0;
    for (const Puff& p : puffs) {
        const double r = kPuffReach * p.sigma_m, pa = glm::dot(p.centre, m_a), pb = glm::dot(p.centre, m_b);
        a_lo = std::min(a_lo, pa - r), a_hi = std::max(a_hi, pa + r);
        b_lo = std::min(b_lo, pb - r), b_hi = std::max(b_hi, pb + r);
        reach = std::max(reach, r);
    }
    m_cell = std::max({reach, (a_hi - a_lo) / kMaxCellsPerSide, (b_hi - b_lo) / kMaxCellsPerSide});
    m_a0 = a_lo, m_b0 = b_lo;
    m_na = std::max(1, static_cast<int>(std::ceil((a_hi - a_lo) / m_cell)));
    m_nb = std::max(1, static_cast<int>(std::ceil((b_hi - b_lo) / m_cell)));
    // Two passes: count each cell's puffs, then fill (compressed rows, no per-cell vectors).
    m_cell_start.assign(static_cast<size_t>(m_na) * m_nb + 1, 0);
    auto span = [&](const Puff& p, int& i0, int& i1, int& j0, int& j1) {
        const double r = kPuffReach * p.sigma_m, pa = glm::dot(p.centre, m_a) - m_a0, pb = glm::dot(p.centre, m_b) - m_b0;
        i0 = std::clamp(static_cast<int>(std::floor((pa - r) / m_cell)), 0, m_na - 1);
        i1 = std::clamp(static_cast<int>(std::floor((pa + r) / m_cell)), 0, m_na - 1);
        j0 = std::clamp(static_cast<int>(std::floor((pb - r) / m_cell)), 0, m_nb - 1);
        j1 = std::clamp(static_cast<int>(std::floor((pb + r) / m_cell)), 0, m_nb - 1);
    };
    for (const Puff& p : puffs) {
        int i0, i1, j0, j1;
        span(p, i0, i1, j0, j1);
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) ++m_cell_start[static_cast<size_t>(j) * m_na + i + 1];
    }
    for (size_t c = 1; c < m_cell_start.size(); ++c) m_cell_start[c] += m_cell_start[c - 1];
    m_cell_puffs.resize(m_cell_start.back());
    std::vector<uint32_t> fill(m_cell_start.begin(), m_cell_start.end() - 1);
    for (uint32_t index = 0; index < puffs.size(); ++index) {
        int i0, i1, j0, j1;
        span(puffs[index], i0, i1, j0, j1);
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) m_cell_puffs[fill[static_cast<size_t>(j) * m_na + i]++] = index;
    }
}

void MediumIndex::cull(const glm::dvec3& apex, const glm::dvec3 corners[4], std::vector<uint32_t>& out) const {
    out.clear();
    const glm::dvec3 middle = corners[0] + corners[1] + corners[2] + corners[3];
    glm::dvec3 normal[4];
    for (int k = 0; k < 4; ++k) {
        normal[k] = glm::cross(corners[k], corners[(k + 1) % 4]);
        const double len = glm::length(normal[k]);
        normal[k] = len > 0.0 ? normal[k] / len : glm::dvec3(0.0);
        if (glm::dot(normal[k], middle) < 0.0) normal[k] = -normal[k];  // inward
    }
    const std::vector<Puff>& puffs = m_medium.puffs;
    for (uint32_t index = 0; index < puffs.size(); ++index) {
        const glm::dvec3 to = puffs[index].centre - apex;
        const double r = kPuffReach * puffs[index].sigma_m;
        bool inside = true;
        for (int k = 0; k < 4 && inside; ++k) inside = glm::dot(normal[k], to) >= -r;
        if (inside) out.push_back(index);
    }
}

void MediumIndex::along(const std::vector<uint32_t>& candidates, const glm::dvec3& origin, const glm::dvec3& dir,
                        double s_max, std::vector<RayPuff>& out, double& enter, double& exit) const {
    out.clear();
    enter = INFINITY, exit = -INFINITY;
    for (uint32_t index : candidates) {
        const Puff& puff = m_medium.puffs[index];
        const glm::dvec3 p = origin - puff.centre;
        const double b = glm::dot(p, dir);
        const double q2 = std::max(0.0, glm::dot(p, p) - b * b);
        const double r = kPuffReach * puff.sigma_m;
        if (q2 >= r * r) continue;
        const double half = std::sqrt(r * r - q2);
        const double in = std::max(0.0, -b - half), out_s = std::min(s_max, -b + half);
        if (!(in < out_s)) continue;
        out.push_back({b, puff.sigma_m, puff.peak_extinction * std::exp(-q2 / (2.0 * puff.sigma_m * puff.sigma_m)), in,
                       out_s});
        enter = std::min(enter, in), exit = std::max(exit, out_s);
    }
}

double MediumIndex::depth_to(const std::vector<RayPuff>& puffs, double s) {
    double tau = 0.0;
    for (const RayPuff& p : puffs) {
        const double w = p.sigma * std::sqrt(2.0);
        tau += p.weight * p.sigma * kSqrtHalfPi * erf_span(p.b / w, (s + p.b) / w);
    }
    return tau;
}

double MediumIndex::extinction_at(const std::vector<RayPuff>& puffs, double s) {
    double k = 0.0;
    for (const RayPuff& p : puffs) {
        const double d = (s + p.b) / p.sigma;
        k += p.weight * std::exp(-0.5 * d * d);
    }
    return k;
}

double MediumIndex::sun_depth(const glm::dvec3& point) const {
    if (m_cell_puffs.empty()) return 0.0;
    const int i = static_cast<int>(std::floor((glm::dot(point, m_a) - m_a0) / m_cell));
    const int j = static_cast<int>(std::floor((glm::dot(point, m_b) - m_b0) / m_cell));
    if (i < 0 || j < 0 || i >= m_na || j >= m_nb) return 0.0;  // beside every puff's reach
    const size_t c = static_cast<size_t>(j) * m_na + i;
    double tau = 0.0;
    for (uint32_t k = m_cell_start[c]; k < m_cell_start[c + 1]; ++k) {
        const Puff& puff = m_medium.puffs[m_cell_puffs[k]];
        const glm::dvec3 p = point - puff.centre;
        const double b = glm::dot(p, m_sun);
        const double q2 = std::max(0.0, glm::dot(p, p) - b * b);
        const double r = kPuffReach * puff.sigma_m;
        if (q2 >= r * r || b >= r) continue;  // passes beside it, or already beyond it
        tau += optical_depth(puff, point, m_sun, INFINITY);
    }
    return tau;
}

}  // namespace moonbot
