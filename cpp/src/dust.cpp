#include "moonbot/dust.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/render.h"  // kMaxThreads
#include "moonbot/rng.h"
#include "rays.h"               // set_ray

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
// A fragment that bounces more often than this in one flight is put to rest: after so many
// bounces at restitution ≤ 0.95 its normal speed is gone, and it guards the loop.
constexpr int kMaxBounces = 1000;
// Dimensions of the fragment's random numbers (key: the seed's ejecta stream, fragment, burst).
enum Dim : uint32_t { kSpawnR, kSpawnPhi, kCone, kAzimuth, kSpeed, kDiameter };

void require(bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw std::invalid_argument(field + ": " + what);
}

/// Where a fragment starts, given the seed's ejecta stream, its index and burst.
Fragment launch(const EjectaParams& p, uint64_t stream, uint32_t index, uint32_t burst) {
    auto u = [&](uint32_t dim) { return static_cast<double>(stream_uniform01(stream, index, burst * 8u + dim)); };
    Fragment f{};
    f.diameter_m = p.min_diameter_m + u(kDiameter) * (p.max_diameter_m - p.min_diameter_m);
    const double r = p.spawn_radius_m * std::sqrt(u(kSpawnR)), phi = 2 * kPi * u(kSpawnPhi);
    // Resting on the ground at the emitter: centre one radius up.
    f.position = p.origin + glm::dvec3(r * std::cos(phi), r * std::sin(phi), f.diameter_m / 2);
    // Uniform over the cone's solid angle about +z.
    const double cos_max = std::cos(p.cone_half_angle_deg * kPi / 180.0);
    const double c = 1.0 - u(kCone) * (1.0 - cos_max), s = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double az = 2 * kPi * u(kAzimuth);
    const double speed = p.mean_speed_m_s * (0.5 + u(kSpeed));
    f.velocity = speed * glm::dvec3(s * std::cos(az), s * std::sin(az), c);
    return f;
}

/// Flies `f` for `duration` seconds in steps of at most `dt`, bouncing on `scene`.
void fly(const Scene& scene, const EjectaParams& p, Fragment& f, double duration, double dt) {
    const glm::dvec3 g(0.0, 0.0, -p.gravity_m_s2);
    const glm::dvec3 down(0.0, 0.0, -1.0);
    while (f.age_s < duration && !f.resting) {
        const double h = std::min(dt, duration - f.age_s);
        const glm::dvec3 next = f.position + f.velocity * h + 0.5 * g * (h * h);
        // The chord of the fragment's lowest point: contact is that point meeting the ground.
        const glm::dvec3 from = f.position + down * (f.diameter_m / 2);
        const glm::dvec3 chord = next - f.position;
        const double length = glm::length(chord);
        RayHit ray{};
        if (length > 0.0) {
            detail::set_ray(ray, from, chord / length);
            ray.tfar = static_cast<float>(length);
            scene.accel().intersect_single(&ray, 1);  // one ray: no stream to build
        }
        if (length == 0.0 || ray.geom_id == kInvalidId) {
            f.position = next;
            f.velocity += g * h;
            f.age_s += h;
            continue;
        }
        // Contact after the chord's fraction s of the step: the chord is parametrised nearly
        // uniformly in time, and it lies below the parabola, so the fragment never gains energy.
        const double s = std::clamp(static_cast<double>(ray.tfar) / length, 0.0, 1.0);
        const double tau = s * h;
        const Instance& inst = scene.instance(ray.inst_id);
        glm::dvec3 n = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
        n /= glm::length(n);
        if (glm::dot(n, chord) > 0.0) n = -n;  // the side the fragment came from
        f.position += chord * s;
        const glm::dvec3 v = f.velocity + g * tau;
        const double vn = glm::dot(v, n);  // < 0: into the ground
        const glm::dvec3 vt = v - vn * n;
        const double impulse = (1.0 + p.restitution) * std::max(0.0, -vn);
        const double speed_t = glm::length(vt);
        const double kept_t = speed_t > 0.0 ? std::max(0.0, speed_t - p.friction * impulse) / speed_t : 0.0;
        const double rebound = -p.restitution * std::min(vn, 0.0);
        f.velocity = rebound * n + vt * kept_t;
        f.age_s += tau;
        ++f.bounces;
        if (rebound < p.rest_speed_m_s || f.bounces >= kMaxBounces) {
            // Too slow to leave the ground again: at rest where it touched (a micro-bounce would
            // otherwise repeat endlessly).
            f.velocity = glm::dvec3(0.0);
            f.resting = true;
            f.age_s = duration;
        }
        // Lift off the surface by a hair so the next chord does not start inside it.
        const double scale = std::max({1.0, std::abs(f.position.x), std::abs(f.position.y), std::abs(f.position.z)});
        f.position += n * (2e-6 * scale);
    }
}

}  // namespace

double optical_depth(const Puff& puff, const glm::dvec3& origin, const glm::dvec3& dir, double t_max) {
    if (!(t_max > 0.0) || puff.peak_extinction == 0.0) return 0.0;
    const glm::dvec3 p = origin - puff.centre;
    const double b = glm::dot(p, dir);
    const double q2 = std::max(0.0, glm::dot(p, p) - b * b);
    const double s = puff.sigma_m * std::sqrt(2.0);
    // erf(x) − erf(y) = erfc(y) − erfc(x); for a ray starting past the centre (b > 0) the erfc
    // form keeps the digits that the difference of two erfs near 1 would lose.
    const bool endless = std::isinf(t_max);
    const double span = b > 0.0 ? std::erfc(b / s) - (endless ? 0.0 : std::erfc((t_max + b) / s))
                                : (endless ? 1.0 : std::erf((t_max + b) / s)) - std::erf(b / s);
    return puff.peak_extinction * std::exp(-q2 / (2.0 * puff.sigma_m * puff.sigma_m)) * puff.sigma_m *
           std::sqrt(kPi / 2.0) * span;
}

void EjectaParams::validate() const {
    require(std::isfinite(origin.x) && std::isfinite(origin.y) && std::isfinite(origin.z), "origin", "must be finite");
    require(spawn_radius_m >= 0.0 && spawn_radius_m <= 100.0, "spawn_radius_m", "must be in [0, 100]");
    require(count >= 0 && count <= 1000000, "count", "must be in 0..1000000");
    require(cone_half_angle_deg >= 0.0 && cone_half_angle_deg <= 90.0, "cone_half_angle_deg", "must be in [0, 90]");
    require(mean_speed_m_s >= 0.0 && mean_speed_m_s <= 100.0, "mean_speed_m_s", "must be in [0, 100]");
    require(min_diameter_m > 0.0 && min_diameter_m <= max_diameter_m && max_diameter_m <= 1.0, "min_diameter_m",
            "must satisfy 0 < min_diameter_m <= max_diameter_m <= 1");
    require(gravity_m_s2 >= 0.0 && gravity_m_s2 <= 100.0, "gravity_m_s2", "must be in [0, 100]");
    require(restitution >= 0.0 && restitution <= 0.95, "restitution", "must be in [0, 0.95]");
    require(friction >= 0.0 && friction <= 10.0, "friction", "must be in [0, 10]");
    require(rest_speed_m_s > 0.0 && rest_speed_m_s <= 10.0, "rest_speed_m_s", "must be in (0, 10]");
    require(burst_period_s > 0.0 && burst_period_s <= 3600.0, "burst_period_s", "must be in (0, 3600]");
}

std::vector<Fragment> simulate_ejecta(const Scene& scene, const EjectaParams& params, uint64_t seed,
                                      double time_s, double dt_s, int threads) {
    params.validate();
    require(std::isfinite(time_s) && time_s >= 0.0, "time_s", "must be finite and >= 0");
    require(dt_s > 0.0 && dt_s <= kMaxDustStep, "dt_s", "must be in (0, " + std::to_string(kMaxDustStep) + "]");
    require(threads >= 0 && threads <= kMaxThreads, "threads", "must be in 0.." + std::to_string(kMaxThreads));
    const Scene::ReadLock lock(scene);
    require(scene.committed(), "scene", "not committed (call commit() after adding geometry)");
    const double burst = std::floor(time_s / params.burst_period_s);
    const double flight = time_s - burst * params.burst_period_s;
    require(burst < 4.0e9, "time_s", "too many bursts for the fragments' random keys");
    const auto burst_index = static_cast<uint32_t>(burst);
    const uint64_t stream = pixel_stream(seed, 0xE7EC7A0000000000ull);  // the ejecta's own stream
    std::vector<Fragment> fragments(static_cast<size_t>(params.count));
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, params.count), [&](const auto& range) {
            for (int i = range.begin(); i != range.end(); ++i) {
                Fragment f = launch(params, stream, static_cast<uint32_t>(i), burst_index);
                fly(scene, params, f, flight, dt_s);
                fragments[static_cast<size_t>(i)] = f;
            }
        });
    });
    return fragments;
}

}  // namespace moonbot
