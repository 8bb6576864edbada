// Granular ejecta (paper 3.2, emitter 1): rock fragments thrown up beside the work site, as a
// rover's wheels would, flying in vacuum under lunar gravity and bouncing on the terrain until
// their energy is spent. Numbers and sources: docs/physics.md.
//
// Kinematics are exact: with no drag a fragment's flight is a parabola, so each step advances it
// in closed form (p + v·dt + ½·g·dt², v + g·dt) and the time step only sets how finely contacts
// are looked for. A fragment collides as the vertical segment from its lowest point to its centre:
// each step casts the step's chord from both ends against the scene (Embree), so a contact is
// found on terrain or a bag wall however thin, however long the step, and neither end crosses a
// surface (short of a ray slipping through a shared edge, which Embree's default, non-robust
// traversal allows and tests/test_dust_containment.py has not seen). The chord cuts the
// parabola's corner by at most g·dt²/8 (0.5 mm at dt = 0.05 s), the only error the step adds.
//
// Surfaces have a front: the side their triangles wind counter-clockwise on, out of every closed
// mesh (bags, rocks) and up from the ground. A fragment starts in front of every surface (clear
// of the ground and of bags by kSpawnClearance); a ray that meets a surface from behind means a
// fragment inside a solid, which is not bounced off but put back out in front (fly_fragment).
//
// Deterministic: every fragment is simulated on its own from its own launch, keyed by the seed,
// its index and its burst; the result does not depend on the number of threads.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/medium.h"
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
    double flight_s;      ///< time it has flown: age_s, or when it came to rest
    uint32_t index;       ///< its number in the burst (with `burst`, keys its shape and spin)
    uint32_t burst;
    int bounces;
    int corrections;      ///< times it was found behind a surface and put back in front of it
    bool resting;
};

/// At launch, a fragment's bounding sphere (which holds its mesh in any orientation) is this far
/// above the highest surface under it, metres.
constexpr double kSpawnClearance = 1e-3;

/// A fragment found behind a surface this many times in one flight is put to rest where it was
/// last put back out (a guard against a fragment wedged between solids that overlap).
constexpr int kMaxCorrections = 16;

/// The state of every fragment of the current burst at `time_s` (≥ 0; burst k launches at
/// k·period, so the state is that of a flight of `time_s mod period`), stepping at most `dt_s`
/// (0 < dt ≤ kMaxDustStep) and colliding with every instance of `scene` (committed). Fragments
/// whose flight leaves the scene keep falling (they are returned where they are). `threads` in
/// 0..1024 (0 = all); the result is the same for any value. Throws std::invalid_argument on bad
/// arguments.
std::vector<Fragment> simulate_ejecta(const Scene& scene, const EjectaParams& params, uint64_t seed, double time_s,
                                      double dt_s, int threads = 0);

/// Flies `f` from its current state until it is `duration` seconds old (or at rest), in steps of
/// at most `dt`, bouncing on `scene` (committed; the caller holds its ReadLock): a bounce keeps
/// `restitution` of the normal speed and loses tangential speed up to `friction` × the normal
/// impulse; a rebound slower than `rest_speed_m_s` leaves it at rest. A fragment that finds
/// itself behind a surface (a chord meets the surface from behind) is moved back out along the
/// surface's normal by the depth found, lifted by a hair, and the step retried with no time
/// passing; `corrections` counts it (see kMaxCorrections). simulate_ejecta flies every fragment
/// so from launch. Throws std::invalid_argument naming the field on bad params, dt (in
/// (0, kMaxDustStep]), duration (finite), a fragment that is not finite or has no positive
/// diameter, or a scene not committed.
void fly_fragment(const Scene& scene, const EjectaParams& params, Fragment& f, double duration, double dt);

/// The fragments as one triangle soup in world coordinates, kFragmentVertices vertices and
/// kFragmentTriangles triangles per fragment in order: each a jagged icosahedron (vertex radii
/// 0.6–1 of its half-diameter, keyed by seed, index and burst), turned by a keyed orientation and
/// tumbling about a keyed axis at up to 3 turns a second while it flies (still once at rest).
/// `vertices` is 3 floats per vertex, metres; `triangles` 3 indices per triangle.
struct FragmentMesh {
    std::vector<float> vertices;
    std::vector<uint32_t> triangles;
};
constexpr int kFragmentVertices = 12, kFragmentTriangles = 20;
FragmentMesh fragment_mesh(const std::vector<Fragment>& fragments, uint64_t seed);

/// The largest time step simulate_ejecta accepts, seconds.
constexpr double kMaxDustStep = 0.1;

/// Emitter 2, the fine-dust cloud: puffs (medium.h) born at a steady rate in a box below the
/// emitter, drifting out along a cone, growing, their opacity rising fast then fading over their
/// life. Defaults are the paper's (box 0.7 × 2.0 × 0.5 m, cone 45° about (1, 0, 500), 0.7 m/s,
/// vertical offset −1.7 m, lifetime 5 s) and ours for what it leaves open (rate, size, opacity).
///
/// Gravity defaults to 0, as the paper's sprites drift: in vacuum fine dust is ballistic too (set
/// 1.62), but a 0.7 m/s launch then rises 15 cm and lands within 0.9 s — no haze lasting 5 s. The
/// paper's cloud stands for dust lofted and renewed by a working rover, which we do not model.
struct CloudParams {
    glm::dvec3 origin{0.0};            ///< the emitter on the ground, world metres
    glm::dvec3 box_m{0.7, 2.0, 0.5};   ///< spawn box east × north × up, metres
    double vertical_offset_m = -1.7;   ///< the box's centre this far above `origin`
    glm::dvec3 axis{1.0, 0.0, 500.0};  ///< cone axis, world (normalised here)
    double cone_half_angle_deg = 45.0;
    double speed_m_s = 0.7;
    double gravity_m_s2 = 0.0;
    double lifetime_s = 5.0;
    double rate_per_s = 40.0;          ///< puffs born a second: rate × lifetime alive at once
    double sigma_m = 0.15;             ///< a puff's standard deviation at birth
    double growth_m_s = 0.08;          ///< ... growing linearly with age
    double optical_depth = 0.25;       ///< through a puff's centre at its most opaque
    double rise_fraction = 0.1;  ///< opacity rises linearly over this fraction of life, then falls as ((1−u)/(1−rise))²

    /// Throws std::invalid_argument naming the field.
    void validate() const;
};

/// The puffs alive at `time_s` (≥ 0): puff k is born at k / rate and lives `lifetime_s`; its
/// place, size and opacity are closed-form functions of its age and of (seed, k), so any time is
/// evaluated directly, with no stepping, and is the same whatever was evaluated before.
std::vector<Puff> cloud_puffs(const CloudParams& params, uint64_t seed, double time_s);

}  // namespace moonbot
