// The Sun as a distant directional source. Azimuth is clockwise from North (0° = +y, 90° = +x)
// in the local East-North-Up frame; elevation is above the local horizon.
#pragma once

#include <glm/glm.hpp>

namespace moonbot {

class Sun {
public:
    /// `azimuth_deg`, `elevation_deg` in degrees (elevation in [-90, 90]); `irradiance` in W/m² on
    /// a surface facing the Sun (1361 at 1 au). Throws std::invalid_argument naming the field.
    Sun(double azimuth_deg, double elevation_deg, double irradiance);

    /// Unit vector toward the Sun: (sin az·cos el, cos az·cos el, sin el).
    const glm::dvec3& direction() const { return m_direction; }
    double irradiance() const { return m_irradiance; }
    double azimuth_deg() const { return m_azimuth_deg; }
    double elevation_deg() const { return m_elevation_deg; }

private:
    double m_azimuth_deg, m_elevation_deg, m_irradiance;
    glm::dvec3 m_direction;
};

}  // namespace moonbot
