#include "moonbot/light_cache.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/concurrent_hash_map.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/render_limits.h"
#include "moonbot/rng.h"
#include "moonbot/sampler.h"
#include "rays.h"

namespace moonbot {

namespace {

using namespace detail;

// Dimension pairs of one gather ray (sampler.h): path vertex b (1-based) takes
// kPairsPerBounce·(b − 1) for the direction that reaches it and the pairs after it for its
// lights. The sequence's index is the ray's number at the vertex, so a vertex's rays are
// stratified together over the hemisphere.
constexpr uint32_t kPairsPerBounce = 32;
// Keeps the cache's random streams apart from the pixels' (rng.h pixel_stream) under one seed.
constexpr uint64_t kCacheStreamSalt = 0x6C69676874636163ull;  // "lightcac"
constexpr uint64_t kNodeStreamSalt = 0x6C61747469636521ull;   // "lattice!"
// Lattice indices are packed in 24-bit fields, offset by 2^19: ±2^19 cells an axis (±26 km at 5 cm).
constexpr int64_t kLatticeHalfRange = int64_t(1) << 19;

/// Rec. 709 luminance of linear RGB: the weight of a ray in the mean incident direction.
double luminance(const glm::dvec3& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

// A gather ray's share of the rotation gradient is its radiance times the tangent of its angle
// from the normal (IndirectLight::tilt_gradient); the tangent is capped at this angle's, 87°,
// so that the rare ray skimming the horizon does not dominate a node's gradient.
constexpr double kGradientMinCosine = 0.05;

// A facet that leans from the normal its light was gathered at sees below that normal's horizon:
// on sunlit ground, its sunlit neighbours; on a bag's top, the ground past its rim. That light
// grows with the square of the lean (an upward face over a bright plane gets (1 − cos t)/2 of
// it), which the rotation gradient cannot carry. So each gather also traces rays into the band
// below its horizon, down to this sine of depth (30°), uniform in solid angle, a sixteenth as many
// as its gather rays and at least kMinBelowHorizonRays (they meet nearby ground, whose light is
// smooth: more of them moved no region's mean, docs/performance.md), and fits the luminance's
// second-order change with the lean (IndirectLight::tilt_curvature) at leans of kCurvatureFitLeans.
constexpr double kBelowHorizonSine = 0.5;
constexpr size_t kBelowHorizonRaysDivisor = 16;
constexpr size_t kMinBelowHorizonRays = 4;
constexpr double kCurvatureFitLeans[2] = {0.2617993877991494, 0.5235987755982988};  // 15°, 30°, radians
constexpr int kCurvatureFitAzimuths = 8;
constexpr double kMaxCurvatureLean = 0.5;  // sin 30°, the largest lean fitted
constexpr uint64_t kBelowHorizonStreamSalt = 0x62656c6f7768727aull;  // "belowhrz"

/// One gather path's current vertex.
struct GatherPath {
    glm::dvec3 point, lifted, normal, albedo, wo, throughput;
    uint32_t instance = 0;
    bool alive = false;
};

/// What one vertex's fill traced.
struct FillCounts {
    uint64_t gather_rays = 0, shadow_rays = 0;
};

struct Block {
    std::atomic<uint8_t> state[LightCache::kBlockVertices];  // kEmpty, kFilling, kReady
    // Doubles, as computed: a racing thread's own copy then equals the stored one bit for bit
    // (GCC 12 at -O3 was seen returning a double → float → double round trip unrounded).
    IndirectLight value[LightCache::kBlockVertices];
    Block() {
        for (auto& s : state) s.store(0, std::memory_order_relaxed);
    }
};
constexpr uint8_t kEmpty = 0, kFilling = 1, kReady = 2;

/// Area-weighted vertex normals of `mesh` (object frame, unit xyz per vertex; a vertex of no
/// triangle gets +z).
std::vector<float> area_weighted_normals(const Mesh& mesh) {
    const size_t nv = mesh.vertex_count();
    std::vector<glm::dvec3> sum(nv, glm::dvec3(0.0));
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        const uint32_t* c = &mesh.triangles[3 * t];
        const glm::dvec3 p0 = mesh.vertex(c[0]);
        // |cross| is twice the area: the area weighting comes for free.
        const glm::dvec3 n = glm::cross(mesh.vertex(c[1]) - p0, mesh.vertex(c[2]) - p0);
        for (int k = 0; k < 3; ++k) sum[c[k]] += n;
    }
    std::vector<float> out(3 * nv);
    for (size_t i = 0; i < nv; ++i) {
        const double len = glm::length(sum[i]);
        const glm::dvec3 n = len > 0.0 ? sum[i] / len : glm::dvec3(0.0, 0.0, 1.0);
        for (int k = 0; k < 3; ++k) out[3 * i + k] = static_cast<float>(n[k]);
    }
    return out;
}

/// Key of a lattice node: its integer coordinates (world / cell size) across its bin's axis and
/// the normal bin of the surface it stands for (normal_bin).
uint64_t node_key(int64_t i, int64_t j, int bin) {
    auto field = [](int64_t c) { return static_cast<uint64_t>(c + kLatticeHalfRange) & 0xFFFFFFull; };
    return field(i) | (field(j) << 24) | (static_cast<uint64_t>(bin) << 48);
}

/// Which of six directions a unit normal leans toward most: 2·axis + (component < 0). Surfaces
/// of different bins never share a lattice node (a rock's sides, its top and the ground beside it).
int normal_bin(const glm::dvec3& n) {
    const glm::dvec3 a = glm::abs(n);
    const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    return 2 * axis + (n[axis] < 0.0 ? 1 : 0);
}

/// A background instance's lattice: its world bounds (where probes start), which vertices read
/// it, and the nodes probed so far.
struct Lattice {
    double spacing = 0.0;       // metres
    int rays = 0;               // gather rays per node
    double filter_cells = 1.0;  // radius of the tent a vertex reads the nodes through, cells (1: bilinear)
    // Whether a node's value is tilted to a vertex's normal to second order (IndirectLight::tilted).
    // Not on the bags: a bag's node can stand a centimetre from the vertex across a fold, its
    // normal tens of degrees off, and there the second-order term overshot the path tracer
    // (docs/performance.md); their vertices' values are tilted to the facets to second order.
    bool second_order = true;
    glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
    std::vector<bool> fine;  // per vertex: every triangle edge at it is shorter than the spacing
    // A node's value: the irradiance at the surface its probe met, or none (see lattice_node).
    using Nodes = tbb::concurrent_hash_map<uint64_t, LightCache::ProbedNode>;
    Nodes nodes;
};

/// Instance `inst`'s lattice of spacing `h` over `mesh`, read through a tent of `filter_cells`
/// cells, its nodes tilted to the vertices to second order or not (Lattice::second_order): its
/// world bounds and which vertices are fine enough to read it.
std::unique_ptr<Lattice> make_lattice(const InstanceData& inst, const Mesh& mesh, double h, int rays,
                                      double filter_cells, bool second_order) {
    auto lattice = std::make_unique<Lattice>();
    lattice->second_order = second_order;
    lattice->spacing = h;
    lattice->rays = rays;
    lattice->filter_cells = filter_cells;
    const size_t nv = mesh.vertex_count();
    std::vector<glm::dvec3> world(nv);
    for (size_t v = 0; v < nv; ++v) {
        world[v] = inst.linear * mesh.vertex(static_cast<uint32_t>(v)) + inst.translation;
        lattice->lo = glm::min(lattice->lo, world[v]);
        lattice->hi = glm::max(lattice->hi, world[v]);
    }
    lattice->fine.assign(nv, true);
    const double h2 = h * h;
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        const uint32_t* c = &mesh.triangles[3 * t];
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3 e = world[c[(k + 1) % 3]] - world[c[k]];
            if (glm::dot(e, e) < h2) continue;
            lattice->fine[c[k]] = false;
            lattice->fine[c[(k + 1) % 3]] = false;
        }
    }
    return lattice;
}

/// A lattice probe's ray along the axis of normal bin `bin`, through `at` (its coordinate along
/// that axis ignored): from beyond the lattice's bounds on the bin's side (one spacing out),
/// pointing against the bin. A node's probe and a vertex's own both start so, so that they see
/// the same instances in front.
struct BinProbe {
    glm::dvec3 origin, along;
};

BinProbe bin_probe(const Lattice& lattice, int bin, glm::dvec3 at) {
    const int a = bin / 2;
    const double sign = bin % 2 ? -1.0 : 1.0;
    at[a] = sign > 0.0 ? lattice.hi[a] + lattice.spacing : lattice.lo[a] - lattice.spacing;
    glm::dvec3 along(0.0);
    along[a] = -sign;
    return {at, along};
}

}  // namespace

struct LightCache::Impl {
    std::vector<InstanceData> instances;
    std::vector<std::unique_ptr<Lattice>> lattices;      // per background instance with a lattice, else null
    std::atomic<uint64_t> n_nodes{0}, probe_rays{0};
    std::vector<LightData> lights;
    std::vector<bool> covered;                           // per instance
    std::vector<const float*> normals;                   // per instance: its mesh's vertex normals (object frame)
    std::vector<std::vector<float>> computed_normals;    // per mesh: area-weighted, where the mesh has none
    std::vector<uint32_t> vertex_count;                  // per instance
    std::vector<std::unique_ptr<std::atomic<Block*>[]>> blocks;  // per instance, per block
    std::vector<size_t> block_count;                     // per instance
    std::atomic<uint64_t> vertices{0}, n_blocks{0}, gather_rays{0}, shadow_rays{0}, redundant{0};
    std::atomic<uint64_t> fill_nanoseconds{0};
    uint64_t table_bytes = 0;

    ~Impl() {
        for (size_t i = 0; i < blocks.size(); ++i)
            for (size_t b = 0; b < block_count[i]; ++b) delete blocks[i][b].load();
    }
};

void LightCacheSettings::validate() const {
    if (bounces < 1 || bounces > kMaxBounces)
        throw std::invalid_argument("bounces: a light cache needs 1.." + std::to_string(kMaxBounces) + ", got " +
                                    std::to_string(bounces));
    if (rays_objects < 1 || rays_objects > kMaxGatherRays)
        throw std::invalid_argument("rays_objects: must be in 1.." + std::to_string(kMaxGatherRays) + ", got " +
                                    std::to_string(rays_objects));
    if (rays_background < 1 || rays_background > kMaxGatherRays)
        throw std::invalid_argument("rays_background: must be in 1.." + std::to_string(kMaxGatherRays) + ", got " +
                                    std::to_string(rays_background));
    if (!(background_cell_m >= 0.0) || !std::isfinite(background_cell_m))
        throw std::invalid_argument("background_cell_m: must be finite and >= 0, got " +
                                    std::to_string(background_cell_m));
    if (!(object_cell_m >= 0.0) || !std::isfinite(object_cell_m))
        throw std::invalid_argument("object_cell_m: must be finite and >= 0, got " + std::to_string(object_cell_m));
    if (!(background_filter_cells >= 1.0 && background_filter_cells <= kMaxLatticeFilterCells))
        throw std::invalid_argument("background_filter_cells: must be in 1.." +
                                    std::to_string(static_cast<int>(kMaxLatticeFilterCells)) + " (1 = bilinear), got " +
                                    std::to_string(background_filter_cells));
    if (!(gather_error >= 0.0 && gather_error <= 1.0))
        throw std::invalid_argument("gather_error: must be in 0..1 (0 = a fixed count of rays), got " +
                                    std::to_string(gather_error));
    if (max_rays_factor < 1 || max_rays_factor > kMaxRaysFactor ||
        static_cast<int64_t>(std::max(rays_objects, rays_background)) * max_rays_factor > kMaxGatherRays)
        throw std::invalid_argument("max_rays_factor: must be in 1.." + std::to_string(kMaxRaysFactor) +
                                    " with rays_objects and rays_background times it at most " +
                                    std::to_string(kMaxGatherRays) + ", got " + std::to_string(max_rays_factor));
    if (threads < 0 || threads > kMaxThreads)
        throw std::invalid_argument("threads: must be in 0.." + std::to_string(kMaxThreads) + " (0 = all), got " +
                                    std::to_string(threads));
}

LightCache::LightCache(const Scene& scene, const Lights& lights, const LightCacheSettings& settings)
    : m_scene(scene),
      m_lights(lights),
      m_settings(settings),
      m_revision(scene.static_revision()),
      m_impl(std::make_unique<Impl>()) {
    settings.validate();
    if (!scene.committed()) throw std::invalid_argument("scene: not committed (call commit() after adding geometry)");
    Impl& m = *m_impl;
    m.instances = instance_table(scene);
    // The cache outlives renders that add instances (a dust task's ejecta, after it is built), which
    // may move the scene's materials: it keeps the mesh pointers alone, as a bounce reads only the
    // mean albedo and photometry.
    for (InstanceData& inst : m.instances) inst.woven = nullptr, inst.stain = nullptr;
    m.lights = light_table(lights);
    const size_t n = scene.instance_count();
    m.covered.assign(n, false);
    m.normals.assign(n, nullptr);
    m.vertex_count.assign(n, 0);
    m.block_count.assign(n, 0);
    m.blocks.resize(n);
    m.computed_normals.resize(scene.mesh_count());
    m.lattices.resize(n);
    for (uint32_t i = 0; i < n; ++i) {
        const Instance& inst = scene.instance(i);
        if (inst.moving) continue;
        const Mesh& mesh = scene.mesh(inst.mesh);
        m.covered[i] = true;
        if (!mesh.vertex_normals.empty()) {
            m.normals[i] = mesh.vertex_normals.data();
        } else {
            std::vector<float>& computed = m.computed_normals[inst.mesh];
            if (computed.empty()) {
                computed = area_weighted_normals(mesh);
                m.table_bytes += computed.size() * sizeof(float);
            }
            m.normals[i] = computed.data();
        }
        const bool labelled = inst.label != 0;
        const double spacing = labelled ? settings.object_cell_m : settings.background_cell_m;
        if (spacing > 0.0) {
            // The bags' lattice is read bilinearly (LightCacheSettings::background_filter_cells).
            m.lattices[i] =
                make_lattice(m.instances[i], mesh, spacing, labelled ? settings.rays_objects : settings.rays_background,
                             labelled ? 1.0 : settings.background_filter_cells, !labelled);
            m.table_bytes += sizeof(Lattice) + mesh.vertex_count() / 8;
        }
        m.vertex_count[i] = static_cast<uint32_t>(mesh.vertex_count());
        m.block_count[i] = (mesh.vertex_count() + kBlockVertices - 1) / kBlockVertices;
        m.blocks[i] = std::make_unique<std::atomic<Block*>[]>(m.block_count[i]);
        for (size_t b = 0; b < m.block_count[i]; ++b) m.blocks[i][b].store(nullptr, std::memory_order_relaxed);
        m.table_bytes += m.block_count[i] * sizeof(std::atomic<Block*>);
    }
}

LightCache::~LightCache() = default;

bool LightCache::covers(uint32_t instance) const {
    return instance < m_impl->covered.size() && m_impl->covered[instance];
}

namespace {

/// The unit world normal of vertex `vertex` of instance `inst` whose object normals are `normals`.
glm::dvec3 world_normal(const InstanceData& inst, const float* normals, uint32_t vertex) {
    const float* q = normals + 3 * static_cast<size_t>(vertex);
    const glm::dvec3 normal = inst.normal_to_world * glm::dvec3(q[0], q[1], q[2]);
    const double len = glm::length(normal);
    return len > 0.0 ? normal / len : glm::dvec3(0.0, 0.0, 1.0);
}

/// The world position and unit world normal of vertex `vertex` of instance `inst` whose object
/// normals are `normals`.
void vertex_frame(const InstanceData& inst, const float* normals, uint32_t vertex, glm::dvec3& point,
                  glm::dvec3& normal) {
    const float* p = inst.vertices + 3 * static_cast<size_t>(vertex);
    point = inst.linear * glm::dvec3(p[0], p[1], p[2]) + inst.translation;
    normal = world_normal(inst, normals, vertex);
}

/// A unit direction uniformly distributed in solid angle over the band below the horizon of the
/// unit `normal`, from the horizon down to kBelowHorizonSine (u1, u2 in [0, 1)); `mu` receives its
/// cosine to the normal (negative).
glm::dvec3 below_horizon_direction(const glm::dvec3& normal, double u1, double u2, double& mu) {
    mu = -kBelowHorizonSine * u1;
    const double r = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    double c, s;
    turn_cos_sin(u2, c, s);
    glm::dvec3 a, b;
    orthonormal_basis(normal, a, b);
    return r * c * a + r * s * b + mu * normal;
}

/// Rays `first` .. `first` + `n` − 1 of the vertex's gather sequence from `lifted` (the gather point
/// lifted off its surface, world metres) on a surface of unit `normal` (sample_pair's stream
/// `stream`, index = the ray's number): each a cosine-distributed direction about the normal (with
/// `below`, uniform over the band below its horizon: below_horizon_direction), continued for
/// `bounces` path vertices as render.cpp's path tracer continues a bounce, against the static
/// geometry only. Appends each ray's radiance (W/(m²·sr), linear RGB) and first direction to
/// `radiance_out` and `first_dir_out`.
void gather_batch(const Accel& accel, const std::vector<InstanceData>& instances, const std::vector<LightData>& lights,
                  const glm::dvec3& lifted, const glm::dvec3& normal, uint64_t stream, uint32_t first, size_t n,
                  int bounces, FillCounts& counts, std::vector<glm::dvec3>& radiance_out,
                  std::vector<glm::dvec3>& first_dir_out, bool below = false) {
    std::vector<GatherPath> paths(n);
    std::vector<glm::dvec3> radiance(n, glm::dvec3(0.0)), first_dir(n);
    std::vector<RayHit> traced(n), shadow(n);
    std::vector<int> of(n), shadow_of(n);
    size_t count = 0;
    for (size_t k = 0; k < n; ++k) {
        double mu;
        const SamplePair q = sample_pair(stream, first + static_cast<uint32_t>(k), 0);
        const glm::dvec3 wi =
            below ? below_horizon_direction(normal, q.u, q.v, mu) : cosine_direction(normal, q.u, q.v, mu);
        first_dir[k] = wi;
        GatherPath& p = paths[k];
        p.throughput = glm::dvec3(1.0);
        p.point = lifted;
        p.wo = wi;
        p.alive = below ? mu < 0.0 : mu > 0.0;
        if (!p.alive) continue;
        set_ray(traced[count], lifted, wi);
        traced[count].mask = kStaticGeometry;
        of[count++] = static_cast<int>(k);
    }
    for (int b = 1; b <= bounces && count > 0; ++b) {
        const uint32_t pair = kPairsPerBounce * static_cast<uint32_t>(b - 1);
        accel.intersect(traced.data(), count);
        counts.gather_rays += count;
        // The hits: where each path's next vertex is.
        for (size_t j = 0; j < count; ++j) {
            GatherPath& p = paths[static_cast<size_t>(of[j])];
            const RayHit& ray = traced[j];
            if (ray.geom_id == kInvalidId) {
                p.alive = false;  // to the black sky
                continue;
            }
            const InstanceData& inst = instances[ray.inst_id];
            const glm::dvec3 wi = p.wo;
            glm::dvec3 n_hit;
            if (!arrival_normal(inst, ray, wi, n_hit)) {
                p.alive = false;
                continue;
            }
            p.point += static_cast<double>(ray.tfar) * wi;
            p.normal = n_hit;
            p.lifted = lift_off(p.point, n_hit, triangle_reach(inst, ray.prim_id));
            // Cloth met by a gather ray shows its mean colour, as a bounce sees it.
            p.albedo = albedo_at(inst, ray.prim_id, ray.u, ray.v);
            p.wo = -wi;
            p.instance = ray.inst_id;
        }
        // The lights at those vertices, one shadow ray each (index k of the light's sequence).
        for (size_t l = 0; l < lights.size(); ++l) {
            const LightData& light = lights[l];
            size_t shadows = 0;
            for (size_t j = 0; j < count; ++j) {
                const size_t k = static_cast<size_t>(of[j]);
                const GatherPath& p = paths[k];
                if (!p.alive || glm::dot(p.normal, light.dir) <= 0.0) continue;
                glm::dvec3 to_light = light.dir;
                if (!light.point) {
                    to_light = light.toward(
                        sample_pair(stream, first + static_cast<uint32_t>(k), pair + 1 + static_cast<uint32_t>(l)));
                    if (glm::dot(p.normal, to_light) <= 0.0) continue;  // below the facet's horizon
                }
                set_ray(shadow[shadows], p.lifted, to_light);
                shadow[shadows].mask = kStaticGeometry;
                shadow_of[shadows++] = static_cast<int>(k);
            }
            if (shadows == 0) continue;
            accel.occluded(shadow.data(), shadows);
            counts.shadow_rays += shadows;
            for (size_t j = 0; j < shadows; ++j) {
                if (!(shadow[j].tfar >= 0.0f)) continue;
                const size_t k = static_cast<size_t>(shadow_of[j]);
                const GatherPath& p = paths[k];
                const double mu_i = glm::dot(p.normal, light.dir);
                const double shape =
                    shape_at(instances[p.instance], mu_i, glm::dot(p.normal, p.wo), glm::dot(light.dir, p.wo));
                radiance[k] += (p.albedo * (light.scale * mu_i)) * shape * light.color * p.throughput;
            }
        }
        if (b == bounces) break;
        // The next bounce: a cosine-distributed direction, the throughput weighted by albedo·shape.
        size_t next = 0;
        for (size_t j = 0; j < count; ++j) {
            const size_t k = static_cast<size_t>(of[j]);
            GatherPath& p = paths[k];
            if (!p.alive) continue;
            double mu_i;
            const SamplePair q = sample_pair(stream, first + static_cast<uint32_t>(k), pair + kPairsPerBounce);
            const glm::dvec3 wi = cosine_direction(p.normal, q.u, q.v, mu_i);
            const double shape = shape_at(instances[p.instance], mu_i, glm::dot(p.normal, p.wo), glm::dot(wi, p.wo));
            p.throughput *= p.albedo * shape;
            if (!(mu_i > 0.0) || p.throughput == glm::dvec3(0.0)) {
                p.alive = false;
                continue;
            }
            p.point = p.lifted;
            p.wo = wi;
            set_ray(traced[next], p.point, wi);
            traced[next].mask = kStaticGeometry;
            of[next++] = static_cast<int>(k);
        }
        count = next;
    }
    radiance_out.insert(radiance_out.end(), radiance.begin(), radiance.end());
    first_dir_out.insert(first_dir_out.end(), first_dir.begin(), first_dir.end());
}

/// The relative standard error of the mean luminance of `radiance` (the ray estimates), as if they
/// were independent (low-discrepancy rays do better, so this errs on the side of more rays); 0
/// where every ray is dark.
double relative_standard_error(const std::vector<glm::dvec3>& radiance) {
    const size_t n = radiance.size();
    double sum = 0.0, sum2 = 0.0;
    for (const glm::dvec3& r : radiance) {
        const double l = luminance(r);
        sum += l;
        sum2 += l * l;
    }
    if (n < 2 || !(sum > 0.0)) return 0.0;
    const double mean = sum / static_cast<double>(n);
    const double variance = std::max(0.0, (sum2 - sum * mean) / static_cast<double>(n - 1));
    return std::sqrt(variance / static_cast<double>(n)) / mean;
}

/// The curvature fit's leaning normals (kCurvatureFitAzimuths for each of kCurvatureFitLeans), in
/// the tangent frame (t, b) of the normal they lean from, each with its row of the least-squares
/// fit for (Q_tt, Q_tb, Q_bb), and the inverse of the fit's normal matrix: the same for every gather.
struct CurvatureFit {
    struct Lean {
        double along, across_t, across_b;  // n = along·n₀ + across_t·t + across_b·b
        glm::dvec3 basis;                  // (d_t², 2·d_t·d_b, d_b²)
    };
    std::array<Lean, std::size(kCurvatureFitLeans) * kCurvatureFitAzimuths> leans{};
    glm::dmat3 inverse_normal_matrix{0.0};

    CurvatureFit() {
        glm::dmat3 normal_matrix(0.0);
        size_t i = 0;
        for (const double lean : kCurvatureFitLeans)
            for (int j = 0; j < kCurvatureFitAzimuths; ++j) {
                double c, s;
                turn_cos_sin(static_cast<double>(j) / kCurvatureFitAzimuths, c, s);
                const double dt = std::sin(lean) * c, db = std::sin(lean) * s;
                Lean& l = leans[i++];
                l = {std::cos(lean), dt, db, glm::dvec3(dt * dt, 2.0 * dt * db, db * db)};
                normal_matrix += glm::outerProduct(l.basis, l.basis);
            }
        inverse_normal_matrix = glm::inverse(normal_matrix);
    }
};
const CurvatureFit kCurvatureFit;

/// IndirectLight::tilt_curvature at unit `normal` from its gather: the cosine-distributed rays
/// (`above_radiance`, W/(m²·sr), along unit `above_dir`) and the rays below its horizon
/// (`below_*`, below_horizon_direction), whose rotation gradient is `gradient`. The irradiance
/// luminance at a leaning normal n is estimated from the same rays (the cosine rays reweighted by
/// n·ω/max(n₀·ω, kGradientMinCosine), as the gradient weighs them; the band's by n·ω over its
/// uniform density), at kCurvatureFitAzimuths azimuths for each of kCurvatureFitLeans, and the
/// symmetric tangent tensor Q fitted by least squares to what is left after the gradient:
/// E(n) − E(n₀) − (n − n₀)·gradient ≈ dᵀQd, d the lean's offset across n₀.
glm::dmat3 fit_tilt_curvature(const glm::dvec3& normal, const std::vector<glm::dvec3>& above_radiance,
                              const std::vector<glm::dvec3>& above_dir, const std::vector<glm::dvec3>& below_radiance,
                              const std::vector<glm::dvec3>& below_dir, const glm::dvec3& gradient) {
    std::vector<double> above_weight(above_radiance.size()), below_weight(below_radiance.size());
    // Band of solid angle 2π·sin(depth), sampled uniformly: each ray stands for 2π·sin/M.
    const double band = 2.0 * kPi * kBelowHorizonSine / static_cast<double>(below_radiance.size());
    for (size_t k = 0; k < above_radiance.size(); ++k)
        above_weight[k] = kPi / static_cast<double>(above_radiance.size()) * luminance(above_radiance[k]) /
                          std::max(glm::dot(above_dir[k], normal), kGradientMinCosine);
    for (size_t k = 0; k < below_radiance.size(); ++k) below_weight[k] = band * luminance(below_radiance[k]);
    const auto estimate = [&](const glm::dvec3& n) {
        double sum = 0.0;
        for (size_t k = 0; k < above_dir.size(); ++k) sum += above_weight[k] * std::max(0.0, glm::dot(n, above_dir[k]));
        for (size_t k = 0; k < below_dir.size(); ++k) sum += below_weight[k] * std::max(0.0, glm::dot(n, below_dir[k]));
        return sum;
    };
    const double upright = estimate(normal);
    glm::dvec3 t, b;
    orthonormal_basis(normal, t, b);
    glm::dvec3 moment(0.0);
    for (const CurvatureFit::Lean& lean : kCurvatureFit.leans) {
        const glm::dvec3 n = lean.along * normal + lean.across_t * t + lean.across_b * b;
        const double rest = estimate(n) - upright - glm::dot(n - normal, gradient);
        moment += rest * lean.basis;
    }
    const glm::dvec3 q = kCurvatureFit.inverse_normal_matrix * moment;
    return q.x * glm::outerProduct(t, t) + q.y * (glm::outerProduct(t, b) + glm::outerProduct(b, t)) +
           q.z * glm::outerProduct(b, b);
}

/// The indirect irradiance at `point` (world, metres) on a surface of unit `normal` from `rays`
/// gather rays (gather_batch), and while `error` > 0 and the rays' relative standard error is
/// above it, `rays` more at a time up to `max_rays`: the rays go where the light is uneven (a
/// shadowed point lit by a few sunlit patches), not everywhere.
IndirectLight gather(const Accel& accel, const std::vector<InstanceData>& instances,
                     const std::vector<LightData>& lights, const glm::dvec3& point, const glm::dvec3& normal,
                     uint64_t stream, int rays, int max_rays, double error, int bounces, FillCounts& counts) {
    const glm::dvec3 lifted = lift_off(point, normal, largest_coordinate(point));
    std::vector<glm::dvec3> radiance, first_dir;
    const size_t batch = static_cast<size_t>(rays);
    gather_batch(accel, instances, lights, lifted, normal, stream, 0, batch, bounces, counts, radiance, first_dir);
    while (error > 0.0 && radiance.size() + batch <= static_cast<size_t>(max_rays) &&
           relative_standard_error(radiance) > error)
        gather_batch(accel, instances, lights, lifted, normal, stream, static_cast<uint32_t>(radiance.size()), batch,
                     bounces, counts, radiance, first_dir);
    const size_t n = radiance.size();
    // Cosine-weighted sampling (pdf μ/π): E = ∫ L μ dω ≈ π/N · Σ L_k.
    IndirectLight out;
    glm::dvec3 direction(0.0);
    double weight = 0.0;
    // The rotation gradient: ∂E/∂n = ∫ L·(ω − (ω·n)n) dω, each cosine-distributed ray weighted by
    // π/(N·cos θ) (Ward & Heckbert 1992, "Irradiance gradients").
    for (size_t k = 0; k < n; ++k) {
        out.irradiance += radiance[k];
        const double w = luminance(radiance[k]);
        direction += w * first_dir[k];
        weight += w;
        const double mu = glm::dot(first_dir[k], normal);
        out.tilt_gradient += (w / std::max(mu, kGradientMinCosine)) * (first_dir[k] - mu * normal);
    }
    out.irradiance *= kPi / static_cast<double>(n);
    out.tilt_gradient *= kPi / static_cast<double>(n);
    out.mean_direction = weight > 0.0 ? direction / weight : glm::dvec3(0.0);
    std::vector<glm::dvec3> below_radiance, below_dir;
    gather_batch(accel, instances, lights, lifted, normal, mix64(stream ^ kBelowHorizonStreamSalt), 0,
                 std::max(kMinBelowHorizonRays, batch / kBelowHorizonRaysDivisor), bounces, counts, below_radiance,
                 below_dir, true);
    out.tilt_curvature = fit_tilt_curvature(normal, radiance, first_dir, below_radiance, below_dir, out.tilt_gradient);
    glm::dvec3 below_sum(0.0);
    for (const glm::dvec3& r : below_radiance) below_sum += r;
    out.below_colour = luminance(below_sum) > 0.0 ? below_sum / luminance(below_sum) : glm::dvec3(1.0);
    return out;
}

}  // namespace

IndirectLight IndirectLight::tilted(const glm::dvec3& from, const glm::dvec3& to, bool second_order) const {
    IndirectLight out = *this;
    const glm::dvec3 across = (to - from) - glm::dot(to - from, from) * from;
    // The curvature was fitted up to kMaxCurvatureLean: past it, its term is held at that lean's.
    const double lean = glm::length(across);
    const glm::dvec3 held = lean > kMaxCurvatureLean ? across * (kMaxCurvatureLean / lean) : across;
    const glm::dvec3 bend = second_order ? tilt_curvature * held : glm::dvec3(0.0);
    const double y = luminance(irradiance);
    if (y > 0.0) out.irradiance *= std::clamp(1.0 + glm::dot(to - from, tilt_gradient) / y, 0.0, kMaxTiltFactor);
    // What a lean gains is light from below the horizon, in that light's colour; what it loses,
    // the light it had. It is added, not scaled: a facet leaning over sunlit ground that sees a
    // black sky upright gets its neighbours' light all the same.
    const double curve = glm::dot(held, bend);
    if (curve > 0.0) {
        out.irradiance += curve * below_colour;
    } else {
        const double left = luminance(out.irradiance);
        if (left > 0.0) out.irradiance *= std::max(0.0, 1.0 + curve / left);
    }
    // The gradient where it now stands, so that a second tilt (lattice node → vertex → facet)
    // adds up to the one from the first normal.
    out.tilt_gradient += 2.0 * bend;
    return out;
}

IndirectLight LightCache::vertex(uint32_t instance, uint32_t vertex) const {
    Impl& m = *m_impl;
    if (!covers(instance))
        throw std::invalid_argument("instance: " + std::to_string(instance) + " is not covered by the light cache");
    if (vertex >= m.vertex_count[instance])
        throw std::invalid_argument("vertex: " + std::to_string(vertex) + " is past instance " +
                                    std::to_string(instance) + "'s " + std::to_string(m.vertex_count[instance]));
    std::atomic<Block*>& slot = m.blocks[instance][vertex / kBlockVertices];
    Block* block = slot.load(std::memory_order_acquire);
    if (!block) {
        auto fresh = std::make_unique<Block>();
        if (slot.compare_exchange_strong(block, fresh.get(), std::memory_order_acq_rel)) {
            block = fresh.release();
            m.n_blocks.fetch_add(1, std::memory_order_relaxed);
        }  // else another thread's block is in `block`, and ours is freed
    }
    const uint32_t j = vertex % kBlockVertices;
    uint8_t state = block->state[j].load(std::memory_order_acquire);
    if (state == kReady) return block->value[j];
    const auto start = std::chrono::steady_clock::now();
    FillCounts counts;
    glm::dvec3 point, normal;
    vertex_frame(m.instances[instance], m.normals[instance], vertex, point, normal);
    std::optional<IndirectLight> value;
    bool near_object = false;
    uint64_t probes = 0;  // the vertex's own probe (from_lattice), counted with its fill below
    if (m.lattices[instance]) value = from_lattice(instance, vertex, point, normal, near_object, probes);
    if (!value) {
        // Beside a bag the light changes within a lattice cell (its sunlit face lights the ground
        // at its foot, its shadowed face hides the sky), and the nodes under it are empty: such a
        // vertex gathers itself, with the bags' rays, as the bag's own vertices do.
        const bool labelled = m.instances[instance].label != 0;
        const int rays = labelled || near_object ? m_settings.rays_objects : m_settings.rays_background;
        const uint64_t stream =
            pixel_stream(m_settings.seed ^ kCacheStreamSalt, (static_cast<uint64_t>(instance) << 32) | vertex);
        value = gather(m_scene.accel(), m.instances, m.lights, point, normal, stream, rays,
                       rays * m_settings.max_rays_factor, m_settings.gather_error, m_settings.bounces, counts);
    }
    state = kEmpty;
    if (block->state[j].compare_exchange_strong(state, kFilling, std::memory_order_acq_rel)) {
        block->value[j] = *value;
        block->state[j].store(kReady, std::memory_order_release);
        m.vertices.fetch_add(1, std::memory_order_relaxed);
        m.gather_rays.fetch_add(counts.gather_rays, std::memory_order_relaxed);
        m.shadow_rays.fetch_add(counts.shadow_rays, std::memory_order_relaxed);
        m.probe_rays.fetch_add(probes, std::memory_order_relaxed);
    } else {
        m.redundant.fetch_add(1, std::memory_order_relaxed);  // another thread filled it meanwhile: the same value
    }
    const auto elapsed = std::chrono::steady_clock::now() - start;
    m.fill_nanoseconds.fetch_add(
        static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(elapsed).count()),
        std::memory_order_relaxed);
    return *value;
}

std::optional<IndirectLight> LightCache::from_lattice(uint32_t instance, uint32_t vertex, const glm::dvec3& point,
                                                      const glm::dvec3& normal, bool& near_object,
                                                      uint64_t& probes) const {
    const Lattice& lattice = *m_impl->lattices[instance];
    if (!lattice.fine[vertex]) return std::nullopt;  // its triangles are as coarse as the lattice
    const double h = lattice.spacing;
    const int bin = normal_bin(normal);
    const int a = bin / 2, b = (a + 1) % 3, c = (a + 2) % 3;  // the bin's axis and the plane across it
    const double u = point[b] / h, v = point[c] / h;
    const double u0 = std::floor(u), v0 = std::floor(v);
    const double fu = u - u0, fv = v - v0;
    // A tent of radius r cells about the vertex: the nodes u0 + du with |du − fu| < r, and the
    // same along v. r = 1 leaves the four corners of its cell, weighted bilinearly (written so,
    // the same bits as before the tent).
    const double r = lattice.filter_cells;
    const int reach = static_cast<int>(std::ceil(r)) - 1;
    const auto tent = [r](int d, double f) {
        return r == 1.0 ? (d ? f : 1.0 - f) : std::max(0.0, 1.0 - std::abs(d - f) / r);
    };
    IndirectLight out;
    glm::dvec3 direction(0.0);
    double total = 0.0, weight = 0.0;
    std::optional<bool> own_probe;  // whether the vertex itself is under a bag, once asked
    for (int du = -reach; du <= 1 + reach; ++du)
        for (int dv = -reach; dv <= 1 + reach; ++dv) {
            const double w = tent(du, fu) * tent(dv, fv);
            if (!(w > 0.0)) continue;
            const ProbedNode probed =
                lattice_node(instance, static_cast<int64_t>(u0) + du, static_cast<int64_t>(v0) + dv, bin);
            if (probed.under_object) {
                // The vertex's own probe, once: is it under a bag too?
                if (!own_probe) {
                    own_probe = under_object(instance, point, normal);
                    ++probes;
                }
                if (!*own_probe) {
                    near_object = true;
                    return std::nullopt;
                }
            }
            const std::optional<Node>& node = probed.node;
            if (!node) continue;
            const IndirectLight light = node->light.tilted(node->normal, normal, lattice.second_order);
            total += w;
            out.irradiance += w * light.irradiance;
            out.tilt_gradient += w * light.tilt_gradient;
            out.tilt_curvature += w * light.tilt_curvature;
            out.below_colour += w * light.below_colour;
            direction += (w * luminance(light.irradiance)) * light.mean_direction;
            weight += w * luminance(light.irradiance);
        }
    if (!(total > 0.0)) return std::nullopt;
    out.irradiance /= total;
    out.tilt_gradient /= total;
    out.tilt_curvature /= total;
    out.below_colour /= total;
    out.mean_direction = weight > 0.0 ? direction / weight : glm::dvec3(0.0);
    return out;
}

bool LightCache::under_object(uint32_t instance, const glm::dvec3& point, const glm::dvec3& normal) const {
    const Impl& m = *m_impl;
    const int bin = normal_bin(normal);
    const BinProbe ray = bin_probe(*m.lattices[instance], bin, point);
    RayHit probe;
    set_ray(probe, ray.origin, ray.along);
    probe.tfar = static_cast<float>(std::abs(point[bin / 2] - ray.origin[bin / 2]));
    probe.mask = kStaticGeometry;
    m_scene.accel().intersect(&probe, 1);
    return probe.geom_id != kInvalidId && probe.inst_id != instance && m.instances[probe.inst_id].label != 0;
}

LightCache::ProbedNode LightCache::lattice_node(uint32_t instance, int64_t i, int64_t j, int bin) const {
    Impl& m = *m_impl;
    Lattice& lattice = *m.lattices[instance];
    const uint64_t key = node_key(i, j, bin);
    {
        Lattice::Nodes::const_accessor found;
        if (lattice.nodes.find(found, key)) return found->second;
    }
    Lattice::Nodes::accessor slot;
    // The first thread to insert computes it while holding the slot; the others wait in find.
    if (!lattice.nodes.insert(slot, key)) return slot->second;
    m.n_nodes.fetch_add(1, std::memory_order_relaxed);
    // The probe comes from beyond the instance's bounds on the bin's side, against the bin.
    const double h = lattice.spacing;
    const int a = bin / 2, b = (a + 1) % 3, c = (a + 2) % 3;
    glm::dvec3 node(0.0);
    node[b] = static_cast<double>(i) * h;
    node[c] = static_cast<double>(j) * h;
    const auto [origin, along] = bin_probe(lattice, bin, node);
    RayHit probe;
    set_ray(probe, origin, along);
    probe.tfar = static_cast<float>(lattice.hi[a] - lattice.lo[a] + 2.0 * h);
    probe.mask = kStaticGeometry;
    m_scene.accel().intersect(&probe, 1);
    m.probe_rays.fetch_add(1, std::memory_order_relaxed);
    // Another instance in front (a bag, a rock on the ground), or a surface facing another bin:
    // the node stands for nothing, and the vertices around it use their other nodes; beside a
    // bag they gather themselves instead (from_lattice), so the node keeps that a bag was there.
    if (probe.geom_id == kInvalidId) return slot->second;
    if (probe.inst_id != instance) {
        slot->second.under_object = m.instances[probe.inst_id].label != 0;
        return slot->second;
    }
    const glm::dvec3 normal = normal_at(instance, probe.prim_id, probe.u, probe.v);
    if (normal_bin(normal) != bin) return slot->second;
    const glm::dvec3 point = origin + static_cast<double>(probe.tfar) * along;
    FillCounts counts;
    const uint64_t stream =
        pixel_stream(m_settings.seed ^ kNodeStreamSalt, mix64(key) ^ (static_cast<uint64_t>(instance) << 32));
    slot->second.node =
        Node{gather(m_scene.accel(), m.instances, m.lights, point, normal, stream, lattice.rays,
                    lattice.rays * m_settings.max_rays_factor, m_settings.gather_error, m_settings.bounces, counts),
             normal};
    m.gather_rays.fetch_add(counts.gather_rays, std::memory_order_relaxed);
    m.shadow_rays.fetch_add(counts.shadow_rays, std::memory_order_relaxed);
    return slot->second;
}

IndirectLight LightCache::at(uint32_t instance, uint32_t prim, double u, double v, const glm::dvec3* normal) const {
    return interpolate(corners(instance, prim, normal), u, v);
}

LightCache::TriangleCorners LightCache::corners(uint32_t instance, uint32_t prim, const glm::dvec3* normal) const {
    const InstanceData& inst = m_impl->instances[instance];
    const uint32_t* c = inst.triangles + 3 * static_cast<size_t>(prim);
    TriangleCorners out;
    for (int k = 0; k < 3; ++k) {
        out[k] = vertex(instance, c[k]);
        if (normal) out[k] = out[k].tilted(world_normal(inst, m_impl->normals[instance], c[k]), *normal);
    }
    return out;
}

IndirectLight LightCache::interpolate(const TriangleCorners& corners, double u, double v) {
    const double w[3] = {1.0 - u - v, u, v};
    IndirectLight out;
    glm::dvec3 direction(0.0);
    double weight = 0.0;
    for (int k = 0; k < 3; ++k) {
        const IndirectLight& corner = corners[k];
        out.irradiance += w[k] * corner.irradiance;
        out.tilt_gradient += w[k] * corner.tilt_gradient;
        out.tilt_curvature += w[k] * corner.tilt_curvature;
        out.below_colour += w[k] * corner.below_colour;
        direction += (w[k] * luminance(corner.irradiance)) * corner.mean_direction;
        weight += w[k] * luminance(corner.irradiance);
    }
    out.mean_direction = weight > 0.0 ? direction / weight : glm::dvec3(0.0);
    return out;
}

glm::dvec3 LightCache::normal_at(uint32_t instance, uint32_t prim, double u, double v) const {
    const InstanceData& inst = m_impl->instances[instance];
    const uint32_t* c = inst.triangles + 3 * static_cast<size_t>(prim);
    const float* normals = m_impl->normals[instance];
    auto normal = [&](int k) {
        const float* q = normals + 3 * static_cast<size_t>(c[k]);
        return glm::dvec3(q[0], q[1], q[2]);
    };
    const glm::dvec3 n = inst.normal_to_world * ((1.0 - u - v) * normal(0) + u * normal(1) + v * normal(2));
    const double len = glm::length(n);
    return len > 0.0 ? n / len : glm::dvec3(0.0);
}

void LightCache::fill_all() const {
    const Scene::ReadLock lock(m_scene);  // no change to the scene while the gathers trace it
    if (m_scene.static_revision() != m_revision)
        throw std::invalid_argument("light_cache: the scene's static geometry changed since the cache was built");
    const Impl& m = *m_impl;
    tbb::task_arena arena(m_settings.threads > 0 ? m_settings.threads : tbb::task_arena::automatic);
    for (uint32_t i = 0; i < m.covered.size(); ++i) {
        if (!m.covered[i]) continue;
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<uint32_t>(0, m.vertex_count[i], 64), [&](const auto& range) {
                for (uint32_t v = range.begin(); v != range.end(); ++v) vertex(i, v);
            });
        });
    }
}

LightCacheStats LightCache::stats() const {
    const Impl& m = *m_impl;
    LightCacheStats s;
    s.vertices = m.vertices.load();
    s.blocks = m.n_blocks.load();
    s.gather_rays = m.gather_rays.load();
    s.shadow_rays = m.shadow_rays.load();
    s.redundant_fills = m.redundant.load();
    s.nodes = m.n_nodes.load();
    s.probe_rays = m.probe_rays.load();
    s.bytes = sizeof(LightCache) + sizeof(Impl) + m.table_bytes + m.instances.size() * sizeof(InstanceData) +
              s.blocks * sizeof(Block) +
              // A node's entry: key, value and the map's list link and lock, about twice the pair.
              s.nodes * 2 * sizeof(Lattice::Nodes::value_type);
    s.fill_seconds = static_cast<double>(m.fill_nanoseconds.load()) * 1e-9;
    return s;
}

}  // namespace moonbot
