// moonbot._core: the C++ core for Python. Each bind_*.cpp binds one header; this file wires them
// and maps the core's exceptions: std::invalid_argument → ValueError (pybind11's default),
// IoError → OSError.
#include <pybind11/pybind11.h>

#include "moonbot/image.h"

namespace py = pybind11;

namespace moonbot::bindings {
void bind_scene(py::module_& m);
void bind_render(py::module_& m);
void bind_image(py::module_& m);
void bind_geo(py::module_& m);
void bind_dem(py::module_& m);
void bind_limit(py::module_& m);
void bind_material(py::module_& m);
void bind_dust(py::module_& m);
void bind_light_cache(py::module_& m);
}  // namespace moonbot::bindings

PYBIND11_MODULE(_core, m) {
    m.doc() =
        "moonbot's C++ core: Embree scene, camera, lights, renderer, image I/O, lunar frames, DEM import, bag "
        "fabric and stain, dust.";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const moonbot::IoError& e) {
            PyErr_SetString(PyExc_OSError, e.what());
        }
    });
    moonbot::bindings::bind_scene(m);
    moonbot::bindings::bind_dust(m);  // before render, which takes its Medium
    moonbot::bindings::bind_light_cache(m);  // before render, which takes it
    moonbot::bindings::bind_render(m);
    moonbot::bindings::bind_image(m);
    moonbot::bindings::bind_geo(m);
    moonbot::bindings::bind_dem(m);
    moonbot::bindings::bind_limit(m);
    moonbot::bindings::bind_material(m);
}
