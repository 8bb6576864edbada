#include "moonbot/dust.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <glm/gtc/quaternion.hpp>

#include "moonbot/render.h"  // kMaxThreads
#include "moonbot/rng.h"
#include "rays.h"               // set_ray

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
// A fragment that bounces more often than this in one flight is put to rest: after so many
// bounces at restitution ≤ 0.95 its normal speed is gone, and it guards the loop.
constexpr int kMaxBounces = 1000;
// How far above and below the emitter's origin a fragment's spawn point looks for the ground, metres.
constexpr double kSpawnProbe = 1.0;
// The spawn looks for the surface under the fragment's centre and under this many points on a
// circle around it, of its radius over (cos − sin)(π / points): with the points that far out, no
// plan corner of 90° or more (a bag's, a rock's) reaches into the fragment's footprint between
// them unseen.
constexpr int kFootprintPoints = 16;
// Climbing out of solids (a probe that starts inside a bag or under the ground) gives up after
// this many exits; each exit is one solid passed through.
constexpr int kMaxExits = 64;
// After a bounce or a push-out, a fragment is lifted off the surface by this much of its largest
// coordinate (of 1 m at least): float32 traversal resolves positions to ~6e-8 of their
// magnitude, so the next rays start clearly in front of the surface.
constexpr double kLift = 2e-6;
// Dimensions of the fragment's random numbers (key: the seed's ejecta stream, fragment, burst).
enum Dim : uint32_t { kSpawnR, kSpawnPhi, kCone, kAzimuth, kSpeed, kDiameter };

const glm::dvec3 kUp(0.0, 0.0, 1.0);

void require(bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw std::invalid_argument(field + ": " + what);
}

/// `point` moved along the unit `normal` by kLift of its largest coordinate (of 1 m at least).
glm::dvec3 lifted(const glm::dvec3& point, const glm::dvec3& normal) {
    const double scale = std::max({1.0, std::abs(point.x), std::abs(point.y), std::abs(point.z)});
    return point + normal * (kLift * scale);
}

/// The first surface a ray meets: its distance `t` (metres along the unit direction), its unit
/// normal in the world facing out of its solid (up, for the ground), and whether the ray met it
/// from behind — that is, started inside a solid or under the ground.
struct Contact {
    bool hit = false;
    double t = 0.0;
    glm::dvec3 normal{0.0};
    bool from_behind = false;
};

/// The first surface along the ray from `from` in the unit direction `dir`, within `reach` metres.
/// Surfaces face the side their triangles wind counter-clockwise on (Embree's geometric normal):
/// out of closed meshes, up from the ground.
Contact first_contact(const Scene& scene, const glm::dvec3& from, const glm::dvec3& dir, double reach) {
    RayHit ray{};
    detail::set_ray(ray, from, dir);
    ray.tfar = static_cast<float>(reach);
    scene.accel().intersect_single(&ray, 1);  // one ray: no stream to build
    Contact c;
    if (ray.geom_id == kInvalidId) return c;
    const Instance& inst = scene.instance(ray.inst_id);
    const glm::dvec3 n = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
    c.hit = true;
    c.t = static_cast<double>(ray.tfar);
    c.normal = n / glm::length(n);
    c.from_behind = glm::dot(c.normal, dir) > 0.0;
    return c;
}

/// How high the vertical line through `point` must climb to be out of every solid (and above
/// the ground) it is in at `point`: the height of the last surface it leaves from behind, or
/// point.z when it is in none. Going up, a ray from inside a solid meets its surface from behind
/// first, and one from outside meets a surface from the front, or nothing.
double climb_out(const Scene& scene, glm::dvec3 point) {
    const double inf = std::numeric_limits<double>::infinity();
    for (int exits = 0; exits < kMaxExits; ++exits) {
        const Contact up = first_contact(scene, point, kUp, inf);
        if (!up.hit || !up.from_behind) break;
        point = lifted(point + kUp * up.t, kUp);
    }
    return point.z;
}

/// The height of the topmost surface under (x, y) between `probe_z` and `floor_z`: the first
/// surface met coming down from `probe_z` — from above any solid `probe_z` is inside — to
/// `floor_z`. NaN where there is none.
double surface_below(const Scene& scene, double x, double y, double probe_z, double floor_z) {
    glm::dvec3 start(x, y, probe_z);
    Contact down = first_contact(scene, start, -kUp, start.z - floor_z);
    if (down.from_behind) {  // the probe starts inside a solid (a bag stacked high): start above it
        start.z = climb_out(scene, start);
        down = first_contact(scene, start, -kUp, start.z - floor_z);
    }
    return down.hit ? start.z - down.t : std::numeric_limits<double>::quiet_NaN();
}

/// Where a fragment starts, given the seed's ejecta stream, its index and burst.
Fragment launch(const Scene& scene, const EjectaParams& p, uint64_t stream, uint32_t index, uint32_t burst) {
    auto u = [&](uint32_t dim) { return static_cast<double>(stream_uniform01(stream, index, burst * 8u + dim)); };
    Fragment f{};
    f.index = index;
    f.burst = burst;
    f.diameter_m = p.min_diameter_m + u(kDiameter) * (p.max_diameter_m - p.min_diameter_m);
    const double radius = f.diameter_m / 2;
    const double r = p.spawn_radius_m * std::sqrt(u(kSpawnR)), phi = 2 * kPi * u(kSpawnPhi);
    f.position = p.origin + glm::dvec3(r * std::cos(phi), r * std::sin(phi), 0.0);
    // Lying on whatever is under it (the ground is rarely level at the origin's height, and a bag
    // may be there): its bounding sphere, which holds its whole mesh in any orientation, clear of
    // the highest surface under its footprint by kSpawnClearance. On a plane of slope s that keeps
    // every point of the sphere at least that high above the plane: the footprint's highest point
    // is at least s·radius above the centre's.
    const double probe_z = p.origin.z + kSpawnProbe, floor_z = p.origin.z - kSpawnProbe;
    const double step = kPi / kFootprintPoints;
    const double reach = radius / (std::cos(step) - std::sin(step));
    double ground = surface_below(scene, f.position.x, f.position.y, probe_z, floor_z);
    for (int k = 0; k < kFootprintPoints; ++k) {
        const double a = 2 * step * k;
        const double z = surface_below(scene, f.position.x + reach * std::cos(a), f.position.y + reach * std::sin(a),
                                       probe_z, floor_z);
        if (std::isnan(ground) || z > ground) ground = z;
    }
    f.position.z = (std::isnan(ground) ? p.origin.z : ground) + kSpawnClearance + radius;
    // A solid reaching into the sphere between the probed lines (a corner sharper than 90°)
    // could still hold its centre or lowest point: then it starts on top of that solid.
    for (int exits = 0; exits < kMaxExits; ++exits) {
        const double low = f.position.z - radius;
        const double low_out = climb_out(scene, glm::dvec3(f.position.x, f.position.y, low));
        const double centre_out = climb_out(scene, f.position);
        if (low_out == low && centre_out == f.position.z) break;
        f.position.z = std::max(low_out, centre_out) + kSpawnClearance + radius;
    }
    // Uniform over the cone's solid angle about +z.
    const double cos_max = std::cos(p.cone_half_angle_deg * kPi / 180.0);
    const double c = 1.0 - u(kCone) * (1.0 - cos_max), s = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double az = 2 * kPi * u(kAzimuth);
    const double speed = p.mean_speed_m_s * (0.5 + u(kSpeed));
    f.velocity = speed * glm::dvec3(s * std::cos(az), s * std::sin(az), c);
    return f;
}

/// fly_fragment without the argument checks (simulate_ejecta has made them once for all).
void fly(const Scene& scene, const EjectaParams& p, Fragment& f, double duration, double dt) {
    const glm::dvec3 g(0.0, 0.0, -p.gravity_m_s2);
    // The fragment collides as the vertical segment from its lowest point up to its centre: the
    // lowest point meets the ground, the centre meets overhangs and walls first. Both start every
    // step in free space; a ray along the step's chord from each finds the first contact.
    const glm::dvec3 leg(0.0, 0.0, f.diameter_m / 2);
    while (f.age_s < duration && !f.resting) {
        const double h = std::min(dt, duration - f.age_s);
        const glm::dvec3 chord = f.velocity * h + 0.5 * g * (h * h);
        const double length = glm::length(chord);
        Contact low, centre;
        glm::dvec3 dir(0.0);
        if (length > 0.0) {
            dir = chord / length;
            low = first_contact(scene, f.position - leg, dir, length);
            centre = first_contact(scene, f.position, dir, length);
        }
        if (low.from_behind || centre.from_behind) {
            // A ray that meets a surface from behind started inside a solid or under the ground:
            // not a contact but a fragment where no valid step can take it (launched there, or a
            // float rounding of a contact). Bouncing off the back of the surface would send it
            // further in; instead it is put back out in front of the surface, along the surface's
            // normal by the depth the ray found there, and the step is taken again. Time does
            // not pass and its velocity (which the chord shows leaving the solid) is kept.
            const Contact& behind = low.from_behind ? low : centre;
            const double depth = behind.t * glm::dot(dir, behind.normal);
            f.position = lifted(f.position + behind.normal * depth, behind.normal);
            if (++f.corrections >= kMaxCorrections) {
                f.velocity = glm::dvec3(0.0);
                f.resting = true;
                f.flight_s = f.age_s;
                f.age_s = duration;
            }
            continue;
        }
        const Contact& first = (centre.hit && (!low.hit || centre.t < low.t)) ? centre : low;
        if (!first.hit) {
            f.position += chord;
            f.velocity += g * h;
            f.age_s += h;
            f.flight_s = f.age_s;
            continue;
        }
        // Contact after the chord's fraction s of the step: the chord is parametrised nearly
        // uniformly in time, and it lies below the parabola, so the fragment never gains energy.
        const double s = std::clamp(first.t / length, 0.0, 1.0);
        const double tau = s * h;
        const glm::dvec3& n = first.normal;  // met from the front: the side the fragment is on
        f.position += chord * s;
        const glm::dvec3 v = f.velocity + g * tau;
        const double vn = glm::dot(v, n);  // < 0: into the surface
        const glm::dvec3 vt = v - vn * n;
        const double impulse = (1.0 + p.restitution) * std::max(0.0, -vn);
        const double speed_t = glm::length(vt);
        const double kept_t = speed_t > 0.0 ? std::max(0.0, speed_t - p.friction * impulse) / speed_t : 0.0;
        const double rebound = -p.restitution * std::min(vn, 0.0);
        f.velocity = rebound * n + vt * kept_t;
        f.age_s += tau;
        ++f.bounces;
        f.flight_s = f.age_s;
        if (rebound < p.rest_speed_m_s || f.bounces >= kMaxBounces) {
            // Too slow to leave the surface again: at rest where it touched (a micro-bounce would
            // otherwise repeat endlessly).
            f.velocity = glm::dvec3(0.0);
            f.resting = true;
            f.age_s = duration;
        }
        // Lift off the surface by a hair so the next chord does not start inside it.
        f.position = lifted(f.position, n);
    }
}

}  // namespace

void fly_fragment(const Scene& scene, const EjectaParams& params, Fragment& f, double duration, double dt) {
    params.validate();
    require(dt > 0.0 && dt <= kMaxDustStep, "dt", "must be in (0, " + std::to_string(kMaxDustStep) + "]");
    require(std::isfinite(duration), "duration", "must be finite");
    require(std::isfinite(f.position.x) && std::isfinite(f.position.y) && std::isfinite(f.position.z) &&
                std::isfinite(f.velocity.x) && std::isfinite(f.velocity.y) && std::isfinite(f.velocity.z) &&
                std::isfinite(f.age_s),
            "fragment", "position, velocity and age must be finite");
    require(f.diameter_m > 0.0 && std::isfinite(f.diameter_m), "fragment.diameter_m", "must be positive and finite");
    const Scene::ReadLock lock(scene);
    require(scene.committed(), "scene", "not committed (call commit() after adding geometry)");
    fly(scene, params, f, duration, dt);
}

FragmentMesh fragment_mesh(const std::vector<Fragment>& fragments, uint64_t seed) {
    // The regular icosahedron: 12 vertices (0, ±1, ±φ) cyclically, 20 faces, outward winding.
    static const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
    static const glm::dvec3 ico[12] = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                                       {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                                       {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
    static const uint32_t faces[kFragmentTriangles][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                          {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                          {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                          {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    const double ico_radius = std::sqrt(1.0 + phi * phi);
    const uint64_t stream = pixel_stream(seed, 0xE7EC7A0000000001ull);  // shapes: their own stream
    FragmentMesh mesh;
    mesh.vertices.reserve(fragments.size() * kFragmentVertices * 3);
    mesh.triangles.reserve(fragments.size() * kFragmentTriangles * 3);
    for (const Fragment& f : fragments) {
        auto u = [&](uint32_t dim) {
            return static_cast<double>(stream_uniform01(stream, f.index, f.burst * 32u + dim));
        };
        // A uniform random orientation (Shoemake 1992, from three uniforms) ...
        const double u1 = u(0), a1 = 2 * kPi * u(1), a2 = 2 * kPi * u(2);
        const glm::dquat q0(std::sqrt(u1) * std::cos(a2), std::sqrt(1 - u1) * std::sin(a1),
                            std::sqrt(1 - u1) * std::cos(a1), std::sqrt(u1) * std::sin(a2));
        // ... turned about a uniform axis at up to 3 turns/s for as long as it has flown.
        const double cz = 2 * u(3) - 1, az = 2 * kPi * u(4), sz = std::sqrt(std::max(0.0, 1 - cz * cz));
        const glm::dvec3 axis(sz * std::cos(az), sz * std::sin(az), cz);
        const double angle = 2 * kPi * 3.0 * u(5) * f.flight_s;
        const glm::dmat3 R = glm::mat3_cast(glm::angleAxis(angle, axis) * q0);
        const auto base = static_cast<uint32_t>(mesh.vertices.size() / 3);
        for (int k = 0; k < kFragmentVertices; ++k) {
            const double radius = f.diameter_m / 2 * (0.6 + 0.4 * u(6 + static_cast<uint32_t>(k)));
            const glm::dvec3 p = f.position + R * (ico[k] * (radius / ico_radius));
            for (int c = 0; c < 3; ++c) mesh.vertices.push_back(static_cast<float>(p[c]));
        }
        for (const auto& face : faces)
            for (uint32_t c : face) mesh.triangles.push_back(base + c);
    }
    return mesh;
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

void CloudParams::validate() const {
    require(std::isfinite(origin.x) && std::isfinite(origin.y) && std::isfinite(origin.z), "origin", "must be finite");
    for (int c = 0; c < 3; ++c)
        require(box_m[c] >= 0.0 && box_m[c] <= 1000.0, "box_m", "each side must be in [0, 1000]");
    require(std::abs(vertical_offset_m) <= 1000.0, "vertical_offset_m", "must be in [-1000, 1000]");
    require(std::isfinite(glm::length(axis)) && glm::length(axis) > 0.0, "axis", "must be finite and non-zero");
    require(cone_half_angle_deg >= 0.0 && cone_half_angle_deg <= 180.0, "cone_half_angle_deg", "must be in [0, 180]");
    require(speed_m_s >= 0.0 && speed_m_s <= 100.0, "speed_m_s", "must be in [0, 100]");
    require(gravity_m_s2 >= 0.0 && gravity_m_s2 <= 100.0, "gravity_m_s2", "must be in [0, 100]");
    require(lifetime_s > 0.0 && lifetime_s <= 3600.0, "lifetime_s", "must be in (0, 3600]");
    require(rate_per_s >= 0.0 && rate_per_s * lifetime_s <= 100000.0, "rate_per_s",
            "must be >= 0 with at most 100000 puffs alive (rate_per_s × lifetime_s)");
    require(sigma_m > 0.0 && sigma_m <= 100.0, "sigma_m", "must be in (0, 100]");
    require(growth_m_s >= 0.0 && growth_m_s <= 100.0, "growth_m_s", "must be in [0, 100]");
    require(optical_depth >= 0.0 && optical_depth <= 100.0, "optical_depth", "must be in [0, 100]");
    require(rise_fraction > 0.0 && rise_fraction < 1.0, "rise_fraction", "must be in (0, 1)");
}

std::vector<Puff> cloud_puffs(const CloudParams& p, uint64_t seed, double time_s) {
    p.validate();
    require(std::isfinite(time_s) && time_s >= 0.0, "time_s", "must be finite and >= 0");
    std::vector<Puff> puffs;
    if (p.rate_per_s == 0.0 || p.optical_depth == 0.0) return puffs;
    // Puff k is born at k / rate: those alive now were born in (time − lifetime, time].
    const double first = std::max(0.0, std::floor((time_s - p.lifetime_s) * p.rate_per_s) + 1.0);
    const double last = std::floor(time_s * p.rate_per_s);
    require(last < 4.0e9, "time_s", "too many puffs since time 0 for their random keys");
    const uint64_t stream = pixel_stream(seed, 0xC10D000000000000ull);  // the cloud's own stream
    const glm::dvec3 w = glm::normalize(p.axis);
    // A basis across the cone's axis (any will do: the cone is round).
    const glm::dvec3 helper = std::abs(w.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
    const glm::dvec3 a = glm::normalize(glm::cross(helper, w)), b = glm::cross(w, a);
    const double cos_max = std::cos(p.cone_half_angle_deg * kPi / 180.0);
    const glm::dvec3 g(0.0, 0.0, -p.gravity_m_s2);
    for (double k = first; k <= last; k += 1.0) {
        const auto key = static_cast<uint32_t>(k);
        auto u = [&](uint32_t dim) { return static_cast<double>(stream_uniform01(stream, key, dim)); };
        const double age = time_s - k / p.rate_per_s;
        const double life = age / p.lifetime_s;
        if (!(life >= 0.0 && life < 1.0)) continue;
        const glm::dvec3 start = p.origin + glm::dvec3((u(0) - 0.5) * p.box_m.x, (u(1) - 0.5) * p.box_m.y,
                                                       p.vertical_offset_m + (u(2) - 0.5) * p.box_m.z);
        const double c = 1.0 - u(3) * (1.0 - cos_max), s = std::sqrt(std::max(0.0, 1.0 - c * c));
        const double phi = 2 * kPi * u(4);
        const glm::dvec3 velocity = p.speed_m_s * (c * w + s * (std::cos(phi) * a + std::sin(phi) * b));
        const double opacity =
            life < p.rise_fraction ? life / p.rise_fraction : std::pow((1.0 - life) / (1.0 - p.rise_fraction), 2.0);
        Puff puff;
        puff.centre = start + velocity * age + 0.5 * g * (age * age);
        puff.sigma_m = p.sigma_m + p.growth_m_s * age;
        // τ through the centre of a Gaussian is peak·σ·√(2π).
        puff.peak_extinction = p.optical_depth * opacity / (puff.sigma_m * std::sqrt(2.0 * kPi));
        if (puff.peak_extinction > 0.0) puffs.push_back(puff);
    }
    return puffs;
}

std::vector<Fragment> simulate_ejecta(const Scene& scene, const EjectaParams& params, uint64_t seed, double time_s,
                                      double dt_s, int threads) {
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
                Fragment f = launch(scene, params, stream, static_cast<uint32_t>(i), burst_index);
                fly(scene, params, f, flight, dt_s);
                fragments[static_cast<size_t>(i)] = f;
            }
        });
    });
    return fragments;
}

}  // namespace moonbot
