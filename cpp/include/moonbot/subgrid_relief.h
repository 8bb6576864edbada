// The terrain's subgrid relief: the roughness octaves a graded mesh could not hold where a pixel
// reads them, given back to the shading as a bump.
//
// Why. A procedural location's mesh (moonbot/terrain/location.py) is one graded grid: 1 cm cells
// about the bags, growing by 2 % a cell outward, so about 0.02·r at r metres. Each octave of the
// fractal roughness (moonbot/terrain/roughness.py: value noise of lattice spacing λ, amplitude a)
// is drawn into the mesh with weight clip(λ/(2c) − 1, 0, 1) for the local cell c, faded out below
// two cells so that it never aliases. The mesh therefore keeps the law of RMS slope against
// baseline only down to a few cells: at 5 m from the target it holds no relief shorter than
// 20–40 cm, although a pixel there spans about a centimetre. What the mesh dropped is exactly the
// complement, weight 1 − clip(λ/(2c) − 1, 0, 1) of the same octaves, and it is given back here,
// prefiltered over the pixel's footprint as the grain is (regolith_texture.h), so a pixel sees the
// law's slopes down to its own size at every distance, and none twice.
//
// The field. Octave k is Python's `Roughness` octave evaluated the same way: at world (x, y),
// u = (cos θ_k·x + sin θ_k·y)/λ_k + o_u, v = (−sin θ_k·x + cos θ_k·y)/λ_k + o_v, and
// n(u, v) = bilinear interpolation, in the quintic fades s(t) = t³(6t² − 15t + 10), of lattice
// values keyed by the octave's 64-bit key and the cell's integer corners (SplitMix64, the value
// (h >> 11)·2⁻⁵² − 1, uniform on [−1, 1)). Heights agree with the Python field to rounding
// (tests/test_subgrid_relief.py).
//
// The prefilter. Octave k's energy lies at wavelengths ≥ 2λ_k, so a footprint f keeps the gain
// g = exp(−½(π·f/(2λ_k))²) of it, and the weight w = max(0, (g − 0.01)/0.99), as the grain does:
// the mean slope over the pixel's box takes w², the spread of the filtered slopes about it
// w²(1 − w²)·Var_k, Var_k the octave's unfiltered 1-D slope variance (a_k·m_k/λ_k)²·V,
// V = ⅓·2·E[s'²]·E[(1 − s)² + s²] = ⅓·2·(10/7)·(181/231) of unit value noise, m_k the octave's
// subgrid weight.
//
// What it leaves out. The bump casts no shadow: at a 12° Sun, Smith's (1967) shadowing function
// puts the shadowed share of a surface of 5° RMS slope below 1 %. The small craters the mesh did
// not draw (location.py keeps a crater where it spans 5 cells) are given back apart
// (subgrid_craters.h).
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace moonbot {

/// The dropped relief over one footprint (regolith_texture.h's GrainSample has the same two fields).
struct ReliefSample {
    glm::dvec3 gradient{0.0};  ///< ∇z over the pixel's box (weights w²), world frame, (∂z/∂x, ∂z/∂y, 0)
    double residual_slope_variance = 0.0;  ///< the filtered slopes' spread over the box, tan²
};

/// One octave of the terrain's roughness field (moonbot/terrain/roughness.py's `Roughness`).
struct ReliefOctave {
    double wavelength_m = 1.0;  ///< λ: the lattice spacing, metres, > 0
    double amplitude_m = 0.0;   ///< a: metres, ≥ 0
    double angle_rad = 0.0;     ///< θ: the lattice's rotation about the vertical
    glm::dvec2 offset{0.0};     ///< (o_u, o_v): the lattice's offset, lattice units
    uint64_t key = 0;           ///< keys the lattice values (roughness.py's `lattice_key`)
};

/// The mesh's graded grid along x and along y (the same axis both ways): its node coordinates and
/// each node's cell (the coarser of the two cells beside it), metres, ascending, ≥ 2 nodes.
struct GradedGrid {
    std::vector<double> axis;
    std::vector<double> spacing;
};

/// The roughness octaves a graded mesh did not hold, as shading relief (see the file's comment).
class SubgridRelief {
public:
    /// Throws std::invalid_argument naming the field: a wavelength ≤ 0 or not finite, an amplitude
    /// < 0 or not finite, an axis that is not strictly ascending and finite, a spacing ≤ 0, or axis
    /// and spacing of different lengths.
    SubgridRelief(std::vector<ReliefOctave> octaves, GradedGrid grid);

    int octaves() const { return static_cast<int>(m_octaves.size()); }

    /// The mesh's cell at world (x, y), metres: the larger of the node spacings interpolated
    /// linearly along x and along y (clamped at the grid's ends), as location.py's mesh uses.
    double cell_m(double x, double y) const;

    /// What the mesh dropped of octave k at a cell of `cell_m` metres: 1 − clip(λ/(2c) − 1, 0, 1).
    double subgrid_weight(int k, double cell_m) const;

    /// Height (metres) of the dropped relief at world (x, y), unfiltered, for a mesh of cell
    /// `cell_m` metres (the field's Python twin, for tests).
    double height(double x, double y, double cell_m) const;

    /// The dropped relief at world point p (metres; z is ignored) as a pixel of footprint
    /// `footprint_m` ≥ 0 metres sees it: the mean gradient over the pixel's box, (∂z/∂x, ∂z/∂y, 0)
    /// in the world frame, and the spread of the filtered slopes about it.
    ReliefSample eval(const glm::dvec3& p, double footprint_m) const;

private:
    struct Octave {
        ReliefOctave octave;
        double cos_angle, sin_angle, inverse_wavelength;
        double slope_variance;  // unfiltered 1-D slope variance at full weight, tan²
    };
    /// Unit value noise n(u, v) of octave `o` and its partial derivatives (∂n/∂u, ∂n/∂v).
    static double value_noise(const Octave& o, double u, double v, glm::dvec2* derivative);

    std::vector<Octave> m_octaves;
    GradedGrid m_grid;
};

/// V: the 1-D slope variance of unit 2-D value noise with quintic fades (lattice values uniform on
/// [−1, 1], variance ⅓), per unit lattice spacing, along any direction: ⅓·2·(10/7)·(181/231).
constexpr double kQuinticNoiseSlopeVariance = (1.0 / 3.0) * 2.0 * (10.0 / 7.0) * (181.0 / 231.0);

}  // namespace moonbot
