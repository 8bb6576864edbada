#include "moonbot/geo.h"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>

#include <cmath>
#include <stdexcept>

namespace moonbot {

struct LunarFrame::Impl {
    GeographicLib::Geocentric body;
    GeographicLib::LocalCartesian local;
    Impl(double radius, double lat0, double lon0, double h0) : body(radius, 0.0), local(lat0, lon0, h0, body) {}
};

LunarFrame::LunarFrame(double lat0_deg, double lon0_deg, double h0, double radius) : m_radius(radius) {
    if (!(std::isfinite(radius) && radius > 0)) throw std::invalid_argument("radius: must be > 0");
    if (!(lat0_deg >= -90.0 && lat0_deg <= 90.0)) throw std::invalid_argument("lat0_deg: must be in [-90, 90] degrees");
    if (!std::isfinite(lon0_deg)) throw std::invalid_argument("lon0_deg: must be finite");
    if (!(std::isfinite(h0) && h0 > -radius))
        throw std::invalid_argument("h0: must be finite and above the body's centre (metres)");
    m_impl = std::make_unique<Impl>(radius, lat0_deg, lon0_deg, h0);
}

LunarFrame::~LunarFrame() = default;
LunarFrame::LunarFrame(LunarFrame&&) noexcept = default;
LunarFrame& LunarFrame::operator=(LunarFrame&&) noexcept = default;

glm::dvec3 LunarFrame::to_enu(double lat_deg, double lon_deg, double h) const {
    if (!(lat_deg >= -90.0 && lat_deg <= 90.0)) throw std::invalid_argument("lat_deg: must be in [-90, 90] degrees");
    if (!std::isfinite(lon_deg)) throw std::invalid_argument("lon_deg: must be finite");
    if (!std::isfinite(h)) throw std::invalid_argument("h: must be finite (metres)");
    glm::dvec3 enu;
    m_impl->local.Forward(lat_deg, lon_deg, h, enu.x, enu.y, enu.z);
    return enu;
}

glm::dvec3 LunarFrame::to_geodetic(const glm::dvec3& enu) const {
    if (!(std::isfinite(enu.x) && std::isfinite(enu.y) && std::isfinite(enu.z)))
        throw std::invalid_argument("east, north, up: must be finite (metres)");
    glm::dvec3 llh;
    m_impl->local.Reverse(enu.x, enu.y, enu.z, llh.x, llh.y, llh.z);
    return llh;
}

double curvature_drop(double distance, double radius) {
    if (!(std::isfinite(radius) && radius > 0)) throw std::invalid_argument("radius: must be > 0");
    if (!std::isfinite(distance)) throw std::invalid_argument("distance: must be finite (metres)");
    const double d = std::abs(distance);
    if (d > radius) throw std::invalid_argument("distance: beyond the sphere's radius");
    return d * d / (radius + std::sqrt((radius - d) * (radius + d)));
}

}  // namespace moonbot
