#include "arrays.h"
#include "moonbot/limit.h"

namespace moonbot::bindings {

void bind_limit(py::module_& m) {
    m.def(
        "measure_embree_limit",
        [](const Scene& scene, const Camera& camera, const DirectionalLight& sun, int threads, int repeats,
           int bounces) {
            EmbreeLimit l;
            {
                py::gil_scoped_release release;
                l = measure_embree_limit(scene, camera, sun, threads, repeats, bounces);
            }
            auto list = [](const auto& values) {
                py::list items;
                for (const auto& v : values) items.append(v);
                return items;
            };
            py::dict out;
            out["camera_rays"] = l.camera_rays;
            out["shadow_rays"] = l.shadow_rays;
            out["intersect_single_s"] = l.intersect_single_s;
            out["intersect_packet8_s"] = l.intersect_packet8_s;
            out["intersect_packet16_s"] = l.intersect_packet16_s;
            out["intersect_stream_s"] = l.intersect_stream_s;
            out["occluded_single_s"] = l.occluded_single_s;
            out["occluded_packet8_s"] = l.occluded_packet8_s;
            out["occluded_packet16_s"] = l.occluded_packet16_s;
            out["occluded_stream_s"] = l.occluded_stream_s;
            out["intersect_stream_from_memory_s"] = l.intersect_stream_from_memory_s;
            out["occluded_stream_from_memory_s"] = l.occluded_stream_from_memory_s;
            out["bounce_rays"] = list(l.bounce_rays);
            out["bounce_stream_s"] = list(l.bounce_stream_s);
            out["bounce_single_s"] = list(l.bounce_single_s);
            out["bounce_shadow_rays"] = list(l.bounce_shadow_rays);
            out["bounce_shadow_stream_s"] = list(l.bounce_shadow_stream_s);
            out["timer_overhead_s"] = l.timer_overhead_s;
            out["threads"] = l.threads;
            return out;
        },
        py::arg("scene"), py::arg("camera"), py::arg("sun"), py::arg("threads") = 0, py::arg("repeats") = 5,
        py::arg("bounces") = 0,
        "Median seconds Embree alone takes for the rays of one spp=1 render (pixel-centre camera "
        "rays, Sun shadow rays from their hits, `bounces` generations of diffuse bounce rays and the Sun shadow "
        "rays from their hits, as lists per generation): one ray at a time, as 8- and 16-ray packets and "
        "as the renderer's 64-ray streams, each tile traced from a cached copy and timed alone "
        "(the busiest thread's sum); the streams also traced in place from memory, wall-clock.");
}

}  // namespace moonbot::bindings
