#include <array>
#include <cmath>
#include <optional>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/light_cache.h"
#include "params.h"

namespace moonbot::bindings {

namespace {

/// ((E_r, E_g, E_b), (x, y, z)): a cached value's irradiance and mean incident direction, as
/// LightCache.vertex and LightCache.at return them.
auto irradiance_and_direction(const IndirectLight& l) {
    return py::make_tuple(py::make_tuple(l.irradiance.x, l.irradiance.y, l.irradiance.z),
                          py::make_tuple(l.mean_direction.x, l.mean_direction.y, l.mean_direction.z));
}

}  // namespace

void bind_light_cache(py::module_& m) {
    ParamsClass<LightCacheSettings>(m, "LightCacheSettings", "How a LightCache gathers (moonbot/light_cache.h).")
        .field("bounces", &LightCacheSettings::bounces,
               "path vertices after each gather point (as RenderSettings.bounces), 1..16")
        .field("rays_objects", &LightCacheSettings::rays_objects,
               "gather rays per vertex (or lattice node) on labelled instances (bags), 1..65536")
        .field("rays_background", &LightCacheSettings::rays_background,
               "gather rays per vertex (or lattice node) on background instances (terrain, rocks), 1..65536")
        .field("background_cell_m", &LightCacheSettings::background_cell_m,
               "the background's world-space lattice spacing, metres (0 = per vertex)")
        .field("object_cell_m", &LightCacheSettings::object_cell_m,
               "the same for labelled instances, metres (0 = per vertex)")
        .field("background_filter_cells", &LightCacheSettings::background_filter_cells,
               "radius, in lattice cells, of the tent filter a background vertex reads the lattice through, 1..4 "
               "(1 = bilinear; the bags' lattice is always read bilinearly)")
        .field("gather_error", &LightCacheSettings::gather_error,
               "adaptive gathering: more rays while a vertex's relative standard error is above this, 0..1 (0 = a "
               "fixed count)")
        .field("max_rays_factor", &LightCacheSettings::max_rays_factor,
               "the most rays adaptive gathering reaches, as a multiple of rays_objects / rays_background, 1..1024")
        .field("seed", &LightCacheSettings::seed, "keys the gather rays")
        .field("threads", &LightCacheSettings::threads, "worker threads of fill_all, 0 = all")
        .done();
    py::class_<LightCache>(m, "LightCache",
                           "A world-space cache of indirect light over a committed scene's non-moving instances "
                           "(cpp/include/moonbot/light_cache.h): filled per vertex on first touch by render(), "
                           "shared by every view of the scene.")
        .def(py::init([](const Scene& scene, const DirectionalLight& sun, const std::optional<DirectionalLight>& earth,
                         const LightCacheSettings& settings) {
                 return std::make_unique<LightCache>(scene, Lights{sun, earth}, settings);
             }),
             py::arg("scene"), py::arg("sun"), py::arg("earth") = py::none(),
             py::arg("settings") = LightCacheSettings{},
             py::keep_alive<1, 2>(),  // the cache reads the scene's meshes for its whole life
             "A cache over `scene` for these lights, gathering as `settings` (a LightCacheSettings) says.")
        .def("covers", &LightCache::covers, py::arg("instance"),
             "Whether instance `instance` is cached (it was not moving when the cache was built).")
        .def(
            "vertex",
            [](const LightCache& c, uint32_t instance, uint32_t vertex) {
                IndirectLight l;
                {
                    py::gil_scoped_release release;
                    l = c.vertex(instance, vertex);
                }
                return irradiance_and_direction(l);
            },
            py::arg("instance"), py::arg("vertex"),
            "((E_r, E_g, E_b) W/m², (x, y, z) luminance-weighted mean of the unit incident directions, world: length 1 "
            "for light from one direction, less the more it spreads) at a vertex of a covered "
            "instance, filled first if it is not yet.")
        .def(
            "tilt_gradient",
            [](const LightCache& c, uint32_t instance, uint32_t vertex) {
                IndirectLight l;
                {
                    py::gil_scoped_release release;
                    l = c.vertex(instance, vertex);
                }
                return py::make_tuple(l.tilt_gradient.x, l.tilt_gradient.y, l.tilt_gradient.z);
            },
            py::arg("instance"), py::arg("vertex"),
            "(x, y, z) W/m², world: the rotation gradient of a vertex's irradiance luminance; a normal n near the "
            "vertex's n0 gets about Y0 + (n - n0)·gradient (light_cache.h IndirectLight::tilt_gradient).")
        .def(
            "at",
            [](const LightCache& c, uint32_t instance, uint32_t prim, double u, double v,
               const std::optional<std::array<double, 3>>& normal) {
                const glm::dvec3 n = normal ? glm::dvec3((*normal)[0], (*normal)[1], (*normal)[2]) : glm::dvec3(0.0);
                if (normal && !(std::abs(glm::length(n) - 1.0) < 1e-6))
                    throw py::value_error("normal: must be a unit vector, got length " +
                                          std::to_string(glm::length(n)));
                IndirectLight l;
                {
                    py::gil_scoped_release release;
                    l = c.at(instance, prim, u, v, normal ? &n : nullptr);
                }
                return irradiance_and_direction(l);
            },
            py::arg("instance"), py::arg("prim"), py::arg("u"), py::arg("v"), py::arg("normal") = py::none(),
            "As vertex(), at barycentrics (u, v) of triangle `prim` (the vertices' values interpolated); with "
            "`normal` (unit, world), each vertex's value tilted from its vertex normal to it first.")
        .def("fill_all", &LightCache::fill_all, py::call_guard<py::gil_scoped_release>(),
             "Fill every vertex of the covered instances (rendering fills only what it touches).")
        .def(
            "stats",
            [](const LightCache& c) {
                const LightCacheStats s = c.stats();
                py::dict d;
                d["vertices"] = s.vertices;
                d["blocks"] = s.blocks;
                d["nodes"] = s.nodes;
                d["probe_rays"] = s.probe_rays;
                d["gather_rays"] = s.gather_rays;
                d["shadow_rays"] = s.shadow_rays;
                d["bytes"] = s.bytes;
                d["redundant_fills"] = s.redundant_fills;
                d["fill_seconds"] = s.fill_seconds;
                return d;
            },
            "Cumulative: vertices filled, blocks allocated, background lattice nodes and their probe_rays, gather_rays "
            "and shadow_rays they traced (each "
            "vertex counted once: deterministic), bytes held, redundant_fills (vertices a racing thread "
            "computed again) and fill_seconds (thread-seconds; these two depend on the threads).");
}

}  // namespace moonbot::bindings
