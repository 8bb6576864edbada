#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "arrays.h"
#include "moonbot/image.h"

namespace moonbot::bindings {

namespace {
// The largest image side accepted at the boundary, as the camera accepts (fits int with room).
constexpr py::ssize_t kMaxImageSide = 32768;
}  // namespace

void bind_image(py::module_& m) {
    m.def(
        "tonemap_reinhard",
        [](const py::handle& rgb, double exposure, double veiling_glare) {
            py::array a = as_array(rgb, "rgb");
            if (a.dtype().kind() != 'f') fail("rgb", "must be a floating-point array");
            if (a.ndim() != 3 || a.shape(2) != 3) fail("rgb", "must have shape (H, W, 3), got " + shape_of(a));
            if (a.shape(0) > kMaxImageSide || a.shape(1) > kMaxImageSide)
                fail("rgb", "sides must be at most " + std::to_string(kMaxImageSide));
            auto in = converted<float>(a, "rgb");
            py::array_t<uint8_t> out({a.shape(0), a.shape(1), py::ssize_t(3)});
            const size_t n = static_cast<size_t>(a.shape(0) * a.shape(1));
            const float* src = in.data();
            uint8_t* dst = out.mutable_data();
            size_t invalid = 0;
            {
                py::gil_scoped_release release;
                invalid = tonemap_reinhard_srgb8(src, n, exposure, dst, veiling_glare);
            }
            return py::make_tuple(out, invalid);
        },
        py::arg("rgb"), py::arg("exposure"), py::arg("veiling_glare") = 0.0,
        "Linear radiance (H, W, 3) × exposure (sr·m²/W) → Reinhard on luminance → 8-bit sRGB. "
        "Returns ((H, W, 3) uint8, number of pixels with a NaN, ±Inf or negative channel). NaN, "
        "-Inf and negatives count as 0; +Inf and overflow as the brightest value (1e30). "
        "veiling_glare > 0 (ISO 9358's index, a fraction) first adds the lens's uniform veil, that "
        "fraction of each channel's mean over the pixels whose channels are all finite and >= 0, to "
        "those pixels.");

    m.def(
        "write_image",
        [](const std::string& path, const py::handle& pixels, int png_compression, const py::dict& attributes) {
            py::array a = as_array(pixels, "pixels");
            if (a.ndim() != 2 && a.ndim() != 3)
                fail("pixels", "must have shape (H, W) or (H, W, C), got " + shape_of(a));
            if (a.shape(0) < 1 || a.shape(1) < 1) fail("pixels", "must not be empty");
            if (a.shape(0) > kMaxImageSide || a.shape(1) > kMaxImageSide)
                fail("pixels", "sides must be at most " + std::to_string(kMaxImageSide));
            if (a.ndim() == 3 && (a.shape(2) < 1 || a.shape(2) > 4)) fail("pixels", "must have 1 to 4 channels");
            const int channels = a.ndim() == 3 ? static_cast<int>(a.shape(2)) : 1;
            // By kind and size, not identity: an equal dtype from a pickle is a different object.
            const char kind = a.dtype().kind();
            const auto size = a.dtype().itemsize();
            PixelType type;
            py::array c;
            if (kind == 'u' && size == 1) {
                type = PixelType::U8;
                c = converted<uint8_t>(a, "pixels");
            } else if (kind == 'u' && size == 2) {
                type = PixelType::U16;
                c = converted<uint16_t>(a, "pixels");
            } else if (kind == 'f' && size == 4) {
                type = PixelType::F32;
                c = converted<float>(a, "pixels");
            } else {
                fail("pixels", "dtype must be uint8, uint16 or float32, got " + std::string(py::str(a.dtype())));
            }
            std::vector<ImageAttribute> attrs;
            for (const auto& [key, value] : attributes) {
                if (!py::isinstance<py::str>(key) || py::len(key) == 0)
                    fail("attributes", "names must be non-empty strings");
                const auto name = key.cast<std::string>();
                if (py::isinstance<py::str>(value)) {
                    attrs.push_back({name, value.cast<std::string>()});
                } else if (py::isinstance<py::float_>(value) ||
                           (py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value))) {
                    const double v = value.cast<double>();
                    if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max())
                        fail("attributes", name + " must be a finite float32, got " + std::string(py::repr(value)));
                    attrs.push_back({name, static_cast<float>(v)});
                } else {
                    fail("attributes", name + " must be a string or a number, got " + std::string(py::repr(value)));
                }
            }
            const std::string& target = checked_path(path);
            const void* data = c.data();
            const int h = static_cast<int>(a.shape(0)), w = static_cast<int>(a.shape(1));
            py::gil_scoped_release release;  // `c` keeps the buffer alive; encoding is long
            write_image(target, data, w, h, channels, type, png_compression, attrs);
        },
        py::arg("path"), py::arg("pixels"), py::arg("png_compression") = 1, py::arg("attributes") = py::dict(),
        "Write an image through OpenImageIO, atomically. Format from the extension: .png "
        "(uint8/uint16), .exr (float32), .tif/.tiff. `attributes` ({name: str or float}) go into "
        "the header (EXR keeps all). Raises OSError naming the path on failure.");

    m.def(
        "read_image",
        [](const std::string& path) {
            const std::string& source = checked_path(path);
            Image image;
            {
                py::gil_scoped_release release;
                image = read_image(source);
            }
            std::vector<py::ssize_t> shape = {image.height, image.width};
            if (image.channels > 1) shape.push_back(image.channels);
            py::dtype dtype = image.type == PixelType::U8    ? py::dtype::of<uint8_t>()
                              : image.type == PixelType::U16 ? py::dtype::of<uint16_t>()
                                                             : py::dtype::of<float>();
            py::array out(dtype, shape);
            std::memcpy(out.mutable_data(), image.bytes.data(), image.bytes.size());
            return out;
        },
        py::arg("path"),
        "Read an image through OpenImageIO: (H, W) or (H, W, C), uint8 / uint16 as stored, "
        "float32 otherwise. Raises OSError naming the path.");
}

}  // namespace moonbot::bindings
