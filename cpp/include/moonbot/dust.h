// Granular ejecta (paper 3.2, emitter 1): rock fragments thrown up beside the work site, as a
// rover's wheels would, flying in vacuum under lunar gravity and bouncing on the terrain until
// their energy is spent. Numbers: ../shared/reference/lunar-physics.md §5.
//
// Kinematics are exact: with no drag a fragment's flight is a parabola, so each step advances it
// in closed form (p + v·dt + ½·g·dt², v + g·dt) and the time step only sets how finely contacts
// are looked for. Contacts are found by casting the step's chord against the scene (Embree), so
// nothing tunnels through terrain however thin or however long the step. The chord cuts the
// parabola's corner by at most g·dt²/8 (0.5 mm at dt = 0.05 s), the only error the step adds.
//
// Deterministic: every fragment is simulated on its own from its own launch, keyed by the seed,
// its index and its burst; the result does not depend on the number of threads.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/scene.h"

namespace moonbot {

/// Emitter 1. Defaults are the paper's (cone 45°, 0.5 m/s, bursts every 2 s) and the
/// reference's (g = 1.62 m/s², restitution 0.4 [unverified; DEM practice 0.3–0.5], friction 0.6).
struct EjectaParams {
    glm::dvec3 origin{0.0};          ///< centre of the spawn disc, world metres (on the ground)
    double spawn_radius_m = 0.1;     ///< fragments leave from a horizontal disc of this radius
    int count = 200;                 ///< fragments per burst
    double cone_half_angle_deg = 45.0;  ///< launch directions: uniform over this cone about +z
    double mean_speed_m_s = 0.5;     ///< launch speeds uniform in [0.5, 1.5] × this
    double min_diameter_m = 0.01;    ///< fragment diameters uniform in [min, max]
    double max_diameter_m = 0.02;
    double gravity_m_s2 = 1.62;
    double restitution = 0.4;        ///< normal speed kept by a bounce
    double friction = 0.6;           ///< Coulomb: tangential speed lost ≤ friction × normal impulse
    double rest_speed_m_s = 0.02;    ///< a bounce leaving less than this puts the fragment at rest
    double burst_period_s = 2.0;     ///< every fragment is re-launched every period (the loop)

    /// Throws std::invalid_argument naming the field.
    void validate() const;
};

/// One fragment at the capture time.
struct Fragment {
    glm::dvec3 position;  ///< centre, world metres
    glm::dvec3 velocity;  ///< m/s (zero at rest)
    double diameter_m;
    double age_s;         ///< time since this burst's launch
    int bounces;
    bool resting;
};

/// The state of every fragment of the current burst at `time_s` (≥ 0; burst k launches at
/// k·period, so the state is that of a flight of `time_s mod period`), stepping at most `dt_s`
/// (0 < dt ≤ kMaxDustStep) and colliding with every instance of `scene` (committed). Fragments
/// whose flight leaves the scene keep falling (they are returned where they are). `threads` in
/// 0..1024 (0 = all); the result is the same for any value. Throws std::invalid_argument on bad
/// arguments.
std::vector<Fragment> simulate_ejecta(const Scene& scene, const EjectaParams& params, uint64_t seed,
                                      double time_s, double dt_s, int threads = 0);

/// The largest time step simulate_ejecta accepts, seconds.
constexpr double kMaxDustStep = 0.1;

/// One puff of the fine-dust cloud (emitter 2): an isotropic Gaussian of extinction coefficient
/// k(x) = peak·exp(−|x − centre|²/(2σ²)) per metre. A cloud is a sum of puffs; its light is
/// attenuated by exp(−Σ optical depths) (Beer–Lambert).
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

}  // namespace moonbot
