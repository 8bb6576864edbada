// Regolith's granular micro-texture: albedo and relief below the terrain mesh's spacing (the mesh
// is 1 cm near the target and coarser outward), a pure function of the world position, prefiltered
// over each camera sample's footprint.
//
// What it stands for. Lunar soil is a powder (median grain size 40–130 µm, Lunar Sourcebook,
// Heiken, Vaniman & French 1991, ch. 7) that no camera here resolves; what a rover camera sees at
// mm to cm scales is its aggregate structure: clods and agglutinates, millimetre rock chips and
// mm–cm pits, whose relief sets the photometric roughness (Hapke 2012 §12.2.4: the slopes behind
// θ̄ are "dominated by millimeter-scale roughness", ~100–1000 µm), and albedo speckle between
// bright fresh fragments and dark glassy agglutinates. We model it as a sum of octaves of 3-D
// value noise (hashed lattice values interpolated with the cubic s(t) = 3t² − 2t³) of cell sizes
// c_k = finest_cell_m·2^k up to coarsest_cell_m, each octave on its own rotated lattice so that no
// grid direction shows:
//
//   albedo factor  a(p) = 1 + A·Σ_k w_k·v_k(R_k p / c_k)
//   height         z(p) = S·Σ_k w_k·c_k^H·u_k(R_k p / c_k)          (metres)
//
// v_k, u_k are two independent lattices (the two halves of one 64-bit hash per lattice point),
// uniform in [−1, 1] at the lattice points, so every octave has mean 0 and the albedo's mean is
// the material's albedo. The relief's amplitude grows with scale as c^H (H = 0.6: Helfenstein &
// Shepard 1999 measured H = 0.54–0.7 for undisturbed regolith at 0.1 mm–cm, as quoted by Shepard
// et al. 2001), so its slopes grow toward the finest scale, as the Moon's do.
//
// Closed-form statistics (lattice values iid uniform on [−1, 1], variance ⅓; averaged over the
// position in a cell): Var v = ⅓·(26/35)³ and, along ANY unit direction d, Var(∂v/∂d) =
// ⅓·2·(6/5)·(26/35)² per unit cell (the cross-covariances of the partial derivatives vanish,
// because E[s'·(2s − 1)] = 0). A and S are set from them so that the unfiltered albedo factor has
// relative RMS `albedo_rms` and the unfiltered relief has a one-dimensional RMS slope (RMS of
// tan along any direction in the surface) of tan(`slope_rms_deg`), the convention of Shepard et
// al. 2001. That slope spread adds to whatever the mesh and the photometric function already
// carry (tan² add for independent scales): it is a separate knob so that the terrain's relief and
// Hapke's θ̄ can be partitioned against it.
//
// Prefilter. A Gaussian of σ = footprint/2 (fabric.h's convention) multiplies a sinusoid of
// wavelength λ by exp(−½(2πσ/λ)²); an octave's energy lies at wavelengths ≥ 2c_k, so it keeps
// g_k = exp(−½(π·footprint/(2c_k))²). Its weight is w_k = max(0, (g_k − 0.01)/0.99): continuous,
// 1 for a footprint far below the cell, exactly 0 once g_k < 1 % (footprint > 1.94 c_k). Finer
// octaves fade into the flat mean instead of aliasing, and beyond 1.94 × coarsest_cell_m the
// texture is exactly the mean (factor 1, no relief) and nothing is evaluated.
//
// A pixel reads the texture once, at its centre, with the footprint of its box (render.cpp's
// texture_point), so that its samples no longer spread over the texture; what they used to do by
// sampling, the texture does in closed form. The albedo is linear in the texture: its box
// average is the prefiltered value (weights w_k). The shading is not linear in the relief's
// slopes, so the relief gives two things: the mean slope over the pixel, the prefiltered field
// averaged over the box once more (weights w_k², the gain of a filter √2 wider), and how far the
// prefiltered slopes spread over the box about it, Σ_k w_k²·(1 − w_k²)·Var_k (the octave's
// filtered variance less the part the box's mean keeps). The renderer averages the lights'
// cosines over that spread.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

namespace moonbot {

/// The texture's parameters. 0 for both albedo_rms and slope_rms_deg turns it off.
struct GrainParams {
    double albedo_rms = 0.0;        ///< relative RMS of the unfiltered albedo factor, [0, 0.5]
    double slope_rms_deg = 0.0;     ///< 1-D RMS slope of the unfiltered relief, degrees, [0, 45]
    double finest_cell_m = 1.0e-3;  ///< smallest lattice cell, metres, > 0
    double coarsest_cell_m = 1.6e-2;  ///< largest lattice cell (octaves double up to it), ≥ finest, ≤ 1 m
    double hurst = 0.6;             ///< relief amplitude ∝ cell^hurst, [0, 1]
    uint64_t seed = 0;              ///< keys the lattices

    bool enabled() const { return albedo_rms > 0.0 || slope_rms_deg > 0.0; }
    /// Throws std::invalid_argument naming the field: ranges above, at most 16 octaves, and an
    /// albedo factor that cannot reach 0 (A·octaves < 1: value noise is bounded by 1).
    void validate() const;
};

/// The texture over one footprint.
struct GrainSample {
    double albedo_factor = 1.0;         ///< multiplies the material's albedo; > 0
    glm::dvec3 gradient{0.0};  ///< ∇z of the relief over the box (weights w_k²), world frame, metres per metre
    /// How far the prefiltered relief's 1-D slopes (tan) spread over a box of the footprint's
    /// width about `gradient`, as a variance (tan²): Σ_k w_k²·(1 − w_k²)·Var_k, Var_k an
    /// octave's unfiltered slope variance (see the file's comment). 0 beyond flat_footprint_m.
    double residual_slope_variance = 0.0;
};

class SubgridRelief;

/// A validated GrainParams with its octaves laid out (cells, rotations, amplitudes), and on the
/// terrain the roughness its mesh did not hold (subgrid_relief.h), read with the grain.
class RegolithGrain {
public:
    /// Throws std::invalid_argument as GrainParams::validate does. Params that are not enabled
    /// lay out no octave (only `subgrid`, if given, is read).
    explicit RegolithGrain(const GrainParams& params, std::shared_ptr<const SubgridRelief> subgrid = nullptr);

    const GrainParams& params() const { return m_params; }
    int octaves() const { return static_cast<int>(m_octaves.size()); }
    /// Footprints (metres) at or above this give exactly the mean: factor 1, zero gradient.
    /// Infinite with a subgrid relief, which holds relief at every footprint.
    double flat_footprint_m() const { return m_flat_footprint; }

    /// The texture at world point p (metres) as a pixel of footprint `footprint_m` ≥ 0 metres sees
    /// it (the width of surface the pixel covers; for an anisotropic footprint, an isotropic one's
    /// of the same area): see the file's comment. With a subgrid relief, its gradient and slope
    /// spread are added to the grain's (independent scales: slopes and variances add).
    GrainSample eval(const glm::dvec3& p, double footprint_m) const;

private:
    struct Octave {
        glm::dmat3 rotation;  // lattice from world, scaled by 1/cell
        glm::dmat3 to_world;  // transpose of rotation (gradients back to the world), times 1/cell
        double cell;  // metres
        double albedo_amplitude;
        double height_amplitude;  // metres
        double slope_variance;  // unfiltered 1-D slope variance, tan²
        uint64_t key;
    };
    GrainParams m_params;
    std::vector<Octave> m_octaves;
    std::shared_ptr<const SubgridRelief> m_subgrid;
    double m_flat_footprint = 0.0;
    double m_grain_flat_footprint = 0.0;  // the grain's own octaves are all filtered out from here
};

/// `normal` (unit) tilted by a relief gradient (world): the normal of the height field z over the
/// surface, n − (g − (g·n)n), normalised.
glm::dvec3 perturbed_normal(const glm::dvec3& normal, const glm::dvec3& gradient);

/// Var of one octave's value noise (lattice values uniform on [−1, 1]): ⅓·(26/35)³.
constexpr double kValueNoiseVariance = (1.0 / 3.0) * (26.0 / 35.0) * (26.0 / 35.0) * (26.0 / 35.0);
/// Var of its derivative along any unit direction, per unit cell: ⅓·2·(6/5)·(26/35)².
constexpr double kValueNoiseSlopeVariance = (1.0 / 3.0) * 2.0 * 1.2 * (26.0 / 35.0) * (26.0 / 35.0);

}  // namespace moonbot
