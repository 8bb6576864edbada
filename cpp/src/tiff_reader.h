// Internal to the core: a reader of the first image of a TIFF 6.0 or BigTIFF file, as much as the
// DEM raster (dem_raster.h) needs: the fields of its directory (the baseline layout tags and the
// GeoTIFF and GDAL tags a georeference is read from), the layout of its one band in strips or
// tiles, and windows of its samples decoded to doubles (uncompressed, LZW, Deflate or PackBits;
// predictor none, horizontal or floating point). Samples are the file's raw values, before any
// scale or offset; windows are in pixels, column u and row v, row 0 the file's first row. Every
// count and offset is checked against the file's size, and every failure is an IoError naming
// the file and the tag or the strip/tile.
//
// Why a reader of its own: OpenImageIO 2.4 keeps none of the GeoTIFF tags (33550, 33922,
// 34735–34737) or GDAL's (42112, 42113) in its ImageSpec — `oiiotool -v` on a GeoTIFF lists only
// tiff:* basics — and libtiff's headers are not installed. The directory is a short, fixed layout
// (TIFF 6.0 §2; BigTIFF: 8-byte counts and offsets). The pixels are decoded here too:
// OpenImageIO 2.4.7 returns zeros with success for a strip that lies past the end of a truncated
// file or whose deflate stream decodes short, and for any read of a tiled float64 TIFF.
#pragma once

#include <algorithm>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace moonbot::tiff {

// The tags the directory keeps (TIFF 6.0 §8; GeoTIFF 1.0 §2.4; GDAL's metadata and nodata).
constexpr uint16_t kTagImageWidth = 256;
constexpr uint16_t kTagImageLength = 257;
constexpr uint16_t kTagBitsPerSample = 258;
constexpr uint16_t kTagCompression = 259;
constexpr uint16_t kTagFillOrder = 266;
constexpr uint16_t kTagStripOffsets = 273;
constexpr uint16_t kTagSamplesPerPixel = 277;
constexpr uint16_t kTagRowsPerStrip = 278;
constexpr uint16_t kTagStripByteCounts = 279;
constexpr uint16_t kTagPredictor = 317;
constexpr uint16_t kTagTileWidth = 322;
constexpr uint16_t kTagTileLength = 323;
constexpr uint16_t kTagTileOffsets = 324;
constexpr uint16_t kTagTileByteCounts = 325;
constexpr uint16_t kTagSampleFormat = 339;
constexpr uint16_t kTagModelPixelScale = 33550;
constexpr uint16_t kTagModelTiepoint = 33922;
constexpr uint16_t kTagModelTransformation = 34264;
constexpr uint16_t kTagGeoKeyDirectory = 34735;
constexpr uint16_t kTagGeoDoubleParams = 34736;
constexpr uint16_t kTagGeoAsciiParams = 34737;
constexpr uint16_t kTagGdalMetadata = 42112;
constexpr uint16_t kTagGdalNodata = 42113;

/// "StripOffsets (273)" for the tags this reader names in messages, else "tag N".
std::string tag_name(uint16_t tag);

/// The first image file directory (IFD) of a TIFF or BigTIFF file: the fields of the tags listed
/// above, read and checked against the file's size when constructed. Throws IoError naming the
/// file (and the field) if it is not a TIFF, is cut short or holds an implausibly large field.
class Directory {
public:
    explicit Directory(const std::string& path);

    const std::string& path() const { return m_path; }
    uint64_t file_size() const { return m_size; }
    bool big_endian() const { return m_big_endian; }
    bool has(uint16_t tag) const { return m_fields.count(tag) != 0; }

    /// A numeric field's values as doubles (exact for every integer type up to 2⁵³). `name`
    /// stands for the tag in messages.
    std::vector<double> numbers(uint16_t tag, const std::string& name) const;
    /// An unsigned integer field (BYTE, SHORT, LONG or LONG8) exactly, as a file's offsets,
    /// counts and sizes are stored.
    std::vector<uint64_t> uints(uint16_t tag) const;
    /// A single unsigned value, or `fallback` (the TIFF 6.0 default) when the tag is absent.
    uint64_t uint_or(uint16_t tag, uint64_t fallback) const;
    /// An ASCII field up to its first NUL.
    std::string text(uint16_t tag, const std::string& name) const;

private:
    struct Field {
        uint16_t type;
        uint64_t count;
        std::vector<uint8_t> bytes;
    };

    static bool wanted(uint16_t tag);
    static unsigned type_size(uint16_t type);
    const Field& field(uint16_t tag, const std::string& name) const;
    uint64_t uint_at(const std::vector<uint8_t>& b, size_t at, unsigned n) const;
    std::vector<uint8_t> read_at(std::ifstream& in, uint64_t offset, uint64_t n, const std::string& what) const;

    std::string m_path;
    uint64_t m_size = 0;
    bool m_big_endian = false, m_big = false;
    std::map<uint16_t, Field> m_fields;
};

/// The sample types a DEM may hold.
enum class SampleType { UInt8, Int8, UInt16, Int16, UInt32, Int32, Float32, Float64 };

/// Bytes of one sample of type `t`.
unsigned sample_bytes(SampleType t);
/// "int16", "float32", ...
const char* sample_type_name(SampleType t);

// TIFF compression and predictor codes (TIFF 6.0 §§9, 13, 14; Adobe Photoshop TIFF Technical
// Notes (2002) for Deflate 8; Adobe TIFF Technical Note 3 (2005) for the floating-point predictor).
constexpr uint64_t kCompressionNone = 1, kCompressionLzw = 5, kCompressionDeflate = 8, kCompressionDeflateOld = 32946,
                   kCompressionPackBits = 32773;
constexpr uint64_t kPredictorNone = 1, kPredictorHorizontal = 2, kPredictorFloatingPoint = 3;

/// How a GeoTIFF's samples are laid out: strips (blocks of whole rows) or tiles, each stored at
/// an offset with a byte count, compressed or not. Everything is checked against TIFF 6.0 and
/// the file's size when it is read, so a truncated file fails on opening, naming the block.
struct Layout {
    int width = 0, height = 0;
    bool tiled = false;
    /// A block's size in pixels: strips are `width` × RowsPerStrip; edge tiles are whole tiles
    /// padded past the image (TIFF 6.0 §15), the last strip holds only the rows left.
    int block_width = 0, block_height = 0;
    int blocks_across = 0, blocks_down = 0;
    SampleType type = SampleType::Float32;
    uint64_t compression = kCompressionNone, predictor = kPredictorNone;
    std::vector<uint64_t> offsets, byte_counts;

    size_t block_count() const { return static_cast<size_t>(blocks_across) * static_cast<size_t>(blocks_down); }
    uint64_t row_bytes() const { return static_cast<uint64_t>(block_width) * sample_bytes(type); }
    /// Rows of image data block k holds (a strip at the bottom may hold fewer than a whole strip).
    int rows_in(size_t k) const {
        if (tiled) return block_height;
        const int y0 = static_cast<int>(k) * block_height;
        return std::min(block_height, height - y0);
    }
    /// Bytes block k must decode to.
    uint64_t decoded_bytes(size_t k) const { return static_cast<uint64_t>(rows_in(k)) * row_bytes(); }
    /// "strip 12 (rows 192–207)" or "tile 40 (rows 128–191, columns 512–575)".
    std::string block_name(size_t k) const;
};

/// Reads and checks the pixel layout of the first image: one band of a supported sample type,
/// a supported compression and predictor, sane dimensions, and a block table whose every block
/// lies inside the file (and, uncompressed, is long enough). Throws IoError naming the file and
/// the tag or the block.
Layout read_layout(const Directory& dir);

/// The samples of a checked layout, decoded block by block (strips or tiles; none, LZW, Deflate
/// or PackBits; predictors 1–3) in parallel. Every block read must decode to exactly its size, so
/// a damaged file is an IoError naming it and the block, never zeros.
class Pixels {
public:
    Pixels(std::string path, Layout layout, bool big_endian);

    const Layout& layout() const { return m_layout; }
    /// Raw samples of pixels [x0, x1) × [y0, y1) as doubles (exactly), row-major. The window
    /// must be non-empty and inside the image (the caller checks it).
    std::vector<double> read(int x0, int y0, int x1, int y1) const;

private:
    void read_block(std::ifstream& in, size_t k, int bx, int by, int cx0, int cx1, int ry0, int ry1, int x0, int y0,
                    int w, std::vector<uint8_t>& stored, std::vector<uint8_t>& decoded, std::vector<uint8_t>& scratch,
                    std::vector<double>& out) const;

    std::string m_path;
    Layout m_layout;
    bool m_big_endian;
};

}  // namespace moonbot::tiff
