// The TIFF reader on GeoTIFF files built byte by byte (TIFF 6.0 §2; GeoTIFF 1.0 §2.6), so each
// field's place is known, read through DemRaster as the import reads them: strips decode exactly
// (uncompressed and Deflate), a file cut at any byte is an IoError naming it (and the strip), and
// random strips in each codec are errors, never crashes or out-of-bounds reads (ASan/UBSan).
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/dem_raster.h"
#include "moonbot/io_error.h"

using namespace moonbot;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

void put16(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    b[at] = static_cast<uint8_t>(v), b[at + 1] = static_cast<uint8_t>(v >> 8);
}
void put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

/// A little-endian geographic GeoTIFF of `w` × `h` float32 samples in strips of `rows` rows,
/// each strip's stored bytes given (compressed with `compression` or not). Pixel (0, 0)'s
/// centre is at lat 10.05°, lon 9.95°, pixels 0.001° (PixelIsArea).
std::vector<uint8_t> geotiff_bytes(int w, int h, int rows, uint16_t compression,
                                   const std::vector<std::vector<uint8_t>>& strips) {
    struct Entry {
        uint16_t tag, type;
        uint32_t count;
        std::vector<uint8_t> value;  // little-endian bytes
    };
    auto shorts = [](std::vector<uint32_t> v) {
        std::vector<uint8_t> b(v.size() * 2);
        for (size_t i = 0; i < v.size(); ++i) put16(b, 2 * i, v[i]);
        return b;
    };
    auto longs = [](std::vector<uint32_t> v) {
        std::vector<uint8_t> b(v.size() * 4);
        for (size_t i = 0; i < v.size(); ++i) put32(b, 4 * i, v[i]);
        return b;
    };
    auto doubles = [](std::vector<double> v) {
        std::vector<uint8_t> b(v.size() * 8);
        std::memcpy(b.data(), v.data(), b.size());  // the test machine is little-endian (x86-64)
        return b;
    };
    const uint32_t n = static_cast<uint32_t>(strips.size());
    std::vector<Entry> entries = {
        {256, 4, 1, longs({static_cast<uint32_t>(w)})},
        {257, 4, 1, longs({static_cast<uint32_t>(h)})},
        {258, 3, 1, shorts({32})},
        {259, 3, 1, shorts({compression})},
        {262, 3, 1, shorts({1})},
        {273, 4, n, {}},  // StripOffsets: filled in once the layout is known
        {277, 3, 1, shorts({1})},
        {278, 4, 1, longs({static_cast<uint32_t>(rows)})},
        {279, 4, n, {}},
        {339, 3, 1, shorts({3})},
        {33550, 12, 3, doubles({0.001, 0.001, 0.0})},
        {33922, 12, 6, doubles({0.0, 0.0, 0.0, 9.9495, 10.0505, 0.0})},
        {34735, 3, 16, shorts({1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2054, 0, 1, 9102})},
    };
    const size_t ifd_size = 2 + 12 * entries.size() + 4;
    size_t values_at = 8 + ifd_size, data_at = values_at;
    for (const Entry& e : entries)
        if (e.tag == 273 || e.tag == 279) data_at += 4 * e.count;
        else if (e.value.size() > 4) data_at += e.value.size();
    std::vector<uint32_t> offsets, counts;
    for (const auto& s : strips) {
        offsets.push_back(static_cast<uint32_t>(data_at));
        counts.push_back(static_cast<uint32_t>(s.size()));
        data_at += s.size();
    }
    for (Entry& e : entries)
        if (e.tag == 273) e.value = longs(offsets);
        else if (e.tag == 279) e.value = longs(counts);
    std::vector<uint8_t> b(8 + ifd_size);
    b[0] = b[1] = 'I';
    put16(b, 2, 42);
    put32(b, 4, 8);
    put16(b, 8, static_cast<uint32_t>(entries.size()));
    for (size_t i = 0; i < entries.size(); ++i) {
        const Entry& e = entries[i];
        const size_t at = 10 + 12 * i;
        put16(b, at, e.tag);
        put16(b, at + 2, e.type);
        put32(b, at + 4, e.count);
        if (e.value.size() <= 4) {
            std::copy(e.value.begin(), e.value.end(), b.begin() + static_cast<std::ptrdiff_t>(at + 8));
        } else {
            put32(b, at + 8, static_cast<uint32_t>(values_at + (b.size() - 8 - ifd_size)));
            b.insert(b.end(), e.value.begin(), e.value.end());
        }
    }
    for (const auto& s : strips) b.insert(b.end(), s.begin(), s.end());
    return b;
}

/// Row-major float32 samples z = x − 2y as the bytes of strips of `rows` rows.
std::vector<std::vector<uint8_t>> plane_strips(int w, int h, int rows) {
    std::vector<std::vector<uint8_t>> strips;
    for (int y0 = 0; y0 < h; y0 += rows) {
        std::vector<uint8_t> s;
        for (int y = y0; y < std::min(h, y0 + rows); ++y)
            for (int x = 0; x < w; ++x) {
                const float z = static_cast<float>(x - 2 * y);
                uint8_t raw[4];
                std::memcpy(raw, &z, 4);
                s.insert(s.end(), raw, raw + 4);
            }
        strips.push_back(std::move(s));
    }
    return strips;
}

std::vector<uint8_t> deflate(const std::vector<uint8_t>& raw) {
    uLongf size = compressBound(static_cast<uLong>(raw.size()));
    std::vector<uint8_t> out(size);
    if (compress(out.data(), &size, raw.data(), static_cast<uLong>(raw.size())) != Z_OK)
        throw std::runtime_error("zlib compress failed");
    out.resize(size);
    return out;
}

/// A scratch folder of its own for this process (release and sanitizer builds may run at once).
std::filesystem::path scratch_dir(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes, size_t n) {
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
}

/// Opens a GeoTIFF and reads every pixel; "" if that worked, else the IoError's message (any
/// other exception fails the test).
std::string read_whole(const std::string& path) {
    try {
        const DemRaster dem = DemRaster::open_geotiff(path);
        const std::vector<double> z = dem.read(0, 0, dem.width(), dem.height());
        return "";
    } catch (const IoError& e) {
        return e.what();
    }
}

}  // namespace

TEST_CASE(geotiff_strips_decode_exactly_uncompressed_and_deflate) {
    const auto dir = scratch_dir("moonbot_test_dem_tiff");
    const int w = 37, h = 29, rows = 4;
    for (uint16_t compression : {1, 8}) {
        std::vector<std::vector<uint8_t>> strips = plane_strips(w, h, rows);
        if (compression == 8)
            for (auto& s : strips) s = deflate(s);
        const std::string path = (dir / "plane.tif").string();
        const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
        write_file(path, bytes, bytes.size());
        const DemRaster dem = DemRaster::open_geotiff(path);
        CHECK(dem.width() == w && dem.height() == h && dem.description() == "GeoTIFF float32, geographic");
        // A window starting and ending mid-strip and mid-row.
        const std::vector<double> z = dem.read(3, 5, 30, 27);
        bool exact = z.size() == 27u * 22u;
        for (int y = 5; y < 27 && exact; ++y)
            for (int x = 3; x < 30; ++x) exact &= z[static_cast<size_t>(y - 5) * 27 + (x - 3)] == x - 2.0 * y;
        CHECK(exact);
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE(geotiff_cut_at_every_byte_is_an_error_naming_the_file) {
    // Cut anywhere — header, directory, tag values, any strip — the file is refused with an
    // IoError naming it; cuts in the pixel data name the strip. Never a crash (this test runs
    // under ASan/UBSan too) and never zeros for the missing part.
    const auto dir = scratch_dir("moonbot_test_dem_cut");
    const std::string path = (dir / "cut.tif").string();
    const int w = 9, h = 7, rows = 2;
    for (uint16_t compression : {1, 8}) {
        std::vector<std::vector<uint8_t>> strips = plane_strips(w, h, rows);
        if (compression == 8)
            for (auto& s : strips) s = deflate(s);
        const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
        write_file(path, bytes, bytes.size());
        CHECK(read_whole(path).empty());
        size_t data_at = bytes.size();
        for (const auto& s : strips) data_at -= s.size();
        int wrong = 0;
        for (size_t n = 0; n < bytes.size(); ++n) {
            write_file(path, bytes, n);
            const std::string msg = read_whole(path);
            const bool named = contains(msg, path + ": ") && (n < data_at || contains(msg, "strip "));
            if (!named && ++wrong <= 3) std::printf("  cut at %zu of %zu bytes: '%s'\n", n, bytes.size(), msg.c_str());
        }
        CHECK(wrong == 0);
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE(garbage_strips_are_errors_not_crashes) {
    // Random bytes as LZW, Deflate and PackBits strips: each read either fails with an IoError
    // naming the file and the strip or (PackBits can) decodes to exactly the strip's size. Run
    // under ASan/UBSan, this is what shows the decoders never read or write out of bounds.
    const auto dir = scratch_dir("moonbot_test_dem_garbage");
    const std::string path = (dir / "garbage.tif").string();
    std::mt19937 rng(20240611);
    const int w = 5, h = 4, rows = 2;  // two strips of 40 bytes
    for (uint16_t compression : {5, 8, 32773}) {
        int errors = 0;
        for (int trial = 0; trial < 300; ++trial) {
            std::vector<std::vector<uint8_t>> strips(2);
            for (auto& s : strips) {
                s.resize(1 + rng() % 120);
                for (auto& byte : s) byte = static_cast<uint8_t>(rng());
            }
            if (compression == 5 && trial % 2 == 0) strips[0][0] = 0x80;  // a Clear code first, as writers do
            const std::vector<uint8_t> bytes = geotiff_bytes(w, h, rows, compression, strips);
            write_file(path, bytes, bytes.size());
            const std::string msg = read_whole(path);
            if (!msg.empty()) {
                ++errors;
                CHECK(contains(msg, path + ": strip "));
            }
        }
        CHECK(errors > 250);  // random bytes almost never decode to exactly 40 bytes
    }
    std::filesystem::remove_all(dir);
}
