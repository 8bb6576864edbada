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
// A node asks for its Sun ray (DustGrid::shade_from_sun) when its extinction is above this, 1/m.
constexpr float kDustyNode = 1e-6f;
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
    return puff.peak_extinction * std::exp(-q2 / (2.0 * puff.sigma_m * puff.sigma_m)) * puff.sigma_m * kSqrtHalfPi *
           erf_span(b / s, upper);
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
    if (!(march_stride_px == 1 || march_stride_px == 2 || march_stride_px == 4 || march_stride_px == 8))
        throw std::invalid_argument("march_stride_px: must be 1, 2, 4 or 8, got " + std::to_string(march_stride_px));
}

double puff_reach(const Puff& puff) {
    if (!(puff.peak_extinction > kExtinctionFloor)) return 0.0;
    return puff.sigma_m * std::min(kPuffReach, std::sqrt(2.0 * std::log(puff.peak_extinction / kExtinctionFloor)));
}

DustGrid::DustGrid(const Medium& medium, const Scene& scene, const glm::dvec3& sun_dir)
    : m_medium(medium), m_sun(sun_dir) {
    // The grid's frame: two axes across the Sun's direction and the Sun's direction itself, so
    // that every Sun ray runs along a grid line.
    detail::orthonormal_basis(m_sun, m_axis[0], m_axis[1]);
    m_axis[2] = m_sun;
    std::vector<glm::dvec3> centre;
    const std::vector<double> reach = bound_puffs(centre);
    if (!lay_out_nodes()) {  // nothing that counts
        m_n[0] = m_n[1] = m_n[2] = 0;
        return;
    }
    const std::vector<float> extinction = bake_extinction(reach, centre);
    integrate_sun_depth(extinction);
    const std::vector<float> visible = shade_from_sun(extinction, scene);
    pack_lookup(extinction, visible);
    mark_empty_blocks(extinction);
}

std::vector<double> DustGrid::bound_puffs(std::vector<glm::dvec3>& centre) {
    const std::vector<Puff>& puffs = m_medium.puffs;
    m_reach.resize(puffs.size());
    std::vector<double> reach(puffs.size());  // m_reach, but 0 for the puffs the grid leaves out
    centre.resize(puffs.size());
    m_lo = glm::dvec3(INFINITY), m_hi = glm::dvec3(-INFINITY);
    for (size_t p = 0; p < puffs.size(); ++p) {
        reach[p] = m_reach[p] = puff_reach(puffs[p]);
        centre[p] = frame(puffs[p].centre);
        // A puff wholly under the floor is never seen or lit.
        if (reach[p] <= 0.0 || puffs[p].centre.z + reach[p] <= m_medium.floor_z) {
            reach[p] = 0.0;
            continue;
        }
        m_lo = glm::min(m_lo, centre[p] - reach[p]);
        m_hi = glm::max(m_hi, centre[p] + reach[p]);
    }
    return reach;
}

bool DustGrid::lay_out_nodes() {
    if (!(m_lo.x < m_hi.x && m_lo.y < m_hi.y && m_lo.z < m_hi.z)) return false;
    const glm::dvec3 extent = m_hi - m_lo;
    m_h = std::max(m_medium.voxel_m, std::max({extent.x, extent.y, extent.z}) / (kMaxGridNodes - 1));
    for (int a = 0; a < 3; ++a) {
        m_n[a] = std::max(2, static_cast<int>(std::ceil(extent[a] / m_h)) + 1);
        m_hi[a] = m_lo[a] + (m_n[a] - 1) * m_h;
    }
    return true;
}

size_t DustGrid::node_count() const { return static_cast<size_t>(m_n[0]) * m_n[1] * m_n[2]; }

std::vector<float> DustGrid::bake_extinction(const std::vector<double>& reach,
                                             const std::vector<glm::dvec3>& centre) const {
    // An isotropic Gaussian is separable in any orthonormal frame, so each puff adds
    // peak·g0[i]·g1[j]·g2[k] over the nodes of its reach: no transcendental per node. Lines along
    // the Sun (i, j) in parallel, each summing the puffs in their fixed order: the same bits
    // whatever the threads.
    const std::vector<Puff>& puffs = m_medium.puffs;
    std::vector<float> extinction(node_count(), 0.0f);
    tbb::parallel_for(0, m_n[1], [&](int j) {
        std::vector<double> g0, g2;
        const double v = m_lo.y + j * m_h;
        for (size_t p = 0; p < puffs.size(); ++p) {
            const double r = reach[p];
            const glm::dvec3& c = centre[p];
            if (r <= 0.0 || std::abs(v - c.y) > r) continue;
            const double inv = 1.0 / (2.0 * puffs[p].sigma_m * puffs[p].sigma_m);
            const double w1 = puffs[p].peak_extinction * std::exp(-(v - c.y) * (v - c.y) * inv);
            auto range = [&](int a, int& first, int& last) {
                first = std::max(0, static_cast<int>(std::ceil((c[a] - r - m_lo[a]) / m_h)));
                last = std::min(m_n[a] - 1, static_cast<int>(std::floor((c[a] + r - m_lo[a]) / m_h)));
            };
            int i0, i1, k0, k1;
            range(0, i0, i1);
            range(2, k0, k1);
            if (i0 > i1 || k0 > k1) continue;
            g0.resize(static_cast<size_t>(i1 - i0 + 1));
            g2.resize(static_cast<size_t>(k1 - k0 + 1));
            for (int i = i0; i <= i1; ++i) {
                const double d = m_lo.x + i * m_h - c.x;
                g0[static_cast<size_t>(i - i0)] = w1 * std::exp(-d * d * inv);
            }
            for (int k = k0; k <= k1; ++k) {
                const double d = m_lo.z + k * m_h - c.z;
                g2[static_cast<size_t>(k - k0)] = std::exp(-d * d * inv);
            }
            for (int k = k0; k <= k1; ++k) {
                float* row = &extinction[node(0, j, k)];
                const double w = g2[static_cast<size_t>(k - k0)];
                for (int i = i0; i <= i1; ++i) row[i] += static_cast<float>(w * g0[static_cast<size_t>(i - i0)]);
            }
        }
    });
    return extinction;
}

void DustGrid::integrate_sun_depth(const std::vector<float>& extinction) {
    // Along each grid line, from the Sun's end (k = n − 1, where nothing lies beyond) back, by the
    // trapezoid rule.
    m_sun_depth.assign(node_count(), 0.0f);
    tbb::parallel_for(0, m_n[1], [&](int j) {
        for (int i = 0; i < m_n[0]; ++i) {
            double depth = 0.0;
            for (int k = m_n[2] - 2; k >= 0; --k) {
                depth += 0.5 * m_h * (double(extinction[node(i, j, k)]) + extinction[node(i, j, k + 1)]);
                m_sun_depth[node(i, j, k)] = static_cast<float>(depth);
            }
        }
    });
}

std::vector<uint8_t> DustGrid::near_dust(const std::vector<float>& extinction) const {
    // Dilated by one node along each axis in turn (in place, line by line, each node's old value
    // carried to the next): the 26 neighbours, the corners of every cell with a dusty corner.
    std::vector<uint8_t> near(node_count(), 0);
    for (size_t n = 0; n < near.size(); ++n) near[n] = extinction[n] > kDustyNode;
    const size_t stride[3] = {1, static_cast<size_t>(m_n[0]), static_cast<size_t>(m_n[0]) * m_n[1]};
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, c = (a + 2) % 3;  // the axes across the lines
        for (int v = 0; v < m_n[c]; ++v)
            for (int u = 0; u < m_n[b]; ++u) {
                const size_t first = u * stride[b] + v * stride[c];
                uint8_t previous = 0;  // the old value of the node before
                for (int t = 0; t < m_n[a]; ++t) {
                    const size_t n = first + t * stride[a];
                    const uint8_t old = near[n];
                    const uint8_t next = t + 1 < m_n[a] ? near[n + stride[a]] : 0;
                    near[n] = old | previous | next;
                    previous = old;
                }
            }
    }
    return near;
}

std::vector<float> DustGrid::shade_from_sun(const std::vector<float>& extinction, const Scene& scene) {
    // Each node with dust, and each node that shares a cell with one, asks what its ray toward the
    // Sun's centre meets first: the lookup interpolates the sunlight over a cell's corners, and an
    // empty corner left lit beside a shadowed dusty one would light the rim of a puff's reach in
    // shadow. Nodes farther from any dust only blend into empty space. A surface's front shades a
    // node; a back face means the node is inside the ground or a bag, where no dust is ever seen:
    // it counts as lit, so that the dust just above the ground is not dimmed by interpolating
    // toward it.
    // The frame's third axis is the Sun's direction, so a node's ray runs along its grid line and
    // every node of the line short of the first surface a ray meets meets that surface first too.
    // A line therefore traces one ray from its lowest node asking and one more from the first
    // node asking past each surface found: a line open to the Sun takes one ray, not one a node.
    const std::vector<uint8_t> near = near_dust(extinction);
    std::vector<float> visible(node_count(), 1.0f);
    std::atomic<uint64_t> rays{0};
    tbb::parallel_for(0, m_n[1], [&](int j) {
        uint64_t traced = 0;
        RayHit ray;
        for (int i = 0; i < m_n[0]; ++i) {
            double surface = -INFINITY;  // frame coordinate along the Sun of the surface ahead (+inf: none)
            float before = 1.0f;         // what a node short of it is
            for (int k = 0; k < m_n[2]; ++k) {
                if (!near[node(i, j, k)]) continue;
                const double along = m_lo.z + k * m_h;
                const glm::dvec3 point = world(glm::dvec3(m_lo.x + i * m_h, m_lo.y + j * m_h, along));
                if (point.z < m_medium.floor_z) continue;
                if (!(along < surface)) {
                    detail::set_ray(ray, point, m_sun);
                    scene.accel().intersect(&ray, 1);
                    ++traced;
                    if (ray.geom_id == kInvalidId) {
                        surface = INFINITY, before = 1.0f;
                    } else {
                        const Instance& inst = scene.instance(ray.inst_id);
                        const glm::dvec3 normal = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
                        surface = along + ray.tfar;
                        before = glm::dot(normal, m_sun) < 0.0 ? 0.0f : 1.0f;
                    }
                }
                visible[node(i, j, k)] = before;
            }
        }
        rays += traced;
    });
    m_shadow_rays = rays;
    return visible;
}

void DustGrid::pack_lookup(const std::vector<float>& extinction, const std::vector<float>& visible) {
    const size_t count = node_count();
    m_lookup.resize(2 * count);
    for (size_t n = 0; n < count; ++n) {
        m_lookup[2 * n] = extinction[n];
        m_lookup[2 * n + 1] = visible[n] * static_cast<float>(std::exp(-double(m_sun_depth[n])));
    }
}

void DustGrid::mark_empty_blocks(const std::vector<float>& extinction) {
    // Block b spans cells kBlock·b .. kBlock·b + kBlock − 1, so nodes kBlock·b .. kBlock·(b + 1),
    // the faces shared with its neighbours included.
    for (int a = 0; a < 3; ++a) m_blocks[a] = (m_n[a] - 2) / kBlock + 1;
    m_empty.assign(static_cast<size_t>(m_blocks[0]) * m_blocks[1] * m_blocks[2], 1);
    tbb::parallel_for(0, m_blocks[2], [&](int bk) {
        for (int bj = 0; bj < m_blocks[1]; ++bj)
            for (int bi = 0; bi < m_blocks[0]; ++bi) {
                bool empty = true;
                for (int k = bk * kBlock; empty && k <= std::min((bk + 1) * kBlock, m_n[2] - 1); ++k)
                    for (int j = bj * kBlock; empty && j <= std::min((bj + 1) * kBlock, m_n[1] - 1); ++j)
                        for (int i = bi * kBlock; i <= std::min((bi + 1) * kBlock, m_n[0] - 1); ++i)
                            if (extinction[node(i, j, k)] != 0.0f) {
                                empty = false;
                                break;
                            }
                m_empty[block(bi, bj, bk)] = empty ? 1 : 0;
            }
    });
}

glm::dvec3 DustGrid::frame(const glm::dvec3& p) const {
    return {glm::dot(p, m_axis[0]), glm::dot(p, m_axis[1]), glm::dot(p, m_axis[2])};
}

glm::dvec3 DustGrid::world(const glm::dvec3& f) const { return f.x * m_axis[0] + f.y * m_axis[1] + f.z * m_axis[2]; }

bool DustGrid::clip(const glm::dvec3& origin, const glm::dvec3& dir, double s_max, double& enter, double& exit) const {
    if (m_n[0] == 0) return false;
    const glm::dvec3 o = frame(origin), d = frame(dir);
    enter = 0.0, exit = s_max;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < m_lo[a] || o[a] > m_hi[a]) return false;
            continue;
        }
        double t0 = (m_lo[a] - o[a]) / d[a], t1 = (m_hi[a] - o[a]) / d[a];
        if (t0 > t1) std::swap(t0, t1);
        enter = std::max(enter, t0), exit = std::min(exit, t1);
    }
    return enter < exit;
}

double DustGrid::trilinear(const std::vector<float>& field, const glm::dvec3& f_point) const {
    int i[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        const double f = std::clamp((f_point[a] - m_lo[a]) / m_h, 0.0, double(m_n[a] - 1));
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

template <typename Visit>
void DustGrid::walk(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step,
                    double opaque, Visit&& visit) const {
    // In the grid's frame, where a lookup needs no rotation: o + s·d is the ray.
    const glm::dvec3 o = frame(origin), d = frame(dir);
    const double inv_h = 1.0 / m_h;
    const size_t sy = 2 * static_cast<size_t>(m_n[0]), sz = sy * static_cast<size_t>(m_n[1]);
    double depth = 0.0;
    for (long k = 0; depth < opaque; ++k) {
        const double a = enter + static_cast<double>(k) * step;
        if (!(a < exit)) break;
        const double length = std::min(step, exit - a);
        const glm::dvec3 p = o + (a + 0.5 * length) * d;
        int i[3];
        double t[3];
        for (int axis = 0; axis < 3; ++axis) {
            const double f = std::clamp((p[axis] - m_lo[axis]) * inv_h, 0.0, double(m_n[axis] - 1));
            i[axis] = std::min(static_cast<int>(f), m_n[axis] - 2);
            t[axis] = f - i[axis];
        }
        if (m_empty[block(i[0] / kBlock, i[1] / kBlock, i[2] / kBlock)]) {
            // Step over the rest of this block: to the first step whose middle lies past the
            // block's exit (the next sample then finds where it is).
            double leave = INFINITY;
            for (int axis = 0; axis < 3; ++axis) {
                if (d[axis] == 0.0) continue;
                const int b = i[axis] / kBlock;
                const int face = d[axis] > 0.0 ? std::min((b + 1) * kBlock, m_n[axis] - 1) : b * kBlock;
                leave = std::min(leave, (m_lo[axis] + face * m_h - o[axis]) / d[axis]);
            }
            const double next = std::ceil((leave - enter) / step - 0.5);
            if (next > static_cast<double>(k + 1)) k = static_cast<long>(std::min(next, 1e15)) - 1;
            continue;
        }
        // Trilinear in x, then y, then z, of both fields at once.
        const float* c = &m_lookup[2 * node(i[0], i[1], i[2])];
        auto x = [&](size_t n, int field) { return (1 - t[0]) * c[n + field] + t[0] * c[n + 2 + field]; };
        auto yz = [&](int field) {
            const double y0 = (1 - t[1]) * x(0, field) + t[1] * x(sy, field);
            const double y1 = (1 - t[1]) * x(sz, field) + t[1] * x(sz + sy, field);
            return (1 - t[2]) * y0 + t[2] * y1;
        };
        const double extinction = yz(0);
        if (!(extinction > 0.0)) continue;
        visit(k, length, extinction, yz(1));
        depth += extinction * length;
    }
}

namespace {

/// The transmittance from a march's start to the middle of a step of `length` (m) through
/// `extinction` (1/m), `depth` the optical depth before the step. expf: a step's light is a
/// sum's term, where single precision's 1e-7 is far below the midpoint rule's own error, and it
/// costs half of exp (the march evaluates one at every step of every marched ray).
double step_transmittance(double depth, double extinction, double length) {
    return std::exp(static_cast<float>(-(depth + 0.5 * extinction * length)));
}

}  // namespace

double DustGrid::march(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step,
                       double opaque, double& lit) const {
    double depth = 0.0;
    lit = 0.0;
    walk(origin, dir, enter, exit, step, opaque, [&](long, double length, double extinction, double sunlight) {
        lit += step_transmittance(depth, extinction, length) * extinction * sunlight * length;
        depth += extinction * length;
    });
    return depth;
}

void DustGrid::march_profile(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step,
                             double opaque, std::vector<double>& tau, std::vector<double>& lit) const {
    const auto count = static_cast<size_t>(std::max(0.0, std::ceil((exit - enter) / step)));
    tau.assign(count + 1, 0.0);
    lit.assign(count + 1, 0.0);
    size_t filled = 0;  // tau[0 .. filled] hold their final sums
    double depth = 0.0, light = 0.0;
    walk(origin, dir, enter, exit, step, opaque, [&](long k, double length, double extinction, double sunlight) {
        const auto j = static_cast<size_t>(k);
        for (; filled < j; ++filled) tau[filled + 1] = depth, lit[filled + 1] = light;  // steps without dust
        light += step_transmittance(depth, extinction, length) * extinction * sunlight * length;
        depth += extinction * length;
        tau[j + 1] = depth, lit[j + 1] = light;
        filled = j + 1;
    });
    for (; filled < count; ++filled) tau[filled + 1] = depth, lit[filled + 1] = light;
}

double DustGrid::sun_transmittance(const glm::dvec3& point) const {
    double enter, exit;
    if (!clip(point, m_sun, INFINITY, enter, exit)) return 1.0;  // its Sun ray misses all the dust
    if (enter == 0.0) return std::exp(-trilinear(m_sun_depth, frame(point)));  // inside the grid
    double tau = 0.0;
    for (size_t k = 0; k < m_medium.puffs.size(); ++k) {
        const Puff& puff = m_medium.puffs[k];
        const double r = m_reach[k];
        if (r <= 0.0) continue;
        const glm::dvec3 p = point - puff.centre;
        const double b = glm::dot(p, m_sun);
        if (glm::dot(p, p) - b * b >= r * r || b >= r) continue;  // beside it, or beyond it
        tau += optical_depth(puff, point, m_sun, INFINITY);
    }
    return std::exp(-tau);
}

}  // namespace moonbot
