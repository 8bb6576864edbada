#include "moonbot/subgrid_craters.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace moonbot {

namespace {

[[noreturn]] void fail(const std::string& field, const std::string& what) {
    throw std::invalid_argument(field + ": " + what);
}

}  // namespace

SubgridCraters::SubgridCraters(std::vector<glm::dvec2> centres, std::vector<double> diameters,
                               std::vector<double> degradation, CraterProfileTable table)
    : m_table(std::move(table)) {
    const std::vector<double>& grid = m_table.degradation;
    if (grid.size() < 2 || grid[0] != 0.0) fail("table_degradation", "must hold at least two rows, from 0");
    for (size_t k = 1; k < grid.size(); ++k)
        if (!(grid[k] > grid[k - 1]) || !std::isfinite(grid[k]))
            fail("table_degradation", "must be ascending and finite");
    if (!(m_table.radius_step > 0.0) || !std::isfinite(m_table.radius_step))
        fail("radius_step", "must be positive and finite");
    if (m_table.heights.empty() || m_table.heights.size() % grid.size() != 0)
        fail("table", "must hold one row of at least two columns per degradation");
    m_columns = static_cast<int>(m_table.heights.size() / grid.size());
    if (m_columns < 2) fail("table", "must hold one row of at least two columns per degradation");
    for (double h : m_table.heights)
        if (!std::isfinite(h)) fail("table", "must be finite");
    if (m_table.reach.size() != grid.size()) fail("table_reach", "must hold one reach per degradation");
    for (double r : m_table.reach)
        if (!(r > 0.0) || !std::isfinite(r)) fail("table_reach", "must be positive and finite");
    if (diameters.size() != centres.size() || degradation.size() != centres.size())
        fail("diameters", "centres, diameters and degradation must have one entry per crater");
    // Where each row's profile ends: its last non-zero column.
    // Each row's crest (its highest value and where it lies) and its steepest rise toward the
    // centre, dz/dr = 2·dh/ds (h = z/D, s = r/R), piecewise linear in the table.
    std::vector<double> row_crest(grid.size(), -INFINITY), row_crest_s(grid.size(), 0.0), row_slope(grid.size(), 0.0);
    for (size_t r = 0; r < grid.size(); ++r) {
        const double* row = &m_table.heights[r * m_columns];
        for (int k = 0; k < m_columns; ++k) {
            if (row[k] > row_crest[r]) {
                row_crest[r] = row[k];
                row_crest_s[r] = k * m_table.radius_step;
            }
            if (k > 0) row_slope[r] = std::max(row_slope[r], 2.0 * std::abs(row[k] - row[k - 1]) / m_table.radius_step);
        }
    }
    m_craters.reserve(centres.size());
    for (size_t i = 0; i < centres.size(); ++i) {
        if (!std::isfinite(centres[i].x) || !std::isfinite(centres[i].y)) fail("centres", "must be finite");
        if (!(diameters[i] > 0.0) || !std::isfinite(diameters[i])) fail("diameters", "must be positive and finite");
        const double d = degradation[i];
        if (!(d >= 0.0 && d <= grid.back()))
            fail("degradation", "must be in [0, " + std::to_string(grid.back()) + "], got " + std::to_string(d));
        Crater c;
        c.centre = centres[i];
        c.diameter = diameters[i];
        c.radius = diameters[i] / 2.0;
        // The row below d (the last row's below it), as craters.py's searchsorted does.
        c.row = static_cast<int>(std::upper_bound(grid.begin(), grid.end(), d) - grid.begin()) - 1;
        c.row = std::clamp(c.row, 0, static_cast<int>(grid.size()) - 2);
        c.row_weight = (d - grid[c.row]) / (grid[c.row + 1] - grid[c.row]);
        c.reach_s = m_table.reach[c.row] * (1.0 - c.row_weight) + m_table.reach[c.row + 1] * c.row_weight;
        c.reach_m = c.reach_s * c.radius;
        c.crest = std::max(row_crest[c.row], row_crest[c.row + 1]);
        c.crest_s = std::max(row_crest_s[c.row], row_crest_s[c.row + 1]);
        c.steepest = std::max(row_slope[c.row], row_slope[c.row + 1]);
        m_steepest = std::max(m_steepest, c.steepest);
        m_craters.push_back(c);
    }
    // Octave bands of diameter from the smallest crater, each with a grid of cells twice its
    // widest reach, so that a crater's reach overlaps at most 2 × 2 cells.
    if (m_craters.empty()) return;
    double smallest = m_craters[0].diameter;
    for (const Crater& c : m_craters) smallest = std::min(smallest, c.diameter);
    std::vector<int> band_of(m_craters.size());
    int bands = 0;
    for (size_t i = 0; i < m_craters.size(); ++i) {
        band_of[i] = static_cast<int>(std::floor(std::log2(m_craters[i].diameter / smallest)));
        bands = std::max(bands, band_of[i] + 1);
    }
    m_bands.resize(static_cast<size_t>(bands));
    for (int b = 0; b < bands; ++b) {
        Band& band = m_bands[static_cast<size_t>(b)];
        glm::dvec2 lo(INFINITY), hi(-INFINITY);
        double reach = 0.0;
        for (size_t i = 0; i < m_craters.size(); ++i) {
            if (band_of[i] != b) continue;
            lo = glm::min(lo, m_craters[i].centre - m_craters[i].reach_m);
            hi = glm::max(hi, m_craters[i].centre + m_craters[i].reach_m);
            reach = std::max(reach, m_craters[i].reach_m);
        }
        if (!(reach > 0.0)) continue;  // an empty band
        band.origin = lo;
        band.cell_m = 2.0 * reach;
        band.inverse_cell = 1.0 / band.cell_m;
        band.columns = std::max(1, static_cast<int>(std::ceil((hi.x - lo.x) / band.cell_m)));
        band.rows = std::max(1, static_cast<int>(std::ceil((hi.y - lo.y) / band.cell_m)));
        const size_t cells = static_cast<size_t>(band.columns) * band.rows;
        std::vector<std::vector<uint32_t>> lists(cells);
        for (size_t i = 0; i < m_craters.size(); ++i) {
            if (band_of[i] != b) continue;
            const Crater& c = m_craters[i];
            auto cell = [&](double v, double origin, int n) {
                return std::clamp(static_cast<int>(std::floor((v - origin) / band.cell_m)), 0, n - 1);
            };
            for (int y = cell(c.centre.y - c.reach_m, lo.y, band.rows);
                 y <= cell(c.centre.y + c.reach_m, lo.y, band.rows); ++y)
                for (int x = cell(c.centre.x - c.reach_m, lo.x, band.columns);
                     x <= cell(c.centre.x + c.reach_m, lo.x, band.columns); ++x)
                    lists[static_cast<size_t>(y) * band.columns + x].push_back(static_cast<uint32_t>(i));
        }
        band.offsets.assign(cells + 1, 0);
        for (size_t k = 0; k < cells; ++k)
            band.offsets[k + 1] = band.offsets[k] + static_cast<uint32_t>(lists[k].size());
        band.members.reserve(band.offsets.back());
        for (const auto& list : lists) band.members.insert(band.members.end(), list.begin(), list.end());
    }
}

double SubgridCraters::profile(const Crater& c, double s, double* slope) const {
    if (!(s < c.reach_s)) {
        if (slope) *slope = 0.0;
        return 0.0;
    }
    const double step = m_table.radius_step;
    const double position = std::clamp(s, 0.0, (m_columns - 1) * step) / step;
    const int col = std::min(static_cast<int>(position), m_columns - 2);
    const double w = position - col;
    const double* low = &m_table.heights[static_cast<size_t>(c.row) * m_columns + col];
    const double* high = low + m_columns;
    const double a = low[0] * (1.0 - w) + low[1] * w, b = high[0] * (1.0 - w) + high[1] * w;
    if (slope) {
        const bool inside = s > 0.0 && s < (m_columns - 1) * step;
        *slope = inside ? ((low[1] - low[0]) * (1.0 - c.row_weight) + (high[1] - high[0]) * c.row_weight) / step : 0.0;
    }
    return a * (1.0 - c.row_weight) + b * c.row_weight;
}

template <typename Visit>
void SubgridCraters::each_near(double x, double y, Visit visit) const {
    for (const Band& band : m_bands) {
        if (band.offsets.empty()) continue;
        const double fx = (x - band.origin.x) * band.inverse_cell, fy = (y - band.origin.y) * band.inverse_cell;
        if (!(fx >= 0.0 && fy >= 0.0 && fx < band.columns && fy < band.rows)) continue;
        const size_t cell = static_cast<size_t>(fy) * band.columns + static_cast<size_t>(fx);
        for (uint32_t k = band.offsets[cell]; k < band.offsets[cell + 1]; ++k) {
            const Crater& c = m_craters[band.members[k]];
            const glm::dvec2 offset(x - c.centre.x, y - c.centre.y);
            const double r2 = glm::dot(offset, offset);
            if (r2 < c.reach_m * c.reach_m && !visit(c, offset, std::sqrt(r2))) return;
        }
    }
}

double SubgridCraters::height(double x, double y) const {
    double z = 0.0;
    each_near(x, y, [&](const Crater& c, const glm::dvec2&, double r) {
        z += c.diameter * profile(c, r / c.radius);
        return true;
    });
    return z;
}

glm::dvec3 SubgridCraters::gradient(double x, double y, double footprint_m) const {
    glm::dvec2 g(0.0);
    each_near(x, y, [&](const Crater& c, const glm::dvec2& offset, double r) {
        const double weight = footprint_m > 0.0 ? std::clamp((c.diameter / footprint_m - 2.0) / 2.0, 0.0, 1.0) : 1.0;
        if (weight == 0.0 || !(r > 0.0)) return true;
        double slope;
        profile(c, r / c.radius, &slope);
        // z = D·h(r/R): dz/dr = D·h'(s)/R = 2·h'(s), along the radial unit vector.
        g += weight * 2.0 * slope * (offset / r);
        return true;
    });
    return {g.x, g.y, 0.0};
}

bool SubgridCraters::shadowed(const glm::dvec3& p, const glm::dvec3& to_light, const glm::dvec3& normal) const {
    const double cos_i = glm::dot(to_light, normal);
    if (!(cos_i > 0.0)) return false;
    // The light's direction within the facet's plane, as a horizontal heading, and its elevation
    // above the facet.
    const glm::dvec3 along = to_light - cos_i * normal;
    // Parts of a unit vector: nothing to overflow, so no libm hypot call on every Sun sample.
    const double horizontal2 = along.x * along.x + along.y * along.y;
    const double heading_length = std::sqrt(horizontal2);
    if (!(heading_length > 1e-9)) return false;  // overhead: nothing rises above it
    const glm::dvec2 heading(along.x / heading_length, along.y / heading_length);
    const double tan_e = cos_i / std::sqrt(horizontal2 + along.z * along.z);
    if (tan_e >= m_steepest) return false;  // above every wall
    bool hidden = false;
    each_near(p.x, p.y, [&](const Crater& c, const glm::dvec2& offset, double r) {
        if (tan_e >= c.steepest) return true;  // no wall of its rises as steeply as the light
        const double s0 = r / c.radius;
        if (s0 >= c.crest_s) return true;  // outside the rim crest: the flank only falls away from it
        const glm::dvec2 q0 = offset / c.radius;  // crater radii
        const double z0 = profile(c, s0);
        // Its wall rises at most to its crest, the profile's highest point, which the ray climbs
        // past (crest − z0)/(rise per radius) radii on; it leaves the crater's reach at the far
        // side of that circle.
        const double rise_per_radius = tan_e / 2.0;  // z/D a crater radius along the ray: R·tan e / D
        const double climb = (c.crest - z0) / rise_per_radius;
        if (!(climb > 0.0)) return true;
        const double b = glm::dot(q0, heading);
        const double reach = c.reach_m / c.radius;
        const double exit = -b + std::sqrt(std::max(0.0, b * b - s0 * s0 + reach * reach));
        const double last = std::min(exit, climb);
        for (int k = 1; k <= kShadowSteps; ++k) {
            const double t = last * k / kShadowSteps;
            if (profile(c, glm::length(q0 + t * heading)) - z0 > t * rise_per_radius) {
                hidden = true;
                return false;  // one wall is enough: the other craters need no look
            }
        }
        return true;
    });
    return hidden;
}

}  // namespace moonbot
