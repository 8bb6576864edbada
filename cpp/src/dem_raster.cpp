// DemRaster (see dem_raster.h): opening a GeoTIFF, a 16-bit PNG or in-memory heights, and reading
// windows of them as metres with voids as NaN. The GeoTIFF's pixels come from the TIFF reader
// (tiff_reader.h), the PNG's from OpenImageIO.
#include "moonbot/dem_raster.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <utility>

#include "geotiff.h"
#include "moonbot/io_error.h"
#include "tiff_reader.h"

namespace moonbot {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

/// A GeoTIFF's samples, decoded by the TIFF reader.
class TiffSource : public DemRaster::Source {
public:
    explicit TiffSource(tiff::Pixels pixels) : m_pixels(std::move(pixels)) {
        float32 = m_pixels.layout().type == tiff::SampleType::Float32;
    }
    std::vector<double> read_raw(int x0, int y0, int x1, int y1) const override {
        return m_pixels.read(x0, y0, x1, y1);
    }

private:
    tiff::Pixels m_pixels;
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
        throw IoError(path + ": " +
                      std::string(spec.format.basetype == OIIO::TypeDesc::UINT8 ? "uint8" : spec.format.c_str()) +
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

DemRaster DemRaster::open_geotiff(const std::string& path, const DemHeightUnits& units) {
    check_units(units);
    require_regular_file(path);
    const tiff::Directory dir(path);  // first: a non-TIFF fails here with a message naming it
    tiff::Layout layout = tiff::read_layout(dir);

    DemRaster r;
    r.m_name = path;
    r.m_width = layout.width;
    r.m_height = layout.height;
    r.m_georef = geotiff_georef(dir, layout.width);
    const GdalHeightTransform file = gdal_height_transform(dir);
    r.m_scale = file.scale * units.height_scale;
    r.m_offset = apply_units(file.offset, units);
    r.m_nodata = units.nodata ? units.nodata : gdal_nodata(dir);
    r.m_description = std::string("GeoTIFF ") + tiff::sample_type_name(layout.type) + ", " + kind_name(r.m_georef.kind);
    r.m_source = std::make_shared<TiffSource>(tiff::Pixels(path, std::move(layout), dir.big_endian()));
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
        throw std::invalid_argument(m_name + ": window [" + std::to_string(x0) + ", " + std::to_string(x1) + ") × [" +
                                    std::to_string(y0) + ", " + std::to_string(y1) + ") is empty or leaves the raster");
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

}  // namespace moonbot
