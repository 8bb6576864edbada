// A lunar digital elevation model as a raster of heights: a GeoTIFF, a 16-bit PNG heightmap whose
// georeference the caller states, or heights in memory, read lazily window by window. Heights are
// metres above the 1737.4 km sphere (SLDEM2015 and the LOLA products are relative to it;
// docs/physics.md); voids read as NaN. Windows are in pixels, column u and row v, integers
// at pixel centres, row 0 the file's first (northernmost for north-up rasters) row; the
// georeference (dem_georef.h) maps them to latitude/longitude.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "moonbot/dem_georef.h"

namespace moonbot {

/// How stored samples become metres: h = (raw·file_scale + file_offset)·height_scale +
/// height_offset, where file_scale/file_offset come from the file (GeoTIFF GDAL_METADATA items
/// role="scale"/"offset", default 1 and 0; PNG: the stated range) and the rest from the caller.
/// So SLDEM2015 float km takes height_scale = 1000, and LOLA int16 in 0.5 m units without GDAL
/// metadata takes height_scale = 0.5.
struct DemHeightUnits {
    double height_scale = 1.0;
    double height_offset = 0.0;   ///< metres
    /// Raw sample value that marks a void; overrides the file's GDAL_NODATA (tag 42113).
    std::optional<double> nodata;
};

/// The georeference of a 16-bit PNG heightmap, which the file cannot carry.
struct DemPngLayout {
    double min_m = 0.0;           ///< height of sample 0, metres
    double max_m = 0.0;           ///< height of sample 65535, metres (linear in between)
    double pixel_m = 0.0;         ///< ground size of a (square) pixel, metres
    double center_lat_deg = 0.0;  ///< selenographic position of the image centre
    double center_lon_deg = 0.0;
};

/// A raster of heights above the 1737.4 km sphere, read lazily: only the windows that a crop
/// needs are decoded. Voids (NaN/±Inf samples and the nodata value) read as NaN.
class DemRaster {
public:
    /// Reads the GeoTIFF's georeference (ModelPixelScale 33550, ModelTiepoint 33922,
    /// GeoKeyDirectory 34735 with its double params 34736; GDAL_METADATA 42112; GDAL_NODATA
    /// 42113) from the TIFF directory and checks the pixel layout: one band of int8/16/32,
    /// uint8/16/32, float32 or float64, in strips or tiles, uncompressed, LZW, Deflate or
    /// PackBits (predictors none, horizontal, floating point). Every strip or tile must lie
    /// inside the file (checked here, so a truncated file fails on opening) and decode to its
    /// size (checked as `read` decodes it; like libtiff, a last strip padded to whole
    /// RowsPerStrip rows is accepted).
    /// GTModelTypeGeoKey 2 is geographic (degrees); 1 is read as equirectangular metres when
    /// ProjCoordTransGeoKey is 17 or absent and ProjectedCSTypeGeoKey is user-defined or absent;
    /// its parameters are ProjCenterLong (3088, else ProjNatOriginLong 3080), ProjCenterLat (3089,
    /// else 3081), ProjStdParallel1 (3078), ProjFalseEasting/Northing (3082/3083), all default 0,
    /// and GeogSemiMajorAxis (2057, default 1737400 m). Anything else is refused.
    /// Throws IoError naming the file and the tag or field.
    static DemRaster open_geotiff(const std::string& path, const DemHeightUnits& units = {});
    /// A single-channel 16-bit PNG: sample s → min_m + (max_m − min_m)·s/65535 (then `units`);
    /// pixels form a local equirectangular grid centred on the stated lat/lon, rows going south.
    static DemRaster open_png(const std::string& path, const DemPngLayout& layout, const DemHeightUnits& units = {});
    /// By extension: .tif/.tiff → open_geotiff; .png → open_png, which needs `png`.
    static DemRaster open(const std::string& path, const DemHeightUnits& units, const std::optional<DemPngLayout>& png);
    /// An in-memory raster (row-major width×height heights in metres, NaN = void), for callers
    /// with their own readers and for tests. `name` stands in for the file in messages.
    static DemRaster from_heights(std::string name, int width, int height, std::vector<double> heights_m,
                                  const DemGeoref& georef);

    const std::string& name() const { return m_name; }
    int width() const { return m_width; }
    int height() const { return m_height; }
    const DemGeoref& georef() const { return m_georef; }
    /// e.g. "GeoTIFF int16, geographic" or "PNG uint16, local equirectangular".
    const std::string& description() const { return m_description; }
    double scale() const { return m_scale; }    ///< raw → metres, composed (see DemHeightUnits)
    double offset() const { return m_offset; }  ///< metres
    std::optional<double> nodata() const { return m_nodata; }  ///< raw void marker in use

    /// Heights in metres of pixels [x0, x1) × [y0, y1), row-major, NaN for voids. Throws IoError
    /// naming the file and the strip or tile if decoding fails (a block that decodes short,
    /// long or corrupt), std::invalid_argument if the window is empty or leaves the raster.
    std::vector<double> read(int x0, int y0, int x1, int y1) const;

    struct Source;  // how samples are decoded (dem_raster.cpp)

private:
    DemRaster() = default;
    std::string m_name, m_description;
    int m_width = 0, m_height = 0;
    DemGeoref m_georef;
    double m_scale = 1.0, m_offset = 0.0;
    std::optional<double> m_nodata;
    std::shared_ptr<const Source> m_source;
};

}  // namespace moonbot
