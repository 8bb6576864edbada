// Distant light sources: the Sun, and optionally the Earth (Earthshine), each a DirectionalLight, a
// disk of given angular diameter in a direction given by azimuth (clockwise from North, 0° = +y,
// 90° = +x) and elevation above the local horizon, in the local East-North-Up frame. Which body a
// light is, is the role it has in Lights.
#pragma once

#include <optional>

#include <glm/glm.hpp>

namespace moonbot {

/// The Sun's irradiance at 1 au, W/m² (Kopp & Lean 2011).
constexpr double kSolarIrradiance = 1361.0;

/// A distant disk light: the Sun, or the Earth lit by it.
class DirectionalLight {
public:
    /// `azimuth_deg`, `elevation_deg` in degrees (elevation in [-90, 90]); `irradiance` in W/m² on
    /// a surface facing the source (1361 for the Sun at 1 au); `angular_diameter_deg` of its disk
    /// in [0, 10] (0 = a point: hard shadows; the Sun is 0.533°); `color` a linear RGB tint of
    /// the irradiance (1, 1, 1 for sunlight, in which renders are expressed). Throws
    /// std::invalid_argument naming the field.
    DirectionalLight(double azimuth_deg, double elevation_deg, double irradiance, double angular_diameter_deg = 0.0,
                     glm::dvec3 color = glm::dvec3(1.0));

    /// Unit vector toward the disk's centre: (sin az·cos el, cos az·cos el, sin el).
    const glm::dvec3& direction() const { return m_direction; }
    double irradiance() const { return m_irradiance; }
    double azimuth_deg() const { return m_azimuth_deg; }
    double elevation_deg() const { return m_elevation_deg; }
    double angular_diameter_deg() const { return m_angular_diameter_deg; }
    /// Half the angular diameter, radians, and its cosine (the disk is the cone of directions
    /// within it of direction()).
    double half_angle() const { return m_half_angle; }
    double cos_half_angle() const { return m_cos_half_angle; }
    const glm::dvec3& color() const { return m_color; }

private:
    double m_azimuth_deg, m_elevation_deg, m_irradiance, m_angular_diameter_deg;
    double m_half_angle, m_cos_half_angle;
    glm::dvec3 m_color;
    glm::dvec3 m_direction;
};

/// The light of a scene: the Sun and, when wanted, Earthshine (the sunlit Earth, a faint bluish
/// disk of ~1.9°; about 1e-4 of the Sun's irradiance near new Moon).
struct Lights {
    DirectionalLight sun;
    std::optional<DirectionalLight> earth;
};

}  // namespace moonbot
