// Lunar geodesy: selenographic latitude/longitude/height to a local East-North-Up frame and back,
// on a sphere (GeographicLib with flattening 0), all in double precision. Positions are shifted to
// the local origin here, before anything is narrowed to float32 for Embree.
#pragma once

#include <memory>

#include <glm/glm.hpp>

namespace moonbot {

/// Mean lunar radius in metres (IAU; SLDEM2015's reference sphere).
constexpr double kLunarRadius = 1737400.0;

class LunarFrame {
public:
    /// Local ENU frame with its origin at (lat0_deg, lon0_deg, h0 metres above the sphere).
    /// Throws std::invalid_argument on a latitude outside [-90, 90] or a non-positive radius.
    LunarFrame(double lat0_deg, double lon0_deg, double h0, double radius = kLunarRadius);
    ~LunarFrame();
    LunarFrame(LunarFrame&&) noexcept;
    LunarFrame& operator=(LunarFrame&&) noexcept;

    /// (lat°, lon°, h m) → (east, north, up) metres.
    glm::dvec3 to_enu(double lat_deg, double lon_deg, double h) const;
    /// (east, north, up) metres → (lat°, lon°, h m).
    glm::dvec3 to_geodetic(const glm::dvec3& enu) const;
    double radius() const { return m_radius; }

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
    double m_radius;
};

/// Height lost to curvature at horizontal distance d on a sphere of radius R: R − √(R² − d²),
/// ≈ d²/2R, computed without cancellation as d² / (R + √(R² − d²)). Metres.
double curvature_drop(double distance, double radius = kLunarRadius);

}  // namespace moonbot
