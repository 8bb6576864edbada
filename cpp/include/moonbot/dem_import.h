// DEM import: resample a square of a lunar DEM raster around a site onto a regular local
// East-North-Up grid, in double precision, through LunarFrame (GeographicLib on the 1737.4 km
// sphere), after filling the raster's voids.
//
// Frames: the source is read in raster coordinates (u, v) (dem_raster.h). The output grid is ENU
// metres about the crop centre at the DEM's own height there, so the ground near the origin is at
// up ≈ 0.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/dem_raster.h"

namespace moonbot {

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

}  // namespace moonbot
