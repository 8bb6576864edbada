// The TIFF reader (see tiff_reader.h): the first directory's fields, the pixel layout, the block
// codecs (LZW, Deflate through zlib, PackBits), the predictors, and windows of samples as doubles.
#include "tiff_reader.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <utility>

#include "moonbot/io_error.h"

namespace moonbot::tiff {

namespace {

// A field larger than this is refused: no real georeference or block table needs it (2 M tile
// offsets in BigTIFF), and a corrupt count must not ask for gigabytes.
constexpr uint64_t kMaxFieldBytes = 16u << 20;

/// The `bytes`-byte unsigned integer at `p` in the given byte order.
uint64_t load_uint(const uint8_t* p, unsigned bytes, bool big_endian) {
    uint64_t v = 0;
    for (unsigned k = 0; k < bytes; ++k) v |= uint64_t(p[k]) << (8 * (big_endian ? bytes - 1 - k : k));
    return v;
}

void store_uint(uint8_t* p, unsigned bytes, bool big_endian, uint64_t v) {
    for (unsigned k = 0; k < bytes; ++k) p[k] = static_cast<uint8_t>(v >> (8 * (big_endian ? bytes - 1 - k : k)));
}

template <typename T, typename Bits>
void widen_as(const uint8_t* src, size_t n, bool big_endian, double* dst) {
    for (size_t i = 0; i < n; ++i) {
        const Bits bits = static_cast<Bits>(load_uint(src + i * sizeof(T), sizeof(T), big_endian));
        T v;
        std::memcpy(&v, &bits, sizeof(T));
        dst[i] = static_cast<double>(v);
    }
}

/// `n` samples stored in the given byte order → doubles, exactly (every supported type fits a
/// double's 53-bit mantissa).
void widen(SampleType type, const uint8_t* src, size_t n, bool big_endian, double* dst) {
    switch (type) {
        case SampleType::UInt8: widen_as<uint8_t, uint8_t>(src, n, big_endian, dst); break;
        case SampleType::Int8: widen_as<int8_t, uint8_t>(src, n, big_endian, dst); break;
        case SampleType::UInt16: widen_as<uint16_t, uint16_t>(src, n, big_endian, dst); break;
        case SampleType::Int16: widen_as<int16_t, uint16_t>(src, n, big_endian, dst); break;
        case SampleType::UInt32: widen_as<uint32_t, uint32_t>(src, n, big_endian, dst); break;
        case SampleType::Int32: widen_as<int32_t, uint32_t>(src, n, big_endian, dst); break;
        case SampleType::Float32: widen_as<float, uint32_t>(src, n, big_endian, dst); break;
        case SampleType::Float64: widen_as<double, uint64_t>(src, n, big_endian, dst); break;
    }
}

std::string compression_name(uint64_t c) {
    switch (c) {
        case kCompressionNone: return "none";
        case kCompressionLzw: return "LZW";
        case kCompressionDeflate:
        case kCompressionDeflateOld: return "Deflate";
        case kCompressionPackBits: return "PackBits";
        case 2:
        case 3:
        case 4: return "CCITT";
        case 6:
        case 7: return "JPEG";
        case 34887: return "LERC";
        case 34925: return "LZMA";
        case 50000: return "ZSTD";
        case 50001: return "WebP";
        default: return "unknown";
    }
}

// A single strip or tile decoding to more than this is refused: a corrupt size must not ask for
// gigabytes, and real DEMs come in strips or tiles far smaller (GDAL writes 8 KiB–1 MiB blocks).
constexpr uint64_t kMaxBlockBytes = uint64_t(1) << 30;

/// Why a block did not decode; the caller adds the file and the block.
struct DecodeError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Inflates a zlib stream (TIFF Deflate) into `out` (its size is the most the block may hold).
/// Returns the bytes it decoded; throws DecodeError if the stream is corrupt, stops early or
/// would decode past `out`.
size_t inflate_block(const std::vector<uint8_t>& in, std::vector<uint8_t>& out) {
    z_stream z{};
    if (inflateInit(&z) != Z_OK) throw std::runtime_error("zlib: inflateInit failed");
    // One byte of room past the block tells a stream that ends exactly at the block's end from
    // one that goes on.
    std::vector<uint8_t> spill(1);
    z.next_in = const_cast<Bytef*>(in.data());
    z.avail_in = static_cast<uInt>(in.size());
    z.next_out = out.data();
    z.avail_out = static_cast<uInt>(out.size());
    int rc = inflate(&z, Z_FINISH);
    if (rc == Z_BUF_ERROR && z.avail_out == 0) {
        z.next_out = spill.data();
        z.avail_out = 1;
        rc = inflate(&z, Z_FINISH);
    }
    const size_t produced = static_cast<size_t>(z.total_out);
    const std::string why = z.msg ? z.msg : "";
    inflateEnd(&z);
    if (rc == Z_STREAM_END && produced <= out.size()) return produced;
    if (produced > out.size())
        throw DecodeError("the Deflate stream decodes to more than the " + std::to_string(out.size()) +
                          " bytes expected");
    if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT)
        throw DecodeError("the Deflate stream is corrupt after " + std::to_string(produced) + " bytes (zlib: " + why +
                          ")");
    throw DecodeError("the Deflate stream stops after " + std::to_string(produced) + " bytes, without its end marker");
}

/// TIFF LZW (TIFF 6.0 §13: codes of 9–12 bits, most significant bit first, Clear 256, EndOfInfo
/// 257, the code width growing one code early). Same contract as inflate_block.
size_t lzw_block(const std::vector<uint8_t>& in, std::vector<uint8_t>& out) {
    constexpr unsigned kClear = 256, kEndOfInfo = 257, kFirstFree = 258, kTableSize = 4096;
    // libtiff's reader detects the pre-TIFF-6.0 LZW (least significant bit first) by these bytes.
    if (in.size() >= 2 && in[0] == 0 && (in[1] & 0x1) != 0)
        throw DecodeError("old-style (pre-TIFF 6.0) LZW is not supported");
    struct Entry {
        uint16_t prefix;  // the code this one extends
        uint16_t length;  // bytes in its string
        uint8_t first, last;
    };
    std::vector<Entry> table(kTableSize);
    for (unsigned c = 0; c < 256; ++c) table[c] = {0, 1, static_cast<uint8_t>(c), static_cast<uint8_t>(c)};
    unsigned next = kFirstFree, width = 9;
    int previous = -1;
    size_t produced = 0;
    uint64_t bit = 0;
    const uint64_t bits = static_cast<uint64_t>(in.size()) * 8;
    auto emit = [&](unsigned code) {
        const size_t length = table[code].length;
        if (produced + length > out.size())
            throw DecodeError("the LZW stream decodes to more than the " + std::to_string(out.size()) +
                              " bytes expected");
        for (size_t k = length; k-- > 0;) {  // a string is its prefix's string plus its last byte
            out[produced + k] = table[code].last;
            code = table[code].prefix;
        }
        produced += length;
    };
    while (bit + width <= bits) {
        unsigned code = 0;
        for (unsigned k = 0; k < width; ++k, ++bit)
            code = (code << 1) | ((in[static_cast<size_t>(bit >> 3)] >> (7 - (bit & 7))) & 1u);
        if (code == kEndOfInfo) return produced;
        if (code == kClear) {
            next = kFirstFree;
            width = 9;
            previous = -1;
            continue;
        }
        if (previous < 0) {
            if (code > 255)
                throw DecodeError("the LZW stream is corrupt: code " + std::to_string(code) + " follows a Clear");
            emit(code);
            previous = static_cast<int>(code);
            continue;
        }
        if (code > next || (code == next && next >= kTableSize))
            throw DecodeError("the LZW stream is corrupt: code " + std::to_string(code) +
                              " is not in the table (after " + std::to_string(produced) + " bytes)");
        if (next < kTableSize) {
            const auto p = static_cast<unsigned>(previous);
            // The new string is the previous one plus the first byte of the current one; a code
            // equal to `next` is that very string (its first byte is the previous one's).
            const uint8_t first = code == next ? table[p].first : table[code].first;
            table[next] = {static_cast<uint16_t>(p), static_cast<uint16_t>(table[p].length + 1), table[p].first, first};
            ++next;
            if (next + 1 >= (1u << width) && width < 12) ++width;  // TIFF's early change
        }
        emit(code);
        previous = static_cast<int>(code);
    }
    return produced;  // no EndOfInfo: libtiff accepts this; the length check below still applies
}

/// PackBits (TIFF 6.0 §9). Same contract as inflate_block.
size_t packbits_block(const std::vector<uint8_t>& in, std::vector<uint8_t>& out) {
    size_t i = 0, produced = 0;
    auto room = [&](size_t n) {
        if (produced + n > out.size())
            throw DecodeError("the PackBits data decode to more than the " + std::to_string(out.size()) +
                              " bytes expected");
    };
    while (i < in.size()) {
        const int header = static_cast<int8_t>(in[i++]);
        if (header >= 0) {  // a literal run of header + 1 bytes
            const size_t n = static_cast<size_t>(header) + 1;
            if (n > in.size() - i)
                throw DecodeError("the PackBits data are cut short in a literal run (after " +
                                  std::to_string(produced) + " bytes)");
            room(n);
            std::memcpy(out.data() + produced, in.data() + i, n);
            i += n;
            produced += n;
        } else if (header != -128) {  // the next byte 1 − header times; −128 is a no-op
            if (i >= in.size())
                throw DecodeError("the PackBits data are cut short in a repeat run (after " + std::to_string(produced) +
                                  " bytes)");
            const size_t n = static_cast<size_t>(1 - header);
            room(n);
            std::memset(out.data() + produced, in[i++], n);
            produced += n;
        }
    }
    return produced;
}

/// Undoes the horizontal predictor on one row of `n` samples of `bytes` each in the file's byte
/// order: each sample is the sum (mod 2^bits) of the stored differences so far, as libtiff
/// applies it to the sample's bits whatever its type.
void undo_horizontal(uint8_t* row, size_t n, unsigned bytes, bool big_endian) {
    const uint64_t mask = bytes == 8 ? ~uint64_t(0) : (uint64_t(1) << (8 * bytes)) - 1;
    uint64_t sum = load_uint(row, bytes, big_endian);
    for (size_t i = 1; i < n; ++i) {
        sum = (sum + load_uint(row + i * bytes, bytes, big_endian)) & mask;
        store_uint(row + i * bytes, bytes, big_endian, sum);
    }
}

/// Undoes the floating-point predictor (TIFF Technical Note 3) on one row: the row's bytes are
/// byte-wise differences of the samples split into planes, most significant bytes first; the
/// samples go back in the file's byte order.
void undo_floating_point(uint8_t* row, size_t n, unsigned bytes, bool big_endian, std::vector<uint8_t>& scratch) {
    const size_t total = n * bytes;
    for (size_t i = 1; i < total; ++i) row[i] = static_cast<uint8_t>(row[i] + row[i - 1]);
    scratch.assign(row, row + total);
    for (size_t i = 0; i < n; ++i)
        for (unsigned b = 0; b < bytes; ++b) {
            const uint8_t byte = scratch[b * n + i];  // plane b holds byte b counted from the most significant
            row[i * bytes + (big_endian ? b : bytes - 1 - b)] = byte;
        }
}

}  // namespace

std::string tag_name(uint16_t tag) {
    const char* name = nullptr;
    switch (tag) {
        case kTagImageWidth: name = "ImageWidth"; break;
        case kTagImageLength: name = "ImageLength"; break;
        case kTagBitsPerSample: name = "BitsPerSample"; break;
        case kTagCompression: name = "Compression"; break;
        case kTagFillOrder: name = "FillOrder"; break;
        case kTagStripOffsets: name = "StripOffsets"; break;
        case kTagSamplesPerPixel: name = "SamplesPerPixel"; break;
        case kTagRowsPerStrip: name = "RowsPerStrip"; break;
        case kTagStripByteCounts: name = "StripByteCounts"; break;
        case kTagPredictor: name = "Predictor"; break;
        case kTagTileWidth: name = "TileWidth"; break;
        case kTagTileLength: name = "TileLength"; break;
        case kTagTileOffsets: name = "TileOffsets"; break;
        case kTagTileByteCounts: name = "TileByteCounts"; break;
        case kTagSampleFormat: name = "SampleFormat"; break;
        case kTagModelPixelScale: name = "ModelPixelScale"; break;
        case kTagModelTiepoint: name = "ModelTiepoint"; break;
        case kTagGeoKeyDirectory: name = "GeoKeyDirectory"; break;
        case kTagGeoDoubleParams: name = "GeoDoubleParams"; break;
        case kTagGeoAsciiParams: name = "GeoAsciiParams"; break;
        case kTagGdalMetadata: name = "GDAL_METADATA"; break;
        case kTagGdalNodata: name = "GDAL_NODATA"; break;
        default: return "tag " + std::to_string(tag);
    }
    return std::string(name) + " (" + std::to_string(tag) + ")";
}

Directory::Directory(const std::string& path) : m_path(path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path + ": cannot open for reading");
    in.seekg(0, std::ios::end);
    const auto end = in.tellg();
    if (end < 0) throw IoError(path + ": cannot read its size");
    m_size = static_cast<uint64_t>(end);
    const std::vector<uint8_t> head = read_at(in, 0, std::min<uint64_t>(16, m_size), "header");
    const bool marked = head.size() >= 2 && ((head[0] == 'I' && head[1] == 'I') || (head[0] == 'M' && head[1] == 'M'));
    if (!marked) throw IoError(path + ": not a TIFF file (no II/MM byte-order mark); not a GeoTIFF?");
    m_big_endian = head[0] == 'M';
    if (head.size() < 8)
        throw IoError(path + ": the TIFF header is cut short: the file has " + std::to_string(m_size) +
                      " bytes, the header needs 8 (truncated?)");
    const uint16_t version = static_cast<uint16_t>(uint_at(head, 2, 2));
    uint64_t ifd = 0;
    if (version == 42) {
        ifd = uint_at(head, 4, 4);
    } else if (version == 43) {  // BigTIFF
        if (head.size() < 16)
            throw IoError(path + ": the BigTIFF header is cut short: the file has " + std::to_string(m_size) +
                          " bytes, the header needs 16 (truncated?)");
        if (uint_at(head, 4, 2) != 8 || uint_at(head, 6, 2) != 0) throw IoError(path + ": malformed BigTIFF header");
        m_big = true;
        ifd = uint_at(head, 8, 8);
    } else {
        throw IoError(path + ": not a TIFF file (version " + std::to_string(version) + ")");
    }
    const unsigned count_size = m_big ? 8 : 2, entry_size = m_big ? 20 : 12, inline_size = m_big ? 8 : 4;
    const uint64_t n = uint_at(read_at(in, ifd, count_size, "first IFD"), 0, count_size);
    if (n == 0 || n > 4096) throw IoError(path + ": first IFD has " + std::to_string(n) + " entries");
    const std::vector<uint8_t> entries = read_at(in, ifd + count_size, n * entry_size, "first IFD");
    for (uint64_t i = 0; i < n; ++i) {
        const size_t at = static_cast<size_t>(i * entry_size);
        const auto tag = static_cast<uint16_t>(uint_at(entries, at, 2));
        const auto type = static_cast<uint16_t>(uint_at(entries, at + 2, 2));
        const uint64_t count = uint_at(entries, at + 4, m_big ? 8 : 4);
        if (!wanted(tag)) continue;
        const unsigned size = type_size(type);
        if (size == 0) continue;  // TIFF 6.0: readers skip fields of unknown type
        if (count > kMaxFieldBytes / size)
            throw IoError(path + ": " + tag_name(tag) + " is implausibly large (" + std::to_string(count) + " values)");
        Field f{type, count, {}};
        const uint64_t bytes = count * size;
        const size_t value_at = at + (m_big ? 12 : 8);
        if (bytes <= inline_size) {
            f.bytes.assign(entries.begin() + static_cast<std::ptrdiff_t>(value_at),
                           entries.begin() + static_cast<std::ptrdiff_t>(value_at + bytes));
        } else {
            f.bytes = read_at(in, uint_at(entries, value_at, inline_size), bytes, tag_name(tag));
        }
        m_fields.emplace(tag, std::move(f));
    }
}

std::vector<double> Directory::numbers(uint16_t tag, const std::string& name) const {
    const Field& f = field(tag, name);
    const unsigned size = type_size(f.type);
    std::vector<double> out;
    out.reserve(static_cast<size_t>(f.count));
    for (uint64_t i = 0; i < f.count; ++i) {
        const size_t at = static_cast<size_t>(i * size);
        const uint64_t u = uint_at(f.bytes, at, std::min(size, 8u));
        double v;
        switch (f.type) {
            case 1:
            case 3:
            case 4:
            case 16: v = static_cast<double>(u); break;  // unsigned
            case 6: v = static_cast<int8_t>(u); break;
            case 8: v = static_cast<int16_t>(u); break;
            case 9: v = static_cast<int32_t>(u); break;
            case 17: v = static_cast<double>(static_cast<int64_t>(u)); break;
            case 11: {
                uint32_t b = static_cast<uint32_t>(u);
                float x;
                std::memcpy(&x, &b, 4);
                v = x;
                break;
            }
            case 12: std::memcpy(&v, &u, 8); break;
            case 5:
            case 10: {
                const uint64_t num = uint_at(f.bytes, at, 4), den = uint_at(f.bytes, at + 4, 4);
                v = f.type == 5 ? static_cast<double>(num) / static_cast<double>(den)
                                : static_cast<double>(static_cast<int32_t>(num)) /
                                      static_cast<double>(static_cast<int32_t>(den));
                break;
            }
            default: throw IoError(m_path + ": " + name + " is not numeric (TIFF type " + std::to_string(f.type) + ")");
        }
        out.push_back(v);
    }
    return out;
}

std::vector<uint64_t> Directory::uints(uint16_t tag) const {
    const Field& f = field(tag, tag_name(tag));
    if (f.type != 1 && f.type != 3 && f.type != 4 && f.type != 16)
        throw IoError(m_path + ": " + tag_name(tag) + " is not an unsigned integer (TIFF type " +
                      std::to_string(f.type) + ")");
    const unsigned size = type_size(f.type);
    std::vector<uint64_t> out(static_cast<size_t>(f.count));
    for (size_t i = 0; i < out.size(); ++i) out[i] = uint_at(f.bytes, i * size, size);
    return out;
}

uint64_t Directory::uint_or(uint16_t tag, uint64_t fallback) const {
    if (!has(tag)) return fallback;
    const std::vector<uint64_t> v = uints(tag);
    if (v.empty()) throw IoError(m_path + ": " + tag_name(tag) + " holds no value");
    // BitsPerSample and SampleFormat hold one value per sample; the band count is checked
    // on its own (SamplesPerPixel), so the first stands for all.
    return v[0];
}

std::string Directory::text(uint16_t tag, const std::string& name) const {
    const Field& f = field(tag, name);
    if (f.type != 2 && f.type != 1 && f.type != 7)
        throw IoError(m_path + ": " + name + " is not ASCII (TIFF type " + std::to_string(f.type) + ")");
    std::string s(f.bytes.begin(), f.bytes.end());
    return s.substr(0, s.find('\0'));
}

bool Directory::wanted(uint16_t tag) {
    switch (tag) {
        case kTagImageWidth:
        case kTagImageLength:
        case kTagBitsPerSample:
        case kTagCompression:
        case kTagFillOrder:
        case kTagStripOffsets:
        case kTagSamplesPerPixel:
        case kTagRowsPerStrip:
        case kTagStripByteCounts:
        case kTagPredictor:
        case kTagTileWidth:
        case kTagTileLength:
        case kTagTileOffsets:
        case kTagTileByteCounts:
        case kTagSampleFormat:
        case kTagModelPixelScale:
        case kTagModelTiepoint:
        case kTagModelTransformation:
        case kTagGeoKeyDirectory:
        case kTagGeoDoubleParams:
        case kTagGeoAsciiParams:
        case kTagGdalMetadata:
        case kTagGdalNodata: return true;
        default: return false;
    }
}

unsigned Directory::type_size(uint16_t type) {
    switch (type) {
        case 1:
        case 2:
        case 6:
        case 7: return 1;
        case 3:
        case 8: return 2;
        case 4:
        case 9:
        case 11:
        case 13: return 4;
        case 5:
        case 10:
        case 12:
        case 16:
        case 17:
        case 18: return 8;
        default: return 0;
    }
}

const Directory::Field& Directory::field(uint16_t tag, const std::string& name) const {
    auto it = m_fields.find(tag);
    if (it == m_fields.end()) throw IoError(m_path + ": no " + name + " tag");
    return it->second;
}

uint64_t Directory::uint_at(const std::vector<uint8_t>& b, size_t at, unsigned n) const {
    uint64_t v = 0;
    for (unsigned k = 0; k < n; ++k) {
        const uint64_t byte = b[at + k];
        v |= m_big_endian ? byte << (8 * (n - 1 - k)) : byte << (8 * k);
    }
    return v;
}

std::vector<uint8_t> Directory::read_at(std::ifstream& in, uint64_t offset, uint64_t n, const std::string& what) const {
    if (offset > m_size || n > m_size - offset)
        throw IoError(m_path + ": TIFF " + what + " lies past the end of the file: it needs bytes " +
                      std::to_string(offset) + "–" + std::to_string(offset + n - 1) + ", the file has " +
                      std::to_string(m_size) + " (truncated?)");
    std::vector<uint8_t> out(static_cast<size_t>(n));
    in.seekg(static_cast<std::streamoff>(offset));
    in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(n));
    if (!in) throw IoError(m_path + ": cannot read TIFF " + what);
    return out;
}

std::string m_path;

unsigned sample_bytes(SampleType t) {
    switch (t) {
        case SampleType::UInt8:
        case SampleType::Int8: return 1;
        case SampleType::UInt16:
        case SampleType::Int16: return 2;
        case SampleType::UInt32:
        case SampleType::Int32:
        case SampleType::Float32: return 4;
        case SampleType::Float64: return 8;
    }
    return 0;
}

const char* sample_type_name(SampleType t) {
    switch (t) {
        case SampleType::UInt8: return "uint8";
        case SampleType::Int8: return "int8";
        case SampleType::UInt16: return "uint16";
        case SampleType::Int16: return "int16";
        case SampleType::UInt32: return "uint32";
        case SampleType::Int32: return "int32";
        case SampleType::Float32: return "float32";
        case SampleType::Float64: return "float64";
    }
    return "?";
}

/// "strip 12 (rows 192–207)" or "tile 40 (rows 128–191, columns 512–575)".
std::string Layout::block_name(size_t k) const {
    const int bx = static_cast<int>(k % static_cast<size_t>(blocks_across));
    const int by = static_cast<int>(k / static_cast<size_t>(blocks_across));
    const int y0 = by * block_height, y1 = std::min(height, y0 + block_height) - 1;
    std::string s = std::string(tiled ? "tile " : "strip ") + std::to_string(k) + " (rows " + std::to_string(y0) + "–" +
                    std::to_string(y1);
    if (tiled) {
        const int x0 = bx * block_width, x1 = std::min(width, x0 + block_width) - 1;
        s += ", columns " + std::to_string(x0) + "–" + std::to_string(x1);
    }
    return s + ")";
}

Layout read_layout(const Directory& dir) {
    const std::string& path = dir.path();
    Layout t;
    for (uint16_t tag : {kTagImageWidth, kTagImageLength})
        if (!dir.has(tag)) throw IoError(path + ": no " + tag_name(tag) + " tag; not a TIFF image?");
    const uint64_t width = dir.uint_or(kTagImageWidth, 0), height = dir.uint_or(kTagImageLength, 0);
    // Rows and columns are ints in the raster's interface; no lunar DEM comes near 2³¹ a side.
    constexpr uint64_t kMaxSide = std::numeric_limits<int>::max();
    if (width > kMaxSide || height > kMaxSide)
        throw IoError(path + ": ImageWidth × ImageLength = " + std::to_string(width) + " × " + std::to_string(height) +
                      " pixels is implausibly large (at most " + std::to_string(kMaxSide) + " a side)");
    if (width < 2 || height < 2)
        throw IoError(path + ": " + std::to_string(width) + "×" + std::to_string(height) +
                      " pixels; a DEM needs at least 2×2 to interpolate");
    t.width = static_cast<int>(width);
    t.height = static_cast<int>(height);

    const uint64_t channels = dir.uint_or(kTagSamplesPerPixel, 1);
    if (channels != 1)
        throw IoError(path + ": " + std::to_string(channels) + " channels (SamplesPerPixel); a DEM has one band");
    const uint64_t bits = dir.uint_or(kTagBitsPerSample, 1), format = dir.uint_or(kTagSampleFormat, 1);
    const char* format_name = format == 1   ? "unsigned integer"
                              : format == 2 ? "signed integer"
                              : format == 3 ? "floating point"
                                            : "undefined";
    switch (format * 100 + bits) {
        case 108: t.type = SampleType::UInt8; break;
        case 208: t.type = SampleType::Int8; break;
        case 116: t.type = SampleType::UInt16; break;
        case 216: t.type = SampleType::Int16; break;
        case 132: t.type = SampleType::UInt32; break;
        case 232: t.type = SampleType::Int32; break;
        case 332: t.type = SampleType::Float32; break;
        case 364: t.type = SampleType::Float64; break;
        default:
            throw IoError(path + ": sample type " + std::to_string(bits) + "-bit " + format_name +
                          " (BitsPerSample/SampleFormat) is not supported; use int8/16/32, uint8/16/32, float32 or "
                          "float64");
    }
    if (dir.uint_or(kTagFillOrder, 1) != 1)
        throw IoError(path + ": FillOrder (266) = 2 (bits reversed in each byte) is not supported");

    t.compression = dir.uint_or(kTagCompression, kCompressionNone);
    switch (t.compression) {
        case kCompressionNone:
        case kCompressionLzw:
        case kCompressionDeflate:
        case kCompressionDeflateOld:
        case kCompressionPackBits: break;
        default:
            throw IoError(path + ": Compression (259) = " + std::to_string(t.compression) + " (" +
                          compression_name(t.compression) +
                          ") is not supported; use none, LZW, Deflate or PackBits "
                          "(e.g. gdal_translate -co COMPRESS=DEFLATE)");
    }
    // libtiff applies a predictor only to the LZW and Deflate codecs and ignores the tag otherwise.
    const bool predicted = t.compression == kCompressionLzw || t.compression == kCompressionDeflate ||
                           t.compression == kCompressionDeflateOld;
    t.predictor = predicted ? dir.uint_or(kTagPredictor, kPredictorNone) : kPredictorNone;
    if (t.predictor != kPredictorNone && t.predictor != kPredictorHorizontal && t.predictor != kPredictorFloatingPoint)
        throw IoError(path + ": Predictor (317) = " + std::to_string(t.predictor) +
                      " is not supported; 1 (none), 2 (horizontal) or 3 (floating point)");
    if (t.predictor == kPredictorFloatingPoint && t.type != SampleType::Float32 && t.type != SampleType::Float64)
        throw IoError(path + ": Predictor (317) = 3 (floating point) on " + sample_type_name(t.type) + " samples");

    const bool tiles = dir.has(kTagTileWidth) || dir.has(kTagTileLength) || dir.has(kTagTileOffsets);
    uint16_t offsets_tag = kTagStripOffsets, counts_tag = kTagStripByteCounts;
    if (tiles) {
        t.tiled = true;
        offsets_tag = kTagTileOffsets;
        counts_tag = kTagTileByteCounts;
        for (uint16_t tag : {kTagTileWidth, kTagTileLength})
            if (!dir.has(tag)) throw IoError(path + ": a tiled TIFF without " + tag_name(tag));
        const uint64_t tw = dir.uint_or(kTagTileWidth, 0), th = dir.uint_or(kTagTileLength, 0);
        if (tw == 0 || th == 0 || tw > kMaxSide || th > kMaxSide)
            throw IoError(path + ": TileWidth × TileLength (322/323) = " + std::to_string(tw) + " × " +
                          std::to_string(th) + " is not a usable tile size");
        t.block_width = static_cast<int>(tw);
        t.block_height = static_cast<int>(th);
    } else {
        // RowsPerStrip defaults to 2³² − 1: the whole image in one strip.
        const uint64_t rows = dir.uint_or(kTagRowsPerStrip, 0xFFFFFFFFu);
        if (rows == 0) throw IoError(path + ": RowsPerStrip (278) = 0");
        t.block_width = t.width;
        t.block_height = static_cast<int>(std::min<uint64_t>(rows, height));
    }
    // Both sides below 2³¹ and 8-byte samples: a block's bytes fit 2⁶⁵, so compare by division.
    const uint64_t block_rows_max = std::numeric_limits<uint64_t>::max() / t.row_bytes();
    if (static_cast<uint64_t>(t.block_height) > block_rows_max || height > block_rows_max)
        throw IoError(path + ": " + std::to_string(width) + " × " + std::to_string(height) + " " +
                      sample_type_name(t.type) + " samples do not fit 64-bit byte counts");
    const uint64_t block_bytes = static_cast<uint64_t>(t.block_height) * t.row_bytes();
    if (block_bytes > kMaxBlockBytes && t.compression != kCompressionNone)
        throw IoError(path + ": a compressed " + std::string(t.tiled ? "tile" : "strip") + " of " +
                      std::to_string(t.block_width) + " × " + std::to_string(t.block_height) + " " +
                      sample_type_name(t.type) + " samples (" + std::to_string(block_bytes) +
                      " bytes) is larger than the " + std::to_string(kMaxBlockBytes) +
                      " bytes this reader decodes at once; re-save it tiled (gdal_translate -co TILED=YES)");
    t.blocks_across = t.tiled ? static_cast<int>((width + t.block_width - 1) / t.block_width) : 1;
    t.blocks_down = static_cast<int>((height + t.block_height - 1) / t.block_height);

    for (uint16_t tag : {offsets_tag, counts_tag})
        if (!dir.has(tag)) throw IoError(path + ": no " + tag_name(tag) + " tag; the pixels cannot be found");
    t.offsets = dir.uints(offsets_tag);
    t.byte_counts = dir.uints(counts_tag);
    const size_t blocks = t.block_count();
    for (const auto& [tag, list] :
         {std::pair<uint16_t, const std::vector<uint64_t>*>{offsets_tag, &t.offsets}, {counts_tag, &t.byte_counts}})
        if (list->size() < blocks)
            throw IoError(path + ": " + tag_name(tag) + " lists " + std::to_string(list->size()) + " " +
                          (t.tiled ? "tiles" : "strips") + "; " + std::to_string(width) + " × " +
                          std::to_string(height) + " pixels in " + std::to_string(t.block_width) + " × " +
                          std::to_string(t.block_height) + " blocks need " + std::to_string(blocks));
    t.offsets.resize(blocks);  // extra entries (libtiff trims them too) are never read
    t.byte_counts.resize(blocks);

    const uint64_t size = dir.file_size();
    for (size_t k = 0; k < blocks; ++k) {
        const uint64_t at = t.offsets[k], n = t.byte_counts[k];
        if (n == 0)
            throw IoError(path + ": " + t.block_name(k) + " has no data (" + tag_name(counts_tag) +
                          " 0; a sparse file? re-save it with every block written)");
        if (at > size || n > size - at)
            throw IoError(path + ": " + t.block_name(k) + " lies past the end of the file: it needs bytes " +
                          std::to_string(at) + "–" + std::to_string(at + n - 1) + " (" + tag_name(offsets_tag) + " " +
                          std::to_string(at) + ", " + tag_name(counts_tag) + " " + std::to_string(n) +
                          "), the file has " + std::to_string(size) + " bytes (truncated?)");
        if (t.compression == kCompressionNone && n < t.decoded_bytes(k))
            throw IoError(path + ": " + t.block_name(k) + " holds " + std::to_string(n) + " bytes (" +
                          tag_name(counts_tag) + "); uncompressed it needs " + std::to_string(t.decoded_bytes(k)) +
                          " (" + std::to_string(t.rows_in(k)) + " rows × " + std::to_string(t.row_bytes()) + " bytes)");
    }
    return t;
}

Pixels::Pixels(std::string path, Layout layout, bool big_endian)
    : m_path(std::move(path)), m_layout(std::move(layout)), m_big_endian(big_endian) {}

std::vector<double> Pixels::read(int x0, int y0, int x1, int y1) const {
    const Layout& t = m_layout;
    const int w = x1 - x0;
    std::vector<double> out(static_cast<size_t>(w) * static_cast<size_t>(y1 - y0));
    const int bx0 = x0 / t.block_width, bx1 = (x1 - 1) / t.block_width;
    const int by0 = y0 / t.block_height, by1 = (y1 - 1) / t.block_height;
    const int across = bx1 - bx0 + 1, blocks = across * (by1 - by0 + 1);
    // Blocks write disjoint parts of `out`, so the result does not depend on the split; of
    // several bad blocks the first in file order is reported, whatever the threads did.
    std::vector<std::exception_ptr> failed(static_cast<size_t>(blocks));
    tbb::parallel_for(tbb::blocked_range<int>(0, blocks, 1), [&](const tbb::blocked_range<int>& range) {
        std::ifstream in(m_path, std::ios::binary);
        std::vector<uint8_t> stored, decoded, scratch;
        for (int b = range.begin(); b != range.end(); ++b) {
            try {
                if (!in) throw IoError(m_path + ": cannot open for reading");
                const int bx = bx0 + b % across, by = by0 + b / across;
                const size_t k = static_cast<size_t>(by) * t.blocks_across + bx;
                // The part of the window this block covers, in image pixels.
                const int cx0 = std::max(x0, bx * t.block_width), cx1 = std::min(x1, (bx + 1) * t.block_width);
                const int ry0 = std::max(y0, by * t.block_height);
                const int ry1 = std::min(y1, by * t.block_height + t.rows_in(k));
                read_block(in, k, bx, by, cx0, cx1, ry0, ry1, x0, y0, w, stored, decoded, scratch, out);
            } catch (...) {
                failed[static_cast<size_t>(b)] = std::current_exception();
                in.clear();  // a failed read leaves the stream unusable for the next block
            }
        }
    });
    for (const std::exception_ptr& e : failed)
        if (e) std::rethrow_exception(e);
    return out;
}

/// Image rows [ry0, ry1) × columns [cx0, cx1) of block k (at block column bx, row by) →
/// `out`, whose pixel (0, 0) is image (x0, y0) and rows are w wide.
void Pixels::read_block(std::ifstream& in, size_t k, int bx, int by, int cx0, int cx1, int ry0, int ry1, int x0, int y0,
                        int w, std::vector<uint8_t>& stored, std::vector<uint8_t>& decoded,
                        std::vector<uint8_t>& scratch, std::vector<double>& out) const {
    const Layout& t = m_layout;
    const unsigned bytes = sample_bytes(t.type);
    const uint64_t row_bytes = t.row_bytes();
    const size_t n = static_cast<size_t>(cx1 - cx0);
    const uint64_t skip = static_cast<uint64_t>(cx0 - bx * t.block_width) * bytes;
    auto where = [&] { return m_path + ": " + t.block_name(k) + ": "; };
    if (t.compression == kCompressionNone) {
        // Only the bytes the window needs, row by row (a one-strip file may be gigabytes).
        stored.resize(n * bytes);
        for (int r = ry0; r < ry1; ++r) {
            const uint64_t at = t.offsets[k] + static_cast<uint64_t>(r - by * t.block_height) * row_bytes + skip;
            in.seekg(static_cast<std::streamoff>(at));
            in.read(reinterpret_cast<char*>(stored.data()), static_cast<std::streamsize>(stored.size()));
            if (!in)
                throw IoError(where() + "cannot read row " + std::to_string(r) +
                              " (the file changed since it was opened?)");
            widen(t.type, stored.data(), n, m_big_endian, out.data() + static_cast<size_t>(r - y0) * w + (cx0 - x0));
        }
        return;
    }
    stored.resize(static_cast<size_t>(t.byte_counts[k]));
    in.seekg(static_cast<std::streamoff>(t.offsets[k]));
    in.read(reinterpret_cast<char*>(stored.data()), static_cast<std::streamsize>(stored.size()));
    if (!in)
        throw IoError(where() + "cannot read its " + std::to_string(stored.size()) +
                      " bytes (the file changed since it was opened?)");
    // Room for a whole strip: some writers pad the last strip to RowsPerStrip rows, which
    // libtiff reads; a stream longer than that is refused.
    decoded.resize(static_cast<size_t>(t.block_height * row_bytes));
    size_t produced = 0;
    try {
        if (t.compression == kCompressionLzw) produced = lzw_block(stored, decoded);
        else if (t.compression == kCompressionPackBits) produced = packbits_block(stored, decoded);
        else produced = inflate_block(stored, decoded);
    } catch (const DecodeError& e) {
        throw IoError(where() + e.what());
    }
    const uint64_t expected = t.decoded_bytes(k);
    if (produced < expected)
        throw IoError(where() + compression_name(t.compression) + " data decode to " + std::to_string(produced) +
                      " bytes; the " + (t.tiled ? "tile" : "strip") + " needs " + std::to_string(expected) + " (" +
                      std::to_string(t.rows_in(k)) + " rows × " + std::to_string(row_bytes) + " bytes)");
    const int row0 = by * t.block_height;
    for (int r = ry0; r < ry1; ++r) {
        uint8_t* row = decoded.data() + static_cast<size_t>(r - row0) * row_bytes;
        // Predictors run along whole block rows, so undo them on the full row.
        if (t.predictor == kPredictorHorizontal)
            undo_horizontal(row, static_cast<size_t>(t.block_width), bytes, m_big_endian);
        else if (t.predictor == kPredictorFloatingPoint)
            undo_floating_point(row, static_cast<size_t>(t.block_width), bytes, m_big_endian, scratch);
        widen(t.type, row + skip, n, m_big_endian, out.data() + static_cast<size_t>(r - y0) * w + (cx0 - x0));
    }
}

}  // namespace moonbot::tiff
