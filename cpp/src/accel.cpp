#include "moonbot/accel.h"

#include "orthonormal_basis.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <limits>
#include <map>
#include <mutex>
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
// performance reference measured as fastest on AVX2 (docs/design.md).
constexpr size_t kStream = 64;

// Embree's packet types and entry points by width, so one template serves 8 and 16.
template <int W>
struct PacketCalls;
template <>
struct PacketCalls<8> {
    using RayHitW = RTCRayHit8;
    using RayW = RTCRay8;
    static constexpr auto intersect = rtcIntersect8;
    static constexpr auto occluded = rtcOccluded8;
};
template <>
struct PacketCalls<16> {
    using RayHitW = RTCRayHit16;
    using RayW = RTCRay16;
    static constexpr auto intersect = rtcIntersect16;
    static constexpr auto occluded = rtcOccluded16;
};

/// Embree's valid mask for a packet whose first `active` lanes carry rays: -1 on, 0 off.
template <int W>
struct alignas(4 * W) ValidMask {
    int lanes[W];
    explicit ValidMask(size_t active) {
        for (int i = 0; i < W; ++i) lanes[i] = static_cast<size_t>(i) < active ? -1 : 0;
    }
};

/// Calls `trace(valid, p)` for each packet p of n rays held W to a packet, in order; `valid` has
/// every lane on, or in a last packet of fewer rays only the lanes that carry one.
template <int W, typename Trace>
void each_packet(size_t n, Trace trace) {
    const ValidMask<W> full(W);
    for (size_t p = 0; p * W < n; ++p) {
        const size_t active = std::min<size_t>(W, n - p * W);
        if (active == W) {
            trace(full.lanes, p);
        } else {
            const ValidMask<W> partial(active);
            trace(partial.lanes, p);
        }
    }
}

[[noreturn]] void throw_device_error(RTCDevice device, const char* what) {
    RTCError code = rtcGetDeviceError(device);
    throw std::runtime_error(std::string("embree: ") + what + " failed (error " +
                             std::to_string(static_cast<int>(code)) + ")");
}

constexpr Isa kIsas[] = {Isa::automatic, Isa::sse2, Isa::sse42, Isa::avx, Isa::avx2, Isa::avx512};

bool cpu_runs(Isa isa) {
    __builtin_cpu_init();
    switch (isa) {
        case Isa::automatic: return true;
        case Isa::sse2: return __builtin_cpu_supports("sse2");
        case Isa::sse42: return __builtin_cpu_supports("sse4.2") && __builtin_cpu_supports("popcnt");
        case Isa::avx: return cpu_runs(Isa::sse42) && __builtin_cpu_supports("avx");
        case Isa::avx2:
            return cpu_runs(Isa::avx) && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                   __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("abm");
        case Isa::avx512:
            return cpu_runs(Isa::avx2) && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                   __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512bw") &&
                   __builtin_cpu_supports("avx512vl");
    }
    return false;
}

std::string isa_list(const std::vector<Isa>& isas) {
    std::string out;
    for (Isa i : isas) out += (out.empty() ? "" : ", ") + std::string(isa_name(i));
    return out;
}

int native_packet_width(RTCDevice device) {
    if (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)) return 16;
    if (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED)) return 8;
    return 4;
}

int expected_packet_width(Isa isa) {
    switch (isa) {
        case Isa::avx512: return 16;
        case Isa::avx2:
        case Isa::avx: return 8;
        default: return 4;
    }
}

/// The process's Embree device for each resolved ISA, shared by the Accels that use it (Embree
/// devices are thread-safe) and released with the last of them.
std::shared_ptr<RTCDeviceTy> device_for(Isa isa) {
    static std::mutex mutex;
    static std::map<Isa, std::weak_ptr<RTCDeviceTy>> devices;
    std::lock_guard<std::mutex> lock(mutex);
    if (auto device = devices[isa].lock()) return device;
    // Embree uses the process's TBB scheduler, so builds honour the caller's task_arena.
    const std::string config = std::string("verbose=0,isa=") + isa_name(isa);
    RTCDevice raw = rtcNewDevice(config.c_str());
    if (!raw) throw std::runtime_error("embree: rtcNewDevice(\"" + config + "\") failed");
    std::shared_ptr<RTCDeviceTy> device(raw, rtcReleaseDevice);
    // Embree silently falls back to a narrower ISA when the library lacks the kernels asked for;
    // its native packet width (4 for SSE, 8 for AVX and AVX2, 16 for AVX-512) tells.
    const int width = native_packet_width(raw);
    if (width != expected_packet_width(isa))
        throw std::runtime_error(std::string("embree: this Embree library has no ") + isa_name(isa) +
                                 " kernels (its devices run " + std::to_string(width) +
                                 "-wide packets); set embree_isa to a narrower ISA");
    devices[isa] = device;
    return device;
}

}  // namespace

const char* isa_name(Isa isa) {
    switch (isa) {
        case Isa::automatic: return "auto";
        case Isa::sse2: return "sse2";
        case Isa::sse42: return "sse4.2";
        case Isa::avx: return "avx";
        case Isa::avx2: return "avx2";
        case Isa::avx512: return "avx512";
    }
    return "?";
}

Isa parse_isa(const std::string& name, const std::string& what) {
    for (Isa isa : kIsas)
        if (name == isa_name(isa)) return isa;
    throw std::invalid_argument(what + ": must be one of auto, sse2, sse4.2, avx, avx2, avx512; got '" + name + "'");
}

std::vector<Isa> cpu_isas() {
    std::vector<Isa> out;
    for (Isa isa : kIsas)
        if (isa != Isa::automatic && cpu_runs(isa)) out.push_back(isa);
    return out;
}

Isa resolve_isa(Isa requested) {
    const std::vector<Isa> offered = cpu_isas();
    if (offered.empty()) throw std::invalid_argument("embree_isa: this CPU runs none of Embree's kernels (no SSE2)");
    // AVX2 where the CPU runs it: as fast as AVX-512 on the benchmark's scenes
    // (bench/results/embree-isa-*.json), and clear of Debian's AVX-512 kernels, whose masks GCC 12
    // may break (the coherent hang is one such case; no other is known, none is ruled out).
    const Isa preferred = cpu_runs(Isa::avx2) ? Isa::avx2 : offered.back();
    if (requested == Isa::automatic) {
        const char* pinned = std::getenv("MOONBOT_EMBREE_ISA");
        if (!pinned || !*pinned) return preferred;
        requested = parse_isa(pinned, "MOONBOT_EMBREE_ISA");
        if (requested == Isa::automatic) return preferred;
    }
    if (!cpu_runs(requested))
        throw std::invalid_argument(std::string("embree_isa: this CPU cannot run '") + isa_name(requested) +
                                    "'; it runs " + isa_list(offered));
    return requested;
}

struct Accel::Impl {
    std::shared_ptr<RTCDeviceTy> device_owner;
    RTCDevice device = nullptr;
    RTCScene top = nullptr;
    std::vector<RTCScene> prototypes;
    std::vector<uint32_t> instance_prototype;  // per instance id: the prototype it instances
    // Per instance id, the cofactor of its linear part, column-major: it maps a prototype's
    // geometric normal to the world with the winding's orientation kept (Embree's Ng is
    // (v1 − v0) × (v2 − v0), outward for counter-clockwise triangles).
    std::vector<std::array<double, 9>> instance_normal;
    uint32_t n_instances = 0;
};

Accel::Accel(Isa isa, bool watertight)
    : m_impl(std::make_unique<Impl>()), m_isa(resolve_isa(isa)), m_watertight(watertight) {
    m_impl->device_owner = device_for(m_isa);
    m_impl->device = m_impl->device_owner.get();
    m_impl->top = rtcNewScene(m_impl->device);
    if (!m_impl->top) throw_device_error(m_impl->device, "rtcNewScene");
    if (m_watertight) rtcSetSceneFlags(m_impl->top, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(m_impl->top, RTC_BUILD_QUALITY_MEDIUM);
}

Accel::~Accel() {
    for (RTCScene s : m_impl->prototypes) rtcReleaseScene(s);
    if (m_impl->top) rtcReleaseScene(m_impl->top);
}

uint32_t Accel::add_prototype(const float* vertices, size_t n_vertices, const uint32_t* triangles, size_t n_triangles) {
    RTCDevice device = m_impl->device;
    RTCScene scene = rtcNewScene(device);
    if (!scene) throw_device_error(device, "rtcNewScene");
    // MEDIUM: HIGH gave no measurable trace speed-up on this CPU and builds 40 % slower
    // (docs/design.md, BVH build table).
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    if (m_watertight) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geom) {
        rtcReleaseScene(scene);
        throw_device_error(device, "rtcNewGeometry");
    }
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices, 0, 3 * sizeof(float),
                               n_vertices);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, triangles, 0, 3 * sizeof(uint32_t),
                               n_triangles);
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
    rtcSetGeometryMask(inst, kAllRays);
    rtcCommitGeometry(inst);
    const uint32_t id = m_impl->n_instances++;
    rtcAttachGeometryByID(m_impl->top, inst, id);
    rtcReleaseGeometry(inst);
    m_impl->instance_prototype.push_back(prototype);
    const float* m = world_from_object_3x4;  // columns: m[0..2], m[3..5], m[6..8], translation
    auto at = [&](int row, int col) { return static_cast<double>(m[3 * col + row]); };
    std::array<double, 9> cof{};
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) {
            const int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            cof[3 * c + r] = at(r1, c1) * at(r2, c2) - at(r1, c2) * at(r2, c1);
        }
    m_impl->instance_normal.push_back(cof);
    return id;
}

void Accel::set_instance_mask(uint32_t instance, uint32_t mask) {
    if (instance >= m_impl->n_instances) throw std::out_of_range("embree: no instance " + std::to_string(instance));
    RTCGeometry geom = rtcGetGeometry(m_impl->top, instance);
    rtcSetGeometryMask(geom, mask);
    rtcCommitGeometry(geom);
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
    if (rtcGetDeviceError(m_impl->device) != RTC_ERROR_NONE) throw_device_error(m_impl->device, "top-level build");
    ++m_builds;
}

// Every context below is rtcInitIntersectContext's: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT (see
// accel.h on the coherent kernels).
void Accel::intersect(RayHit* rays, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (size_t i = 0; i < n; ++i) {
        rays[i].geom_id = kInvalidId;
        rays[i].inst_id = kInvalidId;
    }
    for (size_t begin = 0; begin < n; begin += kStream) {
        const size_t count = std::min(kStream, n - begin);
        rtcIntersect1M(m_impl->top, &context, reinterpret_cast<RTCRayHit*>(rays + begin), static_cast<unsigned>(count),
                       sizeof(RayHit));
    }
}

namespace {

/// Whether `r`'s hit is on the back of its triangle: its world normal (`cofactor` applied to
/// Embree's object-space Ng) points along the ray.
bool back_face(const RayHit& r, const std::array<double, 9>& cofactor) {
    double along = 0.0;
    for (int row = 0; row < 3; ++row) {
        const double n = cofactor[row] * r.ng_x + cofactor[3 + row] * r.ng_y + cofactor[6 + row] * r.ng_z;
        along += n * (row == 0 ? r.dir_x : row == 1 ? r.dir_y : r.dir_z);
    }
    return along > 0.0;
}

}  // namespace

size_t Accel::intersect_watertight(RayHit* rays, size_t n, bool ground) const {
    intersect(rays, n);
    if (!m_watertight) return 0;
    const auto& normals = m_impl->instance_normal;
    // Rays toward the sky miss by right; only a downward one can have slipped through the ground.
    auto suspect = [&](const RayHit& r) {
        return r.geom_id == kInvalidId ? ground && r.dir_z < 0.0f : back_face(r, normals[r.inst_id]);
    };
    std::vector<size_t> again;
    for (size_t i = 0; i < n; ++i)
        if (suspect(rays[i])) again.push_back(i);
    if (again.empty()) return 0;
    constexpr int kLooks = 4;
    std::vector<RayHit> tilted(again.size() * kLooks);
    for (size_t k = 0; k < again.size(); ++k) {
        const RayHit& r = rays[again[k]];
        const glm::dvec3 dir(r.dir_x, r.dir_y, r.dir_z);
        const double len = glm::length(dir);
        glm::dvec3 across[2];  // two directions across the ray
        detail::orthonormal_basis(dir / len, across[0], across[1]);
        for (int look = 0; look < kLooks; ++look) {
            RayHit& t = tilted[k * kLooks + look];
            t = r;
            const double step = (look % 2 ? -kVertexNudge : kVertexNudge) * len;
            const glm::dvec3 d = dir + step * across[look / 2];
            t.dir_x = static_cast<float>(d.x);
            t.dir_y = static_cast<float>(d.y);
            t.dir_z = static_cast<float>(d.z);
            t.tfar = std::numeric_limits<float>::infinity();
            t.geom_id = t.inst_id = kInvalidId;
        }
    }
    intersect(tilted.data(), tilted.size());
    for (size_t k = 0; k < again.size(); ++k) {
        RayHit& r = rays[again[k]];
        // A back face the ray met stands unless a front face comes no later: a ray through a
        // silhouette edge touches the back triangle there, and its tilted copies pass beside it.
        const float limit = r.geom_id == kInvalidId ? std::numeric_limits<float>::infinity() : r.tfar * (1.0f + 1e-4f);
        const RayHit* best = nullptr;
        for (int look = 0; look < kLooks; ++look) {
            const RayHit& t = tilted[k * kLooks + look];
            if (t.geom_id == kInvalidId || back_face(t, normals[t.inst_id]) || !(t.tfar <= limit)) continue;
            if (!best || t.tfar < best->tfar) best = &t;
        }
        if (!best) continue;
        r.tfar = best->tfar;
        r.ng_x = best->ng_x, r.ng_y = best->ng_y, r.ng_z = best->ng_z;
        r.u = best->u, r.v = best->v;
        r.prim_id = best->prim_id, r.geom_id = best->geom_id, r.inst_id = best->inst_id;
    }
    return tilted.size();
}

void Accel::occluded(RayHit* rays, size_t n) const {
    // Eight-wide packets (rtcOccluded8), not ray streams: an any-hit answer is the same yes or no
    // whichever kernel gives it, and the packet kernel traces this renderer's shadow rays faster.
    // Every lane carries a real ray, the last packet's idle lanes a copy of its last one:
    // Debian's Embree checks its SSE2 kernel's lanes (bvh_intersector_hybrid.cpp, assertion
    // `all(valid, ray.valid())`), and garbage in an idle lane aborted the process.
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    constexpr int W = 8;
    RayHitPacket<W> packet;
    each_packet<W>(n, [&](const int* valid, size_t p) {
        const size_t begin = p * W, last = std::min(n, begin + W) - 1;
        for (int lane = 0; lane < W; ++lane) pack_lane(rays[std::min(begin + lane, last)], packet, lane);
        PacketCalls<W>::occluded(valid, m_impl->top, &context, reinterpret_cast<PacketCalls<W>::RayW*>(&packet));
        for (size_t i = begin; i <= last; ++i) rays[i].tfar = packet.tfar[i - begin];
    });
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
    for (size_t i = 0; i < n; ++i) rtcOccluded1(m_impl->top, &context, reinterpret_cast<RTCRay*>(rays + i));
}

template <int W>
void Accel::intersect_packets(RayHitPacket<W>* packets, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    each_packet<W>(n, [&](const int* valid, size_t p) {
        RayHitPacket<W>& packet = packets[p];
        std::fill_n(packet.geom_id, W, kInvalidId);
        std::fill_n(packet.inst_id, W, kInvalidId);
        auto* rays = reinterpret_cast<typename PacketCalls<W>::RayHitW*>(&packet);
        PacketCalls<W>::intersect(valid, m_impl->top, &context, rays);
    });
}

template <int W>
void Accel::occluded_packets(RayHitPacket<W>* packets, size_t n) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    each_packet<W>(n, [&](const int* valid, size_t p) {
        // RTCRayW is the leading member of RTCRayHitW, as for the streams.
        auto* rays = reinterpret_cast<typename PacketCalls<W>::RayW*>(&packets[p]);
        PacketCalls<W>::occluded(valid, m_impl->top, &context, rays);
    });
}

template void Accel::intersect_packets<8>(RayHitPacket<8>*, size_t) const;
template void Accel::intersect_packets<16>(RayHitPacket<16>*, size_t) const;
template void Accel::occluded_packets<8>(RayHitPacket<8>*, size_t) const;
template void Accel::occluded_packets<16>(RayHitPacket<16>*, size_t) const;

}  // namespace moonbot
