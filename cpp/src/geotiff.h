// Internal to the core: what a GeoTIFF's directory says about its heights, for the DEM raster
// (dem_raster.h): the georeference (the GeoTIFF 1.0 tags ModelPixelScale, ModelTiepoint and the
// GeoKeyDirectory with its double params), and GDAL's raw → height transform (GDAL_METADATA
// scale/offset) and void marker (GDAL_NODATA). Heights are metres above the 1737.4 km sphere once
// the transform is applied; the georeference maps raster (u, v), integers at pixel centres, to
// latitude/longitude in degrees (dem_georef.h).
#pragma once

#include <optional>

#include "moonbot/dem_georef.h"
#include "tiff_reader.h"

namespace moonbot {

/// The georeference of a GeoTIFF `width` pixels wide. GTModelTypeGeoKey 2 is geographic
/// (degrees); 1 is projected, in metres: equirectangular when ProjCoordTransGeoKey is 17 or absent
/// and ProjectedCSTypeGeoKey is user-defined or absent, orthographic for 21, polar stereographic
/// for 15 (variant A, a pole and k0, or B, a latitude of true scale). Projection parameters:
/// ProjCenterLong (3088, else ProjNatOriginLong 3080), ProjCenterLat (3089, else 3081),
/// ProjStdParallel1 (3078), ProjFalseEasting/Northing (3082/3083), all default 0, and
/// GeogSemiMajorAxis (2057, default 1737400 m; a sphere only). Anything else is refused.
/// Throws IoError naming the file and the tag or GeoKey.
DemGeoref geotiff_georef(const tiff::Directory& dir, int width);

/// Raw sample → file units: value = raw·scale + offset.
struct GdalHeightTransform {
    double scale = 1.0;
    double offset = 0.0;
};

/// GDAL_METADATA (42112): band 0's items with role "scale" and "offset" (the first of each);
/// {1, 0} without the tag. Throws IoError naming the file if a value is not a finite number or
/// the scale is 0.
GdalHeightTransform gdal_height_transform(const tiff::Directory& dir);

/// GDAL_NODATA (42113), the raw sample value that marks a void; nullopt without the tag. Throws
/// IoError naming the file if it is not a number.
std::optional<double> gdal_nodata(const tiff::Directory& dir);

}  // namespace moonbot
