#include <cmath>
#include <limits>

#include "arrays.h"
#include "moonbot/dust.h"

namespace moonbot::bindings {

void bind_dust(py::module_& m) {
    m.def(
        "simulate_ejecta",
        [](const Scene& scene, uint64_t seed, double time_s, double dt_s, const py::handle& origin, int count,
           double spawn_radius_m, double cone_half_angle_deg, double mean_speed_m_s, double min_diameter_m,
           double max_diameter_m, double gravity_m_s2, double restitution, double friction, double rest_speed_m_s,
           double burst_period_s, int threads) {
            EjectaParams p;
            p.origin = vector<3>(origin, "origin");
            p.count = count;
            p.spawn_radius_m = spawn_radius_m;
            p.cone_half_angle_deg = cone_half_angle_deg;
            p.mean_speed_m_s = mean_speed_m_s;
            p.min_diameter_m = min_diameter_m;
            p.max_diameter_m = max_diameter_m;
            p.gravity_m_s2 = gravity_m_s2;
            p.restitution = restitution;
            p.friction = friction;
            p.rest_speed_m_s = rest_speed_m_s;
            p.burst_period_s = burst_period_s;
            std::vector<Fragment> fragments;
            {
                py::gil_scoped_release release;
                fragments = simulate_ejecta(scene, p, seed, time_s, dt_s, threads);
            }
            const auto n = static_cast<py::ssize_t>(fragments.size());
            py::array_t<double> position({n, py::ssize_t(3)}), velocity({n, py::ssize_t(3)}), diameter(n), age(n);
            py::array_t<int32_t> bounces(n);
            py::array_t<bool> resting(n);
            auto P = position.mutable_unchecked<2>();
            auto V = velocity.mutable_unchecked<2>();
            auto D = diameter.mutable_unchecked<1>();
            auto A = age.mutable_unchecked<1>();
            auto B = bounces.mutable_unchecked<1>();
            auto R = resting.mutable_unchecked<1>();
            for (py::ssize_t i = 0; i < n; ++i) {
                const Fragment& f = fragments[static_cast<size_t>(i)];
                for (int c = 0; c < 3; ++c) {
                    P(i, c) = f.position[c];
                    V(i, c) = f.velocity[c];
                }
                D(i) = f.diameter_m;
                A(i) = f.age_s;
                B(i) = f.bounces;
                R(i) = f.resting;
            }
            py::dict out;
            out["position"] = position;
            out["velocity"] = velocity;
            out["diameter"] = diameter;
            out["age"] = age;
            out["bounces"] = bounces;
            out["resting"] = resting;
            return out;
        },
        py::arg("scene"), py::arg("seed"), py::arg("time_s"), py::arg("dt_s") = 0.01,
        py::arg("origin") = py::make_tuple(0.0, 0.0, 0.0), py::arg("count") = 200, py::arg("spawn_radius_m") = 0.1,
        py::arg("cone_half_angle_deg") = 45.0, py::arg("mean_speed_m_s") = 0.5, py::arg("min_diameter_m") = 0.01,
        py::arg("max_diameter_m") = 0.02, py::arg("gravity_m_s2") = 1.62, py::arg("restitution") = 0.4,
        py::arg("friction") = 0.6, py::arg("rest_speed_m_s") = 0.02, py::arg("burst_period_s") = 2.0,
        py::arg("threads") = 0,
        "Granular ejecta (moonbot/dust.h) of the burst under way at time_s, flown in vacuum under "
        "gravity from launch in steps of at most dt_s and bounced on the scene's geometry. Returns "
        "position (N, 3) and velocity (N, 3) float64 (metres, m/s, world), diameter (N,) metres, "
        "age (N,) seconds since launch, bounces (N,) int32 and resting (N,) bool.");
    m.attr("MAX_DUST_STEP") = kMaxDustStep;
    m.def(
        "puff_optical_depth",
        [](const py::handle& centre, double sigma_m, double peak_extinction, const py::handle& origin,
           const py::handle& direction, double t_max) {
            if (!(sigma_m > 0.0 && std::isfinite(sigma_m))) fail("sigma_m", "must be positive and finite");
            if (!(peak_extinction >= 0.0 && std::isfinite(peak_extinction))) fail("peak_extinction", "must be >= 0");
            glm::dvec3 d = vector<3>(direction, "direction");
            const double len = glm::length(d);
            if (!(len > 0.0)) fail("direction", "must be non-zero");
            return optical_depth(Puff{vector<3>(centre, "centre"), sigma_m, peak_extinction}, vector<3>(origin, "origin"),
                                 d / len, t_max);
        },
        py::arg("centre"), py::arg("sigma_m"), py::arg("peak_extinction"), py::arg("origin"), py::arg("direction"),
        py::arg("t_max") = std::numeric_limits<double>::infinity(),
        "Optical depth of one Gaussian dust puff (extinction peak·exp(-|x-centre|²/2σ²) per metre) "
        "along the ray origin + t·direction/|direction|, t in [0, t_max] metres; closed form.");
}

}  // namespace moonbot::bindings
