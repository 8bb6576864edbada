#include "moonbot/stain.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "moonbot/rng.h"

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::atomic<uint64_t> g_mask_bytes{0};
std::atomic<uint64_t> g_masks_allocated{0};

/// Mixed into the bag's seed so stain draws are a stream of their own ("stain" in ASCII).
constexpr uint64_t kStainDomain = 0x737461696E000000ull;

// The blob's rim R(θ) = kRimRadius(1 + Σ a_m cos(mθ + φ_m)).
constexpr double kRimRadius = 0.55;
struct Lobe {
    int m;
    double amplitude, phase;
};
constexpr Lobe kLobes[] = {{3, 0.12, 0.4}, {5, 0.08, 1.9}, {7, 0.05, 4.1}, {11, 0.04, 2.6}};

// Droplets: (angle of the centre in degrees, distance of the centre, radius), in p-space. Each
// lies wholly outside the blob (distance − radius ≥ 0.76 > 0.55·1.29, the rim's bound) and
// inside r < 0.99, and they are ≥ 55° apart, so no two parts overlap and the support's area is
// the sum of theirs.
struct Droplet {
    double angle_deg, distance, radius;
};
constexpr Droplet kDroplets[] = {{20, 0.86, 0.06},   {75, 0.80, 0.04},   {140, 0.90, 0.05},
                                 {205, 0.84, 0.035}, {260, 0.92, 0.045}, {320, 0.82, 0.055}};
constexpr double kSupportRadius = 0.99;  // B = 0 for r ≥ this

double smoothstep(double e0, double e1, double x) {
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

/// The soft profile shared by blob and droplets, t = distance / rim: 1 − 0.3t² thinning
/// towards the rim, faded to exactly 0 over t in [0.75, 1].
double profile(double t) {
    if (t >= 1.0) return 0.0;
    return (1.0 - 0.3 * t * t) * (1.0 - smoothstep(0.75, 1.0, t));
}

void require(bool ok, const char* field, const std::string& what) {
    if (!ok) throw std::invalid_argument(std::string(field) + ": " + what);
}

}  // namespace

double splat(double lu, double lv) {
    const double x = 2.0 * std::clamp(lu, 0.0, 1.0) - 1.0;
    const double y = 2.0 * std::clamp(lv, 0.0, 1.0) - 1.0;
    const double r2 = x * x + y * y;
    if (r2 >= kSupportRadius * kSupportRadius) return 0.0;
    const double r = std::sqrt(r2);

    double b = 0.0;
    // cos(mθ + φ) = Re(e^{imθ})cos φ − Im(e^{imθ})sin φ, with e^{imθ} = ((x + iy)/r)^m by
    // repeated multiplication: no atan2, no cos of large arguments.
    if (r < kRimRadius * 1.3) {
        double rim = 1.0;
        if (r > 0.0) {
            const double c1 = x / r, s1 = y / r;
            double cm = 1.0, sm = 0.0;
            int m = 0;
            for (const Lobe& lobe : kLobes) {
                for (; m < lobe.m; ++m) {
                    const double c = cm * c1 - sm * s1;
                    sm = sm * c1 + cm * s1;
                    cm = c;
                }
                rim += lobe.amplitude * (cm * std::cos(lobe.phase) - sm * std::sin(lobe.phase));
            }
        }
        b = profile(r / (kRimRadius * rim));
    }
    for (const Droplet& d : kDroplets) {
        const double a = d.angle_deg * (kPi / 180.0);
        const double dx = x - d.distance * std::cos(a), dy = y - d.distance * std::sin(a);
        const double dr2 = dx * dx + dy * dy;
        if (dr2 < d.radius * d.radius) b = std::max(b, profile(std::sqrt(dr2) / d.radius));
    }
    return b;
}

double splat_support_area() {
    double lobes = 0.0;
    for (const Lobe& lobe : kLobes) lobes += lobe.amplitude * lobe.amplitude;
    double area = kPi * kRimRadius * kRimRadius * (1.0 + 0.5 * lobes);
    for (const Droplet& d : kDroplets) area += kPi * d.radius * d.radius;
    return area / 4.0;  // p-space [−1, 1]² has area 4, the local square 1
}

void StainParams::validate() const {
    require(stamps >= 0, "stamps", "must be >= 0, got " + std::to_string(stamps));
    require(std::isfinite(brush_size) && brush_size > 0 && brush_size <= 0.5, "brush_size",
            "must be in (0, 0.5] (UV units)");
    require(std::isfinite(opacity) && opacity >= 0 && opacity <= 1, "opacity", "must be in [0, 1]");
    require(resolution >= 1 && resolution <= 8192, "resolution",
            "must be in 1..8192, got " + std::to_string(resolution));
}

glm::dvec2 stamp_centre(uint64_t seed, uint32_t k) {
    const uint64_t stream = pixel_stream(mix64(seed ^ kStainDomain), k);
    return {stream_uniform01(stream, 0, 0), stream_uniform01(stream, 0, 1)};
}

StainMask::StainMask(int resolution) : resolution_(resolution) {
    if (resolution < 1 || resolution > 8192)
        throw std::invalid_argument("resolution: must be in 1..8192, got " + std::to_string(resolution));
    texels_.assign(static_cast<size_t>(resolution) * resolution, 0.0f);
    g_mask_bytes += texels_.size() * sizeof(float);
    ++g_masks_allocated;
}

StainMask::~StainMask() { g_mask_bytes -= texels_.size() * sizeof(float); }

float StainMask::sample(double u, double v) const {
    const int n = resolution_;
    // Continuous texel coordinates: texel i's centre is at i + ½ in units of 1/R.
    const double fu = (u - std::floor(u)) * n - 0.5;
    const double fv = std::clamp(v * n - 0.5, 0.0, static_cast<double>(n - 1));
    const double iu0 = std::floor(fu), iv0 = std::floor(fv);
    const double tu = fu - iu0, tv = fv - iv0;
    const int i0 = (static_cast<int>(iu0) % n + n) % n, i1 = (i0 + 1) % n;  // wrap in u
    const int j0 = static_cast<int>(iv0), j1 = std::min(j0 + 1, n - 1);
    const double top = (1 - tu) * texel(i0, j0) + tu * texel(i1, j0);
    const double bottom = (1 - tu) * texel(i0, j1) + tu * texel(i1, j1);
    return static_cast<float>((1 - tv) * top + tv * bottom);
}

std::unique_ptr<StainMask> paint_stain(const StainParams& params, uint64_t seed, int threads) {
    params.validate();
    if (threads < 0 || threads > 1024) throw std::invalid_argument("threads: must be in 0..1024 (0 = all)");
    if (params.stamps == 0) return nullptr;

    const int n = params.resolution;
    const double s = params.brush_size, alpha = params.opacity;
    std::vector<glm::dvec2> centres(static_cast<size_t>(params.stamps));
    for (size_t k = 0; k < centres.size(); ++k) centres[k] = stamp_centre(seed, static_cast<uint32_t>(k));

    auto mask = std::make_unique<StainMask>(n);
    float* out = mask->data();
    // Texels whose centre (i + ½)/R lies within s/2 of c: i in [ceil((c − s/2)R − ½),
    // floor((c + s/2)R − ½)]; outside that square the clamped local coordinate is on the
    // border, where B = 0.
    auto first = [&](double c) { return static_cast<int>(std::ceil((c - 0.5 * s) * n - 0.5)); };
    auto last = [&](double c) { return static_cast<int>(std::floor((c + 0.5 * s) * n - 0.5)); };

    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& rows) {
            std::vector<double> sum(static_cast<size_t>(n));
            for (int j = rows.begin(); j != rows.end(); ++j) {
                std::fill(sum.begin(), sum.end(), 0.0);
                const double v = (j + 0.5) / n;
                // Every texel adds its stamps in index order: the same sums on any thread.
                for (const glm::dvec2& c : centres) {
                    if (j < first(c.y) || j > last(c.y)) continue;  // clipped in v
                    const double lv = (v - c.y) / s + 0.5;
                    for (int i = first(c.x), i_end = last(c.x); i <= i_end; ++i) {
                        const double lu = ((i + 0.5) / n - c.x) / s + 0.5;
                        sum[static_cast<size_t>((i % n + n) % n)] += alpha * splat(lu, lv);  // wrapped in u
                    }
                }
                for (int i = 0; i < n; ++i)
                    out[static_cast<size_t>(j) * n + i] =
                        static_cast<float>(std::min(sum[static_cast<size_t>(i)], 1.0));
            }
        });
    });
    return mask;
}

glm::dvec3 stained_base_colour(const glm::dvec3& clean, double m, const glm::dvec3& dirt) {
    m = std::clamp(m, 0.0, 1.0);
    return clean * (1.0 - m) + m * (m * dirt);
}

uint64_t stain_mask_bytes() { return g_mask_bytes.load(); }
uint64_t stain_masks_allocated() { return g_masks_allocated.load(); }

}  // namespace moonbot
