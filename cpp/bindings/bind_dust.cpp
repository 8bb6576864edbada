#include <cmath>
#include <algorithm>
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
            py::array_t<int32_t> bounces(n), corrections(n);
            py::array_t<bool> resting(n);
            auto P = position.mutable_unchecked<2>();
            auto V = velocity.mutable_unchecked<2>();
            auto D = diameter.mutable_unchecked<1>();
            auto A = age.mutable_unchecked<1>();
            auto B = bounces.mutable_unchecked<1>();
            auto C = corrections.mutable_unchecked<1>();
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
                C(i) = f.corrections;
                R(i) = f.resting;
            }
            const FragmentMesh mesh = fragment_mesh(fragments, seed);
            py::array_t<float> vertices({static_cast<py::ssize_t>(mesh.vertices.size() / 3), py::ssize_t(3)});
            py::array_t<uint32_t> triangles({static_cast<py::ssize_t>(mesh.triangles.size() / 3), py::ssize_t(3)});
            std::copy(mesh.vertices.begin(), mesh.vertices.end(), vertices.mutable_data());
            std::copy(mesh.triangles.begin(), mesh.triangles.end(), triangles.mutable_data());
            py::dict out;
            out["vertices"] = vertices;
            out["triangles"] = triangles;
            out["position"] = position;
            out["velocity"] = velocity;
            out["diameter"] = diameter;
            out["age"] = age;
            out["bounces"] = bounces;
            out["corrections"] = corrections;
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
        "gravity from launch in steps of at most dt_s and bounced on the scene's geometry (call it "
        "before the fragments' own mesh is in the scene, or they collide with themselves). Returns "
        "position (N, 3) and velocity (N, 3) float64 (metres, m/s, world), diameter (N,) metres, "
        "age (N,) seconds since launch, bounces (N,) int32, corrections (N,) int32 (times found behind "
        "a surface and put back in front: 0 in a scene of outward-facing solids), resting (N,) bool, and the fragments "
        "as one mesh in world metres: vertices (12 N, 3) float32, triangles (20 N, 3) uint32.");
    m.attr("MAX_DUST_STEP") = kMaxDustStep;
    m.attr("SPAWN_CLEARANCE") = kSpawnClearance;
    m.def(
        "cloud_puffs",
        [](uint64_t seed, double time_s, const py::handle& origin, const py::handle& box_m, double vertical_offset_m,
           const py::handle& axis, double cone_half_angle_deg, double speed_m_s, double gravity_m_s2, double lifetime_s,
           double rate_per_s, double sigma_m, double growth_m_s, double optical_depth, double rise_fraction) {
            CloudParams p;
            p.origin = vector<3>(origin, "origin");
            p.box_m = vector<3>(box_m, "box_m");
            p.vertical_offset_m = vertical_offset_m;
            p.axis = vector<3>(axis, "axis");
            p.cone_half_angle_deg = cone_half_angle_deg;
            p.speed_m_s = speed_m_s;
            p.gravity_m_s2 = gravity_m_s2;
            p.lifetime_s = lifetime_s;
            p.rate_per_s = rate_per_s;
            p.sigma_m = sigma_m;
            p.growth_m_s = growth_m_s;
            p.optical_depth = optical_depth;
            p.rise_fraction = rise_fraction;
            const std::vector<Puff> puffs = cloud_puffs(p, seed, time_s);
            py::array_t<double> out({static_cast<py::ssize_t>(puffs.size()), py::ssize_t(5)});
            auto O = out.mutable_unchecked<2>();
            for (py::ssize_t i = 0; i < O.shape(0); ++i) {
                const Puff& f = puffs[static_cast<size_t>(i)];
                O(i, 0) = f.centre.x, O(i, 1) = f.centre.y, O(i, 2) = f.centre.z;
                O(i, 3) = f.sigma_m, O(i, 4) = f.peak_extinction;
            }
            return out;
        },
        py::arg("seed"), py::arg("time_s"), py::arg("origin") = py::make_tuple(0.0, 0.0, 0.0),
        py::arg("box_m") = py::make_tuple(0.7, 2.0, 0.5), py::arg("vertical_offset_m") = -1.7,
        py::arg("axis") = py::make_tuple(1.0, 0.0, 500.0), py::arg("cone_half_angle_deg") = 45.0,
        py::arg("speed_m_s") = 0.7, py::arg("gravity_m_s2") = 0.0, py::arg("lifetime_s") = 5.0,
        py::arg("rate_per_s") = 40.0, py::arg("sigma_m") = 0.15, py::arg("growth_m_s") = 0.08,
        py::arg("optical_depth") = 0.25, py::arg("rise_fraction") = 0.1,
        "The fine-dust cloud (moonbot/dust.h, emitter 2) at time_s: the puffs alive then, (N, 5) "
        "float64 rows of centre x, y, z (world metres), sigma (metres) and peak extinction (1/m).");
    py::class_<Medium>(m, "Medium", "Dust as a participating medium (moonbot/medium.h): Gaussian puffs, "
                                    "their single-scattering albedo and Henyey-Greenstein asymmetry.")
        .def(py::init([](const py::handle& puffs, const py::handle& albedo, double asymmetry, double voxel_m, double floor_z,
                         int march_stride_px) {
                 const auto rows = converted<double>(as_array(puffs, "puffs"), "puffs");
                 if (!(rows.ndim() == 2 && rows.shape(1) == 5) && !(rows.ndim() == 1 && rows.shape(0) == 0))
                     fail("puffs", "must be (N, 5) rows of centre x, y, z, sigma, peak extinction; got " + shape_of(rows));
                 Medium medium;
                 const py::ssize_t n = rows.ndim() == 2 ? rows.shape(0) : 0;
                 for (py::ssize_t i = 0; i < n; ++i) {
                     const double* r = rows.data() + 5 * i;
                     medium.puffs.push_back(Puff{{r[0], r[1], r[2]}, r[3], r[4]});
                 }
                 medium.albedo = vector<3>(albedo, "albedo");
                 medium.asymmetry = asymmetry;
                 medium.voxel_m = voxel_m;
                 medium.floor_z = floor_z;
                 medium.march_stride_px = march_stride_px;
                 medium.validate();  // std::invalid_argument → ValueError
                 return medium;
             }),
             py::arg("puffs"), py::arg("albedo") = py::make_tuple(0.55, 0.51, 0.45), py::arg("asymmetry") = 0.7,
             py::arg("voxel_m") = 0.05, py::arg("floor_z") = -std::numeric_limits<double>::infinity(),
             py::arg("march_stride_px") = 1,
             "puffs (N, 5) float: centre x, y, z (world metres), sigma (metres), peak extinction (1/m); "
             "albedo: single-scattering albedo (3,) in [0, 1]; asymmetry: Henyey-Greenstein g; voxel_m: "
             "the spacing of the grid the dust is baked on per render and its march step, metres; "
             "floor_z: no dust is seen or lit below this height (the ground), metres; march_stride_px: 1, 2, 4 "
             "or 8, the pixels between the camera rays that march the dust (the others interpolate).")
        .def_property_readonly("puff_count", [](const Medium& m) { return m.puffs.size(); });
    m.def("henyey_greenstein", &henyey_greenstein, py::arg("cos_theta"), py::arg("g"),
          "Henyey-Greenstein phase function per steradian (g > 0: forward).");
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
