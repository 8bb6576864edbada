// Dirt on the bags (paper 3.4): the paper's dirt painting algorithm. Per bag instance, a
// square UV mask of R × R texels over [0, 1]² accumulates N stamps of one fixed splat shape B:
//
//   M(u) = clamp(Σ_k α · B(clamp((u − c_k)/s + ½, 0, 1)), 0, 1)
//
// with stamp centres c_k uniform in [0, 1]², brush size s (UV units: the side of the square a
// stamp covers), opacity α, additive blending, and the local coordinate clamped component-wise
// to [0, 1] as the paper's brush material does. The bag's base colour is then
// lerp(clean, M·DirtColour, M) (stained_base_colour). With N = 0 no mask exists at all.
//
// Texel (i, j) (column i along u, row j along v, both from 0) holds M at its centre
// ((i + ½)/R, (j + ½)/R); row 0 is v = 0 (not flipped like an image).
//
// Edges: stamps wrap around u and are clipped at v = 0 and v = 1. The bag's atlas
// (moonbot/scene/bag_mesh.py uv_atlas) is a belt of the four side faces across the whole of u
// whose two ends, u = 0 and u = 1, are the same edge of the body (the −x/−y edge; the atlas
// scale is the belt's length whenever 2L ≥ H, true of any bag), so wrapping u keeps a stain
// that crosses that edge continuous. v = 0 is the bottom face's far (+y) edge and v = 1 lies in
// the empty top half of the atlas; they are not neighbours, so v clips, as the paper's render
// target does. Sampling (StainMask::sample) follows the same rule: u wraps, v clamps to the
// outermost texel centres.
//
// Stamp centres come from the project's counter-based generator (rng.h) keyed by the bag's
// seed and the stamp's index, and each texel sums its stamps in index order, so a mask is a
// pure function of (seed, parameters), bit for bit, whatever the number of threads.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

namespace moonbot {

/// The splat shape B at local coordinate (lu, lv) in [0, 1]² (clamped to it), in [0, 1]: the
/// procedural stand-in for the paper's marketplace liquid-splat texture. With p = 2(lu, lv) − 1
/// (so p spans [−1, 1]²), r = |p|, θ its angle:
/// - a blob whose rim is R(θ) = 0.55(1 + 0.12 cos(3θ + 0.4) + 0.08 cos(5θ + 1.9)
///   + 0.05 cos(7θ + 4.1) + 0.04 cos(11θ + 2.6)), a few incommensurate lobes that make an
///   irregular, liquid-looking outline; inside it B = (1 − 0.3t²)·(1 − smoothstep(0.75, 1, t)),
///   t = r/R(θ): thickest where the dirt landed, thinning and then fading over the outer quarter
///   of the radius (a soft edge, but one that reaches 0 exactly at the rim);
/// - six droplets thrown clear of the blob (discs of radius 0.035–0.06 at distance 0.80–0.92 from
///   the centre, the same soft profile), the spatter of a splash.
/// B is the maximum of the two. Every part lies within r < 0.99, so B is exactly 0 on and near
/// the border of the local square and clamping the local coordinate smears nothing. The support
/// (B > 0) has the closed-form area splat_support_area().
double splat(double lu, double lv);

/// Area of {B > 0} in local units (the local square has area 1): the blob's
/// ½∫R(θ)²dθ = π·0.55²(1 + ½Σa_m²) plus the droplets' πρ², over the 4 of p-space. ≈ 0.2515.
double splat_support_area();

/// The dirt painting parameters. Defaults (see docs/physics.md "Bags"):
/// - `stamps` N ≥ 0 (the paper's "seeds", swept over 0, 15, 30, 90; 0, clean, by default);
/// - `brush_size` s = 0.18 UV units, in (0, 0.5]: a 19 cm square on the default bag's atlas
///   (1.04 m per UV unit) whose blob is ~10 cm across; one stamp then covers s²·0.2515 of the
///   atlas, so a point is stained (M > 0) with probability 1 − (1 − 0.00815)^N: 11.5 % at 15,
///   22 % at 30, 52 % at 90 — visibly large, never total;
/// - `opacity` α = 0.5, in [0, 1]: one stamp alone half-stains (M ≤ 0.5), two overlapping reach
///   the full dirt colour, so overlaps read darker, as accumulated dust does;
/// - `resolution` R = 512 texels, in [1, 8192]: 2 mm texels on the default bag, as fine as a
///   pixel on the bag at the default 1.1 m orbit (640 px over 60°), 1 MiB of float32 per bag.
struct StainParams {
    int stamps = 0;
    double brush_size = 0.18;
    double opacity = 0.5;
    int resolution = 512;

    /// Throws std::invalid_argument naming the field.
    void validate() const;
};

/// Centre c_k in [0, 1)² of stamp k of the bag with `seed`: two uniform01 draws keyed by
/// (seed with the stain's domain tag, k), so a bag's stain does not correlate with pixel noise
/// drawn from the same seed.
glm::dvec2 stamp_centre(uint64_t seed, uint32_t k);

/// An R × R float32 mask, row-major (row j = v, column i = u), values in [0, 1]. Allocation is
/// counted process-wide (stain_mask_bytes, stain_masks_allocated); held by unique_ptr, never
/// copied, so the count is the masks that exist.
class StainMask {
public:
    explicit StainMask(int resolution);
    ~StainMask();
    StainMask(const StainMask&) = delete;
    StainMask& operator=(const StainMask&) = delete;

    int resolution() const { return resolution_; }
    const float* data() const { return texels_.data(); }
    float* data() { return texels_.data(); }
    float texel(int i, int j) const { return texels_[static_cast<size_t>(j) * resolution_ + i]; }

    /// Bilinear M at (u, v) between texel centres: u wraps (period 1), v clamps to the outermost
    /// texel centres (a constant extension beyond them). u, v finite.
    float sample(double u, double v) const;

private:
    int resolution_;
    std::vector<float> texels_;
};

/// Paints a bag's mask; nullptr when params.stamps == 0, which allocates nothing. `threads`
/// in 0..1024 (0 = all); the result does not depend on it. Throws std::invalid_argument on
/// invalid params or threads.
std::unique_ptr<StainMask> paint_stain(const StainParams& params, uint64_t seed, int threads = 0);

/// The paper's base colour lerp(clean, m·dirt, m) = clean·(1 − m) + m·(m·dirt), m clamped to
/// [0, 1]; linear RGB. m = 0 returns `clean` exactly.
glm::dvec3 stained_base_colour(const glm::dvec3& clean, double m, const glm::dvec3& dirt);

/// Bytes of stain masks alive now, process-wide.
uint64_t stain_mask_bytes();
/// Stain masks ever allocated in this process.
uint64_t stain_masks_allocated();

}  // namespace moonbot
