#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <vector>

#include "check.h"
#include "moonbot/image.h"

using namespace moonbot;

TEST_CASE(tonemap_is_finite_monotone_and_bounded) {
    // Grey ramp over 1e-6 … 1e6 (twelve decades), plus NaN, Inf and negatives.
    std::vector<float> rgb;
    for (int i = 0; i <= 120; ++i) {
        const float v = std::pow(10.0f, -6.0f + i * 0.1f);
        rgb.insert(rgb.end(), {v, v, v});
    }
    const float inf = std::numeric_limits<float>::infinity();
    const float bad[] = {NAN, -inf, -1.0f};
    for (float b : bad) rgb.insert(rgb.end(), {b, b, b});
    // The largest float and +Inf: the top of the curve saturates, it does not wrap to black.
    rgb.insert(rgb.end(), {3.4e38f, 3.4e38f, 3.4e38f, inf, inf, inf});
    std::vector<uint8_t> out(rgb.size());
    const size_t invalid = tonemap_reinhard_srgb8(rgb.data(), rgb.size() / 3, 1.0, out.data());
    CHECK(invalid == 4);  // NaN, -Inf, -1, +Inf; not the largest float
    for (int i = 1; i <= 120; ++i) CHECK(out[3 * i] >= out[3 * (i - 1)]);
    CHECK(out[0] == 0);
    CHECK(out[3 * 120] == 255);
    CHECK(out[3 * 60] == 188);  // Y = 1 → 0.5 → sRGB 0.7354 → 187.5 → 188
    for (int k = 0; k < 3; ++k) CHECK(out[3 * (121 + k)] == 0);
    CHECK(out[3 * 124] == 255 && out[3 * 125] == 255);
    // A huge exposure overflows v to +Inf in float: still white, not black.
    const float one[3] = {1.0f, 1.0f, 1.0f};
    uint8_t px[3];
    CHECK(tonemap_reinhard_srgb8(one, 1, 1e300, px) == 0);
    CHECK(px[0] == 255 && px[1] == 255 && px[2] == 255);
    // An exposure above FLT_MAX (finite in double) must not make 0 · Inf = NaN: black stays black.
    const float zero[3] = {0.0f, 0.0f, 0.0f};
    tonemap_reinhard_srgb8(zero, 1, 3.4028235677973366e38, px);
    CHECK(px[0] == 0 && px[1] == 0 && px[2] == 0);
    CHECK_THROWS(std::invalid_argument, tonemap_reinhard_srgb8(rgb.data(), 1, 0.0, out.data()));
}

TEST_CASE(png16_round_trips_through_a_decoder) {
    const auto dir = std::filesystem::temp_directory_path() / "moonbot_test_image";
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "depth.png").string();
    std::vector<uint16_t> pixels(13 * 7);
    for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint16_t>(i * 719);
    write_image(path, pixels.data(), 13, 7, 1, PixelType::U16);
    auto in = OIIO::ImageInput::open(path);
    CHECK(in != nullptr);
    if (in) {
        CHECK(in->spec().width == 13 && in->spec().height == 7 && in->spec().nchannels == 1);
        std::vector<uint16_t> back(pixels.size());
        in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT16, back.data());
        CHECK(back == pixels);
    }
    // Only the file itself is left behind: no temporaries.
    size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
    CHECK(files == 1);
    std::filesystem::remove_all(dir);
}

TEST_CASE(exr_keeps_float_radiance_and_header_attributes) {
    const auto dir = std::filesystem::temp_directory_path() / "moonbot_test_exr";
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "rgb.exr").string();
    std::vector<float> pixels(5 * 4 * 3);
    for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = std::ldexp(1.0f + 0.37f * i, static_cast<int>(i) - 30);
    write_image(path, pixels.data(), 5, 4, 3, PixelType::F32, 1,
                {{"whiteLuminance", 93.31f}, {"moonbot:radianceUnit", std::string("W/(m^2*sr)")}});
    auto in = OIIO::ImageInput::open(path);
    CHECK(in != nullptr);
    if (in) {
        CHECK(in->spec().format == OIIO::TypeDesc::FLOAT);
        CHECK(in->spec().get_float_attribute("whiteLuminance") == 93.31f);
        CHECK(in->spec().get_string_attribute("moonbot:radianceUnit") == "W/(m^2*sr)");
        std::vector<float> back(pixels.size());
        in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, back.data());
        CHECK(back == pixels);
    }
    CHECK_THROWS(std::invalid_argument, write_image(path, pixels.data(), 5, 4, 3, PixelType::F32, 1, {{"", 1.0f}}));
    std::filesystem::remove_all(dir);
}

TEST_CASE(write_to_missing_directory_throws_io_error) {
    const uint8_t px[3] = {1, 2, 3};
    CHECK_THROWS(IoError, write_image("/nonexistent-moonbot/x.png", px, 1, 1, 3, PixelType::U8));
    CHECK_THROWS(IoError, write_image("/tmp/x.unknown-ext", px, 1, 1, 3, PixelType::U8));
}
