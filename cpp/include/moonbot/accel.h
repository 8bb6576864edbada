// The only doorway to Embree. Everything else in the core speaks in RayHit and plain arrays, so a
// port to Embree 4 (no ray streams, new intersect signatures) changes accel.cpp and nothing else.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace moonbot {

/// The SIMD instruction set Embree's traversal kernels run in, narrowest first. Debian's Embree
/// 3.13.5 carries kernels for each; `automatic` is resolve_isa's choice.
enum class Isa : uint8_t { automatic, sse2, sse42, avx, avx2, avx512 };

/// "auto", "sse2", "sse4.2", "avx", "avx2" or "avx512" (Embree's own spelling of each).
const char* isa_name(Isa isa);

/// The Isa named `name` (as isa_name spells it). Throws std::invalid_argument that lists the
/// names, prefixed with `what` (the field or variable the name came from).
Isa parse_isa(const std::string& name, const std::string& what = "embree_isa");

/// The ISAs this CPU can run Embree's kernels in, narrowest first (never `automatic`), from the
/// CPU's feature flags as Embree requires them (AVX2 with FMA, BMI1/2 and LZCNT; AVX-512 with F,
/// DQ, CD, BW and VL).
std::vector<Isa> cpu_isas();

/// The ISA a device asked for `requested` runs in here. `automatic` is the environment variable
/// MOONBOT_EMBREE_ISA where set (so one machine's every process can be pinned), else AVX2 where
/// the CPU runs it (measured as fast as AVX-512, and clear of the AVX-512 kernels), else the
/// widest of cpu_isas(). Throws std::invalid_argument when the CPU lacks the ISA asked for.
Isa resolve_isa(Isa requested);

/// Sentinel for "no hit" in RayHit::geom_id / inst_id.
constexpr uint32_t kInvalidId = 0xFFFFFFFFu;

/// Ray and instance masks (Embree skips an instance when ray.mask & instance mask is 0). Every
/// instance carries kAllRays unless it moves between views, when it carries kMovingGeometry
/// only; a ray with mask kStaticGeometry (the light cache's) then passes through what moves.
constexpr uint32_t kStaticGeometry = 0x1u;
constexpr uint32_t kMovingGeometry = 0x2u;
constexpr uint32_t kAllRays = 0xFFFFFFFFu;

/// One ray and its hit record. Laid out exactly like Embree 3's RTCRayHit (checked by static_assert
/// in accel.cpp), so a stream of them is handed to Embree without copying.
/// Units: metres; `tfar` is in units of |dir| (the renderer makes the camera-z of dir equal to 1 so
/// tfar is the z-depth directly).
struct alignas(16) RayHit {
    float org_x, org_y, org_z, tnear;
    float dir_x, dir_y, dir_z, time;
    float tfar;
    uint32_t mask, id, flags;
    float ng_x, ng_y, ng_z, u, v;  // geometric normal in the prototype's object space (unnormalised)
    uint32_t prim_id, geom_id, inst_id;
};

/// W rays and their hits in structure-of-arrays form, laid out exactly like Embree 3's
/// RTCRayHit8 / RTCRayHit16 (checked in accel.cpp), for the packet queries. W is 8 or 16.
template <int W>
struct alignas(4 * W) RayHitPacket {
    float org_x[W], org_y[W], org_z[W], tnear[W];
    float dir_x[W], dir_y[W], dir_z[W], time[W];
    float tfar[W];
    uint32_t mask[W], id[W], flags[W];
    float ng_x[W], ng_y[W], ng_z[W], u[W], v[W];
    uint32_t prim_id[W], geom_id[W], inst_id[W];
};

/// Copies the query fields of `r` into lane `lane` of `p` (its hit fields are left alone).
template <int W>
inline void pack_lane(const RayHit& r, RayHitPacket<W>& p, int lane) {
    p.org_x[lane] = r.org_x;
    p.org_y[lane] = r.org_y;
    p.org_z[lane] = r.org_z;
    p.tnear[lane] = r.tnear;
    p.dir_x[lane] = r.dir_x;
    p.dir_y[lane] = r.dir_y;
    p.dir_z[lane] = r.dir_z;
    p.time[lane] = r.time;
    p.tfar[lane] = r.tfar;
    p.mask[lane] = r.mask;
    p.id[lane] = r.id;
    p.flags[lane] = r.flags;
}

/// A two-level bounding volume hierarchy: prototypes (triangle meshes, each its own BVH) and
/// instances of them in a top-level scene. Not copyable; not thread-safe to modify, thread-safe
/// to trace once committed.
///
/// Every query runs in Embree's incoherent mode. With the coherent flag, Debian's Embree 3.13.5
/// (built with GCC 12) spins forever in rtcOccluded1M on AVX-512 CPUs (AMD Zen 4 and Zen 5 seen;
/// the AVX2 kernels finish). Embree 4.4.1 fixed a loop over the ray mask in its coherent hybrid
/// kernel (BVHNIntersectorKHybrid::occludedCoherent) that cannot end when GCC before 14 leaves the
/// mask's upper bits undefined (Embree pull request 574): the same code path. No call here passes
/// the coherent flag, so no ISA reaches those kernels; the coherent mode bought this renderer no
/// speed at any ISA (bench/bench_embree_isa.py). Every BVH is built robust (RTC_SCENE_FLAG_ROBUST): watertight
/// triangle tests, so a ray through an edge or vertex shared by two triangles hits one of them.
class Accel {
public:
    /// A BVH on the process's Embree device for `isa` (resolve_isa's answer; one device per ISA,
    /// shared by every Accel that uses it and released with the last of them). `watertight`
    /// false builds Embree's default (non-robust) BVHs and makes intersect_watertight a plain
    /// intersect: only for measuring what watertightness costs.
    explicit Accel(Isa isa = Isa::automatic, bool watertight = true);
    ~Accel();
    Accel(const Accel&) = delete;
    Accel& operator=(const Accel&) = delete;

    /// Builds a prototype BVH at once over `n_vertices` xyz float triples (the buffer must hold
    /// 4 readable bytes past the last vertex, Embree's padding rule, and outlive this Accel) and
    /// `n_triangles` index triples. Returns the prototype index.
    uint32_t add_prototype(const float* vertices, size_t n_vertices, const uint32_t* triangles, size_t n_triangles);

    /// Adds an instance of `prototype` with a column-major 3x4 world-from-object affine transform.
    /// Instances are numbered 0, 1, 2, ... in the order added; hits report that number in inst_id.
    uint32_t add_instance(uint32_t prototype, const float world_from_object_3x4[12]);

    /// Sets instance `instance`'s mask (kAllRays when added; see kStaticGeometry); takes effect
    /// at the next commit.
    void set_instance_mask(uint32_t instance, uint32_t mask);

    /// Rebuilds `prototype`'s BVH after its vertex buffer (the one given to add_prototype, same
    /// vertex count) was rewritten in place, and marks its instances for the next commit. Only
    /// this prototype's BVH is rebuilt; the others are left alone.
    void update_prototype(uint32_t prototype);

    /// Builds the top-level BVH. Cheap next to prototype builds: it only bounds instances.
    void commit();

    /// Closest hits for `n` rays, as 64-ray streams. Misses keep geom_id == kInvalidId.
    void intersect(RayHit* rays, size_t n) const;

    /// intersect(), made watertight at shared vertices too. Robust traversal closes shared edges,
    /// but a ray through a vertex that several triangles share can still slip past all of them
    /// (0.2 % of rays aimed exactly at terrain-grid vertices). Every mesh here is a closed
    /// surface or a height field seen from above, wound counter-clockwise seen from outside, so a
    /// ray from outside meets a triangle's front first. A ray whose first hit is a back face, or,
    /// with `ground` (the scene has a height field under everything: world z is up), a downward
    /// ray that misses, is traced again along four directions tilted by kVertexNudge; the nearest
    /// front-face hit among them replaces its result if it comes no later than the back face (a
    /// ray grazing a silhouette edge touches the back triangle there); none: the result stands.
    /// The replacement's t and barycentrics are the tilted ray's; callers that need them exact
    /// re-solve against the hit triangle's plane. Returns the rays it traced beyond the n.
    size_t intersect_watertight(RayHit* rays, size_t n, bool ground) const;

    /// The tilt of intersect_watertight's second look, relative to the ray's direction: far
    /// above float32's resolution of a position (6e-8 of it), far below a pixel's footprint.
    static constexpr double kVertexNudge = 1.0 / 65536.0;

    /// Any-hit test for `n` rays, in 8-wide packets; an occluded ray gets tfar = -inf, a free one
    /// keeps its tfar.
    void occluded(RayHit* rays, size_t n) const;

    /// The same two queries one ray at a time (rtcIntersect1 / rtcOccluded1): the baseline the
    /// Embree-limit benchmark compares streams against.
    void intersect_single(RayHit* rays, size_t n) const;
    void occluded_single(RayHit* rays, size_t n) const;

    /// The same two queries as packets of W = 8 or 16 rays (rtcIntersect8/16, rtcOccluded8/16):
    /// `n` rays in ceil(n / W) packets, the lanes past the n-th inactive. Misses keep
    /// geom_id == kInvalidId; an occluded ray gets tfar = -inf. For the Embree-limit benchmark.
    template <int W>
    void intersect_packets(RayHitPacket<W>* packets, size_t n) const;
    template <int W>
    void occluded_packets(RayHitPacket<W>* packets, size_t n) const;

    /// Number of BVH builds so far (prototypes + top-level commits): lets tests prove that a
    /// scene is not rebuilt per view.
    uint64_t builds() const { return m_builds; }

    /// The ISA this BVH's device runs in (never `automatic`).
    Isa isa() const { return m_isa; }
    bool watertight() const { return m_watertight; }

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
    uint64_t m_builds = 0;
    Isa m_isa;
    bool m_watertight;
};

}  // namespace moonbot
