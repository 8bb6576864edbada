#include "arrays.h"
#include "moonbot/geo.h"

namespace moonbot::bindings {

void bind_geo(py::module_& m) {
    m.attr("LUNAR_RADIUS") = kLunarRadius;
    py::class_<LunarFrame>(m, "LunarFrame", "Local East-North-Up frame on the lunar sphere (GeographicLib), metres.")
        .def(py::init<double, double, double, double>(), py::arg("lat0_deg"), py::arg("lon0_deg"), py::arg("h0") = 0.0,
             py::arg("radius") = kLunarRadius,
             "The frame at latitude lat0_deg, longitude lon0_deg (degrees) and height h0 (metres) on a sphere "
             "of `radius` metres.")
        .def(
            "to_enu",
            [](const LunarFrame& f, double lat, double lon, double h) {
                const glm::dvec3 p = f.to_enu(lat, lon, h);
                return py::make_tuple(p.x, p.y, p.z);
            },
            py::arg("lat_deg"), py::arg("lon_deg"), py::arg("h"), "(lat°, lon°, h m) → (east, north, up) metres.")
        .def(
            "to_geodetic",
            [](const LunarFrame& f, double e, double n, double u) {
                const glm::dvec3 p = f.to_geodetic({e, n, u});
                return py::make_tuple(p.x, p.y, p.z);
            },
            py::arg("east"), py::arg("north"), py::arg("up"), "(east, north, up) metres → (lat°, lon°, h m).");
    m.def("curvature_drop", &curvature_drop, py::arg("distance"), py::arg("radius") = kLunarRadius,
          "Height lost to curvature at horizontal distance d (metres) on a sphere: ≈ d²/2R.");
}

}  // namespace moonbot::bindings
