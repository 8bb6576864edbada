// The bag's appearance: the woven fabric (fabric.h) and the dirt stain (stain.h).
#include <cmath>
#include <initializer_list>
#include <memory>
#include <string>

#include "arrays.h"
#include "moonbot/fabric.h"
#include "moonbot/stain.h"

namespace moonbot::bindings {

namespace {

/// An array of `shape` (−1 = any length) as C-contiguous float64; float input only.
py::array_t<double, py::array::c_style> doubles(const py::handle& obj, const std::string& name,
                                                std::initializer_list<py::ssize_t> shape) {
    py::array a = as_array(obj, name);
    if (a.dtype().kind() != 'f')
        fail(name, "must be a floating-point array, got dtype " + std::string(py::str(a.dtype())));
    bool ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
    py::ssize_t axis = 0;
    for (py::ssize_t n : shape) {
        if (ok && n >= 0 && a.shape(axis) != n) ok = false;
        ++axis;
    }
    if (!ok) {
        std::string want = "(";
        axis = 0;
        for (py::ssize_t n : shape) want += (axis++ ? ", " : "") + (n < 0 ? std::string("N") : std::to_string(n));
        fail(name, "must have shape " + want + (shape.size() == 1 ? ",)" : ")") + ", got " + shape_of(a));
    }
    return converted<double>(a, name);
}

}  // namespace

void bind_material(py::module_& m) {
    m.def(
        "fabric_eval",
        [](const py::object& xy, const py::object& footprint, const FabricParams& p) {
            p.validate();
            const auto pts = doubles(xy, "xy", {-1, 2});
            const auto fp = doubles(footprint, "footprint", {-1});
            const py::ssize_t n = pts.shape(0);
            if (fp.shape(0) != n) fail("footprint", "must have one value per point (" + std::to_string(n) + ")");
            for (py::ssize_t i = 0; i < n; ++i)
                if (!(fp.data()[i] >= 0) || !std::isfinite(fp.data()[i])) fail("footprint", "must be finite and >= 0");
            py::array_t<double> out_albedo({n, py::ssize_t{3}}), out_normal({n, py::ssize_t{3}});
            {
                py::gil_scoped_release release;  // only raw buffers below
                const double* in = pts.data();
                double* a = out_albedo.mutable_data();
                double* nn = out_normal.mutable_data();
                for (py::ssize_t i = 0; i < n; ++i) {
                    const FabricSample s = fabric_eval(p, in[2 * i], in[2 * i + 1], fp.data()[i]);
                    for (int c = 0; c < 3; ++c) {
                        a[3 * i + c] = s.albedo[c];
                        nn[3 * i + c] = s.normal[c];
                    }
                }
            }
            return py::make_tuple(out_albedo, out_normal);
        },
        py::arg("xy"), py::arg("footprint"), py::arg("params") = FabricParams{},
        "The woven fabric `params` (its pitch, relief, contrast and albedo; sheen plays no part) at points xy (N, 2) "
        "float64, metres of fabric (x along the warp = tangent, "
        "y along the weft = bitangent), prefiltered over footprint (N,) metres (Gaussian, "
        "sigma = footprint/2). Returns (albedo (N, 3) linear RGB, normal (N, 3) unit vectors in "
        "the (tangent, bitangent, normal) frame), float64.");
    m.def("weave_height", &weave_height, py::arg("a"), py::arg("b"),
          "The unfiltered weave height in [0, 1] at a = pi*x/pitch, b = pi*y/pitch.");

    py::class_<StainMask>(m, "StainMask", py::buffer_protocol(),
                          "A bag's dirt mask: R x R float32 in [0, 1], row j = v, column i = u "
                          "(np.asarray gives a read-only view that keeps it alive).")
        .def_buffer([](StainMask& s) {
            const auto n = static_cast<py::ssize_t>(s.resolution());
            return py::buffer_info(
                s.data(), static_cast<py::ssize_t>(sizeof(float)), py::format_descriptor<float>::format(), 2, {n, n},
                {n * static_cast<py::ssize_t>(sizeof(float)), static_cast<py::ssize_t>(sizeof(float))}, true);
        })
        .def_property_readonly("resolution", &StainMask::resolution, "texels a side")
        .def(
            "sample",
            [](const StainMask& s, const py::object& uv) {
                const auto in = doubles(uv, "uv", {-1, 2});
                const py::ssize_t n = in.shape(0);
                for (py::ssize_t i = 0; i < 2 * n; ++i)
                    if (!std::isfinite(in.data()[i])) fail("uv", "must be finite");
                py::array_t<float> out(n);
                float* o = out.mutable_data();
                for (py::ssize_t i = 0; i < n; ++i) o[i] = s.sample(in.data()[2 * i], in.data()[2 * i + 1]);
                return out;
            },
            py::arg("uv"),
            "Bilinear mask values (N,) float32 at uv (N, 2): u wraps, v clamps to the outermost texel centres.");

    m.def(
        "stain_mask",
        [](uint64_t seed, const StainParams& p, int threads) {
            p.validate();
            std::unique_ptr<StainMask> mask;
            {
                py::gil_scoped_release release;
                mask = paint_stain(p, seed, threads);
            }
            return mask;  // None when stamps == 0
        },
        py::arg("seed"), py::arg("params"), py::arg("threads") = 0,
        "Paints a bag's dirt mask (paper 3.4) from params.stamps splats (a StainParams) at centres keyed "
        "by `seed`: a StainMask, or None when stamps == 0 (nothing allocated). The mask does not "
        "depend on `threads`.");
    m.def(
        "stamp_centres",
        [](uint64_t seed, int stamps) {
            if (stamps < 0) fail("stamps", "must be >= 0");
            py::array_t<double> out({static_cast<py::ssize_t>(stamps), py::ssize_t{2}});
            double* o = out.mutable_data();
            for (int k = 0; k < stamps; ++k) {
                const glm::dvec2 c = stamp_centre(seed, static_cast<uint32_t>(k));
                o[2 * k] = c.x;
                o[2 * k + 1] = c.y;
            }
            return out;
        },
        py::arg("seed"), py::arg("stamps"), "The stamp centres (stamps, 2) float64 in [0, 1)^2 (u, v).");
    m.def(
        "splat",
        [](const py::object& local) {
            const auto in = doubles(local, "local", {-1, 2});
            py::array_t<double> out(in.shape(0));
            for (py::ssize_t i = 0; i < in.shape(0); ++i)
                out.mutable_data()[i] = splat(in.data()[2 * i], in.data()[2 * i + 1]);
            return out;
        },
        py::arg("local"), "The splat shape B (N,) at local coordinates (N, 2), clamped to [0, 1]^2.");
    m.def("splat_support_area", &splat_support_area, "Area of {B > 0} in the unit local square.");
    m.def(
        "stained_base_colour",
        [](const py::object& clean, const py::object& mask, const py::object& dirt) {
            const auto c = doubles(clean, "clean", {-1, 3});
            const auto mv = doubles(mask, "mask", {-1});
            if (mv.shape(0) != c.shape(0))
                fail("mask", "must have one value per colour (" + std::to_string(c.shape(0)) + ")");
            const glm::dvec3 d = vector<3>(dirt, "dirt");
            py::array_t<double> out({c.shape(0), py::ssize_t{3}});
            double* o = out.mutable_data();
            for (py::ssize_t i = 0; i < c.shape(0); ++i) {
                const glm::dvec3 r =
                    stained_base_colour({c.data()[3 * i], c.data()[3 * i + 1], c.data()[3 * i + 2]}, mv.data()[i], d);
                for (int k = 0; k < 3; ++k) o[3 * i + k] = r[k];
            }
            return out;
        },
        py::arg("clean"), py::arg("mask"), py::arg("dirt"),
        "The paper's base colour lerp(clean, m*dirt, m), m clamped to [0, 1]: clean (N, 3) and "
        "dirt (3,) linear RGB, mask (N,). Returns (N, 3) float64.");
    m.def("stain_mask_bytes", &stain_mask_bytes, "Bytes of stain masks alive now, process-wide.");
    m.def("stain_masks_allocated", &stain_masks_allocated, "Stain masks ever allocated in this process.");
}

}  // namespace moonbot::bindings
