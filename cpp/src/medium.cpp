#include "moonbot/medium.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>

#include <tbb/parallel_for.h>

#include "rays.h"

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
const double kSqrtHalfPi = std::sqrt(kPi / 2.0);

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
    if (!(voxel_m >= 1e-3 && voxel_m <= 100.0)) throw std::invalid_argument("voxel_m: must be in [0.001, 100]");
    if (std::isnan(floor_z) || floor_z == INFINITY) throw std::invalid_argument("floor_z: must be a number below +inf");
}

double puff_reach(const Puff& puff) {
    if (!(puff.peak_extinction > kExtinctionFloor)) return 0.0;
    return puff.sigma_m * std::min(kPuffReach, std::sqrt(2.0 * std::log(puff.peak_extinction / kExtinctionFloor)));
}

DustGrid::DustGrid(const Medium& medium, const Scene& scene, const glm::dvec3& sun_dir)
    : m_medium(medium), m_sun(sun_dir) {
    const std::vector<Puff>& puffs = medium.puffs;
    std::vector<double> reach(puffs.size());
    m_lo = glm::dvec3(INFINITY), m_hi = glm::dvec3(-INFINITY);
    for (size_t p = 0; p < puffs.size(); ++p) {
        reach[p] = puff_reach(puffs[p]);
        if (reach[p] <= 0.0) continue;
        m_lo = glm::min(m_lo, puffs[p].centre - reach[p]);
        m_hi = glm::max(m_hi, puffs[p].centre + reach[p]);
    }
    m_lo.z = std::max(m_lo.z, medium.floor_z);
    if (!(m_lo.x < m_hi.x && m_lo.y < m_hi.y && m_lo.z < m_hi.z)) {  // nothing that counts
        m_n[0] = m_n[1] = m_n[2] = 0;
        return;
    }
    const glm::dvec3 extent = m_hi - m_lo;
    m_h = std::max(medium.voxel_m, std::max({extent.x, extent.y, extent.z}) / (kMaxGridNodes - 1));
    for (int a = 0; a < 3; ++a) {
        m_n[a] = std::max(2, static_cast<int>(std::ceil(extent[a] / m_h)) + 1);
        m_hi[a] = m_lo[a] + (m_n[a] - 1) * m_h;
    }
    const size_t count = static_cast<size_t>(m_n[0]) * m_n[1] * m_n[2];
    m_extinction.assign(count, 0.0f);
    m_sun_depth.assign(count, 0.0f);
    m_visible.assign(count, 1.0f);

    // Extinction: a Gaussian is separable, so each puff adds peak·gx[i]·gy[j]·gz[k] over the
    // nodes of its reach: no transcendental per node. Slices in parallel, each summing the puffs
    // in their fixed order: the same bits whatever the threads.
    tbb::parallel_for(0, m_n[2], [&](int k) {
        const double z = m_lo.z + k * m_h;
        std::vector<double> gx, gy;
        for (size_t p = 0; p < puffs.size(); ++p) {
            const Puff& puff = puffs[p];
            const double r = reach[p];
            if (r <= 0.0 || std::abs(z - puff.centre.z) > r) continue;
            const double inv = 1.0 / (2.0 * puff.sigma_m * puff.sigma_m);
            const double dz = z - puff.centre.z;
            const double wz = puff.peak_extinction * std::exp(-dz * dz * inv);
            auto range = [&](int a, int& first, int& last) {
                first = std::max(0, static_cast<int>(std::ceil((puff.centre[a] - r - m_lo[a]) / m_h)));
                last = std::min(m_n[a] - 1, static_cast<int>(std::floor((puff.centre[a] + r - m_lo[a]) / m_h)));
            };
            int i0, i1, j0, j1;
            range(0, i0, i1);
            range(1, j0, j1);
            if (i0 > i1 || j0 > j1) continue;
            gx.resize(static_cast<size_t>(i1 - i0 + 1));
            gy.resize(static_cast<size_t>(j1 - j0 + 1));
            for (int i = i0; i <= i1; ++i) {
                const double d = m_lo.x + i * m_h - puff.centre.x;
                gx[static_cast<size_t>(i - i0)] = std::exp(-d * d * inv);
            }
            for (int j = j0; j <= j1; ++j) {
                const double d = m_lo.y + j * m_h - puff.centre.y;
                gy[static_cast<size_t>(j - j0)] = wz * std::exp(-d * d * inv);
            }
            for (int j = j0; j <= j1; ++j) {
                float* row = &m_extinction[node(0, j, k)];
                const double wy = gy[static_cast<size_t>(j - j0)];
                for (int i = i0; i <= i1; ++i) row[i] += static_cast<float>(wy * gx[static_cast<size_t>(i - i0)]);
            }
        }
    });

    // Optical depth toward the Sun, slice by slice from the Sun's side along the axis the Sun's
    // direction is steepest in: a node's depth is that of the point one slice sunward on its
    // Sun ray (bilinear in the slice already done) plus the trapezoid of the extinction between.
    int a = 0;
    for (int c = 1; c < 3; ++c)
        if (std::abs(m_sun[c]) > std::abs(m_sun[a])) a = c;
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double along = m_h / std::abs(m_sun[a]);  // path length between slices
    const double db = m_sun[b] / std::abs(m_sun[a]), dc = m_sun[c] / std::abs(m_sun[a]);  // in nodes
    const int towards = m_sun[a] > 0.0 ? 1 : -1;
    auto at = [&](int ia, int ib, int ic) {
        int idx[3];
        idx[a] = ia, idx[b] = ib, idx[c] = ic;
        return node(idx[0], idx[1], idx[2]);
    };
    const int first = towards > 0 ? m_n[a] - 1 : 0;
    for (int ia = first - towards; ia >= 0 && ia < m_n[a]; ia -= towards) {
        const int up = ia + towards;
        tbb::parallel_for(0, m_n[c], [&](int ic) {
            for (int ib = 0; ib < m_n[b]; ++ib) {
                const double fb = ib + db, fc = ic + dc;
                double depth_up = 0.0, ext_up = 0.0;
                // Outside the slice's sides the Sun ray has left the grid's box, which holds all
                // the dust: nothing more lies sunward.
                if (fb >= 0.0 && fb <= m_n[b] - 1 && fc >= 0.0 && fc <= m_n[c] - 1) {
                    const int jb = std::min(static_cast<int>(fb), m_n[b] - 2), jc = std::min(static_cast<int>(fc), m_n[c] - 2);
                    const double tb = fb - jb, tc = fc - jc;
                    const size_t n00 = at(up, jb, jc), n10 = at(up, jb + 1, jc), n01 = at(up, jb, jc + 1),
                                 n11 = at(up, jb + 1, jc + 1);
                    auto lerp2 = [&](const std::vector<float>& f) {
                        return (1 - tc) * ((1 - tb) * f[n00] + tb * f[n10]) + tc * ((1 - tb) * f[n01] + tb * f[n11]);
                    };
                    depth_up = lerp2(m_sun_depth);
                    ext_up = lerp2(m_extinction);
                }
                const size_t here = at(ia, ib, ic);
                m_sun_depth[here] = static_cast<float>(depth_up + 0.5 * along * (ext_up + m_extinction[here]));
            }
        });
    }

    // Geometric shade: one shadow ray toward the Sun's centre from each node with dust near it
    // (nodes whose whole neighbourhood is clear keep 1: they only blend into empty space).
    std::atomic<uint64_t> rays{0};
    tbb::parallel_for(0, m_n[2], [&](int k) {
        std::vector<RayHit> batch(static_cast<size_t>(m_n[0]));
        std::vector<int> which(static_cast<size_t>(m_n[0]));
        for (int j = 0; j < m_n[1]; ++j) {
            int n = 0;
            for (int i = 0; i < m_n[0]; ++i) {
                if (!(m_extinction[node(i, j, k)] > 1e-6f)) continue;
                detail::set_ray(batch[static_cast<size_t>(n)], m_lo + glm::dvec3(i, j, k) * m_h, m_sun);
                which[static_cast<size_t>(n++)] = i;
            }
            if (n == 0) continue;
            scene.accel().occluded(batch.data(), static_cast<size_t>(n), /*coherent=*/true);
            rays += static_cast<uint64_t>(n);
            for (int r = 0; r < n; ++r)
                if (batch[static_cast<size_t>(r)].tfar < 0.0f) m_visible[node(which[static_cast<size_t>(r)], j, k)] = 0.0f;
        }
    });
    m_shadow_rays = rays;
    // What the renderer reads per step: the Sun's light left at each node.
    for (size_t n = 0; n < count; ++n) m_visible[n] *= static_cast<float>(std::exp(-double(m_sun_depth[n])));
}

bool DustGrid::clip(const glm::dvec3& origin, const glm::dvec3& dir, double s_max, double& enter, double& exit) const {
    if (m_n[0] == 0) return false;
    enter = 0.0, exit = s_max;
    for (int a = 0; a < 3; ++a) {
        if (dir[a] == 0.0) {
            if (origin[a] < m_lo[a] || origin[a] > m_hi[a]) return false;
            continue;
        }
        double t0 = (m_lo[a] - origin[a]) / dir[a], t1 = (m_hi[a] - origin[a]) / dir[a];
        if (t0 > t1) std::swap(t0, t1);
        enter = std::max(enter, t0), exit = std::min(exit, t1);
    }
    return enter < exit;
}

double DustGrid::trilinear(const std::vector<float>& field, const glm::dvec3& point) const {
    int i[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        const double f = std::clamp((point[a] - m_lo[a]) / m_h, 0.0, double(m_n[a] - 1));
        i[a] = std::min(static_cast<int>(f), m_n[a] - 2);
        t[a] = f - i[a];
    }
    const size_t n0 = node(i[0], i[1], i[2]);
    const size_t sy = static_cast<size_t>(m_n[0]), sz = sy * m_n[1];
    auto x = [&](size_t n) { return (1 - t[0]) * field[n] + t[0] * field[n + 1]; };
    const double y0 = (1 - t[1]) * x(n0) + t[1] * x(n0 + sy);
    const double y1 = (1 - t[1]) * x(n0 + sz) + t[1] * x(n0 + sz + sy);
    return (1 - t[2]) * y0 + t[2] * y1;
}

void DustGrid::sample(const glm::dvec3& point, double& extinction, double& sunlight) const {
    extinction = trilinear(m_extinction, point);
    sunlight = trilinear(m_visible, point);
}

double DustGrid::sun_transmittance(const glm::dvec3& point) const {
    double enter, exit;
    if (!clip(point, m_sun, INFINITY, enter, exit)) return 1.0;  // its Sun ray misses all the dust
    if (enter == 0.0) return std::exp(-trilinear(m_sun_depth, point));  // inside the grid
    double tau = 0.0;
    for (const Puff& puff : m_medium.puffs) {
        const double r = puff_reach(puff);
        if (r <= 0.0) continue;
        const glm::dvec3 p = point - puff.centre;
        const double b = glm::dot(p, m_sun);
        if (glm::dot(p, p) - b * b >= r * r || b >= r) continue;  // beside it, or beyond it
        tau += optical_depth(puff, point, m_sun, INFINITY);
    }
    return std::exp(-tau);
}

}  // namespace moonbot
