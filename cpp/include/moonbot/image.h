// Display transform and image files. Tone mapping is Reinhard (2002) on luminance followed by the
// sRGB transfer curve; files are written through OpenImageIO, atomically (temporary + rename).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "moonbot/io_error.h"

namespace moonbot {

/// Maps linear radiance to 8-bit sRGB. `exposure` (sr·m²/W) scales radiance to the dimensionless
/// signal Reinhard compresses: moonbot passes K_v / L_sat(EV100) (moonbot/render/exposure.py), so
/// v = 1 is the luminance that saturates an ISO 100 sensor at that EV100. Per pixel:
/// v = exposure · rgb, Y = 0.2126 r + 0.7152 g + 0.0722 b (Rec. 709 luminance of linear sRGB),
/// Y' = Y / (1 + Y) (Reinhard et al. 2002, eq. 3), rgb' = v · Y'/Y clamped to [0, 1], then the
/// sRGB transfer curve, rounded to the nearest 8-bit code (exactly, not by a lookup table).
/// `rgb`: n_pixels×3 float32; `out`: n_pixels×3 uint8.
///
/// Invalid samples never reach an image and never make it non-finite: NaN, -Inf and negative
/// channels count as 0 (black); +Inf, and any v that overflows or exceeds 1e30, counts as 1e30
/// (the brightest value, so the curve stays monotone up to the largest float); subnormal inputs
/// (< 1.2e-38) count as 0 whatever the thread's denormal mode. Returns the number of pixels with
/// at least one NaN, ±Inf or negative channel in `rgb` (-0.0 is not counted).
///
/// `veiling_glare_index` > 0 first adds the lens's uniform veil (veiling_glare()) to every sound
/// pixel's radiance (all three channels finite and ≥ 0; the others are left as they are, and
/// counted). Throws std::invalid_argument unless exposure is positive and finite and
/// veiling_glare_index finite and ≥ 0 (the message names it `veiling_glare`, as Python does).
size_t tonemap_reinhard_srgb8(const float* rgb, size_t n_pixels, double exposure, uint8_t* out,
                              double veiling_glare_index = 0.0);

/// The uniform veil (W/(m²·sr) per channel) a lens of veiling glare index `glare_index` (ISO 9358:
/// the light a black spot in a bright field receives, as a fraction of the field's) lays over a
/// frame: glare_index × each channel's mean over the sound pixels of `rgb` (n_pixels×3 float32;
/// sound: all three channels finite and ≥ 0, told by the bit pattern as the tone map tells them;
/// subnormals count as 0), the sums in double in pixel order, so the same on any thread; 0 where
/// no pixel is sound. Throws std::invalid_argument unless glare_index is finite and ≥ 0.
std::array<float, 3> veiling_glare(const float* rgb, size_t n_pixels, double glare_index);

/// A header attribute written with an image: a name and a string or float value. EXR keeps every
/// one of them in its header; PNG keeps what it has a field for and drops the rest.
struct ImageAttribute {
    std::string name;
    std::variant<std::string, float> value;
};

/// Sample type of an image buffer.
enum class PixelType { U8, U16, F32 };

/// Writes a width×height×channels row-major buffer. The format follows the extension:
/// .png (U8 or U16; `png_compression` 0–9, 1 is ~2.5× faster than the default 6 for ~20 % more
/// bytes), .exr (F32, zip at the same deflate level), .tif. `attributes` go into the header (names must be non-empty).
/// Writes `<dir>/.<name>.<pid>.tmp<ext>` and renames it over the target, so a reader never sees a
/// partial file. Throws IoError naming the path on failure.
void write_image(const std::string& path, const void* pixels, int width, int height, int channels, PixelType type,
                 int png_compression = 1, const std::vector<ImageAttribute>& attributes = {});

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
