// GeoTIFF georeference and GDAL height metadata from a TIFF directory (see geotiff.h).
#include "geotiff.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "moonbot/io_error.h"

namespace moonbot {

namespace {

using tiff::kTagGdalMetadata;
using tiff::kTagGdalNodata;
using tiff::kTagGeoDoubleParams;
using tiff::kTagGeoKeyDirectory;
using tiff::kTagModelPixelScale;
using tiff::kTagModelTiepoint;
using tiff::kTagModelTransformation;

constexpr double kPi = 3.14159265358979323846;
double rad(double deg) { return deg * (kPi / 180.0); }

std::string fmt(double v, int digits = 6) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    return s.str();
}

// GeoKey ids (GeoTIFF 1.0 §6.2) and the codes this reader accepts.
constexpr int kGTModelType = 1024, kGTRasterType = 1025, kGeogAngularUnits = 2054, kGeogSemiMajorAxis = 2057,
              kGeogSemiMinorAxis = 2058, kGeogInvFlattening = 2059, kProjectedCSType = 3072, kProjCoordTrans = 3075,
              kProjLinearUnits = 3076, kProjStdParallel1 = 3078, kProjNatOriginLong = 3080, kProjNatOriginLat = 3081,
              kProjFalseEasting = 3082, kProjFalseNorthing = 3083, kProjCenterLong = 3088, kProjCenterLat = 3089,
              kProjScaleAtNatOrigin = 3092, kProjStraightVertPoleLong = 3095;
constexpr int kModelProjected = 1, kModelGeographic = 2;
constexpr int kRasterPixelIsArea = 1, kRasterPixelIsPoint = 2;
constexpr int kUserDefined = 32767, kCTEquirectangular = 17, kCTOrthographic = 21, kCTPolarStereographic = 15,
              kLinearMetre = 9001, kAngularDegree = 9102;

/// The numeric GeoKeys of a GeoKeyDirectory, each key's first value (SHORT inline or DOUBLE
/// from GeoDoubleParams); ASCII keys (citations) are skipped.
std::map<int, double> read_geokeys(const tiff::Directory& dir, const std::string& path) {
    if (!dir.has(kTagGeoKeyDirectory)) throw IoError(path + ": no GeoKeyDirectory tag (34735); not a GeoTIFF?");
    const std::vector<double> keys = dir.numbers(kTagGeoKeyDirectory, "GeoKeyDirectory (34735)");
    if (keys.size() < 4 || keys[0] != 1.0) throw IoError(path + ": GeoKeyDirectory (34735) has no version-1 header");
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
                throw IoError(path + ": GeoKey " + std::to_string(id) + " points past GeoDoubleParams (34736)");
            out.emplace(id, doubles[value]);
        } else if (location == kTagGeoKeyDirectory) {
            if (value >= keys.size())
                throw IoError(path + ": GeoKey " + std::to_string(id) + " points past GeoKeyDirectory (34735)");
            out.emplace(id, keys[value]);
        }  // GeoAsciiParams (34737): citations only, not needed
    }
    return out;
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

}  // namespace

DemGeoref geotiff_georef(const tiff::Directory& dir, int width) {
    const std::string& path = dir.path();
    if (!dir.has(kTagModelPixelScale)) {
        if (dir.has(kTagModelTransformation))
            throw IoError(path +
                          ": georeferenced by ModelTransformation (34264), which is not supported; "
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
            throw IoError(path + ": " + name + " (" + std::to_string(id) + ") = " + fmt(*v) + "; only " +
                          std::to_string(want) + " (" + meaning + ") is supported");
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
                throw IoError(path +
                              ": GeogSemiMinorAxisGeoKey (2058) differs from the semi-major axis; "
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

GdalHeightTransform gdal_height_transform(const tiff::Directory& dir) {
    GdalHeightTransform t;
    if (dir.has(kTagGdalMetadata))
        parse_gdal_metadata(dir.text(kTagGdalMetadata, "GDAL_METADATA (42112)"), dir.path(), t.scale, t.offset);
    return t;
}

std::optional<double> gdal_nodata(const tiff::Directory& dir) {
    if (!dir.has(kTagGdalNodata)) return std::nullopt;
    const std::string text = dir.text(kTagGdalNodata, "GDAL_NODATA (42113)");
    const auto v = parse_number(text);
    if (!v) throw IoError(dir.path() + ": GDAL_NODATA (42113) '" + text + "' is not a number");
    return v;
}

}  // namespace moonbot
