#include "moonbot/accel.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace moonbot {

static_assert(sizeof(RayHit) == sizeof(RTCRayHit), "RayHit must mirror RTCRayHit");
static_assert(alignof(RayHit) == alignof(RTCRayHit), "RayHit must mirror RTCRayHit");
static_assert(offsetof(RayHit, tfar) == offsetof(RTCRayHit, ray.tfar), "RayHit layout");
static_assert(offsetof(RayHit, ng_x) == offsetof(RTCRayHit, hit.Ng_x), "RayHit layout");
static_assert(offsetof(RayHit, prim_id) == offsetof(RTCRayHit, hit.primID), "RayHit layout");
static_assert(offsetof(RayHit, geom_id) == offsetof(RTCRayHit, hit.geomID), "RayHit layout");
static_assert(offsetof(RayHit, inst_id) == offsetof(RTCRayHit, hit.instID), "RayHit layout");
static_assert(sizeof(RayHitPacket<8>) == sizeof(RTCRayHit8), "RayHitPacket<8> mirrors RTCRayHit8");
static_assert(alignof(RayHitPacket<8>) == alignof(RTCRayHit8), "RayHitPacket<8> mirrors RTCRayHit8");
static_assert(offsetof(RayHitPacket<8>, ng_x) == offsetof(RTCRayHit8, hit.Ng_x), "packet layout");
static_assert(offsetof(RayHitPacket<8>, inst_id) == offsetof(RTCRayHit8, hit.instID), "packet layout");
static_assert(sizeof(RayHitPacket<16>) == sizeof(RTCRayHit16), "RayHitPacket<16> mirrors RTCRayHit16");
static_assert(alignof(RayHitPacket<16>) == alignof(RTCRayHit16), "RayHitPacket<16> mirrors RTCRayHit16");
static_assert(offsetof(RayHitPacket<16>, ng_x) == offsetof(RTCRayHit16, hit.Ng_x), "packet layout");
static_assert(offsetof(RayHitPacket<16>, inst_id) == offsetof(RTCRayHit16, hit.instID), "packet layout");
static_assert(RTC_MAX_INSTANCE_LEVEL_COUNT == 1, "RayHit holds one instance level");
static_assert(kInvalidId == RTC_INVALID_GEOMETRY_ID, "kInvalidId mirrors Embree");

namespace {

// Embree's stream calls take at most this many rays at a time in our use; 64 is the width the
// performance reference measured as fastest on AVX2 (reference/performance-limits.md).
constexpr size_t kStream = 64;

// Embree's packet entry points by width, so one template serves 8 and 16.
template <int W>
struct PacketCalls;
template <>
struct PacketCalls<8> {
    using RayHitW = RTCRayHit8;
    using RayW = RTCRay8;
    static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RTCRayHit8* r) {
        rtcIntersect8(valid, s, c, r);
    }
    static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, RTCRay8* r) {
        rtcOccluded8(valid, s, c, r);
    }
};
template <>
struct PacketCalls<16> {
    using RayHitW = RTCRayHit16;
    using RayW = RTCRay16;
    static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RTCRayHit16* r) {
        rtcIntersect16(valid, s, c, r);
    }
    static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, RTCRay16* r) {
        rtcOccluded16(valid, s, c, r);
    }
};

/// Embree's valid mask for a packet whose first `active` lanes carry rays: -1 on, 0 off.
template <int W>
struct alignas(4 * W) ValidMask {
    int lanes[W];
    explicit ValidMask(size_t active) {
        for (int i = 0; i < W; ++i) lanes[i] = static_cast<size_t>(i) < active ? -1 : 0;
    }
};

[[noreturn]] void throw_device_error(RTCDevice device, const char* what) {
    RTCError code = rtcGetDeviceError(device);
    throw std::runtime_error(std::string("embree: ") + what + " failed (error " +
                             std::to_string(static_cast<int>(code)) + ")");
}

}  // namespace

struct Accel::Impl {
    RTCDevice device = nullptr;
    RTCScene top = nullptr;
    std::vector<RTCScene> prototypes;
    std::vector<uint32_t> instance_prototype;  // per instance id: the prototype it instances
    uint32_t n_instances = 0;
};

Accel::Accel() : m_impl(std::make_unique<Impl>()) {
    // Embree uses the process's TBB scheduler, so builds honour the caller's task_arena.
    m_impl->device = rtcNewDevice("verbose=0");
    if (!m_impl->device) throw std::runtime_error("embree: rtcNewDevice failed");
    m_impl->top = rtcNewScene(m_impl->device);
    if (!m_impl->top) throw_device_error(m_impl->device, "rtcNewScene");
    rtcSetSceneBuildQuality(m_impl->top, RTC_BUILD_QUALITY_MEDIUM);
}

Accel::~Accel() {
    for (RTCScene s : m_impl->prototypes) rtcReleaseScene(s);
    if (m_impl->top) rtcReleaseScene(m_impl->top);
    if (m_impl->device) rtcReleaseDevice(m_impl->device);
}

uint32_t Accel::add_prototype(const float* vertices, size_t n_vertices, const uint32_t* triangles,
                              size_t n_triangles) {
    RTCDevice device = m_impl->device;
    RTCScene scene = rtcNewScene(device);
    if (!scene) throw_device_error(device, "rtcNewScene");
    // MEDIUM: HIGH gave no measurable trace speed-up on this CPU and builds 40 % slower
    // (reference/performance-limits.md, BVH build table).
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geom) {
        rtcReleaseScene(scene);
        throw_device_error(device, "rtcNewGeometry");
    }
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices, 0,
                               3 * sizeof(float), n_vertices);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, triangles, 0,
                               3 * sizeof(uint32_t), n_triangles);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene, geom, 0);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
        rtcReleaseScene(scene);
        throw_device_error(device, "prototype build");
    }
    ++m_builds;
    m_impl->prototypes.push_back(scene);
    return static_cast<uint32_t>(m_impl->prototypes.size() - 1);
}

uint32_t Accel::add_instance(uint32_t prototype, const float world_from_object_3x4[12]) {
    if (prototype >= m_impl->prototypes.size())
        throw std::out_of_range("embree: no prototype " + std::to_string(prototype));
    RTCGeometry inst = rtcNewGeometry(m_impl->device, RTC_GEOMETRY_TYPE_INSTANCE);
    if (!inst) throw_device_error(m_impl->device, "rtcNewGeometry(instance)");
    rtcSetGeometryInstancedScene(inst, m_impl->prototypes[prototype]);
    rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, world_from_object_3x4);
    rtcCommitGeometry(inst);
    const uint32_t id = m_impl->n_instances++;
    rtcAttachGeometryByID(m_impl->top, inst, id);
    rtcReleaseGeometry(inst);
    m_impl->instance_prototype.push_back(prototype);
    return id;
}

void Accel::update_prototype(uint32_t prototype) {
    if (prototype >= m_impl->prototypes.size())
        throw std::out_of_range("embree: no prototype " + std::to_string(prototype));
    RTCScene scene = m_impl->prototypes[prototype];
    RTCGeometry geom = rtcGetGeometry(scene, 0);
    rtcUpdateGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(geom);
    rtcCommitScene(scene);
    if (rtcGetDeviceError(m_impl->device) != RTC_ERROR_NONE) throw_device_error(m_impl->device, "prototype rebuild");
    ++m_builds;
    // Its instances' bounds changed: re-commit them so the next top-level build sees it.
    for (uint32_t id = 0; id < m_impl->n_instances; ++id)
        if (m_impl->instance_prototype[id] == prototype) rtcCommitGeometry(rtcGetGeometry(m_impl->top, id));
}

void Accel::commit() {
    rtcCommitScene(m_impl->top);
    if (rtcGetDeviceError(m_impl->device) != RTC_ERROR_NONE)
        throw_device_error(m_impl->device, "top-level build");
    ++m_builds;
}

void Accel::intersect(RayHit* rays, size_t n, bool coherent) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    for (size_t i = 0; i < n; ++i) {
        rays[i].geom_id = kInvalidId;
        rays[i].inst_id = kInvalidId;
    }
    for (size_t begin = 0; begin < n; begin += kStream) {
        const size_t count = std::min(kStream, n - begin);
        rtcIntersect1M(m_impl->top, &context, reinterpret_cast<RTCRayHit*>(rays + begin),
                       static_cast<unsigned>(count), sizeof(RayHit));
    }
}

void Accel::occluded(RayHit* rays, size_t n, bool coherent) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    for (size_t begin = 0; begin < n; begin += kStream) {
        const size_t count = std::min(kStream, n - begin);
        // RTCRay is the leading member of RTCRayHit, so the same buffer with the RayHit stride
        // is a valid ray stream.
        rtcOccluded1M(m_impl->top, &context, reinterpret_cast<RTCRay*>(rays + begin),
                      static_cast<unsigned>(count), sizeof(RayHit));
    }
}

void Accel::intersect_single(RayHit* rays, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (size_t i = 0; i < n; ++i) {
        rays[i].geom_id = kInvalidId;
        rays[i].inst_id = kInvalidId;
        rtcIntersect1(m_impl->top, &context, reinterpret_cast<RTCRayHit*>(rays + i));
    }
}

void Accel::occluded_single(RayHit* rays, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (size_t i = 0; i < n; ++i)
        rtcOccluded1(m_impl->top, &context, reinterpret_cast<RTCRay*>(rays + i));
}

template <int W>
void Accel::intersect_packets(RayHitPacket<W>* packets, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);  // incoherent: see accel.h
    const ValidMask<W> full(W);
    for (size_t p = 0; p * W < n; ++p) {
        RayHitPacket<W>& packet = packets[p];
        std::fill_n(packet.geom_id, W, kInvalidId);
        std::fill_n(packet.inst_id, W, kInvalidId);
        auto* rays = reinterpret_cast<typename PacketCalls<W>::RayHitW*>(&packet);
        const size_t active = std::min<size_t>(W, n - p * W);
        if (active == W) {
            PacketCalls<W>::intersect(full.lanes, m_impl->top, &context, rays);
        } else {
            const ValidMask<W> partial(active);
            PacketCalls<W>::intersect(partial.lanes, m_impl->top, &context, rays);
        }
    }
}

template <int W>
void Accel::occluded_packets(RayHitPacket<W>* packets, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);  // incoherent: see accel.h
    const ValidMask<W> full(W);
    for (size_t p = 0; p * W < n; ++p) {
        // RTCRayW is the leading member of RTCRayHitW, as for the streams.
        auto* rays = reinterpret_cast<typename PacketCalls<W>::RayW*>(&packets[p]);
        const size_t active = std::min<size_t>(W, n - p * W);
        if (active == W) {
            PacketCalls<W>::occluded(full.lanes, m_impl->top, &context, rays);
        } else {
            const ValidMask<W> partial(active);
            PacketCalls<W>::occluded(partial.lanes, m_impl->top, &context, rays);
        }
    }
}

template void Accel::intersect_packets<8>(RayHitPacket<8>*, size_t) const;
template void Accel::intersect_packets<16>(RayHitPacket<16>*, size_t) const;
template void Accel::occluded_packets<8>(RayHitPacket<8>*, size_t) const;
template void Accel::occluded_packets<16>(RayHitPacket<16>*, size_t) const;

}  // namespace moonbot
