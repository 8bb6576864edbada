// Internal to the core: how camera and shadow rays are made and how hits are resolved, shared by
// the renderer and the Embree-limit probe so both trace exactly the same rays.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/accel.h"
#include "moonbot/camera.h"
#include "moonbot/light.h"
#include "moonbot/sampler.h"
#include "moonbot/scene.h"
#include "orthonormal_basis.h"

namespace moonbot::detail {

constexpr int kTile = 8;  // 8×8 = 64 pixels: one Embree ray stream per tile and pass
constexpr int kTilePixels = kTile * kTile;

// Rays leaving a surface start above it, by the larger of two bounds on where float32 traversal
// puts the surface. kShadowBias of the point's largest coordinate (of 1 m at least): float32
// resolves a position to ~6e-8 of its magnitude, so 2e-5 clears self-hits by two orders of
// magnitude (no acne at grazing Sun) while staying far below any feature we model. And
// kTriangleBias of the triangle's largest vertex coordinate (triangle_reach): Embree tests a
// triangle with its vertices relative to the ray's origin, in float32, so a triangle kilometres
// across is placed only to ~1e-4 m even where the hit is near the origin; 1e-6 is 16 float32 ulps.
constexpr double kShadowBias = 2e-5;
constexpr double kTriangleBias = 1e-6;

/// The largest coordinate magnitude of `p` (∞-norm), metres.
inline double largest_coordinate(const glm::dvec3& p) {
    return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
}

/// Where rays leaving a surface start: `point` moved off the surface along the unit `normal` (on
/// the side they leave from) by the larger of kShadowBias of its largest coordinate (of 1 m at
/// least) and kTriangleBias of `reach`, the largest coordinate of the triangle it lies on.
inline glm::dvec3 lift_off(const glm::dvec3& point, const glm::dvec3& normal, double reach) {
    const double scale = std::max(1.0, largest_coordinate(point));
    return point + normal * std::max(kShadowBias * scale, kTriangleBias * reach);
}

/// A cosine-distributed unit direction about the unit `normal` (Malley's method: a uniform point
/// on the unit disk, radius √u1 and angle 2π·u2, lifted onto the hemisphere), u1, u2 in [0, 1);
/// `mu` receives its cosine to the normal. How the renderer's bounces leave a surface, and so the
/// Embree-limit probe's bounce rays.
inline glm::dvec3 cosine_direction(const glm::dvec3& normal, double u1, double u2, double& mu) {
    const double r = std::sqrt(u1);
    double c, s;
    turn_cos_sin(u2, c, s);
    glm::dvec3 a, b;
    orthonormal_basis(normal, a, b);
    mu = std::sqrt(std::max(0.0, 1.0 - r * r));
    return r * c * a + r * s * b + mu * normal;
}

/// What the per-pixel path needs of one instance, gathered once per render into a flat table:
/// reaching it through Scene::instance → Scene::mesh → the mesh's vectors was a chain of five
/// dependent loads per hit. Values are copies (albedo widened to double exactly).
struct InstanceData {
    glm::dmat3 normal_to_world;
    glm::dmat3 linear;
    glm::dvec3 translation;
    glm::dvec3 albedo;
    const uint32_t* triangles;
    const float* vertices;
    uint8_t label;
    Photometry photometry;
    const float* corner_uvs;     // 6 per triangle, or null
    const WovenSurface* woven;   // null unless the material is woven
    const StainMask* stain;      // null unless the instance is stained
    const float* vertex_albedo;  // per-vertex albedo factors, or null
    int vertex_albedo_channels;  // 1: one factor per vertex; 3: one per RGB channel
    const float* vertex_normals; // per-vertex unit shading normals (object frame), or null
    const RegolithGrain* grain;  // granular micro-texture at camera hits, or null
    const SubgridCraters* craters;  // the small craters its mesh did not draw, or null
};

/// The interpolated shading normal of instance `inst` at barycentrics (u, v) of triangle
/// `prim`, in the world, unit, turned to the side of `geometric` (the unit geometric normal the
/// ray sees). Only for instances with vertex normals.
inline glm::dvec3 shading_normal_at(const InstanceData& inst, uint32_t prim, double u, double v,
                                    const glm::dvec3& geometric) {
    const uint32_t* c = inst.triangles + 3 * static_cast<size_t>(prim);
    auto normal = [&](int k) {
        const float* n = inst.vertex_normals + 3 * static_cast<size_t>(c[k]);
        return glm::dvec3(n[0], n[1], n[2]);
    };
    glm::dvec3 n = inst.normal_to_world * ((1.0 - u - v) * normal(0) + u * normal(1) + v * normal(2));
    const double len = glm::length(n);
    if (!(len > 0.0)) return geometric;
    n /= len;
    return glm::dot(n, geometric) < 0.0 ? -n : n;
}

/// The mesh's per-vertex albedo factor of instance `inst` at barycentrics (u, v) of triangle
/// `prim`, per RGB channel (one factor: the same on all three); 1 where the mesh has none.
inline glm::dvec3 vertex_factor_at(const InstanceData& inst, uint32_t prim, double u, double v) {
    if (!inst.vertex_albedo) return glm::dvec3(1.0);
    const uint32_t* c = inst.triangles + 3 * static_cast<size_t>(prim);
    if (inst.vertex_albedo_channels == 3) {
        auto rgb = [&](int k) {
            const float* f = inst.vertex_albedo + 3 * static_cast<size_t>(c[k]);
            return glm::dvec3(f[0], f[1], f[2]);
        };
        return (1.0 - u - v) * rgb(0) + u * rgb(1) + v * rgb(2);
    }
    return glm::dvec3((1.0 - u - v) * inst.vertex_albedo[c[0]] + u * inst.vertex_albedo[c[1]] +
                      v * inst.vertex_albedo[c[2]]);
}

/// The albedo of instance `inst` at barycentrics (u, v) of triangle `prim`: the material's,
/// times the mesh's per-vertex factor there (one, or one per channel) when it has one.
inline glm::dvec3 albedo_at(const InstanceData& inst, uint32_t prim, double u, double v) {
    if (!inst.vertex_albedo) return inst.albedo;
    return inst.albedo * vertex_factor_at(inst, prim, u, v);
}

/// The photometric shape of an instance's surface (photometry.h). Lambert's is 1 outright: no
/// call, and a Lambertian seen past its smooth shading normal's horizon still takes its light.
inline double shape_at(const InstanceData& inst, double mu_i, double mu_o, double cos_g) {
    if (inst.photometry.model == Photometry::Model::Lambert) return 1.0;
    return photometric_shape(inst.photometry, mu_i, mu_o, cos_g);
}

/// shape_at with the phase terms at cos g already taken (phase_terms(inst.photometry, cos g)).
inline double shape_at(const InstanceData& inst, const PhaseTerms& terms, double mu_i, double mu_o, double cos_g) {
    if (inst.photometry.model == Photometry::Model::Lambert) return 1.0;
    return photometric_shape(inst.photometry, terms, mu_i, mu_o, cos_g);
}

/// The unit world normal of the triangle `ray` hit on instance `inst`, turned to the side the
/// ray arrived from (`wi`, its direction); false where the triangle is degenerate (no normal).
inline bool arrival_normal(const InstanceData& inst, const RayHit& ray, const glm::dvec3& wi, glm::dvec3& normal) {
    normal = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
    const double len = glm::length(normal);
    if (!(len > 0.0)) return false;
    normal /= len;
    if (glm::dot(normal, wi) > 0.0) normal = -normal;
    return true;
}

/// Triangle `prim`'s vertex `k` (0–2) of instance `inst`, in the world, metres.
inline glm::dvec3 world_vertex(const InstanceData& inst, uint32_t prim, int k) {
    const float* v = inst.vertices + 3 * static_cast<size_t>(inst.triangles[3 * static_cast<size_t>(prim) + k]);
    return inst.linear * glm::dvec3(v[0], v[1], v[2]) + inst.translation;
}

/// The largest coordinate magnitude (metres, world) of triangle `prim` of instance `inst`: the
/// scale of float32 traversal's error on its plane (lift_off).
inline double triangle_reach(const InstanceData& inst, uint32_t prim) {
    return std::max({largest_coordinate(world_vertex(inst, prim, 0)), largest_coordinate(world_vertex(inst, prim, 1)),
                     largest_coordinate(world_vertex(inst, prim, 2))});
}

inline std::vector<InstanceData> instance_table(const Scene& scene) {
    std::vector<InstanceData> table(scene.instance_count());
    for (size_t i = 0; i < table.size(); ++i) {
        const Instance& inst = scene.instance(static_cast<uint32_t>(i));
        const Mesh& mesh = scene.mesh(inst.mesh);
        table[i] = {inst.normal_to_world,
                    inst.linear,
                    inst.translation,
                    glm::dvec3(inst.material.albedo),
                    mesh.triangles.data(),
                    mesh.vertices.data(),
                    inst.label,
                    inst.material.photometry,
                    mesh.corner_uvs.empty() ? nullptr : mesh.corner_uvs.data(),
                    inst.material.woven ? &*inst.material.woven : nullptr,
                    inst.stain,
                    mesh.vertex_albedo.empty() ? nullptr : mesh.vertex_albedo.data(),
                    mesh.vertex_albedo_channels,
                    mesh.vertex_normals.empty() ? nullptr : mesh.vertex_normals.data(),
                    inst.material.grain.get(),
                    inst.material.craters.get()};
    }
    return table;
}

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 1.0 / kPi;  // the double nearest 1/π

/// A light as the renderer's shading and the light cache's gather paths use it.
struct LightData {
    glm::dvec3 dir;       // unit vector to the disk's centre
    glm::dvec3 color;     // linear RGB tint of the irradiance
    glm::dvec3 a, b;      // with dir, an orthonormal basis for sampling the disk
    double scale;         // E/π: radiance of a white Lambertian facing the light, W/(m²·sr)
    double cos_half;      // the disk is the cone of directions within acos(cos_half) of dir
    bool point;           // no disk to sample: every shadow ray would be the same

    /// A unit direction to a point of the disk, uniform over its solid angle, from the sample
    /// pair `q` (a point light: `dir` itself).
    glm::dvec3 toward(const SamplePair& q) const {
        if (point) return dir;
        double cos_phi, sin_phi;
        turn_cos_sin(q.v, cos_phi, sin_phi);
        const double c = 1.0 - q.u * (1.0 - cos_half);
        const double r = std::sqrt(std::max(0.0, 1.0 - c * c));
        return c * dir + r * (cos_phi * a + sin_phi * b);
    }
};

/// The lights that shine (a dark one adds nothing and traces nothing): the Sun first, if it
/// shines, then the Earth, if present.
inline std::vector<LightData> light_table(const Lights& lights) {
    std::vector<LightData> table;
    auto add = [&](const DirectionalLight& l) {
        if (l.irradiance() <= 0.0) return;
        LightData d;
        d.dir = l.direction();
        d.color = l.color();
        orthonormal_basis(d.dir, d.a, d.b);
        d.scale = kInvPi * l.irradiance();
        d.cos_half = l.cos_half_angle();
        d.point = l.half_angle() == 0.0;
        table.push_back(d);
    };
    add(lights.sun);
    if (lights.earth) add(*lights.earth);
    return table;
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

/// The pixel-centre camera rays of the tile [x0, x1) × [y0, y1) (at most kTile × kTile pixels),
/// row by row: directions into `dirs`, Embree rays into `rays`; returns their number. The
/// renderer's centre pass and the Embree-limit probe both make their rays here.
inline int centre_rays(const Camera& camera, int x0, int y0, int x1, int y1, glm::dvec3* dirs, RayHit* rays) {
    glm::dvec3 x_parts[kTile];
    for (int x = x0; x < x1; ++x) x_parts[x - x0] = camera.x_part(x + 0.5);
    const glm::dvec3 forward = camera.forward();
    int n = 0;
    for (int y = y0; y < y1; ++y) {
        const glm::dvec3 y_part = camera.y_part(y + 0.5);
        for (int x = x0; x < x1; ++x, ++n) {
            dirs[n] = (x_parts[x - x0] + y_part) + forward;
            set_ray(rays[n], camera.center(), dirs[n]);
        }
    }
    return n;
}

/// One triangle hit somewhere in a tile, and everything about the hit that depends on the
/// triangle alone. Its key is the instance, the primitive and Embree's geometric normal bit for
/// bit, so a record serves exactly the hits whose per-pixel computation would have produced the
/// same values.
struct TriangleRecord {
    uint32_t instance = 0, prim = 0;
    float ng[3] = {};
    glm::dvec3 n_raw{};   // world geometric normal from Embree's, unnormalised, either side
    glm::dvec3 n_plane{};  // (v1 − v0) × (v2 − v0) in double from the world vertices: the plane
                           // the double solve uses, the same bits whatever ISA Embree ran in
    double grazing = 0;   // 1e-24·|n_plane|²: a ray with (n_plane·dir)² ≤ grazing·|dir|² is too
                          // close to parallel for the double solve, which then keeps Embree's t
    double offset = 0;    // n_plane · (v0 − camera centre): the plane through the first vertex
    double reach = 0;     // triangle_reach: the scale of its rays' lift_off
    // Filled for the records that get shaded, on first use (see TileHits::shadow_rays):
    bool shading_known = false;
    glm::dvec3 normal[2];  // the unit normal, and its opposite (the side a ray coming from the
                           // other half-space sees)
    double cos_sun[2];     // normal[side] · to_sun
};

/// One pixel's camera-ray hit.
struct PixelHit {
    bool hit = false;
    uint8_t side = 0;    // which TriangleRecord::normal faces the ray (set by shadow_rays)
    uint8_t record = 0;  // index of its TriangleRecord in the tile
    double t = 0;        // ray parameter = z-depth (the camera-z of dir is 1)
    float u = 0, v = 0;  // Embree's barycentrics: the hit is (1 − u − v)·p0 + u·p1 + v·p2
};

/// The camera-ray hits of one tile, resolved in double precision, and the Sun shadow rays from
/// them. Neighbouring pixels mostly hit the same triangle, so the work that depends only on the
/// triangle (world normal, vertex fetch and the plane's offset, the unit normal with its square
/// root and divisions, the Sun's cosine) is done once per distinct triangle in the tile, not
/// once per pixel. Every value comes from the same operations in the same order as a per-pixel
/// computation, so images are unchanged bit for bit (test_render checks against one).
class TileHits {
public:
    /// Resolves the `n` traced rays of a tile whose rows are `row` pixels wide. Embree's float t
    /// carries an error proportional to the scene's coordinates; with `exact`, the hit distance is
    /// re-solved in double against the triangle's plane, spanned in double by its world vertices
    /// (Embree's own float normal differs in its last bit between kernels with and without FMA).
    void resolve(const InstanceData* instances, const glm::dvec3& origin, const glm::dvec3* dirs, const RayHit* rays,
                 int n, int row, bool exact) {
        m_n = n;
        m_used = 0;
        int last = -1;  // record of the previous hit: the likeliest match
        for (int i = 0; i < n; ++i) {
            PixelHit& p = m_pixels[i];
            const RayHit& ray = rays[i];
            p.hit = ray.geom_id != kInvalidId;
            if (!p.hit) continue;
            // The previous hit's triangle, else the one of the pixel above: where neighbours
            // share a triangle, one of the two nearly always is it.
            const PixelHit* above = i >= row ? &m_pixels[i - row] : nullptr;
            int k;
            if (last >= 0 && same(m_records[last], ray)) k = last;
            else if (above && above->hit && same(m_records[above->record], ray)) k = above->record;
            else k = add(instances, origin, ray, exact);
            last = k;
            p.record = static_cast<uint8_t>(k);
            const TriangleRecord& tri = m_records[k];
            p.t = ray.tfar;
            p.u = ray.u;
            p.v = ray.v;
            if (!exact) continue;
            const glm::dvec3& dir = dirs[i];
            const double denom = glm::dot(tri.n_plane, dir);
            // Squared comparison: no square roots on the per-pixel path.
            if (denom * denom > tri.grazing * glm::dot(dir, dir)) {
                const double t = tri.offset / denom;
                if (t > 0.0) p.t = t;
            }
        }
    }

    /// The shadow ray toward the Sun (unit `to_sun`) from every hit whose surface faces it, offset
    /// along the normal facing the camera ray; ray k belongs to pixel of[k]. Returns their number.
    /// Sets each hit's `side`.
    int shadow_rays(const glm::dvec3& origin, const glm::dvec3* dirs, const glm::dvec3& to_sun, RayHit* rays, int* of) {
        int count = 0;
        for (int i = 0; i < m_n; ++i) {
            PixelHit& p = m_pixels[i];
            if (!p.hit) continue;
            TriangleRecord& tri = m_records[p.record];
            if (!tri.shading_known) shading(tri, to_sun);
            const glm::dvec3& dir = dirs[i];
            p.side = glm::dot(tri.normal[0], dir) > 0.0 ? 1 : 0;
            if (tri.cos_sun[p.side] <= 0.0) continue;
            set_ray(rays[count], lift_off(origin + p.t * dir, tri.normal[p.side], tri.reach), to_sun);
            of[count++] = i;
        }
        return count;
    }

    const PixelHit& pixel(int i) const { return m_pixels[i]; }
    const TriangleRecord& record(const PixelHit& p) const { return m_records[p.record]; }

    /// Pixel i's record with its unit normals and cosines to `to_sun` filled in, and the pixel's
    /// `side` set to the one facing its ray `dir` (what shadow_rays does, for a caller that
    /// makes its own shadow rays).
    const TriangleRecord& shaded(int i, const glm::dvec3& dir, const glm::dvec3& to_sun) {
        PixelHit& p = m_pixels[i];
        TriangleRecord& tri = m_records[p.record];
        if (!tri.shading_known) shading(tri, to_sun);
        p.side = glm::dot(tri.normal[0], dir) > 0.0 ? 1 : 0;
        return tri;
    }

private:
    static bool same(const TriangleRecord& r, const RayHit& ray) {
        return r.prim == ray.prim_id && r.instance == ray.inst_id && bits(r.ng[0]) == bits(ray.ng_x) &&
               bits(r.ng[1]) == bits(ray.ng_y) && bits(r.ng[2]) == bits(ray.ng_z);
    }
    static uint32_t bits(float f) {
        uint32_t u;
        std::memcpy(&u, &f, sizeof u);
        return u;
    }

    int add(const InstanceData* instances, const glm::dvec3& origin, const RayHit& ray, bool exact) {
        TriangleRecord& r = m_records[m_used];
        r.instance = ray.inst_id;
        r.prim = ray.prim_id;
        r.ng[0] = ray.ng_x;
        r.ng[1] = ray.ng_y;
        r.ng[2] = ray.ng_z;
        r.shading_known = false;
        const InstanceData& inst = instances[ray.inst_id];
        r.n_raw = inst.normal_to_world * glm::dvec3(ray.ng_x, ray.ng_y, ray.ng_z);
        const glm::dvec3 v0 = world_vertex(inst, ray.prim_id, 0), v1 = world_vertex(inst, ray.prim_id, 1),
                         v2 = world_vertex(inst, ray.prim_id, 2);
        r.reach = std::max({largest_coordinate(v0), largest_coordinate(v1), largest_coordinate(v2)});
        if (exact) {
            r.n_plane = glm::cross(v1 - v0, v2 - v0);
            r.grazing = 1e-24 * glm::dot(r.n_plane, r.n_plane);
            r.offset = glm::dot(r.n_plane, v0 - origin);
        }
        return m_used++;
    }

    static void shading(TriangleRecord& r, const glm::dvec3& to_sun) {
        const double n_len = glm::length(r.n_raw);
        r.normal[0] = n_len > 0.0 ? r.n_raw / n_len : glm::dvec3(0.0, 0.0, 1.0);
        r.normal[1] = -r.normal[0];
        r.cos_sun[0] = glm::dot(r.normal[0], to_sun);
        r.cos_sun[1] = glm::dot(r.normal[1], to_sun);
        r.shading_known = true;
    }

    std::array<PixelHit, kTilePixels> m_pixels;
    std::array<TriangleRecord, kTilePixels> m_records;
    int m_n = 0, m_used = 0;
};

}  // namespace moonbot::detail
