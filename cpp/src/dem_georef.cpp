// DemGeoref (see dem_georef.h): the forward and inverse map of each kind (Snyder 1987, §§12,
// 20, 21, on a sphere), the ground size of a pixel, and the checks of its parameters.
#include "moonbot/dem_georef.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
double rad(double deg) { return deg * (kPi / 180.0); }
double deg(double r) { return r * (180.0 / kPi); }

}  // namespace

const char* kind_name(DemGeoref::Kind kind) {
    switch (kind) {
        case DemGeoref::Kind::Geographic: return "geographic";
        case DemGeoref::Kind::Equirectangular: return "equirectangular";
        case DemGeoref::Kind::Orthographic: return "orthographic";
        case DemGeoref::Kind::PolarStereographic: return "polar stereographic";
    }
    return "?";
}

void DemGeoref::validate() const {
    auto finite = [](double v, const char* name) {
        if (!std::isfinite(v)) throw std::invalid_argument(std::string(name) + ": must be finite");
    };
    finite(x0, "x0");
    finite(y0, "y0");
    if (!(std::isfinite(dx) && dx > 0)) throw std::invalid_argument("dx: must be positive and finite");
    if (!(std::isfinite(dy) && dy > 0)) throw std::invalid_argument("dy: must be positive and finite");
    finite(wrap_lon_deg, "wrap_lon_deg");
    if (kind != Kind::Geographic) {
        finite(center_lon_deg, "center_lon_deg");
        finite(false_easting_m, "false_easting_m");
        finite(false_northing_m, "false_northing_m");
        if (!(origin_lat_deg >= -90.0 && origin_lat_deg <= 90.0))
            throw std::invalid_argument("origin_lat_deg: must be in [-90, 90]");
        if (!(std::abs(std_parallel_deg) < 90.0)) throw std::invalid_argument("std_parallel_deg: must be in (-90, 90)");
        if (!(std::isfinite(radius_m) && radius_m > 0)) throw std::invalid_argument("radius_m: must be positive");
        if (kind == Kind::PolarStereographic && std::abs(origin_lat_deg) != 90.0)
            throw std::invalid_argument("origin_lat_deg: a polar stereographic projection is about a pole (±90)");
        if (!(std::isfinite(scale_k0) && scale_k0 > 0)) throw std::invalid_argument("scale_k0: must be positive");
    }
}

glm::dvec2 DemGeoref::to_raster(double lat_deg, double lon_deg) const {
    // Move the longitude by whole turns into [wrap − 180, wrap + 180).
    const double lon = lon_deg - 360.0 * std::floor((lon_deg - wrap_lon_deg + 180.0) / 360.0);
    const double phi = rad(lat_deg), dlam = rad(lon - center_lon_deg), phi0 = rad(origin_lat_deg);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    double X = 0.0, Y = 0.0;
    switch (kind) {
        case Kind::Geographic:
            X = lon;
            Y = lat_deg;
            break;
        case Kind::Equirectangular:
            X = false_easting_m + radius_m * dlam * std::cos(rad(std_parallel_deg));
            Y = false_northing_m + radius_m * (phi - phi0);
            break;
        case Kind::Orthographic: {
            const double cos_c = std::sin(phi0) * std::sin(phi) + std::cos(phi0) * std::cos(phi) * std::cos(dlam);
            if (cos_c < 0) return {nan, nan};  // the far hemisphere is not in the picture
            X = false_easting_m + radius_m * std::cos(phi) * std::sin(dlam);
            Y = false_northing_m +
                radius_m * (std::cos(phi0) * std::sin(phi) - std::sin(phi0) * std::cos(phi) * std::cos(dlam));
            break;
        }
        case Kind::PolarStereographic: {
            const double s = origin_lat_deg > 0 ? 1.0 : -1.0;  // the pole's hemisphere
            const double rho = 2.0 * radius_m * scale_k0 * std::tan(kPi / 4 - s * phi / 2);
            X = false_easting_m + rho * std::sin(dlam);
            Y = false_northing_m - s * rho * std::cos(dlam);
            break;
        }
    }
    return {(X - x0) / dx, (y0 - Y) / dy};
}

glm::dvec2 DemGeoref::to_latlon(double u, double v) const {
    const double X = x0 + u * dx, Y = y0 - v * dy;
    const double x = X - false_easting_m, y = Y - false_northing_m, phi0 = rad(origin_lat_deg);
    switch (kind) {
        case Kind::Geographic: return {Y, X};
        case Kind::Equirectangular:
            return {origin_lat_deg + deg(y / radius_m),
                    center_lon_deg + deg(x / (radius_m * std::cos(rad(std_parallel_deg))))};
        case Kind::Orthographic: {
            const double rho = std::hypot(x, y);
            if (rho > radius_m)
                return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
            if (rho == 0) return {origin_lat_deg, center_lon_deg};
            const double c = std::asin(rho / radius_m);
            const double phi =
                std::asin(std::clamp(std::cos(c) * std::sin(phi0) + y * std::sin(c) * std::cos(phi0) / rho, -1.0, 1.0));
            const double lam =
                std::atan2(x * std::sin(c), rho * std::cos(phi0) * std::cos(c) - y * std::sin(phi0) * std::sin(c));
            return {deg(phi), center_lon_deg + deg(lam)};
        }
        case Kind::PolarStereographic: {
            const double s = origin_lat_deg > 0 ? 1.0 : -1.0;
            const double rho = std::hypot(x, y);
            const double phi = s * (kPi / 2 - 2.0 * std::atan(rho / (2.0 * radius_m * scale_k0)));
            return {deg(phi), center_lon_deg + deg(std::atan2(x, -s * y))};
        }
    }
    return {0.0, 0.0};  // unreachable: every kind returns above
}

glm::dvec2 DemGeoref::pixel_size_m(double lat_deg, double lon_deg) const {
    const double c = std::cos(rad(lat_deg));
    if (kind == Kind::Geographic) return {kLunarRadius * c * rad(dx), kLunarRadius * rad(dy)};
    // A model metre along a parallel spans 1/(R cos φs) radians of longitude; along a meridian 1/R.
    if (kind == Kind::Equirectangular)
        return {kLunarRadius * c * dx / (radius_m * std::cos(rad(std_parallel_deg))), kLunarRadius * dy / radius_m};
    // The others' scale varies across the raster: measure the pixel's u and v steps on the sphere
    // (central differences; their error is of order (pixel / R)², far below a millimetre).
    const glm::dvec2 uv = to_raster(lat_deg, lon_deg);
    auto arc = [&](glm::dvec2 a, glm::dvec2 b) {
        const glm::dvec2 p = to_latlon(a.x, a.y), q = to_latlon(b.x, b.y);
        const double s = std::sin(rad(q.x - p.x) / 2), t = std::sin(rad(q.y - p.y) / 2);
        const double h = s * s + std::cos(rad(p.x)) * std::cos(rad(q.x)) * t * t;
        return 2.0 * kLunarRadius * std::asin(std::min(1.0, std::sqrt(h)));  // haversine
    };
    return {arc(uv - glm::dvec2(0.5, 0.0), uv + glm::dvec2(0.5, 0.0)),
            arc(uv - glm::dvec2(0.0, 0.5), uv + glm::dvec2(0.0, 0.5))};
}

}  // namespace moonbot
