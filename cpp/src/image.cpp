#include "moonbot/image.h"

#include <OpenImageIO/imageio.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <thread>

#include <unistd.h>

namespace moonbot {

namespace {

// 8-bit sRGB encoding without a pow per channel: code k is the number of code boundaries at or
// below the value, where boundary k is the linear value whose sRGB encoding is (k + 0.5)/255,
// computed once in double. A 4096-bin index gives the code at each bin's lower edge, and at most
// a step or two finishes the search, so the result is exact rounding of the sRGB curve.
class SrgbEncoder {
public:
    SrgbEncoder() {
        for (int k = 0; k < 255; ++k) {
            const double y = (k + 0.5) / 255.0;
            const double linear = y <= 0.04045 ? y / 12.92 : std::pow((y + 0.055) / 1.055, 2.4);
            m_boundary[k] = static_cast<float>(linear);
        }
        m_boundary[255] = std::numeric_limits<float>::infinity();
        int code = 0;
        for (int b = 0; b <= kBins; ++b) {
            const float edge = static_cast<float>(b) / kBins;
            while (edge >= m_boundary[code]) ++code;
            m_start[b] = static_cast<uint8_t>(code);
        }
    }

    /// `linear` in [0, 1] → 8-bit sRGB code.
    uint8_t encode(float linear) const {
        int code = m_start[static_cast<int>(linear * kBins)];
        while (linear >= m_boundary[code]) ++code;
        return static_cast<uint8_t>(code);
    }

private:
    static constexpr int kBins = 4096;
    float m_boundary[256];
    uint8_t m_start[kBins + 1];
};

/// Only the formats moonbot writes are opened: OIIO's rarer plugins abort the process on some
/// inputs (DPX with two channels asserts; a malformed ICO double-frees).
void require_supported_format(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".png" && ext != ".exr" && ext != ".tif" && ext != ".tiff")
        throw IoError(path + ": unsupported image format (use .png, .exr, .tif or .tiff)");
}

/// One radiance sample as the tone map uses it: NaN, -Inf, negatives and subnormals → 0, +Inf
/// stays +Inf (saturated later). `invalid` is set for NaN, ±Inf and negatives other than -0.0.
/// Decided on the bit pattern, not by float comparisons: those depend on the calling thread's
/// denormals-are-zero mode, which Embree leaves set on the TBB worker threads it has run on
/// (seen in the test suite: a negative subnormal compared >= 0 after a BVH build), and neither
/// the count nor the bytes may.
inline float sanitized_sample(float in, bool& invalid) {
    uint32_t bits;
    std::memcpy(&bits, &in, sizeof bits);
    const uint32_t magnitude = bits & 0x7fffffffu;
    const bool negative = (bits >> 31) != 0;
    if (magnitude >= 0x7f800000u) {  // all-ones exponent: Inf or NaN
        invalid = true;
        return magnitude == 0x7f800000u && !negative ? in : 0.0f;
    }
    if (negative) {
        invalid |= magnitude != 0;
        return 0.0f;
    }
    return magnitude < 0x00800000u ? 0.0f : in;  // subnormal (< 1.2e-38): far below code 1
}

/// The three samples of the pixel at `p` through sanitized_sample, into `out`; whether any is
/// invalid (the pixel is sound, finite and ≥ 0 in every channel, when none is).
inline bool sanitized_pixel(const float* p, float out[3]) {
    bool invalid = false;
    for (int c = 0; c < 3; ++c) out[c] = sanitized_sample(p[c], invalid);
    return invalid;
}

// Decoded images larger than this are refused before allocating: a corrupt header must not
// ask for gigabytes.
constexpr int kMaxReadSide = 32768;

}  // namespace

std::array<float, 3> veiling_glare(const float* rgb, size_t n_pixels, double glare_index) {
    if (!(std::isfinite(glare_index) && glare_index >= 0.0))
        throw std::invalid_argument("veiling_glare: must be a finite number >= 0");
    double sum[3] = {0.0, 0.0, 0.0};
    size_t sound = 0;
    for (size_t i = 0; i < n_pixels; ++i) {
        float p[3];
        if (sanitized_pixel(rgb + 3 * i, p)) continue;
        for (int c = 0; c < 3; ++c) sum[c] += static_cast<double>(p[c]);
        ++sound;
    }
    std::array<float, 3> veil{0.0f, 0.0f, 0.0f};
    if (sound == 0) return veil;
    for (int c = 0; c < 3; ++c) veil[c] = static_cast<float>(glare_index * (sum[c] / static_cast<double>(sound)));
    return veil;
}

size_t tonemap_reinhard_srgb8(const float* rgb, size_t n_pixels, double exposure, uint8_t* out,
                              double veiling_glare_index) {
    if (!(std::isfinite(exposure) && exposure > 0.0))
        throw std::invalid_argument("exposure: must be positive and finite (sr·m²/W)");
    // The index is checked whatever its value; at 0 no pixel is summed.
    const std::array<float, 3> veil = veiling_glare(rgb, veiling_glare_index > 0.0 ? n_pixels : 0, veiling_glare_index);
    const bool veiled = veil[0] > 0.0f || veil[1] > 0.0f || veil[2] > 0.0f;
    static const SrgbEncoder srgb;  // built once, thread-safe (C++11 static initialisation)
    // The brightest signal: +Inf and overflow saturate here rather than turning black, and the
    // luminance sum of three such channels (≤ 1e30) stays far from FLT_MAX, so 1/(1+Y) is a
    // normal float and Y'/Y stays finite.
    constexpr float kBrightest = 1e30f;
    // An exposure above FLT_MAX would round to +Inf in float, and 0 · Inf is NaN.
    const auto e = static_cast<float>(std::min(exposure, double(std::numeric_limits<float>::max())));
    std::atomic<size_t> invalid{0};
    // Each pixel is independent, so splitting the work cannot change a byte (nor the count).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n_pixels, 4096), [&](const auto& range) {
        size_t bad_pixels = 0;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            float v[3];
            bool bad = sanitized_pixel(rgb + 3 * i, v);
            // The veil lifts sound pixels only; a lifted sample that overflows counts as invalid.
            if (veiled && !bad)
                for (int c = 0; c < 3; ++c) v[c] = sanitized_sample(v[c] + veil[c], bad);
            for (int c = 0; c < 3; ++c) {
                // ≥ 0 or +Inf, times a positive finite float exposure: ≥ 0 or +Inf, never NaN;
                // the comparison would send a NaN to 0 all the same.
                const float x = v[c] * e;
                v[c] = x > 0.0f ? std::min(x, kBrightest) : 0.0f;
            }
            bad_pixels += bad;
            const float y = 0.2126f * v[0] + 0.7152f * v[1] + 0.0722f * v[2];
            // Y/(1+Y) divided by Y; the ratio form keeps the limit Y→0 exact (factor → 1).
            const float scale = 1.0f / (1.0f + y);
            for (int c = 0; c < 3; ++c) {
                out[3 * i + c] = srgb.encode(std::min(1.0f, v[c] * scale));
            }
        }
        invalid.fetch_add(bad_pixels, std::memory_order_relaxed);
    });
    return invalid.load();
}

void write_image(const std::string& path, const void* pixels, int width, int height, int channels, PixelType type,
                 int png_compression, const std::vector<ImageAttribute>& attributes) {
    namespace fs = std::filesystem;
    if (width < 1 || height < 1 || channels < 1 || channels > 4)
        throw std::invalid_argument("image: bad shape for " + path);
    if (png_compression < 0 || png_compression > 9) throw std::invalid_argument("png_compression: must be in 0..9");
    for (const auto& a : attributes)
        if (a.name.empty()) throw std::invalid_argument("attributes: names must not be empty");
    require_supported_format(path);
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw IoError(path + ": directory does not exist");
    // OIIO picks the format from the extension, so the temporary keeps it; process and thread in
    // its name keep concurrent writers (threads of one worker, several workers) apart.
    const size_t thread = std::hash<std::thread::id>{}(std::this_thread::get_id());
    const fs::path tmp = dir / ("." + target.stem().string() + "." + std::to_string(::getpid()) + "-" +
                                std::to_string(thread % 1000000007u) + ".tmp" + target.extension().string());

    OIIO::TypeDesc format = type == PixelType::U8    ? OIIO::TypeDesc::UINT8
                            : type == PixelType::U16 ? OIIO::TypeDesc::UINT16
                                                     : OIIO::TypeDesc::FLOAT;
    auto output = OIIO::ImageOutput::create(tmp.string());
    if (!output) throw IoError(path + ": no image writer for this extension (" + OIIO::geterror() + ")");
    OIIO::ImageSpec spec(width, height, channels, format);
    spec.attribute("png:compressionLevel", png_compression);
    // Our buffers hold straight (unassociated) values; without this OIIO would un-premultiply a
    // fourth channel on its way into a PNG and change the colour channels.
    spec.attribute("oiio:UnassociatedAlpha", 1);
    // EXR zip is deflate like PNG's, so it takes the same level: 1 writes a 640×480 float32 render
    // in half the time of OIIO's default (4) for 7 % more bytes (bench/bench_tonemap_exr.py).
    if (target.extension() == ".exr") spec.attribute("compression", "zip:" + std::to_string(png_compression));
    spec.attribute("oiio:ColorSpace", type == PixelType::F32 ? "Linear" : "sRGB");
    // OIIO stamps an EXR with the time of writing (capDate) unless DateTime is set: an empty one
    // keeps the same pixels the same bytes (a caller's own DateTime still wins).
    spec.attribute("DateTime", "");
    for (const auto& a : attributes) {
        if (const auto* text = std::get_if<std::string>(&a.value)) spec.attribute(a.name, *text);
        else spec.attribute(a.name, std::get<float>(a.value));
    }
    bool ok = output->open(tmp.string(), spec) && output->write_image(format, pixels) && output->close();
    if (!ok) {
        const std::string why = output->geterror();
        output.reset();
        fs::remove(tmp, ec);
        throw IoError(path + ": write failed (" + why + ")");
    }
    output.reset();
    fs::rename(tmp, target, ec);
    if (ec) {
        fs::remove(tmp, ec);
        throw IoError(path + ": rename into place failed (" + ec.message() + ")");
    }
}

Image read_image(const std::string& path) {
    require_supported_format(path);
    auto input = OIIO::ImageInput::open(path);
    if (!input) throw IoError(path + ": cannot open image (" + OIIO::geterror() + ")");
    const OIIO::ImageSpec& spec = input->spec();
    if (spec.width < 1 || spec.height < 1 || spec.width > kMaxReadSide || spec.height > kMaxReadSide ||
        spec.nchannels < 1 || spec.nchannels > 4 || spec.depth > 1)
        throw IoError(path + ": unsupported image layout (" + std::to_string(spec.width) + "×" +
                      std::to_string(spec.height) + "×" + std::to_string(spec.nchannels) + ")");
    Image image;
    image.width = spec.width;
    image.height = spec.height;
    image.channels = spec.nchannels;
    OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT;
    image.type = PixelType::F32;
    if (spec.format == OIIO::TypeDesc::UINT8) {
        format = OIIO::TypeDesc::UINT8;
        image.type = PixelType::U8;
    } else if (spec.format == OIIO::TypeDesc::UINT16) {
        format = OIIO::TypeDesc::UINT16;
        image.type = PixelType::U16;
    }
    image.bytes.resize(static_cast<size_t>(spec.width) * spec.height * spec.nchannels * format.size());
    if (!input->read_image(0, 0, 0, spec.nchannels, format, image.bytes.data()))
        throw IoError(path + ": cannot decode image (" + input->geterror() + ")");
    input->close();
    return image;
}

}  // namespace moonbot
