#include "moonbot/light.h"

#include <cmath>
#include <stdexcept>

namespace moonbot {

DirectionalLight::DirectionalLight(double azimuth_deg, double elevation_deg, double irradiance,
                                   double angular_diameter_deg, glm::dvec3 color)
    : m_azimuth_deg(azimuth_deg),
      m_elevation_deg(elevation_deg),
      m_irradiance(irradiance),
      m_angular_diameter_deg(angular_diameter_deg),
      m_color(color) {
    if (!std::isfinite(azimuth_deg)) throw std::invalid_argument("azimuth_deg: must be finite");
    if (!(elevation_deg >= -90.0 && elevation_deg <= 90.0))
        throw std::invalid_argument("elevation_deg: must be in [-90, 90]");
    // 1e7 W/m² is ~7000 Suns at 1 au: above it radiance would overflow float32 downstream.
    if (!(irradiance >= 0.0 && irradiance <= 1e7)) throw std::invalid_argument("irradiance: must be in [0, 1e7] W/m^2");
    if (!(angular_diameter_deg >= 0.0 && angular_diameter_deg <= 10.0))
        throw std::invalid_argument("angular_diameter_deg: must be in [0, 10]");
    for (int c = 0; c < 3; ++c)
        if (!(color[c] >= 0.0 && color[c] <= 10.0))
            throw std::invalid_argument("color: each channel must be in [0, 10]");
    const double az = glm::radians(azimuth_deg);
    const double el = glm::radians(elevation_deg);
    m_direction = {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
    m_half_angle = glm::radians(angular_diameter_deg) / 2.0;
    m_cos_half_angle = std::cos(m_half_angle);
}

}  // namespace moonbot
