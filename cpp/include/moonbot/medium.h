// The fine dust as a participating medium: a sum of Gaussian puffs whose extinction is integrated
// in closed form along any ray (Beer–Lambert transmittance), lit by the Sun through single
// scattering with a forward Henyey–Greenstein phase function. Numbers: docs/physics.md
// The medium changes radiance only: depth and labels stay those of the geometry.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/scene.h"

namespace moonbot {

/// One puff: an isotropic Gaussian of extinction coefficient k(x) = peak·exp(−|x − centre|²/(2σ²))
/// per metre. A cloud is a sum of puffs; its light is attenuated by exp(−Σ optical depths).
struct Puff {
    glm::dvec3 centre{0.0};        ///< world metres
    double sigma_m = 0.1;          ///< standard deviation, metres (> 0)
    double peak_extinction = 1.0;  ///< k at the centre, 1/m (≥ 0)
};

/// The optical depth ∫₀^t_max k(origin + t·dir) dt of a puff along a ray (`dir` unit), in closed
/// form: with p = origin − centre, b = p·dir and q² = |p|² − b² (the ray's squared distance
/// from the centre), τ = peak·exp(−q²/2σ²)·σ·√(π/2)·[erf((t_max + b)/(σ√2)) − erf(b/(σ√2))].
/// t_max may be +infinity. Exact to rounding; a few flops and two erf.
double optical_depth(const Puff& puff, const glm::dvec3& origin, const glm::dvec3& dir, double t_max);

/// Henyey–Greenstein phase function per steradian, (1 − g²) / (4π (1 + g² − 2g·cosθ)^{3/2}), θ
/// the angle between the light's travel before and after scattering (g > 0: forward).
double henyey_greenstein(double cos_theta, double g);

/// A puff is taken to reach as far as its extinction stays above kExtinctionFloor per metre (at
/// most kPuffReach σ): beyond, ten metres of it would add an optical depth under 1e-3.
constexpr double kExtinctionFloor = 1e-4;
constexpr double kPuffReach = 5.0;
/// The dust grid has at most this many nodes along an axis (a wider cloud gets coarser voxels).
constexpr int kMaxGridNodes = 512;

/// What a render needs to trace the dust. Defaults: docs/physics.md (forward HG g = 0.7,
/// grain single-scattering albedo ω ≈ 0.55, reddened like regolith, R:G:B ≈ 1 : 0.92 : 0.82).
struct Medium {
    std::vector<Puff> puffs;
    glm::dvec3 albedo{0.55, 0.51, 0.45};  ///< single-scattering albedo per channel, [0, 1]
    double asymmetry = 0.7;               ///< Henyey–Greenstein g, (−1, 1)
    /// Spacing of the grid the dust is baked on per render, and the step camera rays march it
    /// with, metres (> 0): the medium's one quality knob (bench_dust measures it).
    double voxel_m = 0.05;
    /// Dust below this height is never seen or lit (it is under the ground): the grid stops here.
    double floor_z = -INFINITY;
    /// Pixels between the camera rays that march the dust, 1, 2, 4 or 8 (a divisor of the
    /// renderer's 8-pixel tile). 1: every pixel's centre ray marches. S > 1: the rays through
    /// every S-th pixel centre march the whole grid once, recording the optical depth and the
    /// scattered light along their length; each pixel takes them at its own hit distance from the
    /// four marched rays around it, bilinearly. The dust varies over a grid cell (voxel_m), many
    /// pixels wide at the camera's distances, so S² fewer marches cost little accuracy
    /// (bench_medium measures it).
    int march_stride_px = 1;

    /// Throws std::invalid_argument naming the field.
    void validate() const;
};

/// The reach of a puff (reach(p) ≤ 0: it is too faint to count anywhere).
double puff_reach(const Puff& puff);

/// The dust of one render baked on a regular grid over the puffs' reach, in a frame whose third
/// axis is the Sun's direction: the extinction, the optical depth toward the Sun (summed along
/// each grid line from the Sun's end, so no interpolation smears it) and whether the geometry
/// shades each node from the Sun (Sun rays run along grid lines: one a line with dust, and one more
/// past each surface it meets). Camera rays then march it.
class DustGrid {
public:
    /// Bakes `medium` (validated, with puffs) for Sun direction `sun_dir` (unit), shading by
    /// `scene` (committed); in the caller's task arena.
    DustGrid(const Medium& medium, const Scene& scene, const glm::dvec3& sun_dir);

    const Medium& medium() const { return m_medium; }
    /// Shadow rays traced while baking.
    uint64_t shadow_rays() const { return m_shadow_rays; }

    /// The stretch [enter, exit] of the ray origin + s·dir (unit dir), s ∈ [0, s_max], inside the
    /// grid; false if it misses it.
    bool clip(const glm::dvec3& origin, const glm::dvec3& dir, double s_max, double& enter, double& exit) const;

    /// The dust along the ray origin + s·dir (unit dir) over [enter, exit] (from `clip`), marched
    /// in steps of `step` metres from `enter`, each step sampled at its middle (the midpoint
    /// rule; the last step ends at `exit`) by trilinear lookups of the extinction k (1/m) and the
    /// Sun's light left there (exp(−τ_sun) × geometric visibility), until the optical depth passes
    /// `opaque`. Returns the optical depth τ, and in `lit` Σ exp(−τ to the step's middle)·k·sunlight
    /// ·length: the sunlight the dust scatters toward the origin, per unit of phase × radiance.
    /// Stretches of empty blocks (kBlock³ cells of zero extinction) are stepped over unsampled:
    /// their samples would be exactly 0.
    double march(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step, double opaque,
                 double& lit) const;

    /// `march`'s sums along the way: after step j (j = 0 .. count − 1, count = ⌈(exit − enter) /
    /// step⌉), tau[j + 1] and lit[j + 1] hold the optical depth and the scattered light from
    /// `enter` to the step's end, min(enter + (j + 1)·step, exit); tau[0] = lit[0] = 0. Past
    /// `opaque` the sums stay as they are. Both vectors are resized to count + 1.
    void march_profile(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step,
                       double opaque, std::vector<double>& tau, std::vector<double>& lit) const;

    /// The dust's transmittance toward the Sun from `point` anywhere: from the grid inside it, in
    /// closed form (every puff) outside it, and 1 where the Sun ray misses the grid.
    double sun_transmittance(const glm::dvec3& point) const;

    /// Cells a side of the blocks `march` checks for emptiness.
    static constexpr int kBlock = 8;

private:
    size_t node(int i, int j, int k) const { return (static_cast<size_t>(k) * m_n[1] + j) * m_n[0] + i; }
    size_t block(int i, int j, int k) const { return (static_cast<size_t>(k) * m_blocks[1] + j) * m_blocks[0] + i; }
    // The constructor's steps, in order.
    /// Each puff's reach (m_reach) and centre in the grid frame; the box of those the grid holds
    /// (m_lo, m_hi). Returns the reaches with 0 for the puffs the grid leaves out.
    std::vector<double> bound_puffs(std::vector<glm::dvec3>& centre);
    /// The node spacing and counts over that box; false when no puff counts (an empty box).
    bool lay_out_nodes();
    /// The extinction k at every node, 1/m.
    std::vector<float> bake_extinction(const std::vector<double>& reach, const std::vector<glm::dvec3>& centre) const;
    /// m_sun_depth from the extinction.
    void integrate_sun_depth(const std::vector<float>& extinction);
    /// Per node, 1 where it has dust or shares a cell with a node that has: the nodes whose
    /// sunlight a lookup can blend with dust's.
    std::vector<uint8_t> near_dust(const std::vector<float>& extinction) const;
    /// Per node, 0 where the geometry shades it from the Sun, else 1 (counts m_shadow_rays).
    std::vector<float> shade_from_sun(const std::vector<float>& extinction, const Scene& scene);
    /// m_lookup: the extinction and the sunlight left (visibility × exp(−τ_sun)) side by side.
    void pack_lookup(const std::vector<float>& extinction, const std::vector<float>& visible);
    /// m_blocks and m_empty.
    void mark_empty_blocks(const std::vector<float>& extinction);
    size_t node_count() const;

    glm::dvec3 frame(const glm::dvec3& world_point) const;  // world → grid frame (a rotation)
    glm::dvec3 world(const glm::dvec3& frame_point) const;
    double trilinear(const std::vector<float>& field, const glm::dvec3& frame_point) const;
    /// The steps of a march (see `march`): calls visit(j, length, extinction, sunlight) for each
    /// step j with dust, in order, until the optical depth passes `opaque`.
    template <typename Visit>
    void walk(const glm::dvec3& origin, const glm::dvec3& dir, double enter, double exit, double step, double opaque,
              Visit&& visit) const;

    const Medium& m_medium;
    glm::dvec3 m_sun;
    glm::dvec3 m_axis[3];   // the grid frame's axes in the world; m_axis[2] is the Sun's direction
    glm::dvec3 m_lo, m_hi;  // the grid's box in that frame, metres
    double m_h = 0.05;      // node spacing
    int m_n[3] = {1, 1, 1};
    std::vector<float> m_sun_depth;  // per node, optical depth toward the Sun
    std::vector<float> m_lookup;     // per node, extinction and sunlight side by side: one fetch serves both
    int m_blocks[3] = {0, 0, 0};
    std::vector<uint8_t> m_empty;    // per block: every node of it (faces included) has zero extinction
    std::vector<double> m_reach;  // puff_reach of each puff, once (sun_transmittance runs per hit)
    uint64_t m_shadow_rays = 0;
};

}  // namespace moonbot
