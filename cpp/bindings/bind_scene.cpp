#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/camera.h"
#include "moonbot/scene.h"
#include "moonbot/sun.h"

namespace moonbot::bindings {

namespace {

Material material(const py::handle& albedo, const Photometry& photometry,
                  const std::optional<WovenSurface>& woven = std::nullopt,
                  std::shared_ptr<const RegolithGrain> grain = nullptr) {
    return Material{glm::vec3(vector<3>(albedo, "albedo")), photometry, woven, std::move(grain)};
}

std::shared_ptr<const RegolithGrain> make_grain(double albedo_rms, double slope_rms_deg, double finest_cell_m,
                                                double coarsest_cell_m, double hurst, uint64_t seed) {
    GrainParams p;
    p.albedo_rms = albedo_rms;
    p.slope_rms_deg = slope_rms_deg;
    p.finest_cell_m = finest_cell_m;
    p.coarsest_cell_m = coarsest_cell_m;
    p.hurst = hurst;
    p.seed = seed;
    try {
        return std::make_shared<const RegolithGrain>(p);
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
}

WovenSurface make_woven(double pitch_m, double relief_m, double contrast, double metres_per_uv, int stamps,
                        double brush_size, double opacity, int resolution, uint64_t stain_seed,
                        const py::handle& dirt_colour, double sheen, double sheen_along, double sheen_across,
                        const std::string& stain_mode, double contact_height_m, double deposit_radius_m,
                        double handled_share, double speckle) {
    WovenSurface w;
    w.fabric.pitch_m = pitch_m;
    w.fabric.relief_m = relief_m;
    w.fabric.contrast = contrast;
    w.fabric.sheen = sheen;
    w.fabric.sheen_along = sheen_along;
    w.fabric.sheen_across = sheen_across;
    if (stain_mode == "stamp") w.stain_mode = StainMode::Stamp;
    else if (stain_mode == "dust") w.stain_mode = StainMode::Dust;
    else fail("stain_mode", "must be 'stamp' or 'dust', got '" + stain_mode + "'");
    w.soiling.contact_height_m = contact_height_m;
    w.soiling.deposit_radius_m = deposit_radius_m;
    w.soiling.handled_share = handled_share;
    w.soiling.speckle = speckle;
    w.metres_per_uv = metres_per_uv;
    w.stain.stamps = stamps;
    w.stain.brush_size = brush_size;
    w.stain.opacity = opacity;
    w.stain.resolution = resolution;
    w.stain_seed = stain_seed;
    w.dirt_colour = vector<3>(dirt_colour, "dirt_colour");
    try {
        w.fabric.validate();
        w.stain.validate();
        w.soiling.validate();
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
    if (!(std::isfinite(metres_per_uv) && metres_per_uv > 0)) fail("metres_per_uv", "must be positive and finite");
    return w;
}

Photometry make_photometry(const std::string& model, const std::string& phase, double surge_amplitude,
                           double surge_width, double w, double b, double c, double roughness_deg,
                           double filling_factor, double cboe_amplitude, double cboe_width) {
    Photometry p;
    if (model == "lambert") p.model = Photometry::Model::Lambert;
    else if (model == "lunar-lambert") p.model = Photometry::Model::LunarLambert;
    else if (model == "hapke") p.model = Photometry::Model::Hapke;
    else fail("model", "must be 'lambert', 'lunar-lambert' or 'hapke', got '" + model + "'");
    if (phase == "exponential") p.phase = Photometry::Phase::Exponential;
    else if (phase == "mcewen") p.phase = Photometry::Phase::McEwen;
    else fail("phase", "must be 'exponential' or 'mcewen', got '" + phase + "'");
    if (!(surge_amplitude >= 0.0 && surge_amplitude <= 10.0)) fail("surge_amplitude", "must be in [0, 10]");
    if (!(surge_width > 0.0 && surge_width <= 10.0)) fail("surge_width", "must be in (0, 10]");
    // Hapke's parameters are checked whatever the model, so a bad value never waits silently
    // for the day someone switches to Hapke. Ranges: photometry.h, Photometry::HapkeParams.
    if (!(w >= 0.0 && w <= 1.0)) fail("w", "must be in [0, 1]");
    if (!(b >= 0.0 && b < 1.0)) fail("b", "must be in [0, 1)");
    if (!(c >= -1.0 && c <= 1.0)) fail("c", "must be in [-1, 1]");
    if (!(roughness_deg >= 0.0 && roughness_deg <= 60.0)) fail("roughness_deg", "must be in [0, 60]");
    if (!(filling_factor >= 0.0 && filling_factor <= 0.75)) fail("filling_factor", "must be in [0, 0.75]");
    if (!(cboe_amplitude >= 0.0 && cboe_amplitude <= 1.0)) fail("cboe_amplitude", "must be in [0, 1]");
    if (!(cboe_width > 0.0 && cboe_width <= 10.0)) fail("cboe_width", "must be in (0, 10]");
    if (p.model == Photometry::Model::Hapke) {
        Photometry::HapkeParams h;
        h.w = w;
        h.b = b;
        h.c = c;
        h.roughness_rad = roughness_deg * (3.14159265358979323846 / 180.0);
        h.filling_factor = filling_factor;
        h.cboe_amplitude = cboe_amplitude;
        h.cboe_width = cboe_width;
        return make_hapke(h, surge_amplitude, surge_width);
    }
    p.surge_amplitude = surge_amplitude;
    p.surge_width = surge_width;
    return p;
}

}  // namespace

void bind_scene(py::module_& m) {
    py::class_<Photometry>(m, "Photometry",
                           "A photometric function: BRDF = albedo/π · shape(μi, μo, g) (moonbot/photometry.h).")
        .def(py::init(&make_photometry), py::arg("model") = "lambert", py::arg("phase") = "exponential",
             py::arg("surge_amplitude") = 0.0, py::arg("surge_width") = 0.07, py::kw_only(),
             py::arg("w") = 0.32, py::arg("b") = 0.24, py::arg("c") = 0.30, py::arg("roughness_deg") = 23.4,
             py::arg("filling_factor") = 0.3, py::arg("cboe_amplitude") = 0.0, py::arg("cboe_width") = 1.0,
             "model 'lambert' | 'lunar-lambert' (McEwen) | 'hapke' (Hapke 2012 with porosity, SHOE, "
             "CBOE, roughness; shape normalised to 1 at i = e = g = 0); phase weight L(g) 'exponential' "
             "(exp(-g/60°)) | 'mcewen' (cubic, clamped), lunar-lambert only; opposition surge 1 + B0/(1 + "
             "tan(g/2)/h) with B0 = surge_amplitude (0 = off), h = surge_width (Hapke's B_S0, h_S). "
             "Hapke only (keywords): w single-scattering albedo; b, c double Henyey-Greenstein (c > 0 "
             "back-scattering); roughness_deg mean slope θ̄, degrees; filling_factor φ (porosity "
             "factor K); cboe_amplitude B_C0, cboe_width h_C. Defaults: Sato et al. 2014 lunar set.")
        .def("shape", [](const Photometry& p, double mu_i, double mu_o, double cos_g) {
            return photometric_shape(p, mu_i, mu_o, cos_g);
        }, py::arg("mu_i"), py::arg("mu_o"), py::arg("cos_g"),
           "BRDF / (albedo/π) for cosines of incidence and emission (both > 0, else 0) and cos phase.")
        .def_property_readonly("model", [](const Photometry& p) {
            return p.model == Photometry::Model::Lambert ? "lambert"
                   : p.model == Photometry::Model::LunarLambert ? "lunar-lambert" : "hapke";
        })
        .def("hapke_reflectance", [](const Photometry& p, double mu_i, double mu_o, double cos_g) {
            if (p.model != Photometry::Model::Hapke) fail("model", "hapke_reflectance needs model 'hapke'");
            return mu_i > 0.0 ? mu_i * hapke_brdf(p, mu_i, mu_o, cos_g) : 0.0;
        }, py::arg("mu_i"), py::arg("mu_o"), py::arg("cos_g"),
           "Hapke's bidirectional reflectance r(i, e, g) = μi·BRDF, per steradian, un-normalised "
           "(radiance / collimated irradiance).")
        .def_property_readonly("hapke_normal_albedo", [](const Photometry& p) -> py::object {
            if (p.model != Photometry::Model::Hapke) return py::none();
            return py::float_(p.hapke.normal_albedo);
        }, "Hapke's normal albedo A_N = π·r(0, 0, 0) for these parameters (the shape's normaliser); "
           "None for other models.")
        .def_property_readonly("porosity_factor", [](const Photometry& p) -> py::object {
            if (p.model != Photometry::Model::Hapke) return py::none();
            return py::float_(p.hapke.K);
        }, "Hapke's porosity factor K(filling_factor); None for other models.");

    py::class_<WovenSurface>(m, "WovenSurface",
                             "A bag's cloth: the procedural weave (fabric.h; sheen > 0 adds the tapes' glossy "
                             "lobe) on the mesh's corner UVs and its dirt, made per instance from stain_seed: "
                             "stain_mode 'stamp' paints the paper's stain (stain.h), 'dust' gathers regolith dust "
                             "(soiling.h); 0 stamps = clean, nothing made.")
        .def(py::init(&make_woven), py::arg("pitch_m") = 1.5e-3, py::arg("relief_m") = 1.0e-4,
             py::arg("contrast") = 0.04, py::arg("metres_per_uv") = 1.0, py::arg("stamps") = 0,
             py::arg("brush_size") = 0.18, py::arg("opacity") = 0.5, py::arg("resolution") = 512,
             py::arg("stain_seed") = 0, py::arg("dirt_colour") = py::make_tuple(0.12, 0.11, 0.10),
             py::arg("sheen") = 0.0, py::arg("sheen_along") = FabricParams{}.sheen_along,
             py::arg("sheen_across") = FabricParams{}.sheen_across, py::arg("stain_mode") = "stamp",
             py::arg("contact_height_m") = SoilingParams{}.contact_height_m,
             py::arg("deposit_radius_m") = SoilingParams{}.deposit_radius_m,
             py::arg("handled_share") = SoilingParams{}.handled_share, py::arg("speckle") = SoilingParams{}.speckle);

    py::class_<RegolithGrain, std::shared_ptr<RegolithGrain>>(
        m, "RegolithGrain",
        "Regolith's granular micro-texture (regolith_texture.h): octaves of value noise of cells "
        "finest_cell_m·2^k up to coarsest_cell_m (metres), an albedo factor of relative RMS albedo_rms "
        "and relief of 1-D RMS slope slope_rms_deg (degrees), prefiltered over each pixel's footprint.")
        .def(py::init([](double albedo_rms, double slope_rms_deg, double finest_cell_m, double coarsest_cell_m,
                         double hurst, uint64_t seed) {
                 return std::const_pointer_cast<RegolithGrain>(
                     make_grain(albedo_rms, slope_rms_deg, finest_cell_m, coarsest_cell_m, hurst, seed));
             }),
             py::arg("albedo_rms") = 0.0, py::arg("slope_rms_deg") = 0.0, py::arg("finest_cell_m") = 1e-3,
             py::arg("coarsest_cell_m") = 1.6e-2, py::arg("hurst") = 0.6, py::arg("seed") = 0)
        .def_property_readonly("octaves", &RegolithGrain::octaves)
        .def_property_readonly("flat_footprint_m", &RegolithGrain::flat_footprint_m,
                               "footprints (metres) at or above this give exactly the mean")
        .def(
            "eval",
            [](const RegolithGrain& g, const py::handle& points, double footprint_m) {
                py::array a = as_array(points, "points");
                if (a.ndim() != 2 || a.shape(1) != 3) fail("points", "must have shape (N, 3), got " + shape_of(a));
                auto p = converted<double>(a, "points").unchecked<2>();
                const auto n = static_cast<py::ssize_t>(p.shape(0));
                py::array_t<double> factor(n), gradient({n, py::ssize_t{3}});
                auto f = factor.mutable_unchecked<1>();
                auto gr = gradient.mutable_unchecked<2>();
                if (!(footprint_m >= 0.0)) fail("footprint_m", "must be >= 0");
                for (py::ssize_t i = 0; i < n; ++i) {
                    const GrainSample s = g.eval({p(i, 0), p(i, 1), p(i, 2)}, footprint_m);
                    f(i) = s.albedo_factor;
                    for (int c = 0; c < 3; ++c) gr(i, c) = s.gradient[c];
                }
                return py::make_tuple(factor, gradient);
            },
            py::arg("points"), py::arg("footprint_m"),
            "(albedo factor (N,) float64, relief gradient (N, 3) float64) at world points (N, 3) metres, "
            "prefiltered over footprint_m metres.");

    m.def("embree_isas", [] {
        std::vector<std::string> names;
        for (Isa isa : cpu_isas()) names.emplace_back(isa_name(isa));
        return names;
    }, "The ISAs this CPU can run Embree's kernels in, narrowest first (names as embree_isa takes them).");
    m.def("resolve_embree_isa", [](const std::string& name) { return std::string(isa_name(resolve_isa(parse_isa(name)))); },
          py::arg("name") = "auto",
          "The ISA a scene asked for `name` traces in here: 'auto' is $MOONBOT_EMBREE_ISA where set, else avx2 "
          "where this CPU runs it, else the widest it runs. ValueError for an unknown name or one this CPU "
          "cannot run.");

    py::class_<Scene>(m, "Scene", "Triangle-mesh prototypes and their instances; metres, world ENU.")
        .def(py::init([](const std::string& embree_isa, bool watertight) {
                 return std::make_unique<Scene>(parse_isa(embree_isa), watertight);
             }),
             py::arg("embree_isa") = "auto", py::arg("watertight") = true,
             "An empty scene whose rays Embree traces in `embree_isa` (auto, sse2, sse4.2, avx, avx2, avx512; "
             "see resolve_embree_isa). watertight=False (Embree's default BVHs, no second look at shared "
             "vertices) exists only to measure what watertightness costs and buys.")
        .def_property_readonly("embree_isa", [](const Scene& s) { return std::string(isa_name(s.isa())); },
                               "The ISA Embree traces this scene's rays in (never 'auto').")
        .def(
            "add_mesh",
            [](Scene& s, const py::handle& vertices, const py::handle& triangles, const py::handle& corner_uvs,
               const py::handle& vertex_albedo, const py::handle& vertex_normals) {
                auto v = float_rows(vertices, "vertices", 3);
                const std::vector<uint32_t> t = index_rows(triangles, "triangles");
                std::optional<py::array_t<float, py::array::c_style>> uv;
                if (!corner_uvs.is_none()) {
                    uv = float_rows(corner_uvs, "corner_uvs", 6);
                    if (static_cast<size_t>(uv->shape(0)) != t.size() / 3)
                        fail("corner_uvs", "must have one row per triangle (" + std::to_string(t.size() / 3) +
                                               "), got " + std::to_string(uv->shape(0)));
                }
                std::optional<py::array_t<float, py::array::c_style>> va;
                int channels = 1;
                if (!vertex_albedo.is_none()) {
                    auto given = py::reinterpret_borrow<py::object>(vertex_albedo);
                    const py::tuple shape = py::module_::import("numpy").attr("shape")(given);
                    channels = shape.size() == 2 && shape[1].cast<int>() == 3 ? 3 : 1;
                    va = float_rows(channels == 3 ? given : given.attr("reshape")(-1, 1), "vertex_albedo", channels);
                    if (va->shape(0) != v.shape(0))
                        fail("vertex_albedo", "must have one value per vertex (" + std::to_string(v.shape(0)) +
                                                  "), got " + std::to_string(va->shape(0)));
                }
                std::optional<py::array_t<float, py::array::c_style>> vn;
                if (!vertex_normals.is_none()) {
                    vn = float_rows(vertex_normals, "vertex_normals", 3);
                    if (vn->shape(0) != v.shape(0))
                        fail("vertex_normals", "must have one row per vertex (" + std::to_string(v.shape(0)) +
                                                   "), got " + std::to_string(vn->shape(0)));
                }
                // Safe without the GIL: the arrays are our own contiguous copies or held references.
                py::gil_scoped_release release;
                return s.add_mesh(v.data(), static_cast<size_t>(v.shape(0)), t.data(), t.size() / 3,
                                  uv ? uv->data() : nullptr, va ? va->data() : nullptr, vn ? vn->data() : nullptr,
                                  channels);
            },
            py::arg("vertices"), py::arg("triangles"), py::arg("corner_uvs") = py::none(),
            py::arg("vertex_albedo") = py::none(), py::arg("vertex_normals") = py::none(),
            "Add a prototype mesh: vertices (N, 3) float, metres; triangles (M, 3) int; optional "
            "corner_uvs (M, 6) float: (u, v) of each triangle's three corners, for woven materials; "
            "optional vertex_albedo (N,) or (N, 3) float >= 0: a factor on the albedo per vertex, or per "
            "vertex and RGB channel; optional "
            "vertex_normals (N, 3) float: smooth shading normals (object frame). Builds its BVH. "
            "Returns the mesh index.")
        .def(
            "update_mesh",
            [](Scene& s, uint32_t mesh, const py::handle& vertices) {
                auto v = float_rows(vertices, "vertices", 3);
                py::gil_scoped_release release;
                s.update_mesh(mesh, v.data(), static_cast<size_t>(v.shape(0)));
            },
            py::arg("mesh"), py::arg("vertices"),
            "Move mesh `mesh`'s vertices to `vertices` (N, 3) float, metres, the same N (triangles "
            "stay) and rebuild that mesh's BVH alone; commit() before the next render. For geometry "
            "that moves between views (the dust's ejecta); not for meshes with vertex normals.")
        .def(
            "add_instance",
            [](Scene& s, uint32_t mesh, const py::handle& world_from_object, int instance_id,
               const py::handle& albedo, const Photometry& photometry, const std::optional<WovenSurface>& woven) {
                const Material mat = material(albedo, photometry, woven);
                const glm::dmat4 xfm = matrix<4, 4>(world_from_object, "world_from_object");
                py::gil_scoped_release release;  // painting a stain takes a few milliseconds
                return s.add_instance(mesh, xfm, instance_id, mat);
            },
            py::arg("mesh"), py::arg("world_from_object"), py::arg("instance_id"),
            py::arg("albedo"), py::arg("photometry") = Photometry{}, py::arg("woven") = py::none(),
            "Add a labelled object: world_from_object (4, 4) affine, metres; instance_id 1..255 "
            "(unique); albedo (3,) linear RGB in [0, 1] (a woven surface's mean colour); woven: a "
            "WovenSurface (the mesh needs corner_uvs). Returns the instance index.")
        .def(
            "add_background",
            [](Scene& s, uint32_t mesh, const py::handle& world_from_object, const py::handle& albedo,
               const Photometry& photometry, std::shared_ptr<RegolithGrain> grain, bool moving) {
                return s.add_background(mesh, matrix<4, 4>(world_from_object, "world_from_object"),
                                        material(albedo, photometry, std::nullopt, std::move(grain)), moving);
            },
            py::arg("mesh"), py::arg("world_from_object"), py::arg("albedo"), py::arg("photometry") = Photometry{},
            py::arg("grain") = py::none(), py::arg("moving") = false,
            "Add unlabelled geometry (terrain, rocks): label 0 in masks. grain: a RegolithGrain textures "
            "its camera hits (None: no texture). moving: it moves between views (the dust's ejecta), so a "
            "LightCache neither caches it nor lets it shade what it caches. Returns the instance index.")
        .def("commit", &Scene::commit, py::call_guard<py::gil_scoped_release>(),
             "Build the top-level BVH; required before rendering.")
        .def(
            "intersect",
            [](const Scene& s, const py::handle& origins, const py::handle& directions) {
                if (!s.committed()) throw std::logic_error("intersect: the scene is not committed");
                auto o = float_rows(origins, "origins", 3);
                auto d = float_rows(directions, "directions", 3);
                if (o.shape(0) != d.shape(0))
                    fail("directions", "must have as many rows as origins (" + std::to_string(o.shape(0)) +
                                           "), got " + std::to_string(d.shape(0)));
                const auto n = static_cast<size_t>(o.shape(0));
                std::vector<RayHit> rays(n);
                for (size_t i = 0; i < n; ++i) {
                    RayHit& r = rays[i];
                    r = RayHit{};
                    r.org_x = o.at(i, 0), r.org_y = o.at(i, 1), r.org_z = o.at(i, 2);
                    r.dir_x = d.at(i, 0), r.dir_y = d.at(i, 1), r.dir_z = d.at(i, 2);
                    r.tfar = std::numeric_limits<float>::infinity();
                    r.mask = 0xFFFFFFFFu;
                }
                {
                    py::gil_scoped_release release;
                    Scene::ReadLock lock(s);
                    s.accel().intersect_watertight(rays.data(), n, s.has_background());
                }
                py::array_t<double> t(static_cast<py::ssize_t>(n));
                py::array_t<int64_t> instance(static_cast<py::ssize_t>(n)), primitive(static_cast<py::ssize_t>(n));
                auto tt = t.mutable_unchecked<1>();
                auto ii = instance.mutable_unchecked<1>();
                auto pp = primitive.mutable_unchecked<1>();
                for (size_t i = 0; i < n; ++i) {
                    const bool hit = rays[i].geom_id != kInvalidId;
                    const auto k = static_cast<py::ssize_t>(i);
                    tt(k) = hit ? rays[i].tfar : std::numeric_limits<double>::infinity();
                    ii(k) = hit ? static_cast<int64_t>(rays[i].inst_id) : -1;
                    pp(k) = hit ? static_cast<int64_t>(rays[i].prim_id) : -1;
                }
                return py::make_tuple(t, instance, primitive);
            },
            py::arg("origins"), py::arg("directions"),
            "Closest hits of rays (origins and directions (N, 3), metres, world; narrowed to float32 as Embree "
            "traces them), watertight as the renderer's camera rays are: (t (N,) float64 in units of |direction|, inf on a miss; instance (N,) int64, -1 on a "
            "miss; primitive (N,) int64, the triangle's index in its mesh, -1 on a miss). For checking the "
            "traversal itself; renders resolve hits in double on top of this.")
        .def_property_readonly("committed", &Scene::committed)
        .def_property_readonly("mesh_count", &Scene::mesh_count)
        .def_property_readonly("instance_count", &Scene::instance_count)
        .def_property_readonly("bvh_builds", &Scene::bvh_builds,
                               "BVH builds so far: one per mesh plus one per commit.");

    py::class_<Camera>(m, "Camera", "Pinhole camera, OpenCV axes (x right, y down, z forward).")
        .def(py::init([](double fx, double fy, double cx, double cy, int width, int height,
                         const py::handle& R, const py::handle& t) {
                 return Camera(Intrinsics{fx, fy, cx, cy, width, height}, matrix<3, 3>(R, "R"),
                               vector<3>(t, "t"));
             }),
             py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"), py::arg("width"),
             py::arg("height"), py::arg("R"), py::arg("t"),
             "Intrinsics in pixels; R (3, 3) and t (3,) metres map world to camera: "
             "x_cam = R x_world + t.")
        .def_property_readonly("width", &Camera::width)
        .def_property_readonly("height", &Camera::height)
        .def_property_readonly("center", [](const Camera& c) {
            const glm::dvec3 p = c.center();
            return py::array_t<double>(3, &p.x);
        }, "Camera centre in the world frame (3,), metres.")
        .def(
            "project",
            [](const Camera& c, const py::handle& points) {
                py::array a = as_array(points, "points");
                if (a.ndim() != 2 || a.shape(1) != 3)
                    fail("points", "must have shape (N, 3), got " + shape_of(a));
                auto p = converted<double>(a, "points");
                py::array_t<double> out({p.shape(0), py::ssize_t(3)});
                auto o = out.mutable_unchecked<2>();
                for (py::ssize_t i = 0; i < p.shape(0); ++i) {
                    const glm::dvec3 uvz = c.project({p.at(i, 0), p.at(i, 1), p.at(i, 2)});
                    for (int k = 0; k < 3; ++k) o(i, k) = uvz[k];
                }
                return out;
            },
            py::arg("points"),
            "Project world points (N, 3) metres to (u, v, z): pixel coordinates with pixel "
            "centres at +0.5, and z-depth in metres.");

    py::class_<Sun>(m, "Sun",
                    "A distant disk light (the Sun, or the Earth for Earthshine): azimuth clockwise from "
                    "North, elevation, irradiance W/m², angular diameter (0 = point), linear RGB tint.")
        .def(py::init([](double az, double el, double irradiance, double diameter, const py::handle& color) {
                 return Sun(az, el, irradiance, diameter, vector<3>(color, "color"));
             }),
             py::arg("azimuth_deg"), py::arg("elevation_deg"), py::arg("irradiance") = 1361.0,
             py::arg("angular_diameter_deg") = 0.0, py::arg("color") = py::make_tuple(1.0, 1.0, 1.0))
        .def_property_readonly("direction", [](const Sun& s) {
            const glm::dvec3 d = s.direction();
            return py::array_t<double>(3, &d.x);
        }, "Unit vector toward the Sun, world ENU.")
        .def_property_readonly("irradiance", &Sun::irradiance)
        .def_property_readonly("angular_diameter_deg", &Sun::angular_diameter_deg);
}

}  // namespace moonbot::bindings
