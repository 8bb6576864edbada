// The only doorway to Embree. Everything else in the core speaks in RayHit and plain arrays, so a
// port to Embree 4 (no ray streams, new intersect signatures) changes accel.cpp and nothing else.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace moonbot {

/// Sentinel for "no hit" in RayHit::geom_id / inst_id.
constexpr uint32_t kInvalidId = 0xFFFFFFFFu;

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
class Accel {
public:
    Accel();
    ~Accel();
    Accel(const Accel&) = delete;
    Accel& operator=(const Accel&) = delete;

    /// Builds a prototype BVH at once over `n_vertices` xyz float triples (the buffer must hold
    /// 4 readable bytes past the last vertex, Embree's padding rule, and outlive this Accel) and
    /// `n_triangles` index triples. Returns the prototype index.
    uint32_t add_prototype(const float* vertices, size_t n_vertices, const uint32_t* triangles,
                           size_t n_triangles);

    /// Adds an instance of `prototype` with a column-major 3x4 world-from-object affine transform.
    /// Instances are numbered 0, 1, 2, ... in the order added; hits report that number in inst_id.
    uint32_t add_instance(uint32_t prototype, const float world_from_object_3x4[12]);

    /// Rebuilds `prototype`'s BVH after its vertex buffer (the one given to add_prototype, same
    /// vertex count) was rewritten in place, and marks its instances for the next commit. Only
    /// this prototype's BVH is rebuilt; the others are left alone.
    void update_prototype(uint32_t prototype);

    /// Builds the top-level BVH. Cheap next to prototype builds: it only bounds instances.
    void commit();

    /// Closest hits for `n` rays, as 64-ray streams. `coherent` hints that rays share origin and
    /// nearly share direction (camera rays). Misses keep geom_id == kInvalidId.
    void intersect(RayHit* rays, size_t n, bool coherent) const;

    /// Any-hit test for `n` rays; an occluded ray gets tfar = -inf, a free one keeps its tfar.
    void occluded(RayHit* rays, size_t n, bool coherent) const;

    /// The same two queries one ray at a time (rtcIntersect1 / rtcOccluded1): the baseline the
    /// Embree-limit benchmark compares streams against.
    void intersect_single(RayHit* rays, size_t n) const;
    void occluded_single(RayHit* rays, size_t n) const;

    /// The same two queries as packets of W = 8 or 16 rays (rtcIntersect8/16, rtcOccluded8/16):
    /// `n` rays in ceil(n / W) packets, the lanes past the n-th inactive. Misses keep
    /// geom_id == kInvalidId; an occluded ray gets tfar = -inf. For the Embree-limit benchmark.
    /// Always with Embree's default (incoherent) context: with RTC_INTERSECT_CONTEXT_FLAG_COHERENT,
    /// Debian's Embree 3.13.5 on an AVX-512 CPU never returned from rtcOccluded16 once
    /// rtcIntersect16 had been called on the scene (sun shadow rays of the default scene).
    template <int W>
    void intersect_packets(RayHitPacket<W>* packets, size_t n) const;
    template <int W>
    void occluded_packets(RayHitPacket<W>* packets, size_t n) const;

    /// Number of BVH builds so far (prototypes + top-level commits): lets tests prove that a
    /// scene is not rebuilt per view.
    uint64_t builds() const { return m_builds; }

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
    uint64_t m_builds = 0;
};

}  // namespace moonbot
