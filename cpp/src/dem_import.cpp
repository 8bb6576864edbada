// import_dem (see dem_import.h): the crop's footprint in the raster, the window read around it
// and void-filled, and each node's height by bilinear reads along its radial, in parallel rows.
#include "moonbot/dem_import.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "moonbot/geo.h"
#include "moonbot/void_fill.h"

namespace moonbot {

namespace {

std::string fmt(double v, int digits = 6) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    return s.str();
}

// Source pixels read beyond the footprint on every side, so a void at the footprint's edge is
// filled from data on both sides of it rather than from the window's edge.
constexpr int kFillMargin = 8;
constexpr int kMaxGridSide = 8193;
constexpr int64_t kMaxWindowPixels = int64_t(1) << 26;  // 512 MiB of float64
// Horizontal fixed-point tolerance, metres. 0.1 mm would do for the ground's shape; 1 µm costs
// about one more step and keeps the up error (≈ residual·d/R) below a nanometre.
constexpr double kConvergedM = 1e-6;
constexpr int kMaxIterations = 50;
// Raster coordinates within this of the outermost pixel centre count as inside (rounding).
constexpr double kEdgeSlack = 1e-9;

/// A bounding box in raster coordinates.
struct Box {
    double umin = std::numeric_limits<double>::infinity(), vmin = umin;
    double umax = -std::numeric_limits<double>::infinity(), vmax = umax;
    void add(const glm::dvec2& p) {
        if (std::isnan(p.x) || std::isnan(p.y)) {  // off the projection (orthographic far side)
            umin = vmin = -std::numeric_limits<double>::infinity();
            umax = vmax = std::numeric_limits<double>::infinity();
            return;
        }
        umin = std::min(umin, p.x), umax = std::max(umax, p.x);
        vmin = std::min(vmin, p.y), vmax = std::max(vmax, p.y);
    }
    void add(const Box& b) {
        umin = std::min(umin, b.umin), umax = std::max(umax, b.umax);
        vmin = std::min(vmin, b.vmin), vmax = std::max(vmax, b.vmax);
    }
};

/// Filled heights of source pixels [x0, x0 + w) × [y0, y0 + h).
struct Window {
    int x0 = 0, y0 = 0, w = 0, h = 0;
    std::vector<double> z;

    /// Bilinear height at raster (u, v); false if (u, v) is outside this window's pixel centres.
    bool sample(const glm::dvec2& p, double& out) const {
        double u = p.x - x0, v = p.y - y0;
        if (!(u >= -kEdgeSlack && u <= w - 1 + kEdgeSlack && v >= -kEdgeSlack && v <= h - 1 + kEdgeSlack)) return false;
        u = std::clamp(u, 0.0, w - 1.0);
        v = std::clamp(v, 0.0, h - 1.0);
        // The last column/row interpolates from the cell before it with weight 1 on its own side.
        const int i = std::min(static_cast<int>(u), w - 2), j = std::min(static_cast<int>(v), h - 2);
        const double fu = u - i, fv = v - j;
        const double* r0 = z.data() + static_cast<size_t>(j) * w + i;
        const double* r1 = r0 + w;
        out = (1 - fv) * ((1 - fu) * r0[0] + fu * r0[1]) + fv * ((1 - fu) * r1[0] + fu * r1[1]);
        return true;
    }
};

enum class NodeStatus { Ok, Outside, NoConvergence };

/// The height of node (e, n); every raster point it sampled is added to `box`.
NodeStatus node_height(const LunarFrame& frame, const DemGeoref& g, const Window& win, double e, double n, double h0,
                       bool curvature, double& up, Box& box) {
    if (!curvature) {
        // The radial through the tangent-plane point (e, n, 0): the ground directly below the node.
        const glm::dvec3 llh = frame.to_geodetic({e, n, 0.0});
        const glm::dvec2 uv = g.to_raster(llh.x, llh.y);
        box.add(uv);
        double h;
        if (!win.sample(uv, h)) return NodeStatus::Outside;
        up = h - h0;
        return NodeStatus::Ok;
    }
    // Fixed point: the radial through (e, n, guess) meets the surface at p; p lies off the node
    // horizontally by about (h_p − h_guess)·d/R, so taking p's up as the next guess converges
    // by a factor ~d/R per step (two or three steps at 10 km).
    double guess = 0.0;
    for (int it = 0; it < kMaxIterations; ++it) {
        const glm::dvec3 llh = frame.to_geodetic({e, n, guess});
        const glm::dvec2 uv = g.to_raster(llh.x, llh.y);
        box.add(uv);
        double h;
        if (!win.sample(uv, h)) return NodeStatus::Outside;
        const glm::dvec3 p = frame.to_enu(llh.x, llh.y, h);
        if (std::hypot(p.x - e, p.y - n) < kConvergedM) {
            up = p.z;
            return NodeStatus::Ok;
        }
        guess = p.z;
    }
    return NodeStatus::NoConvergence;
}

/// Throws if the raster points in `need` are not all inside the raster's pixel centres, naming
/// each edge the crop crosses.
void require_inside(const DemRaster& dem, const Box& need, const DemCrop& crop) {
    const DemGeoref& g = dem.georef();
    const double W = dem.width() - 1.0, H = dem.height() - 1.0;
    const double uc = std::clamp((need.umin + need.umax) / 2, 0.0, W),
                 vc = std::clamp((need.vmin + need.vmax) / 2, 0.0, H);
    std::string sides;
    auto side = [&](const std::string& s) { sides += (sides.empty() ? "" : "; ") + s; };
    if (need.umin < -kEdgeSlack)
        side("west edge (it needs column " + fmt(need.umin, 5) + "; the first pixel centre, column 0, is at lon " +
             fmt(g.to_latlon(0, vc).y, 9) + "°)");
    if (need.umax > W + kEdgeSlack)
        side("east edge (it needs column " + fmt(need.umax, 5) + "; the last pixel centre, column " + fmt(W, 9) +
             ", is at lon " + fmt(g.to_latlon(W, vc).y, 9) + "°)");
    if (need.vmin < -kEdgeSlack)
        side("north edge (it needs row " + fmt(need.vmin, 5) + "; the first pixel centre, row 0, is at lat " +
             fmt(g.to_latlon(uc, 0).x, 9) + "°)");
    if (need.vmax > H + kEdgeSlack)
        side("south edge (it needs row " + fmt(need.vmax, 5) + "; the last pixel centre, row " + fmt(H, 9) +
             ", is at lat " + fmt(g.to_latlon(uc, H).x, 9) + "°)");
    if (!sides.empty())
        throw std::invalid_argument(dem.name() + ": a " + fmt(crop.size_m) + " m crop at lat " + fmt(crop.lat_deg, 9) +
                                    "°, lon " + fmt(crop.lon_deg, 9) + "° leaves the raster (" +
                                    std::to_string(dem.width()) + "×" + std::to_string(dem.height()) +
                                    " pixels) past its " + sides);
}

/// The source pixels a bilinear read of the points in `b` touches, as [x0, x1) × [y0, y1).
std::array<int, 4> pixel_range(const Box& b, int width, int height) {
    const auto lo = [](double v, int n) { return std::clamp(static_cast<int>(std::floor(v + kEdgeSlack)), 0, n - 1); };
    const auto hi = [](double v, int n) { return std::clamp(static_cast<int>(std::floor(v - kEdgeSlack)) + 2, 1, n); };
    return {lo(b.umin, width), lo(b.vmin, height), hi(b.umax, width), hi(b.vmax, height)};
}

}  // namespace

LocalDemGrid import_dem(const DemRaster& dem, const DemCrop& crop) {
    if (!(crop.lat_deg >= -90.0 && crop.lat_deg <= 90.0))
        throw std::invalid_argument("lat_deg: must be in [-90, 90] degrees");
    if (!std::isfinite(crop.lon_deg)) throw std::invalid_argument("lon_deg: must be finite");
    // Beyond a tenth of the radius the tangent-plane grid stops being a local patch (the corner
    // would sit kilometres below it and the grid would wrap noticeably around the sphere).
    if (!(std::isfinite(crop.size_m) && crop.size_m > 0 && crop.size_m <= 0.1 * kLunarRadius))
        throw std::invalid_argument("size_m: must be > 0 and at most " + fmt(0.1 * kLunarRadius) + " m, got " +
                                    fmt(crop.size_m));
    if (!(std::isfinite(crop.spacing_m) && crop.spacing_m >= 0))
        throw std::invalid_argument("spacing_m: must be >= 0 (0 = the source pixel size) and finite");

    const DemGeoref& g = dem.georef();
    const glm::dvec2 pixel = g.pixel_size_m(crop.lat_deg, crop.lon_deg);
    const double spacing = crop.spacing_m > 0 ? crop.spacing_m : std::min(pixel.x, pixel.y);
    // The 1e-9 keeps an exact multiple (size 200, spacing 0.1) from losing a node to rounding.
    const double half_nodes = std::floor(crop.size_m / (2 * spacing) + 1e-9);
    if (half_nodes < 1)
        throw std::invalid_argument("size_m: " + fmt(crop.size_m) + " m is less than 2 × spacing_m (" + fmt(spacing) +
                                    " m)");
    if (2 * half_nodes + 1 > kMaxGridSide)
        throw std::invalid_argument("spacing_m: " + fmt(crop.size_m) + " m at " + fmt(spacing) + " m spacing needs " +
                                    fmt(2 * half_nodes + 1) + " nodes a side; at most " + std::to_string(kMaxGridSide));
    const int half = static_cast<int>(half_nodes), n = 2 * half + 1;

    // A first footprint from the grid's boundary nodes on the tangent plane at height 0: the map
    // from the square to the raster is one-to-one, so the boundary bounds it. Heights shift the
    // true footprint by about d·Δh/R, which the margin absorbs; if not, the loop below reads again.
    Box need;
    {
        const LunarFrame flat(crop.lat_deg, crop.lon_deg, 0.0);
        const glm::dvec3 c = flat.to_geodetic({0, 0, 0});
        need.add(g.to_raster(c.x, c.y));
        for (int k = -half; k <= half; ++k)
            for (const glm::dvec2 en :
                 {glm::dvec2(k, -half), glm::dvec2(k, half), glm::dvec2(-half, k), glm::dvec2(half, k)}) {
                const glm::dvec3 llh = flat.to_geodetic({en.x * spacing, en.y * spacing, 0.0});
                need.add(g.to_raster(llh.x, llh.y));
            }
    }
    const glm::dvec2 centre_uv = g.to_raster(crop.lat_deg, crop.lon_deg);

    LocalDemGrid out;
    out.nx = out.ny = n;
    out.spacing_m = spacing;
    out.lat_deg = crop.lat_deg;
    out.lon_deg = crop.lon_deg;
    out.curvature = crop.curvature;
    out.source_pixel_east_m = pixel.x;
    out.source_pixel_north_m = pixel.y;
    out.heights.assign(static_cast<size_t>(n) * n, 0.0);

    for (int attempt = 0;; ++attempt) {
        require_inside(dem, need, crop);
        const std::array<int, 4> core = pixel_range(need, dem.width(), dem.height());
        Window win;
        win.x0 = std::max(0, core[0] - kFillMargin);
        win.y0 = std::max(0, core[1] - kFillMargin);
        win.w = std::min(dem.width(), core[2] + kFillMargin) - win.x0;
        win.h = std::min(dem.height(), core[3] + kFillMargin) - win.y0;
        if (static_cast<int64_t>(win.w) * win.h > kMaxWindowPixels)
            throw std::invalid_argument("size_m: the crop covers " + std::to_string(win.w) + "×" +
                                        std::to_string(win.h) + " source pixels of " + dem.name() + "; at most " +
                                        std::to_string(kMaxWindowPixels) + " are read at once");
        win.z = dem.read(win.x0, win.y0, win.x0 + win.w, win.y0 + win.h);
        std::vector<uint8_t> was_void(win.z.size());
        for (size_t i = 0; i < win.z.size(); ++i) was_void[i] = std::isnan(win.z[i]);
        auto all_void = [&](const std::array<int, 4>& r) {
            return std::invalid_argument(dem.name() + ": every source pixel under the crop is void (columns " +
                                         std::to_string(r[0]) + "–" + std::to_string(r[2] - 1) + ", rows " +
                                         std::to_string(r[1]) + "–" + std::to_string(r[3] - 1) +
                                         (dem.nodata() ? ", nodata " + fmt(*dem.nodata(), 9) : std::string()) + ")");
        };
        try {
            fill_voids(win.z, win.w, win.h);
        } catch (const std::invalid_argument&) {
            throw all_void(core);
        }

        double h0;
        if (!win.sample(centre_uv, h0)) throw std::logic_error("import_dem: the crop centre is outside its window");
        const LunarFrame frame(crop.lat_deg, crop.lon_deg, h0);

        std::vector<Box> row_box(static_cast<size_t>(n));
        std::vector<NodeStatus> row_status(static_cast<size_t>(n), NodeStatus::Ok);
        std::vector<double> row_fail_e(static_cast<size_t>(n), 0.0);
        // Rows are independent and each writes only its own slots, so the result does not depend
        // on how TBB splits them.
        tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& rows) {
            for (int j = rows.begin(); j != rows.end(); ++j) {
                const double north = (j - half) * spacing;
                for (int i = 0; i < n; ++i) {
                    const double east = (i - half) * spacing;
                    double up = 0.0;
                    const NodeStatus s = node_height(frame, g, win, east, north, h0, crop.curvature, up,
                                                     row_box[static_cast<size_t>(j)]);
                    if (s != NodeStatus::Ok) {
                        if (row_status[static_cast<size_t>(j)] == NodeStatus::Ok) {
                            row_status[static_cast<size_t>(j)] = s;
                            row_fail_e[static_cast<size_t>(j)] = east;
                        }
                        continue;
                    }
                    out.heights[static_cast<size_t>(j) * n + i] = up;
                }
            }
        });
        Box used;
        bool outside = false;
        for (int j = 0; j < n; ++j) {
            used.add(row_box[static_cast<size_t>(j)]);
            if (row_status[static_cast<size_t>(j)] == NodeStatus::NoConvergence)
                throw std::runtime_error(dem.name() + ": the surface under node (east " +
                                         fmt(row_fail_e[static_cast<size_t>(j)]) + " m, north " +
                                         fmt((j - half) * spacing) + " m) was not found in " +
                                         std::to_string(kMaxIterations) + " steps (a near-vertical cliff?)");
            outside |= row_status[static_cast<size_t>(j)] == NodeStatus::Outside;
        }
        if (outside) {
            // The surface moved the footprint past the margin: read again around what was asked.
            if (attempt >= 3) throw std::logic_error("import_dem: the footprint did not settle in 4 reads");
            need.add(used);
            continue;
        }

        const std::array<int, 4> touched = pixel_range(used, dem.width(), dem.height());
        int64_t voids = 0, pixels = 0;
        for (int y = touched[1]; y < touched[3]; ++y)
            for (int x = touched[0]; x < touched[2]; ++x) {
                voids += was_void[static_cast<size_t>(y - win.y0) * win.w + (x - win.x0)];
                ++pixels;
            }
        if (voids == pixels) throw all_void(touched);
        out.voids_filled = voids;
        out.h0_m = h0;
        out.footprint_min = {used.umin, used.vmin};
        out.footprint_max = {used.umax, used.vmax};
        return out;
    }
}

}  // namespace moonbot
