// The fine dust as a participating medium: a sum of Gaussian puffs whose extinction is integrated
// in closed form along any ray (Beer–Lambert transmittance), lit by the Sun through single
// scattering with a forward Henyey–Greenstein phase function. Numbers: lunar-physics.md §5.1.
// The medium changes radiance only: depth and labels stay those of the geometry.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

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

/// A puff is cut off beyond this many σ from its centre: its extinction there is below
/// exp(−12.5) ≈ 4e-6 of its peak.
constexpr double kPuffReach = 5.0;
/// The most scattering samples a camera sample may take through the dust.
constexpr int kMaxScatterSamples = 256;

/// What a render needs to trace the dust. Defaults: lunar-physics.md §5.1 (forward HG g = 0.7,
/// grain single-scattering albedo ω ≈ 0.55, reddened like regolith, R:G:B ≈ 1 : 0.92 : 0.82).
struct Medium {
    std::vector<Puff> puffs;
    glm::dvec3 albedo{0.55, 0.51, 0.45};  ///< single-scattering albedo per channel, [0, 1]
    double asymmetry = 0.7;               ///< Henyey–Greenstein g, (−1, 1)
    /// Points per camera sample at which sunlight scattered toward the camera is gathered,
    /// stratified along the stretch of the ray that passes through dust; 1..kMaxScatterSamples.
    int scatter_samples = 8;

    /// Throws std::invalid_argument naming the field.
    void validate() const;
};

/// One puff as one ray sees it: the ray x(s) = origin + s·dir (unit dir) passes at squared
/// distance q² from its centre, closest at s = −b; within its reach over [enter, exit].
struct RayPuff {
    double b, sigma, weight;  // weight = peak·exp(−q²/2σ²): the extinction at the closest point
    double enter, exit;
};

/// The puffs indexed for the queries of one render: which might meet a bundle of camera rays, and
/// the optical depth toward the Sun from any point (a grid over the plane across the Sun's
/// direction, each cell listing the puffs whose reach crosses it).
class MediumIndex {
public:
    MediumIndex(const Medium& medium, const glm::dvec3& sun_dir);

    const Medium& medium() const { return m_medium; }

    /// Indices of the puffs whose reach may meet the pyramid from `apex` spanned by the four
    /// directions `corners` (in order round it): the rays of one image tile. Conservative.
    void cull(const glm::dvec3& apex, const glm::dvec3 corners[4], std::vector<uint32_t>& out) const;

    /// The puffs among `candidates` that the ray origin + s·dir (unit dir), s ∈ [0, s_max], passes
    /// within reach of, into `out`; returns the stretch [enter, exit] that they span (enter ≥
    /// exit: none).
    void along(const std::vector<uint32_t>& candidates, const glm::dvec3& origin, const glm::dvec3& dir,
               double s_max, std::vector<RayPuff>& out, double& enter, double& exit) const;

    /// Σ optical depth of `puffs` from the ray's origin to s, and Σ extinction at s.
    static double depth_to(const std::vector<RayPuff>& puffs, double s);
    static double extinction_at(const std::vector<RayPuff>& puffs, double s);

    /// The optical depth from `point` toward the Sun, out of the cloud.
    double sun_depth(const glm::dvec3& point) const;

private:
    const Medium& m_medium;
    glm::dvec3 m_sun, m_a, m_b;          // the Sun's direction and a basis across it
    double m_cell = 1.0, m_a0 = 0.0, m_b0 = 0.0;
    int m_na = 0, m_nb = 0;
    std::vector<uint32_t> m_cell_start;  // CSR: cell c holds m_cell_puffs[start[c] .. start[c + 1])
    std::vector<uint32_t> m_cell_puffs;
};

}  // namespace moonbot
