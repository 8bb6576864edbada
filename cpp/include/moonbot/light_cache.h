// A world-space cache of indirect light for one static scene, shared by every view of a task.
//
// Indirect irradiance at a surface point does not depend on the camera, so the many views of one
// scene would each re-estimate it per pixel. The cache estimates it once per (instance, vertex)
// of the scene's non-moving instances, from `rays_*` cosine-distributed gather rays at the vertex
// each continued as the renderer's path tracer continues a bounce (a shadow ray to every light at
// every path vertex, then the next bounce, `bounces` in all), and a pixel's first hit reads it
// interpolated across its triangle, each vertex's value tilted to the facet's own normal through
// its rotation gradient and curvature (IndirectLight::tilt_gradient, tilt_curvature: the latter
// from a few more rays into the band below the vertex's horizon), shaded with the hit's own BRDF.
//
// A vertex's value is a pure function of (the static scene, the lights, the seed, the vertex):
// its random numbers are keyed by (seed, instance, vertex, ray), and its rays pass through moving
// instances (accel.h kStaticGeometry). So images do not depend on the thread count, on which views
// were rendered before, or on the order vertices are filled. Vertices are filled on first touch,
// in blocks of kBlockVertices allocated on first touch: memory follows what the views see.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/light.h"
#include "moonbot/scene.h"

namespace moonbot {

struct LightCacheSettings {
    /// Path vertices after the gather point, each lit through a shadow ray per light, as
    /// RenderSettings::bounces counts them; 1..kMaxBounces (a scene without bounces has no cache).
    int bounces = 2;
    /// Gather rays per vertex on labelled instances (the bags: few vertices, much of the
    /// indirect light's variance), 1..kMaxGatherRays.
    int rays_objects = 1024;
    /// Gather rays per vertex (or lattice node) on background instances (terrain, rocks),
    /// 1..kMaxGatherRays.
    int rays_background = 64;
    /// Background instances' lattice spacing, metres (0 = per vertex). Indirect light varies
    /// slowly over regolith, far more slowly than a 1 cm terrain grid. With a spacing h, a
    /// background vertex whose triangle edges are all shorter than h takes its value bilinearly
    /// from the 2D world-space lattice (multiples of h) across the axis its normal leans to most
    /// (one of ±x, ±y, ±z); each node's value is the gather at the surface a probe ray meets
    /// coming along that axis from beyond the instance's bounds, if that surface is the
    /// instance's own and faces the same way (a bag or rock in front leaves the node empty).
    /// Other vertices, or those with no valid node around them, gather themselves; so does a
    /// vertex with a node under a bag (a labelled instance) around it that is not under a bag
    /// itself, with rays_objects: beside a bag the light changes within a cell. (The same holds
    /// for the bags' own lattice, object_cell_m, where one bag stands in front of another.)
    double background_cell_m = 0.0;
    /// The same for labelled instances (the bags), with rays_objects a node; 0 = per vertex.
    double object_cell_m = 0.0;
    /// Radius, in lattice cells, of the tent filter through which a background vertex reads the
    /// lattice: its value is the nodes within that radius along each lattice axis, weighted by
    /// (1 − |du|/r)·(1 − |dv|/r). 1 is bilinear between the four nodes around it; wider averages
    /// more nodes' independent gathers, so their noise (blotches on shadowed ground) shrinks, at
    /// the price of blurring the light over 2r cells. 1..kMaxLatticeFilterCells. The bags' lattice
    /// is read bilinearly (through the tent their shadowed faces' error grew; docs/performance.md).
    double background_filter_cells = 1.0;
    /// Adaptive gathering: while the relative standard error of a vertex's (or node's) gathered
    /// luminance is above this, it gathers as many rays again, up to max_rays_factor × its rays.
    /// The extra rays go where the indirect light is uneven (shadowed ground lit by a few sunlit
    /// patches), where a fixed count leaves blotches. 0 = the fixed count (rays_*) everywhere.
    double gather_error = 0.0;
    /// The most rays adaptive gathering may reach, as a multiple of rays_objects / rays_background,
    /// 1..kMaxRaysFactor (the products at most kMaxGatherRays).
    int max_rays_factor = 8;
    uint64_t seed = 0;  ///< keys the gather rays' random numbers (with instance, vertex, ray)
    int threads = 0;    ///< worker threads of fill_all; 0 = all

    /// Throws std::invalid_argument naming the first field out of its range (LightCache's
    /// constructor calls it).
    void validate() const;
};

constexpr int kMaxGatherRays = 65536;
constexpr int kMaxRaysFactor = 1024;
constexpr double kMaxLatticeFilterCells = 4.0;

/// Indirect light arriving at a surface point.
struct IndirectLight {
    glm::dvec3 irradiance{0.0};  ///< W/m², linear RGB, on the cached side of the surface
    /// The luminance-weighted mean of the unit incident directions (world; toward where the light
    /// comes from), 0 if dark. Its length R̄ ≤ 1 says how spread the light is: 1 from a single
    /// direction, 2/3 for light of one radiance over the whole hemisphere.
    glm::dvec3 mean_direction{0.0};
    /// The irradiance's rotation gradient (Ward & Heckbert 1992): for a unit normal n near the
    /// normal n₀ the value was gathered at, the luminance of `irradiance` is about
    /// Y₀ + (n − n₀)·tilt_gradient (W/m², world, tangent to n₀). The cache gathers at smooth vertex
    /// normals; a facet that leans from them toward bright low ground or a sunlit wall gets more.
    glm::dvec3 tilt_gradient{0.0};
    /// The luminance's second-order change with the tilt, W/m² (world, symmetric, acting across
    /// n₀): a normal n gets Y₀ + (n − n₀)·tilt_gradient + dᵀ·tilt_curvature·d, d = (n − n₀) less
    /// its part along n₀. Fitted from the gather's rays and rays into the band below its horizon
    /// (light_cache.cpp): a facet leaning from n₀ sees what lies below n₀'s horizon, and that
    /// light grows with the square of the lean.
    glm::dmat3 tilt_curvature{0.0};
    /// The colour of the light below the horizon (linear RGB of luminance 1; grey where the
    /// gather's band found none): what a lean's second-order gain is added in.
    glm::dvec3 below_colour{0.0};

    /// This value as seen by a surface of unit normal `to`, when it was gathered at unit normal
    /// `from`: every channel of the irradiance scaled by the first-order change of its luminance,
    /// the factor kept within [0, kMaxTiltFactor] (a tilt past the light's horizon takes it all);
    /// then the second-order change added in below_colour where it is a gain, or scaled in where
    /// it is a loss (never below zero); and the gradient moved to where it now stands. Without
    /// `second_order`, the first-order change alone.
    IndirectLight tilted(const glm::dvec3& from, const glm::dvec3& to, bool second_order = true) const;
};

/// The most a tilt may raise a cached irradiance (IndirectLight::tilted): a first-order gradient
/// from a few grazing gather rays must not turn into a bright speck.
constexpr double kMaxTiltFactor = 2.0;

/// What the cache has done so far, cumulatively. Counts cover each vertex once (its first fill),
/// so they are deterministic; `fill_seconds` is thread time and is not.
struct LightCacheStats {
    uint64_t vertices = 0;       ///< vertices filled
    uint64_t blocks = 0;         ///< blocks of kBlockVertices allocated
    uint64_t nodes = 0;          ///< lattice nodes probed (valid or not)
    uint64_t probe_rays = 0;     ///< rays probing under a lattice node, or a vertex beside a bag
    uint64_t gather_rays = 0;    ///< rays leaving a vertex or node, or a later path vertex
    uint64_t shadow_rays = 0;    ///< toward the lights, from the path vertices
    uint64_t bytes = 0;          ///< held now: tables, vertex normals, blocks
    uint64_t redundant_fills = 0;  ///< vertices computed again by a thread racing the first (thread-dependent)
    double fill_seconds = 0.0;   ///< thread-seconds spent filling (thread-dependent)
};

class LightCache {
public:
    /// Up to kBlockVertices consecutive vertices of one instance share a block.
    static constexpr uint32_t kBlockVertices = 64;

    /// What a lattice node holds: the gather at the surface its probe met, and that surface's
    /// unit world normal (what IndirectLight::tilted tilts from).
    struct Node {
        IndirectLight light;
        glm::dvec3 normal{0.0};
    };
    /// A lattice node as its probe found it: its value, or none; and whether a labelled instance
    /// (a bag) stood in front of it.
    struct ProbedNode {
        std::optional<Node> node;
        bool under_object = false;
    };

    /// A cache over the instances of `scene` that are not moving now (Instance::moving); the
    /// scene must be committed and must outlive the cache. Throws std::invalid_argument naming
    /// the setting on bad settings. Computes vertex normals for the meshes without their own
    /// (area-weighted face normals); fills no vertex.
    LightCache(const Scene& scene, const Lights& lights, const LightCacheSettings& settings);
    ~LightCache();
    LightCache(const LightCache&) = delete;
    LightCache& operator=(const LightCache&) = delete;

    /// Whether instance `instance`'s surface is cached (it was not moving when the cache was built).
    bool covers(uint32_t instance) const;

    /// The indirect light at barycentrics (u, v) of triangle `prim` of covered instance
    /// `instance` (the hit is (1 − u − v)·p0 + u·p1 + v·p2), on the side its vertex normals face:
    /// the vertices' values interpolated, each filled first if it is not yet. With `normal` (unit,
    /// world; the facet's own), each vertex's value is first tilted from its vertex normal to it
    /// (IndirectLight::tilted). Thread-safe.
    IndirectLight at(uint32_t instance, uint32_t prim, double u, double v, const glm::dvec3* normal = nullptr) const;

    /// The three vertices' values of triangle `prim` of covered instance `instance` as `at`
    /// reads them (each filled first if it is not yet, and tilted to `normal` when given): what
    /// every point of the triangle shares. Thread-safe.
    using TriangleCorners = std::array<IndirectLight, 3>;
    TriangleCorners corners(uint32_t instance, uint32_t prim, const glm::dvec3* normal = nullptr) const;

    /// `at`'s value from its triangle's corners (corners()) at barycentrics (u, v): the same
    /// number, to the bit.
    static IndirectLight interpolate(const TriangleCorners& corners, double u, double v);

    /// The unit world normal of the cached side at barycentrics (u, v) of triangle `prim` (the
    /// vertex normals interpolated): a hit seen from the other side is not served by the cache.
    glm::dvec3 normal_at(uint32_t instance, uint32_t prim, double u, double v) const;

    /// Fills every vertex of the covered instances (for tests and measurements; rendering fills
    /// on demand), in parallel on settings.threads. Throws std::invalid_argument if the scene's
    /// static geometry changed since the cache was built.
    void fill_all() const;

    /// The value of vertex `vertex` of covered instance `instance`, filling it if needed.
    IndirectLight vertex(uint32_t instance, uint32_t vertex) const;

    const Scene& scene() const { return m_scene; }
    const Lights& lights() const { return m_lights; }
    const LightCacheSettings& settings() const { return m_settings; }
    /// Scene::static_revision when built: the cache serves that state of the scene only.
    uint64_t scene_revision() const { return m_revision; }
    LightCacheStats stats() const;

private:
    /// Vertex `vertex`'s value (at `point`, unit `normal`) from the lattice nodes
    /// around it (LightCacheSettings::background_filter_cells; the bags' bilinearly), each tilted
    /// from its own surface's normal to `normal`; none where the vertex is coarse or no node around
    /// it is valid, or (`near_object` then set) where a node around it lies under a bag and the
    /// vertex itself does not: the vertex then gathers itself. `probes` gets the probe rays it cast
    /// for the vertex itself (0 or 1; its nodes' probes are counted as they are made).
    std::optional<IndirectLight> from_lattice(uint32_t instance, uint32_t vertex, const glm::dvec3& point,
                                              const glm::dvec3& normal, bool& near_object, uint64_t& probes) const;
    /// Lattice node (i, j)·h across the axis of normal bin `bin` on instance `instance`, probed
    /// and gathered on first touch; no value where its probe meets another instance or another bin.
    ProbedNode lattice_node(uint32_t instance, int64_t i, int64_t j, int bin) const;
    /// Whether a labelled instance (a bag) other than `instance` stands in front of `point` (a
    /// vertex of `instance`, unit `normal`) along the axis of its normal's bin, as a node's probe
    /// would find it.
    bool under_object(uint32_t instance, const glm::dvec3& point, const glm::dvec3& normal) const;

    struct Impl;
    const Scene& m_scene;
    const Lights m_lights;
    const LightCacheSettings m_settings;
    const uint64_t m_revision;
    std::unique_ptr<Impl> m_impl;
};

}  // namespace moonbot
