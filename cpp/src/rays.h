// Internal to the core: how camera and shadow rays are made and how hits are resolved, shared by
// the renderer and the Embree-limit probe so both trace exactly the same rays.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/glm.hpp>

#include "moonbot/accel.h"
#include "moonbot/scene.h"

namespace moonbot::detail {

constexpr int kTile = 8;  // 8×8 = 64 pixels: one coherent Embree ray stream per tile and pass
constexpr int kTilePixels = kTile * kTile;

// Shadow rays start this far above the surface, relative to the magnitude of the hit position:
// float32 traversal resolves positions to ~6e-8 of their magnitude, so 2e-5 clears self-hits by
// two orders of magnitude (no acne at grazing Sun) while staying far below any feature we model.
constexpr double kShadowBias = 2e-5;

/// A primary hit resolved in double precision. Only what every pass needs is computed here;
/// the unit normal and the hit point are derived by `surface()` for the hits that get shaded.
struct SurfaceHit {
    bool hit = false;
    double t = 0.0;        // ray parameter = z-depth (camera-z of the direction is 1)
    glm::dvec3 n_raw{};    // world geometric normal, unnormalised, either side
    double denom = 0.0;    // n_raw · dir: its sign tells which side the ray hit
    uint32_t instance = 0;
};

/// Recomputes the hit distance in double: Embree's float t carries an error proportional to the
/// scene's coordinates; the intersection with the triangle's plane in double does not. The plane
/// is Embree's geometric normal (exact enough: its float rounding moves t by ~1e-7 of the
/// triangle's size) through the triangle's first vertex, so one vertex is fetched, not three.
/// With `exact` false, Embree's t is kept and no vertex is fetched. Writes into `s` in place:
/// returning the struct by value made every pixel pay a store-forwarding stall (its one-byte
/// `hit` flag stored, then re-read as part of 16-byte copies).
inline void resolve(const Scene& scene, const glm::dvec3& origin, const glm::dvec3& dir,
                    const RayHit& ray, bool exact, SurfaceHit& s) {
    s.hit = ray.geom_id != kInvalidId;
    if (!s.hit) return;
    s.instance = ray.inst_id;
    const Instance& inst = scene.instance(ray.inst_id);
    s.n_raw = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
    s.denom = glm::dot(s.n_raw, dir);
    s.t = ray.tfar;
    if (!exact) return;
    const Mesh& mesh = scene.mesh(inst.mesh);
    const uint32_t first = mesh.triangles[3 * static_cast<size_t>(ray.prim_id)];
    const glm::dvec3 v0 = inst.linear * mesh.vertex(first) + inst.translation;
    // A ray nearly parallel to the plane: the double solve is ill-conditioned, keep Embree's t.
    // (Squared comparison: no square roots on the per-pixel path.)
    if (s.denom * s.denom > 1e-24 * glm::dot(s.n_raw, s.n_raw) * glm::dot(dir, dir)) {
        const double t = glm::dot(s.n_raw, v0 - origin) / s.denom;
        if (t > 0.0) s.t = t;
    }
}

/// Hit point (world, metres) and unit normal facing the incoming ray, for shading.
struct Surface {
    glm::dvec3 point;
    glm::dvec3 normal;
};

inline Surface surface(const SurfaceHit& h, const glm::dvec3& origin, const glm::dvec3& dir) {
    const double n_len = glm::length(h.n_raw);
    glm::dvec3 n = n_len > 0.0 ? h.n_raw / n_len : glm::dvec3(0.0, 0.0, 1.0);
    if (glm::dot(n, dir) > 0.0) n = -n;
    return {origin + h.t * dir, n};
}

inline void set_ray(RayHit& r, const glm::dvec3& o, const glm::dvec3& d) {
    r.org_x = static_cast<float>(o.x);
    r.org_y = static_cast<float>(o.y);
    r.org_z = static_cast<float>(o.z);
    r.tnear = 0.0f;
    r.dir_x = static_cast<float>(d.x);
    r.dir_y = static_cast<float>(d.y);
    r.dir_z = static_cast<float>(d.z);
    r.time = 0.0f;
    r.tfar = std::numeric_limits<float>::infinity();
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

/// The shadow ray toward the Sun (unit `to_sun`) from a shaded surface point, offset along the
/// normal. Returns false, and makes no ray, when the surface faces away from the Sun.
inline bool shadow_ray(const Surface& s, const glm::dvec3& to_sun, RayHit& ray) {
    if (glm::dot(s.normal, to_sun) <= 0.0) return false;
    const double scale = std::max({1.0, std::abs(s.point.x), std::abs(s.point.y), std::abs(s.point.z)});
    set_ray(ray, s.point + s.normal * (kShadowBias * scale), to_sun);
    return true;
}

}  // namespace moonbot::detail
