#include "moonbot/dem.h"

#include <OpenImageIO/imageio.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "moonbot/image.h"

namespace moonbot {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;
double rad(double deg) { return deg * (kPi / 180.0); }
double deg(double r) { return r * (180.0 / kPi); }

std::string fmt(double v, int digits = 6) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    return s.str();
}

std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

/// A missing or unreadable file is an IoError naming it, before any decoder sees the path.
void require_regular_file(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError(path + ": no such file");
    if (!std::filesystem::is_regular_file(path, ec)) throw IoError(path + ": not a regular file");
}

// ---------------------------------------------------------------------------------------------
// TIFF directory. OpenImageIO 2.4 keeps none of the GeoTIFF tags (33550, 33922, 34735–34737) or
// GDAL's (42112, 42113) in its ImageSpec — `oiiotool -v` on a GeoTIFF lists only tiff:* basics —
// and libtiff's headers are not installed. The directory is a short, fixed layout (TIFF 6.0 §2;
// BigTIFF: 8-byte counts and offsets), so it is read here, with every count and offset checked
// against the file size. The pixels are decoded here too (below): OpenImageIO 2.4.7 returns
// zeros with success for a strip that lies past the end of a truncated file or whose deflate
// stream decodes short, and for any read of a tiled float64 TIFF.

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

// A field larger than this is refused: no real georeference or block table needs it (2 M tile
// offsets in BigTIFF), and a corrupt count must not ask for gigabytes.
constexpr uint64_t kMaxFieldBytes = 16u << 20;

class TiffDirectory {
public:
    explicit TiffDirectory(const std::string& path) : m_path(path) {
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
                throw IoError(path + ": " + tag_name(tag) + " is implausibly large (" + std::to_string(count) +
                              " values)");
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

    const std::string& path() const { return m_path; }
    uint64_t file_size() const { return m_size; }
    bool big_endian() const { return m_big_endian; }
    bool has(uint16_t tag) const { return m_fields.count(tag) != 0; }

    /// A numeric field's values as doubles (exact for every integer type up to 2⁵³).
    std::vector<double> numbers(uint16_t tag, const std::string& name) const {
        const Field& f = field(tag, name);
        const unsigned size = type_size(f.type);
        std::vector<double> out;
        out.reserve(static_cast<size_t>(f.count));
        for (uint64_t i = 0; i < f.count; ++i) {
            const size_t at = static_cast<size_t>(i * size);
            const uint64_t u = uint_at(f.bytes, at, std::min(size, 8u));
            double v;
            switch (f.type) {
                case 1: case 3: case 4: case 16: v = static_cast<double>(u); break;  // unsigned
                case 6: v = static_cast<int8_t>(u); break;
                case 8: v = static_cast<int16_t>(u); break;
                case 9: v = static_cast<int32_t>(u); break;
                case 17: v = static_cast<double>(static_cast<int64_t>(u)); break;
                case 11: { uint32_t b = static_cast<uint32_t>(u); float x; std::memcpy(&x, &b, 4); v = x; break; }
                case 12: std::memcpy(&v, &u, 8); break;
                case 5: case 10: {
                    const uint64_t num = uint_at(f.bytes, at, 4), den = uint_at(f.bytes, at + 4, 4);
                    v = f.type == 5 ? static_cast<double>(num) / static_cast<double>(den)
                                    : static_cast<double>(static_cast<int32_t>(num)) /
                                          static_cast<double>(static_cast<int32_t>(den));
                    break;
                }
                default:
                    throw IoError(m_path + ": " + name + " is not numeric (TIFF type " + std::to_string(f.type) + ")");
            }
            out.push_back(v);
        }
        return out;
    }

    /// An unsigned integer field (BYTE, SHORT, LONG or LONG8) exactly, as a file's offsets,
    /// counts and sizes are stored.
    std::vector<uint64_t> uints(uint16_t tag) const {
        const Field& f = field(tag, tag_name(tag));
        if (f.type != 1 && f.type != 3 && f.type != 4 && f.type != 16)
            throw IoError(m_path + ": " + tag_name(tag) + " is not an unsigned integer (TIFF type " +
                          std::to_string(f.type) + ")");
        const unsigned size = type_size(f.type);
        std::vector<uint64_t> out(static_cast<size_t>(f.count));
        for (size_t i = 0; i < out.size(); ++i) out[i] = uint_at(f.bytes, i * size, size);
        return out;
    }

    /// A single unsigned value, or `fallback` (the TIFF 6.0 default) when the tag is absent.
    uint64_t uint_or(uint16_t tag, uint64_t fallback) const {
        if (!has(tag)) return fallback;
        const std::vector<uint64_t> v = uints(tag);
        if (v.empty()) throw IoError(m_path + ": " + tag_name(tag) + " holds no value");
        // BitsPerSample and SampleFormat hold one value per sample; the band count is checked
        // on its own (SamplesPerPixel), so the first stands for all.
        return v[0];
    }

    /// An ASCII field up to its first NUL.
    std::string text(uint16_t tag, const std::string& name) const {
        const Field& f = field(tag, name);
        if (f.type != 2 && f.type != 1 && f.type != 7)
            throw IoError(m_path + ": " + name + " is not ASCII (TIFF type " + std::to_string(f.type) + ")");
        std::string s(f.bytes.begin(), f.bytes.end());
        return s.substr(0, s.find('\0'));
    }

private:
    struct Field {
        uint16_t type;
        uint64_t count;
        std::vector<uint8_t> bytes;
    };

    static bool wanted(uint16_t tag) {
        switch (tag) {
            case kTagImageWidth: case kTagImageLength: case kTagBitsPerSample: case kTagCompression:
            case kTagFillOrder: case kTagStripOffsets: case kTagSamplesPerPixel: case kTagRowsPerStrip:
            case kTagStripByteCounts: case kTagPredictor: case kTagTileWidth: case kTagTileLength:
            case kTagTileOffsets: case kTagTileByteCounts: case kTagSampleFormat:
            case kTagModelPixelScale: case kTagModelTiepoint:
            case kTagModelTransformation: case kTagGeoKeyDirectory: case kTagGeoDoubleParams:
            case kTagGeoAsciiParams: case kTagGdalMetadata: case kTagGdalNodata:
                return true;
            default:
                return false;
        }
    }

    static unsigned type_size(uint16_t type) {
        switch (type) {
            case 1: case 2: case 6: case 7: return 1;
            case 3: case 8: return 2;
            case 4: case 9: case 11: case 13: return 4;
            case 5: case 10: case 12: case 16: case 17: case 18: return 8;
            default: return 0;
        }
    }

    const Field& field(uint16_t tag, const std::string& name) const {
        auto it = m_fields.find(tag);
        if (it == m_fields.end()) throw IoError(m_path + ": no " + name + " tag");
        return it->second;
    }

    uint64_t uint_at(const std::vector<uint8_t>& b, size_t at, unsigned n) const {
        uint64_t v = 0;
        for (unsigned k = 0; k < n; ++k) {
            const uint64_t byte = b[at + k];
            v |= m_big_endian ? byte << (8 * (n - 1 - k)) : byte << (8 * k);
        }
        return v;
    }

    std::vector<uint8_t> read_at(std::ifstream& in, uint64_t offset, uint64_t n, const std::string& what) const {
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
    uint64_t m_size = 0;
    bool m_big_endian = false, m_big = false;
    std::map<uint16_t, Field> m_fields;
};

// GeoKey ids (GeoTIFF 1.0 §6.2) and the codes this reader accepts.
constexpr int kGTModelType = 1024, kGTRasterType = 1025, kGeogAngularUnits = 2054,
              kGeogSemiMajorAxis = 2057, kGeogSemiMinorAxis = 2058, kGeogInvFlattening = 2059,
              kProjectedCSType = 3072, kProjCoordTrans = 3075, kProjLinearUnits = 3076,
              kProjStdParallel1 = 3078, kProjNatOriginLong = 3080, kProjNatOriginLat = 3081,
              kProjFalseEasting = 3082, kProjFalseNorthing = 3083, kProjCenterLong = 3088,
              kProjCenterLat = 3089, kProjScaleAtNatOrigin = 3092, kProjStraightVertPoleLong = 3095;
constexpr int kModelProjected = 1, kModelGeographic = 2;
constexpr int kRasterPixelIsArea = 1, kRasterPixelIsPoint = 2;
constexpr int kUserDefined = 32767, kCTEquirectangular = 17, kCTOrthographic = 21, kCTPolarStereographic = 15,
              kLinearMetre = 9001, kAngularDegree = 9102;

/// The numeric GeoKeys of a GeoKeyDirectory, each key's first value (SHORT inline or DOUBLE
/// from GeoDoubleParams); ASCII keys (citations) are skipped.
std::map<int, double> read_geokeys(const TiffDirectory& dir, const std::string& path) {
    if (!dir.has(kTagGeoKeyDirectory))
        throw IoError(path + ": no GeoKeyDirectory tag (34735); not a GeoTIFF?");
    const std::vector<double> keys = dir.numbers(kTagGeoKeyDirectory, "GeoKeyDirectory (34735)");
    if (keys.size() < 4 || keys[0] != 1.0)
        throw IoError(path + ": GeoKeyDirectory (34735) has no version-1 header");
    const size_t n = static_cast<size_t>(keys[3]);
    if (keys.size() < 4 + 4 * n)
        throw IoError(path + ": GeoKeyDirectory (34735) lists " + std::to_string(n) + " keys but holds " +
                      std::to_string((keys.size() - 4) / 4));
    std::vector<double> doubles;
    if (dir.has(kTagGeoDoubleParams)) doubles = dir.numbers(kTagGeoDoubleParams, "GeoDoubleParams (34736)");
    std::map<int, double> out;
    for (size_t k = 0; k < n; ++k) {
        const int id = static_cast<int>(keys[4 + 4 * k]);
        const int location = static_cast<int>(keys[5 + 4 * k]);
        const size_t count = static_cast<size_t>(keys[6 + 4 * k]);
        const size_t value = static_cast<size_t>(keys[7 + 4 * k]);
        if (count == 0) continue;
        if (location == 0) {
            out.emplace(id, static_cast<double>(value));
        } else if (location == kTagGeoDoubleParams) {
            if (value + count > doubles.size())
                throw IoError(path + ": GeoKey " + std::to_string(id) +
                              " points past GeoDoubleParams (34736)");
            out.emplace(id, doubles[value]);
        } else if (location == kTagGeoKeyDirectory) {
            if (value >= keys.size())
                throw IoError(path + ": GeoKey " + std::to_string(id) + " points past GeoKeyDirectory (34735)");
            out.emplace(id, keys[value]);
        }  // GeoAsciiParams (34737): citations only, not needed
    }
    return out;
}

DemGeoref georef_from_geotiff(const TiffDirectory& dir, const std::string& path, int width) {
    if (!dir.has(kTagModelPixelScale)) {
        if (dir.has(kTagModelTransformation))
            throw IoError(path + ": georeferenced by ModelTransformation (34264), which is not supported; "
                                 "need ModelPixelScale (33550) + ModelTiepoint (33922)");
        throw IoError(path + ": no ModelPixelScale tag (33550); not a GeoTIFF?");
    }
    if (!dir.has(kTagModelTiepoint)) throw IoError(path + ": no ModelTiepoint tag (33922); not a GeoTIFF?");
    const std::vector<double> scale = dir.numbers(kTagModelPixelScale, "ModelPixelScale (33550)");
    const std::vector<double> tie = dir.numbers(kTagModelTiepoint, "ModelTiepoint (33922)");
    if (scale.size() < 2) throw IoError(path + ": ModelPixelScale (33550) has fewer than 2 values");
    for (int i = 0; i < 2; ++i)
        if (!(std::isfinite(scale[i]) && scale[i] > 0))
            throw IoError(path + ": ModelPixelScale (33550) " + std::string(i ? "ScaleY" : "ScaleX") + " = " +
                          fmt(scale[i]) + "; must be positive");
    if (tie.size() != 6)
        throw IoError(path + ": ModelTiepoint (33922) holds " + std::to_string(tie.size() / 6) +
                      " tiepoints; only one (with ModelPixelScale) is supported");
    for (double t : tie)
        if (!std::isfinite(t)) throw IoError(path + ": ModelTiepoint (33922) holds a non-finite value");

    const std::map<int, double> keys = read_geokeys(dir, path);
    auto key = [&](int id) -> std::optional<double> {
        auto it = keys.find(id);
        return it == keys.end() ? std::nullopt : std::optional<double>(it->second);
    };
    auto require_code = [&](int id, const char* name, int want, const char* meaning) {
        if (auto v = key(id); v && *v != want)
            throw IoError(path + ": " + name + " (" + std::to_string(id) + ") = " + fmt(*v) +
                          "; only " + std::to_string(want) + " (" + meaning + ") is supported");
    };

    // PixelIsArea (the default): raster point (0, 0) is the outer corner of the first pixel, so
    // its centre is half a pixel in; PixelIsPoint: the tiepoint's raster point is a centre.
    double centre = 0.5;
    if (auto r = key(kGTRasterType)) {
        if (*r == kRasterPixelIsPoint) centre = 0.0;
        else if (*r != kRasterPixelIsArea)
            throw IoError(path + ": GTRasterTypeGeoKey (1025) = " + fmt(*r) + "; must be 1 (area) or 2 (point)");
    }
    DemGeoref g;
    g.dx = scale[0];
    g.dy = scale[1];
    g.x0 = tie[3] + (centre - tie[0]) * g.dx;
    g.y0 = tie[4] - (centre - tie[1]) * g.dy;

    const auto model = key(kGTModelType);
    if (!model) throw IoError(path + ": GeoKeyDirectory (34735) has no GTModelTypeGeoKey (1024)");
    require_code(kGeogAngularUnits, "GeogAngularUnitsGeoKey", kAngularDegree, "degree");
    if (*model == kModelGeographic) {
        g.kind = DemGeoref::Kind::Geographic;
        g.wrap_lon_deg = g.x0 + g.dx * (width - 1) / 2.0;
    } else if (*model == kModelProjected) {
        g.kind = DemGeoref::Kind::Equirectangular;
        if (auto ct = key(kProjCoordTrans)) {
            if (*ct == kCTOrthographic) g.kind = DemGeoref::Kind::Orthographic;
            else if (*ct == kCTPolarStereographic) g.kind = DemGeoref::Kind::PolarStereographic;
            else if (*ct != kCTEquirectangular)
                throw IoError(path + ": ProjCoordTransGeoKey (3075) = " + fmt(*ct) +
                              "; only 17 (equirectangular), 21 (orthographic) or 15 (polar stereographic) "
                              "is supported");
        } else if (auto cs = key(kProjectedCSType); cs && *cs != kUserDefined) {
            throw IoError(path + ": ProjectedCSTypeGeoKey (3072) = " + fmt(*cs) +
                          " (an EPSG projection); only user-defined projections (ProjCoordTransGeoKey) are supported");
        }
        require_code(kProjLinearUnits, "ProjLinearUnitsGeoKey", kLinearMetre, "metre");
        if (auto a = key(kGeogSemiMajorAxis)) {
            if (!(std::isfinite(*a) && *a > 0))
                throw IoError(path + ": GeogSemiMajorAxisGeoKey (2057) = " + fmt(*a) + "; must be positive");
            g.radius_m = *a;
            if (auto b = key(kGeogSemiMinorAxis); b && *b != *a)
                throw IoError(path + ": GeogSemiMinorAxisGeoKey (2058) differs from the semi-major axis; "
                                     "only a sphere is supported");
        }
        if (auto f = key(kGeogInvFlattening); f && *f != 0.0)
            throw IoError(path + ": GeogInvFlatteningGeoKey (2059) = " + fmt(*f) + "; only a sphere is supported");
        // Writers name the central meridian and latitude of origin with either the "Center" or
        // the "NatOrigin" keys; the Center keys win when both are present.
        g.center_lon_deg = key(kProjCenterLong).value_or(key(kProjNatOriginLong).value_or(0.0));
        g.origin_lat_deg = key(kProjCenterLat).value_or(key(kProjNatOriginLat).value_or(0.0));
        g.std_parallel_deg = key(kProjStdParallel1).value_or(0.0);
        g.false_easting_m = key(kProjFalseEasting).value_or(0.0);
        g.false_northing_m = key(kProjFalseNorthing).value_or(0.0);
        if (g.kind == DemGeoref::Kind::PolarStereographic) {
            // The pole's meridian has its own key; writers also use the natural-origin one.
            g.center_lon_deg = key(kProjStraightVertPoleLong).value_or(key(kProjNatOriginLong).value_or(0.0));
            // Variant A names the pole and k0; variant B names the latitude of true scale φs
            // instead, which on a sphere is k0 = (1 + sin|φs|)/2 at the pole of φs's sign.
            const double lat = key(kProjNatOriginLat).value_or(90.0);
            const double k0 = key(kProjScaleAtNatOrigin).value_or(1.0);
            if (!(std::abs(lat) > 0.0 && std::abs(lat) <= 90.0))
                throw IoError(path + ": ProjNatOriginLatGeoKey (3081) = " + fmt(lat) +
                              "; a polar stereographic raster needs a pole or a latitude of true scale");
            if (std::abs(lat) != 90.0 && k0 != 1.0)
                throw IoError(path + ": both a latitude of true scale (3081 = " + fmt(lat) + ") and a scale (3092 = " +
                              fmt(k0) + ") are given; a polar stereographic raster takes one");
            g.origin_lat_deg = lat > 0 ? 90.0 : -90.0;
            g.scale_k0 = std::abs(lat) == 90.0 ? k0 : (1.0 + std::sin(rad(std::abs(lat)))) / 2.0;
        }
        g.wrap_lon_deg = g.center_lon_deg;
    } else {
        throw IoError(path + ": GTModelTypeGeoKey (1024) = " + fmt(*model) +
                      "; only 1 (projected, equirectangular) or 2 (geographic) is supported");
    }
    try {
        g.validate();
    } catch (const std::invalid_argument& e) {
        throw IoError(path + ": georeference: " + e.what());
    }
    return g;
}

/// A number in a GDAL text field: the whole string (bar surrounding blanks) must parse.
std::optional<double> parse_number(std::string s) {
    const auto blank = [](unsigned char c) { return std::isspace(c) != 0; };
    s.erase(s.begin(), std::find_if_not(s.begin(), s.end(), blank));
    s.erase(std::find_if_not(s.rbegin(), s.rend(), blank).base(), s.end());
    if (s.empty()) return std::nullopt;
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || errno == ERANGE) return std::nullopt;
    return v;
}

/// GDAL_METADATA (42112) is a small XML document of <Item name=".." sample=".." role="..">value</Item>
/// elements; band 0's items with role "scale" and "offset" give the raw → height transform.
void parse_gdal_metadata(const std::string& xml, const std::string& path, double& scale, double& offset) {
    size_t pos = 0;
    bool have_scale = false, have_offset = false;
    while ((pos = xml.find("<Item", pos)) != std::string::npos) {
        const size_t tag_end = xml.find('>', pos);
        if (tag_end == std::string::npos) break;
        const std::string attrs = xml.substr(pos + 5, tag_end - pos - 5);
        auto attr = [&](const std::string& name) -> std::optional<std::string> {
            for (size_t at = 0; (at = attrs.find(name, at)) != std::string::npos; at += name.size()) {
                // Whole attribute names only: "role" must not match inside "xrole".
                if (at > 0 && !std::isspace(static_cast<unsigned char>(attrs[at - 1]))) continue;
                size_t eq = attrs.find_first_not_of(" \t\r\n", at + name.size());
                if (eq == std::string::npos || attrs[eq] != '=') continue;
                const size_t q = attrs.find_first_not_of(" \t\r\n", eq + 1);
                if (q == std::string::npos || (attrs[q] != '"' && attrs[q] != '\'')) continue;
                const size_t close = attrs.find(attrs[q], q + 1);
                if (close == std::string::npos) return std::nullopt;
                return attrs.substr(q + 1, close - q - 1);
            }
            return std::nullopt;
        };
        pos = tag_end + 1;
        const auto role = attr("role");
        const auto sample = attr("sample");
        if (!role || (sample && *sample != "0")) continue;
        const size_t close = xml.find("</Item>", pos);
        if (close == std::string::npos)
            throw IoError(path + ": GDAL_METADATA (42112): unterminated <Item role=\"" + *role + "\">");
        const std::string body = xml.substr(pos, close - pos);
        if (*role != "scale" && *role != "offset") continue;
        const auto v = parse_number(body);
        if (!v || !std::isfinite(*v))
            throw IoError(path + ": GDAL_METADATA (42112): " + *role + " '" + body + "' is not a finite number");
        if (*role == "scale" && !have_scale) {
            scale = *v;
            have_scale = true;
        } else if (*role == "offset" && !have_offset) {
            offset = *v;
            have_offset = true;
        }
    }
    if (have_scale && scale == 0.0) throw IoError(path + ": GDAL_METADATA (42112): scale is 0");
}

// ---------------------------------------------------------------------------------------------
// Pixel sources.

/// The sample types a DEM may hold.
enum class SampleType { UInt8, Int8, UInt16, Int16, UInt32, Int32, Float32, Float64 };

unsigned sample_bytes(SampleType t) {
    switch (t) {
        case SampleType::UInt8: case SampleType::Int8: return 1;
        case SampleType::UInt16: case SampleType::Int16: return 2;
        case SampleType::UInt32: case SampleType::Int32: case SampleType::Float32: return 4;
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

// TIFF compression and predictor codes (TIFF 6.0 §§9, 13, 14; Adobe Photoshop TIFF Technical
// Notes (2002) for Deflate 8; Adobe TIFF Technical Note 3 (2005) for the floating-point predictor).
constexpr uint64_t kCompressionNone = 1, kCompressionLzw = 5, kCompressionDeflate = 8,
                   kCompressionDeflateOld = 32946, kCompressionPackBits = 32773;
constexpr uint64_t kPredictorNone = 1, kPredictorHorizontal = 2, kPredictorFloatingPoint = 3;

std::string compression_name(uint64_t c) {
    switch (c) {
        case kCompressionNone: return "none";
        case kCompressionLzw: return "LZW";
        case kCompressionDeflate: case kCompressionDeflateOld: return "Deflate";
        case kCompressionPackBits: return "PackBits";
        case 2: case 3: case 4: return "CCITT";
        case 6: case 7: return "JPEG";
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

/// How a GeoTIFF's samples are laid out: strips (blocks of whole rows) or tiles, each stored at
/// an offset with a byte count, compressed or not. Everything is checked against TIFF 6.0 and
/// the file's size when it is read, so a truncated file fails on opening, naming the block.
struct TiffLayout {
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
    std::string block_name(size_t k) const {
        const int bx = static_cast<int>(k % static_cast<size_t>(blocks_across));
        const int by = static_cast<int>(k / static_cast<size_t>(blocks_across));
        const int y0 = by * block_height, y1 = std::min(height, y0 + block_height) - 1;
        std::string s = std::string(tiled ? "tile " : "strip ") + std::to_string(k) + " (rows " + std::to_string(y0) +
                        "–" + std::to_string(y1);
        if (tiled) {
            const int x0 = bx * block_width, x1 = std::min(width, x0 + block_width) - 1;
            s += ", columns " + std::to_string(x0) + "–" + std::to_string(x1);
        }
        return s + ")";
    }
};

/// Reads and checks the pixel layout of the first image: one band of a supported sample type,
/// a supported compression and predictor, sane dimensions, and a block table whose every block
/// lies inside the file (and, uncompressed, is long enough). Throws IoError naming the file and
/// the tag or the block.
TiffLayout read_tiff_layout(const TiffDirectory& dir) {
    const std::string& path = dir.path();
    TiffLayout t;
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
    const char* format_name = format == 1 ? "unsigned integer" : format == 2 ? "signed integer"
                              : format == 3 ? "floating point" : "undefined";
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
        case kCompressionNone: case kCompressionLzw: case kCompressionDeflate: case kCompressionDeflateOld:
        case kCompressionPackBits: break;
        default:
            throw IoError(path + ": Compression (259) = " + std::to_string(t.compression) + " (" +
                          compression_name(t.compression) + ") is not supported; use none, LZW, Deflate or PackBits "
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
    for (const auto& [tag, list] : {std::pair<uint16_t, const std::vector<uint64_t>*>{offsets_tag, &t.offsets},
                                    {counts_tag, &t.byte_counts}})
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
                          std::to_string(at) + "–" + std::to_string(at + n - 1) + " (" + tag_name(offsets_tag) +
                          " " + std::to_string(at) + ", " + tag_name(counts_tag) + " " + std::to_string(n) +
                          "), the file has " + std::to_string(size) + " bytes (truncated?)");
        if (t.compression == kCompressionNone && n < t.decoded_bytes(k))
            throw IoError(path + ": " + t.block_name(k) + " holds " + std::to_string(n) + " bytes (" +
                          tag_name(counts_tag) + "); uncompressed it needs " + std::to_string(t.decoded_bytes(k)) +
                          " (" + std::to_string(t.rows_in(k)) + " rows × " + std::to_string(t.row_bytes()) + " bytes)");
    }
    return t;
}

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
        throw DecodeError("the Deflate stream decodes to more than the " + std::to_string(out.size()) + " bytes expected");
    if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT)
        throw DecodeError("the Deflate stream is corrupt after " + std::to_string(produced) + " bytes (zlib: " + why + ")");
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
            throw DecodeError("the LZW stream decodes to more than the " + std::to_string(out.size()) + " bytes expected");
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
            if (code > 255) throw DecodeError("the LZW stream is corrupt: code " + std::to_string(code) + " follows a Clear");
            emit(code);
            previous = static_cast<int>(code);
            continue;
        }
        if (code > next || (code == next && next >= kTableSize))
            throw DecodeError("the LZW stream is corrupt: code " + std::to_string(code) + " is not in the table (after " +
                              std::to_string(produced) + " bytes)");
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
            throw DecodeError("the PackBits data decode to more than the " + std::to_string(out.size()) + " bytes expected");
    };
    while (i < in.size()) {
        const int header = static_cast<int8_t>(in[i++]);
        if (header >= 0) {  // a literal run of header + 1 bytes
            const size_t n = static_cast<size_t>(header) + 1;
            if (n > in.size() - i)
                throw DecodeError("the PackBits data are cut short in a literal run (after " + std::to_string(produced) +
                                  " bytes)");
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

// Windows are decoded in pieces of about this many bytes, so a crop of a wide PNG never holds
// whole-width rows of the full crop height at once.
constexpr size_t kChunkBytes = 8u << 20;

}  // namespace

struct DemRaster::Source {
    virtual ~Source() = default;
    /// Raw samples of [x0, x1) × [y0, y1) as doubles, row-major.
    virtual std::vector<double> read_raw(int x0, int y0, int x1, int y1) const = 0;
    /// Float32 samples compare with the nodata value rounded to float32, as the writer stored it.
    bool float32 = false;
};

namespace {

/// A GeoTIFF's samples, decoded here block by block (strips or tiles; none, LZW, Deflate or
/// PackBits; predictors 1–3). Every block read must decode to exactly its size, so a damaged
/// file is an IoError naming it and the block, never zeros.
class TiffSource : public DemRaster::Source {
public:
    TiffSource(std::string path, TiffLayout layout, bool big_endian)
        : m_path(std::move(path)), m_layout(std::move(layout)), m_big_endian(big_endian) {
        float32 = m_layout.type == SampleType::Float32;
    }

    std::vector<double> read_raw(int x0, int y0, int x1, int y1) const override {
        const TiffLayout& t = m_layout;
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

private:
    /// Image rows [ry0, ry1) × columns [cx0, cx1) of block k (at block column bx, row by) →
    /// `out`, whose pixel (0, 0) is image (x0, y0) and rows are w wide.
    void read_block(std::ifstream& in, size_t k, int bx, int by, int cx0, int cx1, int ry0, int ry1, int x0, int y0,
                    int w, std::vector<uint8_t>& stored, std::vector<uint8_t>& decoded, std::vector<uint8_t>& scratch,
                    std::vector<double>& out) const {
        const TiffLayout& t = m_layout;
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
                if (!in) throw IoError(where() + "cannot read row " + std::to_string(r) + " (the file changed since it was opened?)");
                widen(t.type, stored.data(), n, m_big_endian, out.data() + static_cast<size_t>(r - y0) * w + (cx0 - x0));
            }
            return;
        }
        stored.resize(static_cast<size_t>(t.byte_counts[k]));
        in.seekg(static_cast<std::streamoff>(t.offsets[k]));
        in.read(reinterpret_cast<char*>(stored.data()), static_cast<std::streamsize>(stored.size()));
        if (!in) throw IoError(where() + "cannot read its " + std::to_string(stored.size()) + " bytes (the file changed since it was opened?)");
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

    std::string m_path;
    TiffLayout m_layout;
    bool m_big_endian;
};

/// A 16-bit PNG's samples, decoded by OpenImageIO row by row.
class PngSource : public DemRaster::Source {
public:
    PngSource(std::string path, const OIIO::ImageSpec& spec) : m_path(std::move(path)), m_spec(spec) {}

    std::vector<double> read_raw(int x0, int y0, int x1, int y1) const override {
        auto input = OIIO::ImageInput::open(m_path);
        if (!input) throw IoError(m_path + ": cannot open image (" + OIIO::geterror() + ")");
        const int w = x1 - x0;
        std::vector<double> out(static_cast<size_t>(w) * static_cast<size_t>(y1 - y0));
        const size_t row_bytes = static_cast<size_t>(m_spec.width) * sizeof(uint16_t);
        const int band = std::max(1, static_cast<int>(kChunkBytes / row_bytes));
        std::vector<uint16_t> buf;
        for (int yb = y0; yb < y1; yb += band) {
            const int ye = std::min(yb + band, y1);
            buf.resize(static_cast<size_t>(m_spec.width) * static_cast<size_t>(ye - yb));
            if (!input->read_scanlines(0, 0, yb + m_spec.y, ye + m_spec.y, m_spec.z, 0, 1, OIIO::TypeDesc::UINT16,
                                       buf.data()))
                throw IoError(m_path + ": cannot decode rows " + std::to_string(yb) + "–" + std::to_string(ye - 1) +
                              " (" + input->geterror() + ")");
            for (int r = yb; r < ye; ++r) {
                const uint16_t* src = buf.data() + static_cast<size_t>(r - yb) * m_spec.width + x0;
                double* dst = out.data() + static_cast<size_t>(r - y0) * w;
                for (int i = 0; i < w; ++i) dst[i] = src[i];
            }
        }
        return out;
    }

private:
    std::string m_path;
    OIIO::ImageSpec m_spec;
};

class MemorySource : public DemRaster::Source {
public:
    MemorySource(int width, std::vector<double> heights) : m_width(width), m_heights(std::move(heights)) {}
    std::vector<double> read_raw(int x0, int y0, int x1, int y1) const override {
        std::vector<double> out;
        out.reserve(static_cast<size_t>(x1 - x0) * static_cast<size_t>(y1 - y0));
        for (int y = y0; y < y1; ++y) {
            const auto row = m_heights.begin() + static_cast<std::ptrdiff_t>(y) * m_width;
            out.insert(out.end(), row + x0, row + x1);
        }
        return out;
    }

private:
    int m_width;
    std::vector<double> m_heights;
};

/// Opens a PNG with OpenImageIO and checks that it holds one band of 16-bit samples.
OIIO::ImageSpec open_png_spec(const std::string& path) {
    auto input = OIIO::ImageInput::open(path);
    if (!input) throw IoError(path + ": cannot open as a PNG (" + OIIO::geterror() + ")");
    const OIIO::ImageSpec spec = input->spec();
    if (spec.nchannels != 1)
        throw IoError(path + ": " + std::to_string(spec.nchannels) + " channels; a PNG heightmap has one band (grey)");
    if (spec.width < 2 || spec.height < 2)
        throw IoError(path + ": " + std::to_string(spec.width) + "×" + std::to_string(spec.height) +
                      " pixels; a DEM needs at least 2×2 to interpolate");
    if (spec.format.basetype != OIIO::TypeDesc::UINT16)
        throw IoError(path + ": " + std::string(spec.format.basetype == OIIO::TypeDesc::UINT8 ? "uint8" : spec.format.c_str()) +
                      " samples; a PNG heightmap must be 16-bit grey");
    return spec;
}

double apply_units(double file_value, const DemHeightUnits& u) { return file_value * u.height_scale + u.height_offset; }

void check_units(const DemHeightUnits& u) {
    if (!(std::isfinite(u.height_scale) && u.height_scale != 0.0))
        throw std::invalid_argument("height_scale: must be finite and non-zero");
    if (!std::isfinite(u.height_offset)) throw std::invalid_argument("height_offset: must be finite (metres)");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// DemGeoref

namespace {

const char* kind_name(DemGeoref::Kind kind) {
    switch (kind) {
    case DemGeoref::Kind::Geographic: return "geographic";
    case DemGeoref::Kind::Equirectangular: return "equirectangular";
    case DemGeoref::Kind::Orthographic: return "orthographic";
    case DemGeoref::Kind::PolarStereographic: return "polar stereographic";
    }
    return "?";
}

}  // namespace

void DemGeoref::validate() const {
    auto finite = [](double v, const char* name) {
        if (!std::isfinite(v)) throw std::invalid_argument(std::string(name) + ": must be finite");
    };
    finite(x0, "x0");
    finite(y0, "y0");
    if (!(std::isfinite(dx) && dx > 0)) throw std::invalid_argument("dx: must be positive and finite");
    if (!(std::isfinite(dy) && dy > 0)) throw std::invalid_argument("dy: must be positive and finite");
    finite(wrap_lon_deg, "wrap_lon_deg");
    if (kind != Kind::Geographic) {
        finite(center_lon_deg, "center_lon_deg");
        finite(false_easting_m, "false_easting_m");
        finite(false_northing_m, "false_northing_m");
        if (!(origin_lat_deg >= -90.0 && origin_lat_deg <= 90.0))
            throw std::invalid_argument("origin_lat_deg: must be in [-90, 90]");
        if (!(std::abs(std_parallel_deg) < 90.0))
            throw std::invalid_argument("std_parallel_deg: must be in (-90, 90)");
        if (!(std::isfinite(radius_m) && radius_m > 0)) throw std::invalid_argument("radius_m: must be positive");
        if (kind == Kind::PolarStereographic && std::abs(origin_lat_deg) != 90.0)
            throw std::invalid_argument("origin_lat_deg: a polar stereographic projection is about a pole (±90)");
        if (!(std::isfinite(scale_k0) && scale_k0 > 0)) throw std::invalid_argument("scale_k0: must be positive");
    }
}

glm::dvec2 DemGeoref::to_raster(double lat_deg, double lon_deg) const {
    // Move the longitude by whole turns into [wrap − 180, wrap + 180).
    const double lon = lon_deg - 360.0 * std::floor((lon_deg - wrap_lon_deg + 180.0) / 360.0);
    const double phi = rad(lat_deg), dlam = rad(lon - center_lon_deg), phi0 = rad(origin_lat_deg);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    double X = 0.0, Y = 0.0;
    switch (kind) {
    case Kind::Geographic:
        X = lon;
        Y = lat_deg;
        break;
    case Kind::Equirectangular:
        X = false_easting_m + radius_m * dlam * std::cos(rad(std_parallel_deg));
        Y = false_northing_m + radius_m * (phi - phi0);
        break;
    case Kind::Orthographic: {
        const double cos_c = std::sin(phi0) * std::sin(phi) + std::cos(phi0) * std::cos(phi) * std::cos(dlam);
        if (cos_c < 0) return {nan, nan};  // the far hemisphere is not in the picture
        X = false_easting_m + radius_m * std::cos(phi) * std::sin(dlam);
        Y = false_northing_m + radius_m * (std::cos(phi0) * std::sin(phi) - std::sin(phi0) * std::cos(phi) * std::cos(dlam));
        break;
    }
    case Kind::PolarStereographic: {
        const double s = origin_lat_deg > 0 ? 1.0 : -1.0;  // the pole's hemisphere
        const double rho = 2.0 * radius_m * scale_k0 * std::tan(kPi / 4 - s * phi / 2);
        X = false_easting_m + rho * std::sin(dlam);
        Y = false_northing_m - s * rho * std::cos(dlam);
        break;
    }
    }
    return {(X - x0) / dx, (y0 - Y) / dy};
}

glm::dvec2 DemGeoref::to_latlon(double u, double v) const {
    const double X = x0 + u * dx, Y = y0 - v * dy;
    const double x = X - false_easting_m, y = Y - false_northing_m, phi0 = rad(origin_lat_deg);
    switch (kind) {
    case Kind::Geographic:
        return {Y, X};
    case Kind::Equirectangular:
        return {origin_lat_deg + deg(y / radius_m), center_lon_deg + deg(x / (radius_m * std::cos(rad(std_parallel_deg))))};
    case Kind::Orthographic: {
        const double rho = std::hypot(x, y);
        if (rho > radius_m) return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
        if (rho == 0) return {origin_lat_deg, center_lon_deg};
        const double c = std::asin(rho / radius_m);
        const double phi = std::asin(std::clamp(std::cos(c) * std::sin(phi0) + y * std::sin(c) * std::cos(phi0) / rho, -1.0, 1.0));
        const double lam = std::atan2(x * std::sin(c), rho * std::cos(phi0) * std::cos(c) - y * std::sin(phi0) * std::sin(c));
        return {deg(phi), center_lon_deg + deg(lam)};
    }
    case Kind::PolarStereographic: {
        const double s = origin_lat_deg > 0 ? 1.0 : -1.0;
        const double rho = std::hypot(x, y);
        const double phi = s * (kPi / 2 - 2.0 * std::atan(rho / (2.0 * radius_m * scale_k0)));
        return {deg(phi), center_lon_deg + deg(std::atan2(x, -s * y))};
    }
    }
    return {0.0, 0.0};  // unreachable: every kind returns above
}

glm::dvec2 DemGeoref::pixel_size_m(double lat_deg, double lon_deg) const {
    const double c = std::cos(rad(lat_deg));
    if (kind == Kind::Geographic) return {kLunarRadius * c * rad(dx), kLunarRadius * rad(dy)};
    // A model metre along a parallel spans 1/(R cos φs) radians of longitude; along a meridian 1/R.
    if (kind == Kind::Equirectangular)
        return {kLunarRadius * c * dx / (radius_m * std::cos(rad(std_parallel_deg))), kLunarRadius * dy / radius_m};
    // The others' scale varies across the raster: measure the pixel's u and v steps on the sphere
    // (central differences; their error is of order (pixel / R)², far below a millimetre).
    const glm::dvec2 uv = to_raster(lat_deg, lon_deg);
    auto arc = [&](glm::dvec2 a, glm::dvec2 b) {
        const glm::dvec2 p = to_latlon(a.x, a.y), q = to_latlon(b.x, b.y);
        const double s = std::sin(rad(q.x - p.x) / 2), t = std::sin(rad(q.y - p.y) / 2);
        const double h = s * s + std::cos(rad(p.x)) * std::cos(rad(q.x)) * t * t;
        return 2.0 * kLunarRadius * std::asin(std::min(1.0, std::sqrt(h)));  // haversine
    };
    return {arc(uv - glm::dvec2(0.5, 0.0), uv + glm::dvec2(0.5, 0.0)),
            arc(uv - glm::dvec2(0.0, 0.5), uv + glm::dvec2(0.0, 0.5))};
}

// ---------------------------------------------------------------------------------------------
// DemRaster

DemRaster DemRaster::open_geotiff(const std::string& path, const DemHeightUnits& units) {
    check_units(units);
    require_regular_file(path);
    const TiffDirectory dir(path);  // first: a non-TIFF fails here with a message naming it
    TiffLayout layout = read_tiff_layout(dir);

    DemRaster r;
    r.m_name = path;
    r.m_width = layout.width;
    r.m_height = layout.height;
    r.m_georef = georef_from_geotiff(dir, path, layout.width);
    double file_scale = 1.0, file_offset = 0.0;
    if (dir.has(kTagGdalMetadata))
        parse_gdal_metadata(dir.text(kTagGdalMetadata, "GDAL_METADATA (42112)"), path, file_scale, file_offset);
    r.m_scale = file_scale * units.height_scale;
    r.m_offset = apply_units(file_offset, units);
    if (units.nodata) {
        r.m_nodata = units.nodata;
    } else if (dir.has(kTagGdalNodata)) {
        const std::string text = dir.text(kTagGdalNodata, "GDAL_NODATA (42113)");
        const auto v = parse_number(text);
        if (!v) throw IoError(path + ": GDAL_NODATA (42113) '" + text + "' is not a number");
        r.m_nodata = *v;
    }
    r.m_description = std::string("GeoTIFF ") + sample_type_name(layout.type) + ", " + kind_name(r.m_georef.kind);
    r.m_source = std::make_shared<TiffSource>(path, std::move(layout), dir.big_endian());
    return r;
}

DemRaster DemRaster::open_png(const std::string& path, const DemPngLayout& layout, const DemHeightUnits& units) {
    check_units(units);
    if (!(std::isfinite(layout.min_m) && std::isfinite(layout.max_m) && layout.max_m > layout.min_m))
        throw std::invalid_argument("png_range: max must exceed min (metres), both finite");
    if (!(std::isfinite(layout.pixel_m) && layout.pixel_m > 0))
        throw std::invalid_argument("png_pixel_m: must be positive and finite (metres)");
    if (!(std::abs(layout.center_lat_deg) < 90.0))
        throw std::invalid_argument("png center_lat_deg: must be in (-90, 90) degrees");
    if (!std::isfinite(layout.center_lon_deg)) throw std::invalid_argument("png center_lon_deg: must be finite");
    require_regular_file(path);
    const OIIO::ImageSpec spec = open_png_spec(path);

    DemRaster r;
    r.m_name = path;
    r.m_width = spec.width;
    r.m_height = spec.height;
    // A local equirectangular grid true to scale at the centre: the image centre is model (0, 0).
    DemGeoref& g = r.m_georef;
    g.kind = DemGeoref::Kind::Equirectangular;
    g.dx = g.dy = layout.pixel_m;
    g.x0 = -(spec.width - 1) / 2.0 * layout.pixel_m;
    g.y0 = (spec.height - 1) / 2.0 * layout.pixel_m;
    g.center_lon_deg = g.wrap_lon_deg = layout.center_lon_deg;
    g.origin_lat_deg = g.std_parallel_deg = layout.center_lat_deg;
    g.radius_m = kLunarRadius;
    g.validate();
    const double file_scale = (layout.max_m - layout.min_m) / 65535.0;
    r.m_scale = file_scale * units.height_scale;
    r.m_offset = apply_units(layout.min_m, units);
    r.m_nodata = units.nodata;
    r.m_description = "PNG uint16, local equirectangular";
    r.m_source = std::make_shared<PngSource>(path, spec);
    return r;
}

DemRaster DemRaster::open(const std::string& path, const DemHeightUnits& units,
                          const std::optional<DemPngLayout>& png) {
    const std::string ext = lower_extension(path);
    if (ext == ".tif" || ext == ".tiff") {
        if (png) throw std::invalid_argument("png_range/png_pixel_m: given for a GeoTIFF (" + path + ")");
        return open_geotiff(path, units);
    }
    if (ext == ".png") {
        if (!png)
            throw std::invalid_argument(path + ": a PNG heightmap needs png_range (min, max metres) and png_pixel_m");
        return open_png(path, *png, units);
    }
    throw IoError(path + ": unsupported DEM format '" + ext + "' (use .tif/.tiff GeoTIFF or a 16-bit .png)");
}

DemRaster DemRaster::from_heights(std::string name, int width, int height, std::vector<double> heights_m,
                                  const DemGeoref& georef) {
    if (width < 2 || height < 2) throw std::invalid_argument("width, height: a DEM needs at least 2×2 pixels");
    if (heights_m.size() != static_cast<size_t>(width) * static_cast<size_t>(height))
        throw std::invalid_argument("heights_m: size must be width × height");
    georef.validate();
    DemRaster r;
    r.m_name = std::move(name);
    r.m_width = width;
    r.m_height = height;
    r.m_georef = georef;
    r.m_description = "in-memory float64";
    r.m_source = std::make_shared<MemorySource>(width, std::move(heights_m));
    return r;
}

std::vector<double> DemRaster::read(int x0, int y0, int x1, int y1) const {
    if (!(0 <= x0 && x0 < x1 && x1 <= m_width && 0 <= y0 && y0 < y1 && y1 <= m_height))
        throw std::invalid_argument(m_name + ": window [" + std::to_string(x0) + ", " + std::to_string(x1) +
                                    ") × [" + std::to_string(y0) + ", " + std::to_string(y1) +
                                    ") is empty or leaves the raster");
    std::vector<double> z = m_source->read_raw(x0, y0, x1, y1);
    std::optional<double> marker = m_nodata;
    if (marker && m_source->float32) marker = static_cast<double>(static_cast<float>(*marker));
    for (double& v : z) {
        if (!std::isfinite(v) || (marker && v == *marker)) {
            v = kNaN;
        } else {
            v = v * m_scale + m_offset;
            if (!std::isfinite(v)) v = kNaN;  // out of double's range after scaling: no height
        }
    }
    return z;
}

// ---------------------------------------------------------------------------------------------
// Void filling

int64_t fill_voids(std::vector<double>& grid, int width, int height) {
    if (width < 1 || height < 1 || grid.size() != static_cast<size_t>(width) * static_cast<size_t>(height))
        throw std::invalid_argument("grid: size must be width × height");
    const size_t n = grid.size();
    std::vector<uint8_t> is_void(n);
    size_t voids = 0;
    for (size_t i = 0; i < n; ++i) {
        is_void[i] = !std::isfinite(grid[i]);
        voids += is_void[i];
    }
    if (voids == n) throw std::invalid_argument("grid: every cell is void");
    if (voids == 0) return 0;

    const auto W = static_cast<size_t>(width);
    std::vector<uint8_t> seen(n, 0);
    std::vector<size_t> cells;
    std::deque<size_t> queue;
    for (size_t start = 0; start < n; ++start) {
        if (!is_void[start] || seen[start]) continue;
        // One 4-connected void region, gathered breadth-first.
        cells.clear();
        queue.push_back(start);
        seen[start] = 1;
        while (!queue.empty()) {
            const size_t c = queue.front();
            queue.pop_front();
            cells.push_back(c);
            const size_t x = c % W, y = c / W;
            const size_t nb[4] = {x > 0 ? c - 1 : n, x + 1 < W ? c + 1 : n, y > 0 ? c - W : n,
                                  y + 1 < static_cast<size_t>(height) ? c + W : n};
            for (size_t m : nb)
                if (m != n && is_void[m] && !seen[m]) {
                    seen[m] = 1;
                    queue.push_back(m);
                }
        }
        // Raster order makes the sweep a plain lexicographic Gauss-Seidel, independent of the
        // breadth-first order.
        std::sort(cells.begin(), cells.end());
        size_t xmin = W, xmax = 0, ymin = n, ymax = 0;
        double seed = 0.0;
        size_t seeds = 0;
        for (size_t c : cells) {
            const size_t x = c % W, y = c / W;
            xmin = std::min(xmin, x), xmax = std::max(xmax, x), ymin = std::min(ymin, y), ymax = std::max(ymax, y);
            const size_t nb[4] = {x > 0 ? c - 1 : n, x + 1 < W ? c + 1 : n, y > 0 ? c - W : n,
                                  y + 1 < static_cast<size_t>(height) ? c + W : n};
            for (size_t m : nb)
                if (m != n && !is_void[m]) seed += grid[m], ++seeds;
        }
        // A maximal void region that is not the whole grid borders a finite cell, so seeds > 0.
        seed /= static_cast<double>(seeds);
        for (size_t c : cells) grid[c] = seed;
        // Successive over-relaxation with the optimal factor for a square of side L (Young):
        // ω = 2 / (1 + sin(π/(L+1))); it cuts the sweeps from O(L²) (Gauss-Seidel) to O(L).
        const double L = static_cast<double>(std::max(xmax - xmin, ymax - ymin) + 1);
        const double omega = 2.0 / (1.0 + std::sin(kPi / (L + 1.0)));
        const int max_sweeps = static_cast<int>(100.0 * L) + 1000;
        for (int sweep = 0; sweep < max_sweeps; ++sweep) {
            double moved = 0.0;
            for (size_t c : cells) {
                const size_t x = c % W, y = c / W;
                double sum = 0.0;
                int count = 0;
                // At the grid's edge only the neighbours inside count: zero normal slope there.
                if (x > 0) sum += grid[c - 1], ++count;
                if (x + 1 < W) sum += grid[c + 1], ++count;
                if (y > 0) sum += grid[c - W], ++count;
                if (y + 1 < static_cast<size_t>(height)) sum += grid[c + W], ++count;
                const double step = omega * (sum / count - grid[c]);
                grid[c] += step;
                moved = std::max(moved, std::abs(step));
            }
            if (moved < 1e-9) break;
        }
    }
    return static_cast<int64_t>(voids);
}

// ---------------------------------------------------------------------------------------------
// Import

namespace {

// Source pixels read beyond the footprint on every side, so a void at the footprint's edge is
// filled from data on both sides of it rather than from the window's edge.
constexpr int kFillMargin = 8;
constexpr int kMaxGridSide = 8193;
constexpr int64_t kMaxWindowPixels = int64_t(1) << 26;  // 512 MiB of float64
// Horizontal fixed-point tolerance, metres. 0.1 mm would do for the ground's shape; 1 µm costs
// about one more step and keeps the up error (≈ residual·d/R) below a nanometre.
constexpr double kConvergedM = 1e-6;
constexpr int kMaxIterations = 50;
// Raster coordinates within this of the outermost pixel centre count as inside (rounding).
constexpr double kEdgeSlack = 1e-9;

/// A bounding box in raster coordinates.
struct Box {
    double umin = std::numeric_limits<double>::infinity(), vmin = umin;
    double umax = -std::numeric_limits<double>::infinity(), vmax = umax;
    void add(const glm::dvec2& p) {
        if (std::isnan(p.x) || std::isnan(p.y)) {  // off the projection (orthographic far side)
            umin = vmin = -std::numeric_limits<double>::infinity();
            umax = vmax = std::numeric_limits<double>::infinity();
            return;
        }
        umin = std::min(umin, p.x), umax = std::max(umax, p.x);
        vmin = std::min(vmin, p.y), vmax = std::max(vmax, p.y);
    }
    void add(const Box& b) {
        umin = std::min(umin, b.umin), umax = std::max(umax, b.umax);
        vmin = std::min(vmin, b.vmin), vmax = std::max(vmax, b.vmax);
    }
};

/// Filled heights of source pixels [x0, x0 + w) × [y0, y0 + h).
struct Window {
    int x0 = 0, y0 = 0, w = 0, h = 0;
    std::vector<double> z;

    /// Bilinear height at raster (u, v); false if (u, v) is outside this window's pixel centres.
    bool sample(const glm::dvec2& p, double& out) const {
        double u = p.x - x0, v = p.y - y0;
        if (!(u >= -kEdgeSlack && u <= w - 1 + kEdgeSlack && v >= -kEdgeSlack && v <= h - 1 + kEdgeSlack))
            return false;
        u = std::clamp(u, 0.0, w - 1.0);
        v = std::clamp(v, 0.0, h - 1.0);
        // The last column/row interpolates from the cell before it with weight 1 on its own side.
        const int i = std::min(static_cast<int>(u), w - 2), j = std::min(static_cast<int>(v), h - 2);
        const double fu = u - i, fv = v - j;
        const double* r0 = z.data() + static_cast<size_t>(j) * w + i;
        const double* r1 = r0 + w;
        out = (1 - fv) * ((1 - fu) * r0[0] + fu * r0[1]) + fv * ((1 - fu) * r1[0] + fu * r1[1]);
        return true;
    }
};

enum class NodeStatus { Ok, Outside, NoConvergence };

/// The height of node (e, n); every raster point it sampled is added to `box`.
NodeStatus node_height(const LunarFrame& frame, const DemGeoref& g, const Window& win, double e, double n,
                       double h0, bool curvature, double& up, Box& box) {
    if (!curvature) {
        // The radial through the tangent-plane point (e, n, 0): the ground directly below the node.
        const glm::dvec3 llh = frame.to_geodetic({e, n, 0.0});
        const glm::dvec2 uv = g.to_raster(llh.x, llh.y);
        box.add(uv);
        double h;
        if (!win.sample(uv, h)) return NodeStatus::Outside;
        up = h - h0;
        return NodeStatus::Ok;
    }
    // Fixed point: the radial through (e, n, guess) meets the surface at p; p lies off the node
    // horizontally by about (h_p − h_guess)·d/R, so taking p's up as the next guess converges
    // by a factor ~d/R per step (two or three steps at 10 km).
    double guess = 0.0;
    for (int it = 0; it < kMaxIterations; ++it) {
        const glm::dvec3 llh = frame.to_geodetic({e, n, guess});
        const glm::dvec2 uv = g.to_raster(llh.x, llh.y);
        box.add(uv);
        double h;
        if (!win.sample(uv, h)) return NodeStatus::Outside;
        const glm::dvec3 p = frame.to_enu(llh.x, llh.y, h);
        if (std::hypot(p.x - e, p.y - n) < kConvergedM) {
            up = p.z;
            return NodeStatus::Ok;
        }
        guess = p.z;
    }
    return NodeStatus::NoConvergence;
}

/// Throws if the raster points in `need` are not all inside the raster's pixel centres, naming
/// each edge the crop crosses.
void require_inside(const DemRaster& dem, const Box& need, const DemCrop& crop) {
    const DemGeoref& g = dem.georef();
    const double W = dem.width() - 1.0, H = dem.height() - 1.0;
    const double uc = std::clamp((need.umin + need.umax) / 2, 0.0, W), vc = std::clamp((need.vmin + need.vmax) / 2, 0.0, H);
    std::string sides;
    auto side = [&](const std::string& s) { sides += (sides.empty() ? "" : "; ") + s; };
    if (need.umin < -kEdgeSlack)
        side("west edge (it needs column " + fmt(need.umin, 5) + "; the first pixel centre, column 0, is at lon " +
             fmt(g.to_latlon(0, vc).y, 9) + "°)");
    if (need.umax > W + kEdgeSlack)
        side("east edge (it needs column " + fmt(need.umax, 5) + "; the last pixel centre, column " + fmt(W, 9) +
             ", is at lon " + fmt(g.to_latlon(W, vc).y, 9) + "°)");
    if (need.vmin < -kEdgeSlack)
        side("north edge (it needs row " + fmt(need.vmin, 5) + "; the first pixel centre, row 0, is at lat " +
             fmt(g.to_latlon(uc, 0).x, 9) + "°)");
    if (need.vmax > H + kEdgeSlack)
        side("south edge (it needs row " + fmt(need.vmax, 5) + "; the last pixel centre, row " + fmt(H, 9) +
             ", is at lat " + fmt(g.to_latlon(uc, H).x, 9) + "°)");
    if (!sides.empty())
        throw std::invalid_argument(dem.name() + ": a " + fmt(crop.size_m) + " m crop at lat " + fmt(crop.lat_deg, 9) +
                                    "°, lon " + fmt(crop.lon_deg, 9) + "° leaves the raster (" +
                                    std::to_string(dem.width()) + "×" + std::to_string(dem.height()) +
                                    " pixels) past its " + sides);
}

/// The source pixels a bilinear read of the points in `b` touches, as [x0, x1) × [y0, y1).
std::array<int, 4> pixel_range(const Box& b, int width, int height) {
    const auto lo = [](double v, int n) { return std::clamp(static_cast<int>(std::floor(v + kEdgeSlack)), 0, n - 1); };
    const auto hi = [](double v, int n) { return std::clamp(static_cast<int>(std::floor(v - kEdgeSlack)) + 2, 1, n); };
    return {lo(b.umin, width), lo(b.vmin, height), hi(b.umax, width), hi(b.vmax, height)};
}

}  // namespace

LocalDemGrid import_dem(const DemRaster& dem, const DemCrop& crop) {
    if (!(crop.lat_deg >= -90.0 && crop.lat_deg <= 90.0))
        throw std::invalid_argument("lat_deg: must be in [-90, 90] degrees");
    if (!std::isfinite(crop.lon_deg)) throw std::invalid_argument("lon_deg: must be finite");
    // Beyond a tenth of the radius the tangent-plane grid stops being a local patch (the corner
    // would sit kilometres below it and the grid would wrap noticeably around the sphere).
    if (!(std::isfinite(crop.size_m) && crop.size_m > 0 && crop.size_m <= 0.1 * kLunarRadius))
        throw std::invalid_argument("size_m: must be > 0 and at most " + fmt(0.1 * kLunarRadius) + " m, got " +
                                    fmt(crop.size_m));
    if (!(std::isfinite(crop.spacing_m) && crop.spacing_m >= 0))
        throw std::invalid_argument("spacing_m: must be >= 0 (0 = the source pixel size) and finite");

    const DemGeoref& g = dem.georef();
    const glm::dvec2 pixel = g.pixel_size_m(crop.lat_deg, crop.lon_deg);
    const double spacing = crop.spacing_m > 0 ? crop.spacing_m : std::min(pixel.x, pixel.y);
    // The 1e-9 keeps an exact multiple (size 200, spacing 0.1) from losing a node to rounding.
    const double half_nodes = std::floor(crop.size_m / (2 * spacing) + 1e-9);
    if (half_nodes < 1)
        throw std::invalid_argument("size_m: " + fmt(crop.size_m) + " m is less than 2 × spacing_m (" +
                                    fmt(spacing) + " m)");
    if (2 * half_nodes + 1 > kMaxGridSide)
        throw std::invalid_argument("spacing_m: " + fmt(crop.size_m) + " m at " + fmt(spacing) + " m spacing needs " +
                                    fmt(2 * half_nodes + 1) + " nodes a side; at most " + std::to_string(kMaxGridSide));
    const int half = static_cast<int>(half_nodes), n = 2 * half + 1;

    // A first footprint from the grid's boundary nodes on the tangent plane at height 0: the map
    // from the square to the raster is one-to-one, so the boundary bounds it. Heights shift the
    // true footprint by about d·Δh/R, which the margin absorbs; if not, the loop below reads again.
    Box need;
    {
        const LunarFrame flat(crop.lat_deg, crop.lon_deg, 0.0);
        const glm::dvec3 c = flat.to_geodetic({0, 0, 0});
        need.add(g.to_raster(c.x, c.y));
        for (int k = -half; k <= half; ++k)
            for (const glm::dvec2 en : {glm::dvec2(k, -half), glm::dvec2(k, half), glm::dvec2(-half, k), glm::dvec2(half, k)}) {
                const glm::dvec3 llh = flat.to_geodetic({en.x * spacing, en.y * spacing, 0.0});
                need.add(g.to_raster(llh.x, llh.y));
            }
    }
    const glm::dvec2 centre_uv = g.to_raster(crop.lat_deg, crop.lon_deg);

    LocalDemGrid out;
    out.nx = out.ny = n;
    out.spacing_m = spacing;
    out.lat_deg = crop.lat_deg;
    out.lon_deg = crop.lon_deg;
    out.curvature = crop.curvature;
    out.source_pixel_east_m = pixel.x;
    out.source_pixel_north_m = pixel.y;
    out.heights.assign(static_cast<size_t>(n) * n, 0.0);

    for (int attempt = 0;; ++attempt) {
        require_inside(dem, need, crop);
        const std::array<int, 4> core = pixel_range(need, dem.width(), dem.height());
        Window win;
        win.x0 = std::max(0, core[0] - kFillMargin);
        win.y0 = std::max(0, core[1] - kFillMargin);
        win.w = std::min(dem.width(), core[2] + kFillMargin) - win.x0;
        win.h = std::min(dem.height(), core[3] + kFillMargin) - win.y0;
        if (static_cast<int64_t>(win.w) * win.h > kMaxWindowPixels)
            throw std::invalid_argument("size_m: the crop covers " + std::to_string(win.w) + "×" + std::to_string(win.h) +
                                        " source pixels of " + dem.name() + "; at most " +
                                        std::to_string(kMaxWindowPixels) + " are read at once");
        win.z = dem.read(win.x0, win.y0, win.x0 + win.w, win.y0 + win.h);
        std::vector<uint8_t> was_void(win.z.size());
        for (size_t i = 0; i < win.z.size(); ++i) was_void[i] = std::isnan(win.z[i]);
        auto all_void = [&](const std::array<int, 4>& r) {
            return std::invalid_argument(dem.name() + ": every source pixel under the crop is void (columns " +
                                         std::to_string(r[0]) + "–" + std::to_string(r[2] - 1) + ", rows " +
                                         std::to_string(r[1]) + "–" + std::to_string(r[3] - 1) +
                                         (dem.nodata() ? ", nodata " + fmt(*dem.nodata(), 9) : std::string()) + ")");
        };
        try {
            fill_voids(win.z, win.w, win.h);
        } catch (const std::invalid_argument&) {
            throw all_void(core);
        }

        double h0;
        if (!win.sample(centre_uv, h0)) throw std::logic_error("import_dem: the crop centre is outside its window");
        const LunarFrame frame(crop.lat_deg, crop.lon_deg, h0);

        std::vector<Box> row_box(static_cast<size_t>(n));
        std::vector<NodeStatus> row_status(static_cast<size_t>(n), NodeStatus::Ok);
        std::vector<double> row_fail_e(static_cast<size_t>(n), 0.0);
        // Rows are independent and each writes only its own slots, so the result does not depend
        // on how TBB splits them.
        tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& rows) {
            for (int j = rows.begin(); j != rows.end(); ++j) {
                const double north = (j - half) * spacing;
                for (int i = 0; i < n; ++i) {
                    const double east = (i - half) * spacing;
                    double up = 0.0;
                    const NodeStatus s = node_height(frame, g, win, east, north, h0, crop.curvature, up,
                                                     row_box[static_cast<size_t>(j)]);
                    if (s != NodeStatus::Ok) {
                        if (row_status[static_cast<size_t>(j)] == NodeStatus::Ok) {
                            row_status[static_cast<size_t>(j)] = s;
                            row_fail_e[static_cast<size_t>(j)] = east;
                        }
                        continue;
                    }
                    out.heights[static_cast<size_t>(j) * n + i] = up;
                }
            }
        });
        Box used;
        bool outside = false;
        for (int j = 0; j < n; ++j) {
            used.add(row_box[static_cast<size_t>(j)]);
            if (row_status[static_cast<size_t>(j)] == NodeStatus::NoConvergence)
                throw std::runtime_error(dem.name() + ": the surface under node (east " +
                                         fmt(row_fail_e[static_cast<size_t>(j)]) + " m, north " +
                                         fmt((j - half) * spacing) + " m) was not found in " +
                                         std::to_string(kMaxIterations) + " steps (a near-vertical cliff?)");
            outside |= row_status[static_cast<size_t>(j)] == NodeStatus::Outside;
        }
        if (outside) {
            // The surface moved the footprint past the margin: read again around what was asked.
            if (attempt >= 3) throw std::logic_error("import_dem: the footprint did not settle in 4 reads");
            need.add(used);
            continue;
        }

        const std::array<int, 4> touched = pixel_range(used, dem.width(), dem.height());
        int64_t voids = 0, pixels = 0;
        for (int y = touched[1]; y < touched[3]; ++y)
            for (int x = touched[0]; x < touched[2]; ++x) {
                voids += was_void[static_cast<size_t>(y - win.y0) * win.w + (x - win.x0)];
                ++pixels;
            }
        if (voids == pixels) throw all_void(touched);
        out.voids_filled = voids;
        out.h0_m = h0;
        out.footprint_min = {used.umin, used.vmin};
        out.footprint_max = {used.umax, used.vmax};
        return out;
    }
}

}  // namespace moonbot

