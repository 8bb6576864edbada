#include <string>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/light_cache.h"
#include "moonbot/render.h"
#include "params.h"

namespace moonbot::bindings {

void bind_render(py::module_& m) {
    ParamsClass<RenderSettings>(m, "RenderSettings", "A render's quality and threads (moonbot/render.h).")
        .field("spp", &RenderSettings::spp, "RGB samples per pixel, 1..65536; 1 = the pixel-centre ray, no jitter")
        .field("seed", &RenderSettings::seed, "keys the counter-based generator (with pixel and sample)")
        .field("threads", &RenderSettings::threads, "worker threads, 0 = all hardware threads, at most 1024")
        .field("exact_depth", &RenderSettings::exact_depth,
               "re-solve hit distances in double (exact at kilometre coordinates); False keeps Embree's float32 t")
        .field("light_samples", &RenderSettings::light_samples, "shadow rays per sample toward the Sun's disk, 1..1024")
        .field("penumbra_light_samples", &RenderSettings::penumbra_light_samples,
               "shadow rays toward the Sun's disk per refinement sample in a penumbra, 1..1024")
        .field("adaptive_full_spread", &RenderSettings::adaptive_full_spread,
               "0: every refined pixel gets adaptive_spp; f > 0: its samples past spp in proportion to its spread "
               "over f times the frame's mean, moved to the nearest power of two")
        .field("adaptive_contrast", &RenderSettings::adaptive_contrast,
               "0 = off; c > 0: a pixel whose 3x3 neighbourhood's base samples together spread beyond c times "
               "sqrt(their mean x the frame's) is refined, its share following that spread")
        .field("adaptive_error_target", &RenderSettings::adaptive_error_target,
               "0 = off; e in (0, 1]: the share's f is chosen per view, the largest adaptive_full_spread x 2^(j/8) "
               "whose refined pixels' predicted error, relative to the image's mean luminance (through the dust, its "
               "glow included), is at most e")
        .field("bounces", &RenderSettings::bounces, "diffuse inter-reflections, 0 (direct light only)..16")
        .field("adaptive_spp", &RenderSettings::adaptive_spp,
               "0 = off, else the samples (direct light only past spp) a pixel whose samples disagree is brought "
               "up to, spp < adaptive_spp <= 65536")
        .field("adaptive_threshold", &RenderSettings::adaptive_threshold,
               "relative spread of direct luminance over a pixel's base samples that refines it, >= 0")
        .field("texture_filter_px", &RenderSettings::texture_filter_px,
               "width in pixels of the box each sample's textures are prefiltered over, 0.25..8 (1 = its pixel)")
        .done();
    m.def(
        "render",
        [](const Scene& scene, const Camera& camera, const std::optional<DirectionalLight>& sun,
           const RenderSettings& given, const std::vector<std::string>& passes,
           const std::optional<DirectionalLight>& earth, const Medium* medium, const LightCache* light_cache) {
            const RenderSettings settings = given;  // a copy: the Python object may change once the GIL is released
            bool rgb = false, depth = false, instance = false;
            for (const std::string& p : passes) {
                if (p == "rgb") rgb = true;
                else if (p == "depth") depth = true;
                else if (p == "instance") instance = true;
                else fail("passes", "unknown pass '" + p + "' (rgb, depth, instance)");
            }
            if (!rgb && !depth && !instance) fail("passes", "must name at least one pass");
            if (!sun && rgb) fail("sun", "is None: only the depth and instance passes render without a light");
            if (!sun && (earth || medium || light_cache))
                fail("sun", "is None: earth, medium and light_cache light the rgb pass, which needs a light");
            const auto h = static_cast<py::ssize_t>(camera.height());
            const auto w = static_cast<py::ssize_t>(camera.width());
            // The outputs are allocated as numpy arrays and the core renders straight into them.
            py::dict out;
            FrameView view;
            if (rgb) {
                py::array_t<float> a({h, w, py::ssize_t(3)});
                view.rgb = a.mutable_data();
                out["rgb"] = a;
            }
            if (depth) {
                py::array_t<float> a({h, w});
                view.depth = a.mutable_data();
                out["depth"] = a;
            }
            if (instance) {
                py::array_t<uint8_t> a({h, w});
                view.instance = a.mutable_data();
                out["instance"] = a;
            }
            RenderStats stats;
            {
                // The buffers are owned by `out`, which outlives this block; the scene guards
                // itself against modification while the render runs.
                py::gil_scoped_release release;
                stats = sun ? render(scene, camera, Lights{*sun, earth}, settings, view, medium, light_cache)
                            : render_geometry(scene, camera, settings, view);
            }
            out["camera_rays"] = stats.camera_rays;
            out["second_look_rays"] = stats.second_look_rays;
            out["shadow_rays"] = stats.shadow_rays;
            out["bounce_shadow_rays"] = stats.bounce_shadow_rays;
            out["bounce_rays"] = stats.bounce_rays;
            out["medium_rays"] = stats.medium_rays;
            out["refined_pixels"] = stats.refined_pixels;
            out["refinement_rays"] = stats.refinement_rays;
            out["seconds"] = stats.seconds;
            return out;
        },
        py::arg("scene"), py::arg("camera"), py::arg("sun"), py::arg("settings") = RenderSettings{},
        py::arg("passes") = std::vector<std::string>{"rgb", "depth", "instance"}, py::arg("earth") = py::none(),
        py::arg("medium") = nullptr, py::arg("light_cache") = nullptr,
        "Render one view with `settings` (a RenderSettings). Returns a dict with the requested passes: rgb "
        "(H, W, 3) float32 W/(m^2 sr), depth (H, W) float32 z-depth in metres (0 = no hit), instance (H, W) "
        "uint8 (0 = background); and the counts camera_rays, second_look_rays (camera rays traced again where "
        "one may have slipped through a shared vertex), shadow_rays (bounce_shadow_rays of them from bounce "
        "vertices), bounce_rays, medium_rays (the dust's shadow rays toward the Sun), refined_pixels and "
        "refinement_rays (adaptive anti-aliasing's pixels and their extra rays), and seconds. sun: the Sun (a "
        "DirectionalLight), or None for the depth and instance passes alone (nothing is lit, no shadow ray "
        "traced); earth: a second light (Earthshine); medium: dust (a Medium) attenuating and scattering "
        "sunlight in rgb only; light_cache: a LightCache built for this scene, these lights and "
        "settings.bounces, from which camera hits on the surfaces it covers take their indirect light (no "
        "bounce rays).");
}

}  // namespace moonbot::bindings
