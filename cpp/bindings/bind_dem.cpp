#include <cstring>
#include <optional>
#include <string>
#include <utility>

#include <pybind11/stl.h>

#include "arrays.h"
#include "moonbot/dem_import.h"

namespace moonbot::bindings {

void bind_dem(py::module_& m) {
    m.def(
        "import_dem",
        [](const std::string& path, double lat_deg, double lon_deg, double size_m, double spacing_m, bool curvature,
           double height_scale, double height_offset, std::optional<double> nodata,
           std::optional<std::pair<double, double>> png_range, std::optional<double> png_pixel_m,
           std::optional<std::pair<double, double>> png_center) {
            const std::string& source = checked_path(path);
            DemHeightUnits units{height_scale, height_offset, nodata};
            std::optional<DemPngLayout> png;
            if (png_range || png_pixel_m || png_center) {
                if (!png_range || !png_pixel_m) fail("png_range, png_pixel_m", "a PNG heightmap needs both");
                const auto centre = png_center.value_or(std::make_pair(lat_deg, lon_deg));
                png = DemPngLayout{png_range->first, png_range->second, *png_pixel_m, centre.first, centre.second};
            }
            DemCrop crop{lat_deg, lon_deg, size_m, spacing_m, curvature};
            std::optional<DemRaster> dem;
            LocalDemGrid grid;
            {
                py::gil_scoped_release release;
                dem.emplace(DemRaster::open(source, units, png));
                grid = import_dem(*dem, crop);
            }
            py::array_t<double> heights({static_cast<py::ssize_t>(grid.ny), static_cast<py::ssize_t>(grid.nx)});
            std::memcpy(heights.mutable_data(), grid.heights.data(), grid.heights.size() * sizeof(double));
            py::dict out;
            out["heights"] = heights;
            out["spacing_m"] = grid.spacing_m;
            out["lat_deg"] = grid.lat_deg;
            out["lon_deg"] = grid.lon_deg;
            out["h0_m"] = grid.h0_m;
            out["curvature"] = grid.curvature;
            out["voids_filled"] = grid.voids_filled;
            out["source_pixel_m"] = std::min(grid.source_pixel_east_m, grid.source_pixel_north_m);
            out["source_pixel_east_m"] = grid.source_pixel_east_m;
            out["source_pixel_north_m"] = grid.source_pixel_north_m;
            out["source_format"] = dem->description();
            out["source_width"] = dem->width();
            out["source_height"] = dem->height();
            out["height_scale"] = dem->scale();
            out["height_offset"] = dem->offset();
            out["nodata"] = dem->nodata() ? py::cast(*dem->nodata()) : py::none();
            out["footprint"] =
                py::make_tuple(grid.footprint_min.x, grid.footprint_min.y, grid.footprint_max.x, grid.footprint_max.y);
            return out;
        },
        py::arg("path"), py::arg("lat_deg"), py::arg("lon_deg"), py::arg("size_m"), py::arg("spacing_m") = 0.0,
        py::arg("curvature") = true, py::arg("height_scale") = 1.0, py::arg("height_offset") = 0.0,
        py::arg("nodata") = py::none(), py::arg("png_range") = py::none(), py::arg("png_pixel_m") = py::none(),
        py::arg("png_center") = py::none(),
        "Crop a square of size_m metres around (lat_deg, lon_deg) from a GeoTIFF (.tif/.tiff) or a "
        "16-bit PNG heightmap (.png: needs png_range=(min_m, max_m) and png_pixel_m; png_center "
        "(lat, lon) defaults to the crop centre) and resample it onto a local ENU grid. Heights: "
        "(raw·file scale + file offset)·height_scale + height_offset metres; nodata overrides the "
        "file's GDAL_NODATA. Returns a dict: heights (ny, nx) float64 metres, row 0 = south, east "
        "fastest; spacing_m; lat_deg, lon_deg, h0_m (the ENU origin); curvature; voids_filled; "
        "source_pixel_m (the smaller of source_pixel_east_m / _north_m); source_format, "
        "source_width, source_height, height_scale, height_offset (composed), nodata; footprint "
        "(u_min, v_min, u_max, v_max) in source pixels. OSError for unreadable files and bad "
        "georeferences, ValueError for arguments and crops (both name the file or field).");
}

}  // namespace moonbot::bindings
