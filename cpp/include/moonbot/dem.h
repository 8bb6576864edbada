// DEM import: read a lunar digital elevation model (a GeoTIFF, or a 16-bit PNG heightmap whose
// georeference the caller states) and resample a square around a site onto a regular local
// East-North-Up grid, in double precision, through LunarFrame (GeographicLib on the 1737.4 km
// sphere). Heights in files are taken relative to that sphere (SLDEM2015 and the LOLA products
// are; lunar-physics.md §3.1).
//
// Frames: raster coordinates (u, v) are column and row with integers at pixel centres, v growing
// south (row 0 is the file's first row). The output grid is ENU metres about the crop centre at
// the DEM's own height there, so the ground near the origin is at up ≈ 0.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/geo.h"

namespace moonbot {

/// How a raster's pixels map to selenographic latitude/longitude (degrees).
///
/// Model coordinates of the centre of pixel (u, v): X = x0 + u·dx, Y = y0 − v·dy (dx, dy > 0).
/// Geographic: X = longitude°, Y = latitude°. The projections are on a sphere of radius R, in
/// metres, angles in radians (Snyder 1987, "Map Projections — A Working Manual", §§12, 20, 21):
/// - Equirectangular (simple cylindrical): X = FE + R·(λ − λc)·cos φs, Y = FN + R·(φ − φ0).
/// - Orthographic about (φ0, λc), the hemisphere facing it: X = FE + R·cos φ·sin(λ − λc),
///   Y = FN + R·(cos φ0·sin φ − sin φ0·cos φ·cos(λ − λc)). (LOLA crater cut-outs use it.)
/// - Polar stereographic about the pole φ0 = ±90°, meridian λc, scale k0 at the pole:
///   ρ = 2R·k0·tan(π/4 − |φ|/2), X = FE + ρ·sin(λ − λc), Y = FN ∓ ρ·cos(λ − λc) (− north,
///   + south). (The LOLA polar products, e.g. the 5 m south-pole DEMs of the Artemis sites.)
struct DemGeoref {
    enum class Kind { Geographic, Equirectangular, Orthographic, PolarStereographic };
    Kind kind = Kind::Geographic;
    double x0 = 0.0, y0 = 0.0;       ///< model coordinates of the centre of pixel (0, 0)
    double dx = 1.0, dy = 1.0;       ///< model units per pixel along +u (east) and +v (south)
    double center_lon_deg = 0.0;     ///< λc (projections)
    double origin_lat_deg = 0.0;     ///< φ0 (projections; ±90 for polar stereographic)
    double std_parallel_deg = 0.0;   ///< φs, where the projection is true to scale (equirectangular)
    double scale_k0 = 1.0;           ///< k0, the scale at the pole (polar stereographic)
    double false_easting_m = 0.0;    ///< FE (projections)
    double false_northing_m = 0.0;   ///< FN (projections)
    double radius_m = kLunarRadius;  ///< R of the projection (projections)
    /// Longitudes are moved by whole turns to within ±180° of this one before mapping, so a
    /// 0–360° E raster and a −180…180° request meet (geographic: the raster's middle column).
    double wrap_lon_deg = 0.0;

    /// (lat°, lon°) → raster (u, v). An orthographic raster cannot hold the far hemisphere:
    /// such points map to NaN (and so lie outside every raster).
    glm::dvec2 to_raster(double lat_deg, double lon_deg) const;
    /// Raster (u, v) → (lat°, lon°); NaN where an orthographic model point lies off the sphere.
    glm::dvec2 to_latlon(double u, double v) const;
    /// Ground size in metres on the lunar sphere of one pixel at (lat_deg, lon_deg), as the
    /// lengths of its u step and its v step (east-west and north-south for geographic and
    /// equirectangular rasters; along the grid axes for the others).
    glm::dvec2 pixel_size_m(double lat_deg, double lon_deg) const;
    /// Throws std::invalid_argument naming the field if a parameter is non-finite or out of range.
    void validate() const;
};

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
    static DemRaster open_png(const std::string& path, const DemPngLayout& layout,
                              const DemHeightUnits& units = {});
    /// By extension: .tif/.tiff → open_geotiff; .png → open_png, which needs `png`.
    static DemRaster open(const std::string& path, const DemHeightUnits& units,
                          const std::optional<DemPngLayout>& png);
    /// An in-memory raster (row-major width×height heights in metres, NaN = void), for callers
    /// with their own readers and for tests. `name` stands in for the file in messages.
    static DemRaster from_heights(std::string name, int width, int height,
                                  std::vector<double> heights_m, const DemGeoref& georef);

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

    struct Source;  // how samples are decoded (dem.cpp)

private:
    DemRaster() = default;
    std::string m_name, m_description;
    int m_width = 0, m_height = 0;
    DemGeoref m_georef;
    double m_scale = 1.0, m_offset = 0.0;
    std::optional<double> m_nodata;
    std::shared_ptr<const Source> m_source;
};

/// The square to cut out and its sampling.
struct DemCrop {
    double lat_deg = 0.0, lon_deg = 0.0;  ///< centre of the crop and origin of the ENU grid
    double size_m = 0.0;                  ///< side of the square, metres
    double spacing_m = 0.0;               ///< grid spacing, metres; 0 → the source pixel size
    /// true: heights are the true ENU `up` of the DEM surface above each node (the sphere falls
    /// away, ≈ d²/2R). false: a flat-earth patch, up = h_dem − h0 under each node.
    bool curvature = true;
};

/// A DEM resampled onto a local ENU grid.
struct LocalDemGrid {
    int nx = 0, ny = 0;
    /// ny×nx float64 metres, row-major: row 0 is the south edge, east varies fastest. Node (i, j)
    /// sits at east = (i − (nx−1)/2)·spacing, north = (j − (ny−1)/2)·spacing; the centre node is
    /// the origin. Never NaN.
    std::vector<double> heights;
    double spacing_m = 0.0;
    double lat_deg = 0.0, lon_deg = 0.0;  ///< ENU origin
    double h0_m = 0.0;  ///< DEM height at the origin above the 1737.4 km sphere; the ENU origin's h
    bool curvature = true;
    int64_t voids_filled = 0;  ///< void source pixels inside the crop's footprint that were filled
    double source_pixel_east_m = 0.0, source_pixel_north_m = 0.0;  ///< at the crop centre
    /// The grid's footprint in the source, raster coordinates (u, v) of the samples read.
    glm::dvec2 footprint_min{0.0}, footprint_max{0.0};
};

/// Crops `crop.size_m` around (lat, lon) and resamples it (bilinear in the source's pixel grid,
/// after filling voids) onto an odd n×n ENU grid with n = 2·floor(size/2/spacing) + 1, so the
/// grid spans at most size_m and has a node at the origin. The ENU origin is (lat, lon, h0) with
/// h0 the DEM height there. Curvature on: each node's height is the `up` of the surface point
/// (lat, lon, h_dem(lat, lon)) whose east/north equal the node's, found by fixed-point iteration
/// (converged to < 1 µm horizontally). Curvature off: the lat/lon under the node is where the
/// radial through (east, north, 0) meets the sphere, and up = h_dem − h0 there.
/// Throws std::invalid_argument naming the field (size_m, spacing_m, lat_deg, lon_deg) or,
/// with the file's name, the raster bound the crop leaves, or an all-void footprint.
LocalDemGrid import_dem(const DemRaster& dem, const DemCrop& crop);

/// Fills the NaN cells of a row-major width×height grid in place with a discrete harmonic
/// (Laplace) interpolant of the finite cells: each connected void region is seeded with the mean
/// of its finite neighbours and relaxed by successive over-relaxation until no cell moves more
/// than 1e-9 m in a sweep. A linear surface is reproduced exactly (to that tolerance) inside a
/// void enclosed by finite cells; at the grid's edge the fill has zero normal slope. Returns the
/// number of cells filled. Throws std::invalid_argument if no cell is finite.
int64_t fill_voids(std::vector<double>& grid, int width, int height);

}  // namespace moonbot
