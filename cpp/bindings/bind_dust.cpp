#include <algorithm>
#include <cmath>
#include <limits>

#include "arrays.h"
#include "moonbot/dust.h"
#include "params.h"

namespace moonbot::bindings {

namespace {

py::array_t<double> puff_rows(const std::vector<Puff>& puffs) {
    py::array_t<double> out({static_cast<py::ssize_t>(puffs.size()), py::ssize_t(5)});
    auto O = out.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < O.shape(0); ++i) {
        const Puff& f = puffs[static_cast<size_t>(i)];
        O(i, 0) = f.centre.x, O(i, 1) = f.centre.y, O(i, 2) = f.centre.z;
        O(i, 3) = f.sigma_m, O(i, 4) = f.peak_extinction;
    }
    return out;
}

std::vector<Puff> puffs_from_rows(const py::handle& given) {
    const auto rows = converted<double>(as_array(given, "puffs"), "puffs");
    if (!(rows.ndim() == 2 && rows.shape(1) == 5) && !(rows.ndim() == 1 && rows.shape(0) == 0))
        fail("puffs", "must be (N, 5) rows of centre x, y, z, sigma, peak extinction; got " + shape_of(rows));
    std::vector<Puff> puffs;
    const py::ssize_t n = rows.ndim() == 2 ? rows.shape(0) : 0;
    for (py::ssize_t i = 0; i < n; ++i) {
        const double* r = rows.data() + 5 * i;
        puffs.push_back(Puff{{r[0], r[1], r[2]}, r[3], r[4]});
    }
    return puffs;
}

}  // namespace

void bind_dust(py::module_& m) {
    ParamsClass<EjectaParams>(m, "EjectaParams",
                              "Emitter 1, granular ejecta (moonbot/dust.h): world metres, seconds, degrees.")
        .vec3("origin", &EjectaParams::origin, "centre of the spawn disc (3,), world metres, on the ground")
        .field("spawn_radius_m", &EjectaParams::spawn_radius_m,
               "fragments leave from a horizontal disc of this radius, metres, [0, 100]")
        .field("count", &EjectaParams::count, "fragments per burst, 0..1000000")
        .field("cone_half_angle_deg", &EjectaParams::cone_half_angle_deg,
               "launch directions: uniform over this cone about +z, degrees, [0, 90]")
        .field("mean_speed_m_s", &EjectaParams::mean_speed_m_s,
               "launch speeds uniform in [0.5, 1.5] x this, m/s, [0, 100]")
        .field("min_diameter_m", &EjectaParams::min_diameter_m, "fragment diameters uniform in [min, max], metres, > 0")
        .field("max_diameter_m", &EjectaParams::max_diameter_m, "metres, >= min_diameter_m, <= 1")
        .field("gravity_m_s2", &EjectaParams::gravity_m_s2, "m/s^2, [0, 100]")
        .field("restitution", &EjectaParams::restitution, "normal speed kept by a bounce, [0, 0.95]")
        .field("friction", &EjectaParams::friction,
               "Coulomb: tangential speed lost <= friction x normal impulse, [0, 10]")
        .field("rest_speed_m_s", &EjectaParams::rest_speed_m_s,
               "a bounce leaving less than this puts the fragment at rest, m/s, (0, 10]")
        .field("burst_period_s", &EjectaParams::burst_period_s,
               "every fragment is re-launched every period, seconds, (0, 3600]")
        .done();
    ParamsClass<CloudParams>(m, "CloudParams",
                             "Emitter 2, the fine-dust cloud (moonbot/dust.h): world metres, seconds, degrees.")
        .vec3("origin", &CloudParams::origin, "the emitter on the ground (3,), world metres")
        .vec3("box_m", &CloudParams::box_m, "spawn box east x north x up (3,), metres, each in [0, 1000]")
        .field("vertical_offset_m", &CloudParams::vertical_offset_m,
               "the box's centre this far above origin, metres, [-1000, 1000]")
        .vec3("axis", &CloudParams::axis, "cone axis (3,), world, any length but 0")
        .field("cone_half_angle_deg", &CloudParams::cone_half_angle_deg, "degrees, [0, 180]")
        .field("speed_m_s", &CloudParams::speed_m_s, "launch speed of a puff, m/s, [0, 100]")
        .field("gravity_m_s2", &CloudParams::gravity_m_s2, "m/s^2, [0, 100]")
        .field("lifetime_s", &CloudParams::lifetime_s, "a puff's life, seconds, (0, 3600]")
        .field("rate_per_s", &CloudParams::rate_per_s, "puffs born a second, >= 0, rate x lifetime <= 100000")
        .field("sigma_m", &CloudParams::sigma_m, "a puff's standard deviation at birth, metres, (0, 100]")
        .field("growth_m_s", &CloudParams::growth_m_s, "growth of that deviation with age, m/s, [0, 100]")
        .field("optical_depth", &CloudParams::optical_depth, "through a puff's centre at its most opaque, [0, 100]")
        .field("rise_fraction", &CloudParams::rise_fraction,
               "opacity rises linearly over this fraction of life, (0, 1)")
        .done();
    m.def(
        "simulate_ejecta",
        [](const Scene& scene, const EjectaParams& params, uint64_t seed, double time_s, double dt_s, int threads) {
            std::vector<Fragment> fragments;
            {
                py::gil_scoped_release release;
                fragments = simulate_ejecta(scene, params, seed, time_s, dt_s, threads);
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
        py::arg("scene"), py::arg("params"), py::arg("seed"), py::arg("time_s"), py::arg("dt_s") = 0.01,
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
        [](const CloudParams& params, uint64_t seed, double time_s) {
            return puff_rows(cloud_puffs(params, seed, time_s));
        },
        py::arg("params"), py::arg("seed"), py::arg("time_s"),
        "The fine-dust cloud (moonbot/dust.h, emitter 2) at time_s: the puffs alive then, (N, 5) "
        "float64 rows of centre x, y, z (world metres), sigma (metres) and peak extinction (1/m).");
    ParamsClass<Medium>(m, "Medium",
                        "Dust as a participating medium (moonbot/medium.h): Gaussian puffs, their single-scattering "
                        "albedo and Henyey-Greenstein asymmetry, and how finely a render traces them.")
        .property(
            "puffs", [](const Medium& medium) { return puff_rows(medium.puffs); },
            [](Medium& medium, const py::handle& rows) { medium.puffs = puffs_from_rows(rows); },
            "(N, 5) float64: centre x, y, z (world metres), sigma (metres, > 0), peak extinction (1/m, >= 0)")
        .vec3("albedo", &Medium::albedo, "single-scattering albedo (3,), linear RGB, each in [0, 1]")
        .field("asymmetry", &Medium::asymmetry, "Henyey-Greenstein g, (-1, 1)")
        .field("voxel_m", &Medium::voxel_m,
               "spacing of the grid the dust is baked on per render and its march step, metres, [0.001, 100]")
        .field("floor_z", &Medium::floor_z, "no dust is seen or lit below this height (the ground), metres")
        .field("march_stride_px", &Medium::march_stride_px,
               "1, 2, 4 or 8: the pixels between the camera rays that march the dust (the others interpolate)")
        .done()
        .def(py::init([](const py::handle& puffs, const py::kwargs& fields) {
                 py::dict given(fields);
                 given["puffs"] = puffs;
                 return py::type::of<Medium>()(**given).cast<Medium>();
             }),
             py::arg("puffs"), "Medium(puffs=puffs, **fields).")
        .def_property_readonly(
            "puff_count", [](const Medium& medium) { return medium.puffs.size(); }, "puffs in the medium");
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
            return optical_depth(Puff{vector<3>(centre, "centre"), sigma_m, peak_extinction},
                                 vector<3>(origin, "origin"), d / len, t_max);
        },
        py::arg("centre"), py::arg("sigma_m"), py::arg("peak_extinction"), py::arg("origin"), py::arg("direction"),
        py::arg("t_max") = std::numeric_limits<double>::infinity(),
        "Optical depth of one Gaussian dust puff (extinction peak·exp(-|x-centre|²/2σ²) per metre) "
        "along the ray origin + t·direction/|direction|, t in [0, t_max] metres; closed form.");
}

}  // namespace moonbot::bindings
