#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/camera.h"
#include "moonbot/light.h"
#include "moonbot/scene.h"
#include "moonbot/subgrid_craters.h"
#include "moonbot/subgrid_relief.h"
#include "params.h"

namespace moonbot::bindings {

namespace {

Material material(const py::handle& albedo, const Photometry& photometry,
                  const std::optional<WovenSurface>& woven = std::nullopt,
                  std::shared_ptr<const RegolithGrain> grain = nullptr) {
    return Material{glm::vec3(vector<3>(albedo, "albedo")), validated(photometry), woven, std::move(grain), nullptr};
}

const char* model_name(Photometry::Model model) {
    return model == Photometry::Model::Lambert        ? "lambert"
           : model == Photometry::Model::LunarLambert ? "lunar-lambert"
                                                      : "hapke";
}

Photometry::Model parse_model(const std::string& model) {
    if (model == "lambert") return Photometry::Model::Lambert;
    if (model == "lunar-lambert") return Photometry::Model::LunarLambert;
    if (model == "hapke") return Photometry::Model::Hapke;
    fail("model", "must be 'lambert', 'lunar-lambert' or 'hapke', got '" + model + "'");
}

Photometry::Phase parse_phase(const std::string& phase) {
    if (phase == "exponential") return Photometry::Phase::Exponential;
    if (phase == "mcewen") return Photometry::Phase::McEwen;
    fail("phase", "must be 'exponential' or 'mcewen', got '" + phase + "'");
}

StainMode parse_stain_mode(const std::string& mode) {
    if (mode == "stamp") return StainMode::Stamp;
    if (mode == "dust") return StainMode::Dust;
    fail("stain_mode", "must be 'stamp' or 'dust', got '" + mode + "'");
}

/// A Hapke parameter of Photometry as a read/write Python attribute.
template <double Photometry::HapkeParams::* member>
double get_hapke(const Photometry& p) {
    return p.hapke.*member;
}
template <double Photometry::HapkeParams::* member>
void set_hapke(Photometry& p, double value) {
    p.hapke.*member = value;
}

void bind_photometry(py::module_& m) {
    using H = Photometry::HapkeParams;
    ParamsClass<Photometry>(
        m, "Photometry",
        "A photometric function: BRDF = albedo/pi * shape(mu_i, mu_o, g) (moonbot/photometry.h). model "
        "'lambert' | 'lunar-lambert' (McEwen) | 'hapke' (Hapke 2012 with porosity, SHOE, CBOE, roughness; "
        "shape normalised to 1 at i = e = g = 0). The Hapke fields are read only by 'hapke' but checked "
        "whatever the model; their defaults are the Sato et al. 2014 lunar set. Ranges: `ranges`.")
        .property(
            "model", [](const Photometry& p) { return std::string(model_name(p.model)); },
            [](Photometry& p, const std::string& v) { p.model = parse_model(v); },
            "'lambert' | 'lunar-lambert' | 'hapke'")
        .property(
            "phase",
            [](const Photometry& p) {
                return std::string(p.phase == Photometry::Phase::Exponential ? "exponential" : "mcewen");
            },
            [](Photometry& p, const std::string& v) { p.phase = parse_phase(v); },
            "lunar-lambert phase weight L(g): 'exponential' (exp(-g/60 deg)) | 'mcewen' (cubic, clamped)")
        .field("surge_amplitude", &Photometry::surge_amplitude,
               "opposition surge 1 + B0/(1 + tan(g/2)/h): B0 (0 = off; Hapke's B_S0)")
        .field("surge_width", &Photometry::surge_width, "the surge's width h (Hapke's h_S)")
        .property("w", &get_hapke<&H::w>, &set_hapke<&H::w>, "hapke: single-scattering albedo of a grain")
        .property("b", &get_hapke<&H::b>, &set_hapke<&H::b>, "hapke: double Henyey-Greenstein lobe width")
        .property("c", &get_hapke<&H::c>, &set_hapke<&H::c>,
                  "hapke: double Henyey-Greenstein weight (c > 0: back-scattering)")
        .property(
            "roughness_deg", [](const Photometry& p) { return p.hapke.roughness_rad / kRadPerDeg; },
            [](Photometry& p, double degrees) { p.hapke.roughness_rad = degrees * kRadPerDeg; },
            "hapke: mean facet slope theta-bar of Hapke 1984, degrees")
        .property("filling_factor", &get_hapke<&H::filling_factor>, &set_hapke<&H::filling_factor>,
                  "hapke: volume fraction of grains phi (porosity factor K; 0: K = 1)")
        .property("cboe_amplitude", &get_hapke<&H::cboe_amplitude>, &set_hapke<&H::cboe_amplitude>,
                  "hapke: coherent-backscatter amplitude B_C0")
        .property("cboe_width", &get_hapke<&H::cboe_width>, &set_hapke<&H::cboe_width>,
                  "hapke: coherent-backscatter width h_C")
        .done()
        .def(
            "shape",
            [](const Photometry& p, double mu_i, double mu_o, double cos_g) {
                return photometric_shape(validated(p), mu_i, mu_o, cos_g);
            },
            py::arg("mu_i"), py::arg("mu_o"), py::arg("cos_g"),
            "BRDF / (albedo/pi) for cosines of incidence and emission (both > 0, else 0) and cos phase.")
        .def(
            "hapke_reflectance",
            [](const Photometry& p, double mu_i, double mu_o, double cos_g) {
                if (p.model != Photometry::Model::Hapke) fail("model", "hapke_reflectance needs model 'hapke'");
                return mu_i > 0.0 ? mu_i * hapke_brdf(validated(p), mu_i, mu_o, cos_g) : 0.0;
            },
            py::arg("mu_i"), py::arg("mu_o"), py::arg("cos_g"),
            "Hapke's bidirectional reflectance r(i, e, g) = mu_i * BRDF, per steradian, un-normalised "
            "(radiance / collimated irradiance).")
        .def_property_readonly(
            "hapke_normal_albedo",
            [](const Photometry& p) -> std::optional<double> {
                if (p.model != Photometry::Model::Hapke) return std::nullopt;
                return validated(p).hapke.normal_albedo;
            },
            "Hapke's normal albedo A_N = pi * r(0, 0, 0) for these parameters (the shape's normaliser); "
            "None for other models.")
        .def_property_readonly(
            "porosity_factor",
            [](const Photometry& p) -> std::optional<double> {
                if (p.model != Photometry::Model::Hapke) return std::nullopt;
                return validated(p).hapke.K;
            },
            "Hapke's porosity factor K(filling_factor); None for other models.");
    py::dict ranges;
    for (const ParamRange& r : kPhotometryRanges) ranges[r.field] = py::make_tuple(r.lo, r.hi, r.lo_open, r.hi_open);
    m.attr("Photometry").attr("ranges") = ranges;
}

void bind_woven(py::module_& m) {
    ParamsClass<FabricParams>(m, "FabricParams", "The procedural weave of a bag's cloth (moonbot/fabric.h).")
        .field("pitch_m", &FabricParams::pitch_m, "weave pitch, metres, > 0")
        .field("relief_m", &FabricParams::relief_m, "weave relief, metres, >= 0")
        .field("contrast", &FabricParams::contrast, "albedo contrast between warp and weft, [0, 1]")
        .vec3("albedo", &FabricParams::albedo, "the tapes' albedo (3,), linear RGB, each in [0, 1]")
        .field("sheen", &FabricParams::sheen, "weight of the tapes' glossy lobe, [0, 1] (0: matte)")
        .field("sheen_along", &FabricParams::sheen_along, "GGX roughness along a tape, [0.01, 1]")
        .field("sheen_across", &FabricParams::sheen_across, "GGX roughness across a tape, [0.01, 1]")
        .done();
    ParamsClass<StainParams>(m, "StainParams", "The dirt on a bag (moonbot/stain.h; Dust mode: its deposits).")
        .field("stamps", &StainParams::stamps, "stamps (Dust mode: deposits), >= 0; 0 = clean, nothing made")
        .field("brush_size", &StainParams::brush_size, "stamp size, a fraction of the texture")
        .field("opacity", &StainParams::opacity, "one stamp's coverage at its centre, [0, 1]")
        .field("resolution", &StainParams::resolution, "stain mask texels a side, [1, 8192]")
        .done();
    ParamsClass<SoilingParams>(m, "SoilingParams",
                               "The shape of Dust mode's regolith dust (moonbot/soiling.h); its deposits and "
                               "opacity are StainParams' stamps and opacity.")
        .field("contact_height_m", &SoilingParams::contact_height_m,
               "the contact band's e-folding height, metres, (0, 1]")
        .field("deposit_radius_m", &SoilingParams::deposit_radius_m, "mean deposit radius, metres, (0, 1]")
        .field("handled_share", &SoilingParams::handled_share, "share of deposits near the top, [0, 1]")
        .field("speckle", &SoilingParams::speckle, "grain strength, [0, 2]")
        .done();
    ParamsClass<WovenSurface>(m, "WovenSurface",
                              "A bag's cloth: the procedural weave (fabric; sheen > 0 adds the tapes' glossy "
                              "lobe) on the mesh's corner UVs and its dirt, made per instance from stain_seed: "
                              "stain_mode 'stamp' paints the paper's stain (stain.h), 'dust' gathers regolith dust "
                              "(soiling.h); 0 stamps = clean, nothing made.")
        .field("fabric", &WovenSurface::fabric, "the weave (FabricParams)")
        .field("metres_per_uv", &WovenSurface::metres_per_uv, "fabric metres per atlas UV unit, > 0")
        .field("stain", &WovenSurface::stain, "the dirt's stamps (StainParams)")
        .field("stain_seed", &WovenSurface::stain_seed, "keys this instance's dirt")
        .vec3("dirt_colour", &WovenSurface::dirt_colour, "the dirt's colour (3,), linear RGB, each in [0, 1]")
        .property(
            "stain_mode",
            [](const WovenSurface& w) { return std::string(w.stain_mode == StainMode::Stamp ? "stamp" : "dust"); },
            [](WovenSurface& w, const std::string& mode) { w.stain_mode = parse_stain_mode(mode); }, "'stamp' | 'dust'")
        .field("soiling", &WovenSurface::soiling, "Dust mode's shape (SoilingParams)")
        .done();
}

}  // namespace

namespace {

/// (N, cols) float64 rows of `name` (any number of columns for cols < 0), C-contiguous.
py::array_t<double, py::array::c_style> double_rows(const py::handle& obj, const std::string& name, int cols) {
    py::array a = as_array(obj, name);
    if (a.ndim() != 2 || (cols >= 0 && a.shape(1) != cols))
        fail(name,
             "must have shape (N, " + (cols >= 0 ? std::to_string(cols) : std::string("M")) + "), got " + shape_of(a));
    return converted<double>(a, name);
}

/// A 1-D float64 array of `name` as a vector (length n, or any length for n < 0).
std::vector<double> double_vector(const py::handle& obj, const std::string& name, py::ssize_t n = -1) {
    py::array a = as_array(obj, name);
    if (a.ndim() != 1 || (n >= 0 && a.shape(0) != n))
        fail(name, "must have shape (" + (n >= 0 ? std::to_string(n) : std::string("N")) + ",), got " + shape_of(a));
    auto c = converted<double>(a, name);
    return {c.data(), c.data() + c.shape(0)};
}

/// f(x, y) at each world point of `points` (N, 2), metres: a float64 array (N,).
template <typename F>
py::array_t<double> at_points(const py::handle& points, F f) {
    auto p = double_rows(points, "points", 2).unchecked<2>();
    py::array_t<double> out(p.shape(0));
    auto o = out.mutable_unchecked<1>();
    for (py::ssize_t i = 0; i < p.shape(0); ++i) o(i) = f(p(i, 0), p(i, 1));
    return out;
}

void bind_subgrid_relief(py::module_& m) {
    py::class_<SubgridRelief, std::shared_ptr<SubgridRelief>>(
        m, "SubgridRelief",
        "The roughness octaves a graded terrain mesh did not hold, given back to the shading "
        "(subgrid_relief.h; moonbot/terrain/location.py's subgrid_relief builds it).")
        .def(py::init([](const py::handle& wavelengths, const py::handle& amplitudes, const py::handle& angles,
                         const py::handle& offsets, const py::handle& keys, const py::handle& axis,
                         const py::handle& spacing) {
                 const std::vector<double> lam = double_vector(wavelengths, "wavelengths");
                 const auto n = static_cast<py::ssize_t>(lam.size());
                 const std::vector<double> amp = double_vector(amplitudes, "amplitudes", n);
                 const std::vector<double> angle = double_vector(angles, "angles", n);
                 auto off = double_rows(offsets, "offsets", 2).unchecked<2>();
                 if (off.shape(0) != n) fail("offsets", "must have one row per wavelength");
                 py::array key_array = as_array(keys, "keys");
                 if (key_array.ndim() != 1 || key_array.shape(0) != n || key_array.dtype().kind() != 'u' ||
                     key_array.itemsize() != 8)
                     fail("keys", "must be a uint64 array with one key per wavelength");
                 auto key = converted<uint64_t>(key_array, "keys").unchecked<1>();
                 std::vector<ReliefOctave> octaves(static_cast<size_t>(n));
                 for (py::ssize_t k = 0; k < n; ++k) {
                     const auto i = static_cast<size_t>(k);
                     octaves[i] = {lam[i], amp[i], angle[i], {off(k, 0), off(k, 1)}, key(k)};
                 }
                 GradedGrid grid{double_vector(axis, "axis"), double_vector(spacing, "spacing")};
                 try {
                     return std::make_shared<SubgridRelief>(std::move(octaves), std::move(grid));
                 } catch (const std::invalid_argument& e) {
                     throw py::value_error(e.what());
                 }
             }),
             py::arg("wavelengths"), py::arg("amplitudes"), py::arg("angles"), py::arg("offsets"), py::arg("keys"),
             py::arg("axis"), py::arg("spacing"),
             "Octaves: wavelengths and amplitudes (K,) metres, angles (K,) radians, lattice offsets (K, 2), "
             "lattice keys (K,) uint64; the mesh's graded axis (n,) and each node's cell (n,), metres. "
             "ValueError naming the argument on bad input.")
        .def_property_readonly("octaves", &SubgridRelief::octaves, "octaves with a non-zero amplitude")
        .def(
            "cell",
            [](const SubgridRelief& r, const py::handle& points) {
                return at_points(points, [&](double x, double y) { return r.cell_m(x, y); });
            },
            py::arg("points"), "The mesh's cell (N,) metres at world points (N, 2) (x, y) metres.")
        .def(
            "height",
            [](const SubgridRelief& r, const py::handle& points, const py::handle& cell) {
                auto p = double_rows(points, "points", 2).unchecked<2>();
                const std::vector<double> c = double_vector(cell, "cell", p.shape(0));
                py::array_t<double> out(p.shape(0));
                auto o = out.mutable_unchecked<1>();
                for (py::ssize_t i = 0; i < p.shape(0); ++i)
                    o(i) = r.height(p(i, 0), p(i, 1), c[static_cast<size_t>(i)]);
                return out;
            },
            py::arg("points"), py::arg("cell"),
            "Unfiltered height (N,) metres of the relief a mesh of cell (N,) metres drops, at world points (N, 2).")
        .def(
            "eval",
            [](const SubgridRelief& r, const py::handle& points, double footprint_m) {
                if (!(footprint_m >= 0.0)) fail("footprint_m", "must be >= 0");
                auto p = double_rows(points, "points", 3).unchecked<2>();
                const py::ssize_t n = p.shape(0);
                py::array_t<double> gradient({n, py::ssize_t{3}}), spread(n);
                auto g = gradient.mutable_unchecked<2>();
                auto v = spread.mutable_unchecked<1>();
                for (py::ssize_t i = 0; i < n; ++i) {
                    const ReliefSample s = r.eval({p(i, 0), p(i, 1), p(i, 2)}, footprint_m);
                    for (int c = 0; c < 3; ++c) g(i, c) = s.gradient[c];
                    v(i) = s.residual_slope_variance;
                }
                return py::make_tuple(gradient, spread);
            },
            py::arg("points"), py::arg("footprint_m"),
            "(mean gradient over the pixel's box (N, 3), slope spread about it (N,) tan²) of the dropped relief at "
            "world points (N, 3) metres, for a pixel of footprint footprint_m metres.");
}

void bind_subgrid_craters(py::module_& m) {
    py::class_<SubgridCraters, std::shared_ptr<SubgridCraters>>(
        m, "SubgridCraters",
        "The small craters a graded terrain mesh did not draw, given back to the shading as their slopes and "
        "their walls' shadows (subgrid_craters.h; moonbot/terrain/location.py's subgrid_craters builds it).")
        .def(py::init([](const py::handle& centres, const py::handle& diameters, const py::handle& degradation,
                         const py::handle& table_degradation, double radius_step, const py::handle& table,
                         const py::handle& table_reach) {
                 auto c = double_rows(centres, "centres", 2).unchecked<2>();
                 const py::ssize_t n = c.shape(0);
                 std::vector<glm::dvec2> points(static_cast<size_t>(n));
                 for (py::ssize_t i = 0; i < n; ++i) points[static_cast<size_t>(i)] = {c(i, 0), c(i, 1)};
                 CraterProfileTable profiles;
                 profiles.degradation = double_vector(table_degradation, "table_degradation");
                 profiles.radius_step = radius_step;
                 auto t = double_rows(table, "table", -1).unchecked<2>();
                 if (t.shape(0) != static_cast<py::ssize_t>(profiles.degradation.size()))
                     fail("table", "must have one row per table_degradation");
                 for (py::ssize_t r = 0; r < t.shape(0); ++r)
                     for (py::ssize_t k = 0; k < t.shape(1); ++k) profiles.heights.push_back(t(r, k));
                 profiles.reach = double_vector(table_reach, "table_reach", t.shape(0));
                 try {
                     return std::make_shared<SubgridCraters>(
                         std::move(points), double_vector(diameters, "diameters", n),
                         double_vector(degradation, "degradation", n), std::move(profiles));
                 } catch (const std::invalid_argument& e) {
                     throw py::value_error(e.what());
                 }
             }),
             py::arg("centres"), py::arg("diameters"), py::arg("degradation"), py::arg("table_degradation"),
             py::arg("radius_step"), py::arg("table"), py::arg("table_reach"),
             "Craters: centres (K, 2) world metres, diameters (K,) metres, degradation (K,) σ/R; craters.py's "
             "profile table: its diffusion lengths (R,) from 0, its radius step (crater radii), its heights "
             "over diameter (R, C) and each row's reach (R,) crater radii. ValueError naming the argument on "
             "bad input.")
        .def("__len__", &SubgridCraters::count)
        .def(
            "height",
            [](const SubgridCraters& s, const py::handle& points) {
                return at_points(points, [&](double x, double y) { return s.height(x, y); });
            },
            py::arg("points"), "Summed height (N,) metres of the craters' profiles at world points (N, 2) metres.")
        .def(
            "gradient",
            [](const SubgridCraters& s, const py::handle& points, double footprint_m) {
                if (!(footprint_m >= 0.0)) fail("footprint_m", "must be >= 0");
                auto p = double_rows(points, "points", 2).unchecked<2>();
                py::array_t<double> out({p.shape(0), py::ssize_t{2}});
                auto o = out.mutable_unchecked<2>();
                for (py::ssize_t i = 0; i < p.shape(0); ++i) {
                    const glm::dvec3 g = s.gradient(p(i, 0), p(i, 1), footprint_m);
                    o(i, 0) = g.x, o(i, 1) = g.y;
                }
                return out;
            },
            py::arg("points"), py::arg("footprint_m") = 0.0,
            "(∂z/∂x, ∂z/∂y) (N, 2) of the summed profiles at world points (N, 2) metres, craters narrower than two "
            "footprints of footprint_m metres left out (0: all).")
        .def(
            "shadowed",
            [](const SubgridCraters& s, const py::handle& points, const py::handle& to_light,
               const py::handle& normal) {
                auto p = double_rows(points, "points", 3).unchecked<2>();
                const glm::dvec3 l = vector<3>(to_light, "to_light"), n = vector<3>(normal, "normal");
                py::array_t<bool> out(p.shape(0));
                auto o = out.mutable_unchecked<1>();
                for (py::ssize_t i = 0; i < p.shape(0); ++i)
                    o(i) = s.shadowed({p(i, 0), p(i, 1), p(i, 2)}, glm::normalize(l), glm::normalize(n));
                return out;
            },
            py::arg("points"), py::arg("to_light"), py::arg("normal"),
            "Whether a crater's wall hides light from to_light (3,) at terrain points (N, 3) world metres on ground of "
            "normal (3,): (N,) bool.");
}

}  // namespace

void bind_scene(py::module_& m) {
    bind_photometry(m);
    bind_woven(m);
    ParamsClass<GrainParams>(m, "GrainParams", "Regolith's granular micro-texture (moonbot/regolith_texture.h).")
        .field("albedo_rms", &GrainParams::albedo_rms, "relative RMS of the unfiltered albedo factor, [0, 0.5]")
        .field("slope_rms_deg", &GrainParams::slope_rms_deg, "1-D RMS slope of the unfiltered relief, degrees, [0, 45]")
        .field("finest_cell_m", &GrainParams::finest_cell_m, "smallest lattice cell, metres, > 0")
        .field("coarsest_cell_m", &GrainParams::coarsest_cell_m, "largest lattice cell, metres, >= finest, <= 1")
        .field("hurst", &GrainParams::hurst, "relief amplitude grows as cell^hurst, [0, 1]")
        .field("seed", &GrainParams::seed, "keys the lattices")
        .done();
    bind_subgrid_relief(m);
    bind_subgrid_craters(m);
    py::class_<RegolithGrain, std::shared_ptr<RegolithGrain>>(
        m, "RegolithGrain",
        "Regolith's granular micro-texture (regolith_texture.h): octaves of value noise of cells "
        "finest_cell_m·2^k up to coarsest_cell_m (metres), an albedo factor of relative RMS albedo_rms "
        "and relief of 1-D RMS slope slope_rms_deg (degrees), prefiltered over each pixel's footprint; "
        "on the terrain also the roughness its mesh did not hold (a SubgridRelief).")
        .def(py::init([](const GrainParams& params, std::shared_ptr<SubgridRelief> subgrid) {
                 return std::make_shared<RegolithGrain>(params, std::move(subgrid));
             }),
             py::arg("params"), py::arg("subgrid") = py::none(),
             "Its octaves laid out (none where params are not enabled); ValueError naming the field on bad "
             "params. subgrid: read with the grain, its gradient and slope spread added.")
        .def_property_readonly("octaves", &RegolithGrain::octaves, "octaves of value noise, finest to coarsest cell")
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
            "(albedo factor (N,) float64, relief gradient (N, 3) float64) at world points (N, 3) metres, as a "
            "pixel of footprint footprint_m metres sees them there: the albedo prefiltered over it, the relief's "
            "mean gradient over the pixel's box (regolith_texture.h).");

    m.def(
        "embree_isas",
        [] {
            std::vector<std::string> names;
            for (Isa isa : cpu_isas()) names.emplace_back(isa_name(isa));
            return names;
        },
        "The ISAs this CPU can run Embree's kernels in, narrowest first (names as embree_isa takes them).");
    m.def(
        "resolve_embree_isa",
        [](const std::string& name) { return std::string(isa_name(resolve_isa(parse_isa(name)))); },
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
        .def_property_readonly(
            "embree_isa", [](const Scene& s) { return std::string(isa_name(s.isa())); },
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
            [](Scene& s, uint32_t mesh, const py::handle& world_from_object, int instance_id, const py::handle& albedo,
               const Photometry& photometry, const std::optional<WovenSurface>& woven) {
                const Material mat = material(albedo, photometry, woven);
                const glm::dmat4 xfm = matrix<4, 4>(world_from_object, "world_from_object");
                py::gil_scoped_release release;  // painting a stain takes a few milliseconds
                return s.add_instance(mesh, xfm, instance_id, mat);
            },
            py::arg("mesh"), py::arg("world_from_object"), py::arg("instance_id"), py::arg("albedo"),
            py::arg("photometry") = Photometry{}, py::arg("woven") = py::none(),
            "Add a labelled object: world_from_object (4, 4) affine, metres; instance_id 1..255 "
            "(unique); albedo (3,) linear RGB in [0, 1] (a woven surface's mean colour); woven: a "
            "WovenSurface (the mesh needs corner_uvs). Returns the instance index.")
        .def(
            "add_background",
            [](Scene& s, uint32_t mesh, const py::handle& world_from_object, const py::handle& albedo,
               const Photometry& photometry, std::shared_ptr<RegolithGrain> grain, bool moving,
               std::shared_ptr<SubgridCraters> craters) {
                if (craters && !grain) fail("craters", "are read with the grain: give a grain too");
                Material mat = material(albedo, photometry, std::nullopt, std::move(grain));
                mat.craters = std::move(craters);
                return s.add_background(mesh, matrix<4, 4>(world_from_object, "world_from_object"), mat, moving);
            },
            py::arg("mesh"), py::arg("world_from_object"), py::arg("albedo"), py::arg("photometry") = Photometry{},
            py::arg("grain") = py::none(), py::arg("moving") = false, py::arg("craters") = py::none(),
            "Add unlabelled geometry (terrain, rocks): label 0 in masks. grain: a RegolithGrain textures "
            "its camera hits (None: no texture). moving: it moves between views (the dust's ejecta), so a "
            "LightCache neither caches it nor lets it shade what it caches. craters: the SubgridCraters its "
            "mesh did not draw (needs a grain; world coordinates, so only for geometry placed at the "
            "identity). Returns the instance index.")
        .def("commit", &Scene::commit, py::call_guard<py::gil_scoped_release>(),
             "Build the top-level BVH; required before rendering.")
        .def(
            "intersect",
            [](const Scene& s, const py::handle& origins, const py::handle& directions) {
                if (!s.committed()) throw std::logic_error("intersect: the scene is not committed");
                auto o = float_rows(origins, "origins", 3);
                auto d = float_rows(directions, "directions", 3);
                if (o.shape(0) != d.shape(0))
                    fail("directions", "must have as many rows as origins (" + std::to_string(o.shape(0)) + "), got " +
                                           std::to_string(d.shape(0)));
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
            "traces them), watertight as the renderer's camera rays are: (t (N,) float64 in units of |direction|, inf "
            "on a miss; instance (N,) int64, -1 on a "
            "miss; primitive (N,) int64, the triangle's index in its mesh, -1 on a miss). For checking the "
            "traversal itself; renders resolve hits in double on top of this.")
        .def_property_readonly("committed", &Scene::committed, "commit() has run since the last change")
        .def_property_readonly("mesh_count", &Scene::mesh_count, "prototype meshes added")
        .def_property_readonly("instance_count", &Scene::instance_count, "instances added, labelled and background")
        .def_property_readonly("bvh_builds", &Scene::bvh_builds,
                               "BVH builds so far: one per mesh plus one per commit.");

    py::class_<Camera>(m, "Camera", "Pinhole camera, OpenCV axes (x right, y down, z forward).")
        .def(py::init([](double fx, double fy, double cx, double cy, int width, int height, const py::handle& R,
                         const py::handle& t) {
                 return Camera(Intrinsics{fx, fy, cx, cy, width, height}, matrix<3, 3>(R, "R"), vector<3>(t, "t"));
             }),
             py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"), py::arg("width"), py::arg("height"),
             py::arg("R"), py::arg("t"),
             "Intrinsics in pixels; R (3, 3) and t (3,) metres map world to camera: "
             "x_cam = R x_world + t.")
        .def_property_readonly("width", &Camera::width, "pixels")
        .def_property_readonly("height", &Camera::height, "pixels")
        .def_property_readonly(
            "center",
            [](const Camera& c) {
                const glm::dvec3 p = c.center();
                return py::array_t<double>(3, &p.x);
            },
            "Camera centre in the world frame (3,), metres.")
        .def(
            "project",
            [](const Camera& c, const py::handle& points) {
                py::array a = as_array(points, "points");
                if (a.ndim() != 2 || a.shape(1) != 3) fail("points", "must have shape (N, 3), got " + shape_of(a));
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

    py::class_<DirectionalLight>(m, "DirectionalLight",
                                 "A distant disk light, the Sun or the Earth (Earthshine): azimuth clockwise from "
                                 "North (0 = +y, 90 = +x) and elevation above the horizon, degrees; irradiance, "
                                 "W/m^2 on a surface facing it (default: the Sun's at 1 au); angular diameter of its "
                                 "disk, degrees (0 = a point); linear RGB tint of the irradiance.")
        .def(py::init([](double az, double el, double irradiance, double diameter, const py::handle& color) {
                 return DirectionalLight(az, el, irradiance, diameter, vector<3>(color, "color"));
             }),
             py::arg("azimuth_deg"), py::arg("elevation_deg"), py::arg("irradiance") = kSolarIrradiance,
             py::arg("angular_diameter_deg") = 0.0, py::arg("color") = py::make_tuple(1.0, 1.0, 1.0),
             "ValueError naming the field: elevation in [-90, 90], irradiance in [0, 1e7], angular diameter in "
             "[0, 10], each color channel in [0, 10].")
        .def_property_readonly(
            "direction",
            [](const DirectionalLight& s) {
                const glm::dvec3 d = s.direction();
                return py::array_t<double>(3, &d.x);
            },
            "Unit vector toward the light, world ENU, (3,) float64.")
        .def_property_readonly("azimuth_deg", &DirectionalLight::azimuth_deg, "clockwise from North, degrees")
        .def_property_readonly("elevation_deg", &DirectionalLight::elevation_deg, "above the horizon, degrees")
        .def_property_readonly("irradiance", &DirectionalLight::irradiance, "W/m^2")
        .def_property_readonly(
            "color", [](const DirectionalLight& s) { return py::make_tuple(s.color().x, s.color().y, s.color().z); },
            "linear RGB tint")
        .def_property_readonly("angular_diameter_deg", &DirectionalLight::angular_diameter_deg);
}

}  // namespace moonbot::bindings
