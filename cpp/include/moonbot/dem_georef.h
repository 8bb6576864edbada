// The georeference of a DEM raster: how its pixel grid maps to selenographic latitude and
// longitude, for geographic rasters and three projections on a sphere (equirectangular,
// orthographic, polar stereographic).
//
// Frames and units: raster coordinates (u, v) are column and row with integers at pixel centres,
// v growing south (row 0 is the file's first row); latitude and longitude in degrees; model
// coordinates in degrees (geographic) or metres (projections); ground sizes in metres on the
// 1737.4 km lunar sphere.
#pragma once

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

/// "geographic", "equirectangular", "orthographic" or "polar stereographic".
const char* kind_name(DemGeoref::Kind kind);

}  // namespace moonbot
