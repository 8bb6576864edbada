#include <string>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/light_cache.h"
#include "moonbot/render.h"

namespace moonbot::bindings {

void bind_render(py::module_& m) {
    m.def(
        "render",
        [](const Scene& scene, const Camera& camera, const std::optional<DirectionalLight>& sun, int spp, uint64_t seed,
           int threads, const std::vector<std::string>& passes, bool exact_depth, int light_samples,
           int bounces, const std::optional<DirectionalLight>& earth, const Medium* medium,
           const LightCache* light_cache,
           int adaptive_spp, double adaptive_threshold) {
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
                const RenderSettings settings{spp,           seed,    threads,      exact_depth,
                                              light_samples, bounces, adaptive_spp, adaptive_threshold};
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
        // The settings' defaults are RenderSettings' (moonbot/render.h).
        py::arg("scene"), py::arg("camera"), py::arg("sun"), py::arg("spp") = RenderSettings{}.spp,
        py::arg("seed") = RenderSettings{}.seed, py::arg("threads") = RenderSettings{}.threads,
        py::arg("passes") = std::vector<std::string>{"rgb", "depth", "instance"},
        py::arg("exact_depth") = RenderSettings{}.exact_depth, py::arg("light_samples") = RenderSettings{}.light_samples,
        py::arg("bounces") = RenderSettings{}.bounces, py::arg("earth") = py::none(), py::arg("medium") = nullptr,
        py::arg("light_cache") = nullptr, py::arg("adaptive_spp") = RenderSettings{}.adaptive_spp,
        py::arg("adaptive_threshold") = RenderSettings{}.adaptive_threshold,
        "Render one view. Returns a dict with the requested passes — rgb (H, W, 3) float32 "
        "W/(m²·sr), depth (H, W) float32 z-depth in metres (0 = no hit), instance (H, W) uint8 "
        "(0 = background) — and camera_rays, second_look_rays (camera rays traced again where one may have "
        "slipped through a shared vertex), shadow_rays (bounce_shadow_rays of them from bounce vertices), "
        "bounce_rays, medium_rays, seconds. sun: the Sun (a DirectionalLight), or None for the depth and "
        "instance passes alone (nothing is lit, no shadow ray traced). exact_depth "
        "re-solves hit distances in double (exact at kilometre coordinates); False keeps Embree's "
        "float32 t. light_samples: shadow rays per sample toward each light's disk; bounces: "
        "diffuse inter-reflections (0 = direct light only); earth: a second light (Earthshine); "
        "medium: dust (a Medium) attenuating and scattering sunlight in rgb only (medium_rays: its "
        "shadow rays toward the Sun); light_cache: a LightCache built for this scene, these lights and "
        "bounces, from which camera hits on the surfaces it covers take their indirect light (no bounce rays); "
        "adaptive_spp: 0 = off, else the samples (direct light only past spp) "
        "a pixel whose spp base samples (or a neighbour's) disagree in hit instance, Sun visibility or direct luminance "
        "(relative spread > adaptive_threshold) is brought up to (refined_pixels: how many; refinement_rays: "
        "their extra camera, second-look and shadow rays).");
}

}  // namespace moonbot::bindings
