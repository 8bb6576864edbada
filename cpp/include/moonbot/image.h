// Display transform and image files. Tone mapping is Reinhard (2002) on luminance followed by the
// sRGB transfer curve; files are written through OpenImageIO, atomically (temporary + rename).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace moonbot {

/// A file could not be written or read; the message names the path. Maps to Python's OSError.
class IoError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Maps linear radiance to 8-bit sRGB: v = exposure · rgb (exposure in sr·m²/W, so v is
/// dimensionless), luminance Y = 0.2126 r + 0.7152 g + 0.0722 b (Rec. 709), Y' = Y / (1 + Y),
/// rgb' = v · Y'/Y clamped to [0, 1], sRGB-encoded and rounded. Non-finite or negative input
/// becomes 0, so NaN/Inf never reach an image. `rgb`: n_pixels×3 float32; `out`: n_pixels×3.
void tonemap_reinhard_srgb8(const float* rgb, size_t n_pixels, double exposure, uint8_t* out);

/// Sample type of an image buffer.
enum class PixelType { U8, U16, F32 };

/// Writes a width×height×channels row-major buffer. The format follows the extension:
/// .png (U8 or U16; `png_compression` 0–9, 1 is ~2.5× faster than the default 6 for ~20 % more
/// bytes), .exr (F32, zip), .tif. Writes `<dir>/.<name>.<pid>.tmp<ext>` and renames it over the
/// target, so a reader never sees a partial file. Throws IoError naming the path on failure.
void write_image(const std::string& path, const void* pixels, int width, int height,
                 int channels, PixelType type, int png_compression = 1);

/// A decoded image: row-major width×height×channels samples of `type`, as stored in the file.
struct Image {
    int width = 0, height = 0, channels = 0;
    PixelType type = PixelType::U8;
    std::vector<uint8_t> bytes;
};

/// Reads an image through OpenImageIO in its stored sample type (8-bit → U8, 16-bit → U16,
/// anything else → F32). Throws IoError naming the path if it cannot be opened or decoded.
Image read_image(const std::string& path);

}  // namespace moonbot
