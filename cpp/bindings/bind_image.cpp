#include <cstring>
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
        [](const py::handle& rgb, double exposure) {
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
            {
                py::gil_scoped_release release;
                tonemap_reinhard_srgb8(src, n, exposure, dst);
            }
            return out;
        },
        py::arg("rgb"), py::arg("exposure"),
        "Linear radiance (H, W, 3) × exposure (sr·m²/W) → Reinhard on luminance → 8-bit sRGB "
        "(H, W, 3) uint8. NaN, Inf and negatives become 0.");

    m.def(
        "write_image",
        [](const std::string& path, const py::handle& pixels, int png_compression) {
            py::array a = as_array(pixels, "pixels");
            if (a.ndim() != 2 && a.ndim() != 3) fail("pixels", "must have shape (H, W) or (H, W, C), got " + shape_of(a));
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
            const std::string& target = checked_path(path);
            const void* data = c.data();
            const int h = static_cast<int>(a.shape(0)), w = static_cast<int>(a.shape(1));
            py::gil_scoped_release release;  // `c` keeps the buffer alive; encoding is long
            write_image(target, data, w, h, channels, type, png_compression);
        },
        py::arg("path"), py::arg("pixels"), py::arg("png_compression") = 1,
        "Write an image through OpenImageIO, atomically. Format from the extension: .png "
        "(uint8/uint16), .exr (float32), .tif/.tiff. Raises OSError naming the path on failure.");

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
