// The terrain's subgrid craters: the small craters a graded mesh could not draw, given back to the
// shading as their slopes and the shadows their walls cast.
//
// Why. A procedural location (moonbot/terrain/location.py) samples small craters from the
// standard equilibrium N(≥D) = 0.079·D⁻² per m² (Trask 1966) and draws one into its mesh only
// where the crater spans five cells; the cells grow as about 0.02 × the distance, so no crater
// narrower than a tenth of its distance is drawn. Under a low Sun such a crater is a dark crescent
// beside a bright far wall a few pixels across: the small dark blobs that Apollo surface photographs
// show to the horizon and that the renders lacked (docs/performance.md, "Realism"). What the mesh
// did not draw is given back here, at every distance where a crater still spans a few pixels
// (location.py's SUBGRID_CRATER_REACH), and nowhere it was drawn, so no crater counts twice.
//
// The profile. Each crater's height is location.py's: the radial profile crater_profile(s, D, σ/R)
// of moonbot/terrain/craters.py (a fresh simple crater diffused by σ/R), read here from the same
// table (`CraterProfileTable`, linear in σ/R and in s), so heights agree with the Python field to
// rounding (tests/test_subgrid_craters.py).
//
// The shadow. A point inside a crater's rim crest, at horizontal offset q (in crater radii) from its
// centre, sees the Sun at elevation e above the facet it lies on. The crater shades it where the
// profile rises above the ray toward the Sun: max over t of z(q + t·u) − z(q) − t·R·tan e > 0, u
// the Sun's heading in the facet's plane, the maximum taken at kShadowSteps evenly spaced points
// up to where the ray passes the crest's height or leaves the crater. Each crater is tested on its
// own: overlapping craters do not shade one another. Points outside the crest are not tested: a
// fresh crater's outer flank falls at most 12° (tan = 3·0.036·2) and shades a sliver behind the
// rim only under a lower Sun.
//
// What it leaves out. Depth, masks and the light cache see the mesh alone, as with the subgrid
// relief (subgrid_relief.h); a crater's shadow is tested for the camera's hits, not for the light
// cache's paths or a bounce.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace moonbot {

/// craters.py's tabulated radial profiles: heights over diameter z/D, one row per diffusion length
/// σ/R of `degradation` (ascending, from 0), at radii s = k·radius_step (crater radii), k = 0 ..
/// columns − 1; and each row's reach (crater radii), from which a profile is 0. A crater between
/// two rows takes both linearly in σ/R, its reach too.
struct CraterProfileTable {
    std::vector<double> degradation;
    double radius_step = 0.01;
    std::vector<double> heights;  ///< degradation.size() × columns, row-major
    std::vector<double> reach;    ///< degradation.size(), > 0
};

/// Small craters on the terrain, each a centre (x, y) in world metres, a diameter D (metres, > 0)
/// and a degradation σ/R within the table's rows.
class SubgridCraters {
public:
    /// Throws std::invalid_argument naming the field: centres not (K, 2) finite, diameters not
    /// positive and finite, degradation outside the table's range, or a table that is not
    /// rectangular, ascending from 0 and finite.
    SubgridCraters(std::vector<glm::dvec2> centres, std::vector<double> diameters, std::vector<double> degradation,
                   CraterProfileTable table);

    size_t count() const { return m_craters.size(); }

    /// Height (metres) of the craters' profiles summed at world (x, y).
    double height(double x, double y) const;

    /// ∇z of the summed profiles at world (x, y): (∂z/∂x, ∂z/∂y, 0), world frame. Craters narrower
    /// than two footprints (`footprint_m` metres) are left out, those wider than four kept whole,
    /// linearly between: a crater a pixel cannot resolve has no slope of its own to show.
    glm::dvec3 gradient(double x, double y, double footprint_m) const;

    /// Whether a crater's wall hides the light coming from `to_light` (unit, world) at the terrain
    /// point p (world metres) of geometric normal `normal` (unit; the light must be above it).
    bool shadowed(const glm::dvec3& p, const glm::dvec3& to_light, const glm::dvec3& normal) const;

    /// Points along a shadow test's ray, from just past its point to the rim crest.
    static constexpr int kShadowSteps = 16;

private:
    struct Crater {
        glm::dvec2 centre;
        double diameter, radius, reach_m;  // reach: where its profile ends, metres ...
        double reach_s;                    // ... and in crater radii
        double crest;                      // z/D: no higher than this anywhere (its rows' highest) ...
        double crest_s;                    // ... and the farther of the radii (crater radii) where they lie
        double steepest;                   // tan of its steepest slope (its rows' steepest)
        int row;                           // the table row below its degradation ...
        double row_weight;                 // ... and the weight of the row above
    };
    /// One octave band of diameters [d, 2d): a uniform grid of cells `cell_m` wide from `origin`,
    /// each listing the craters whose reach overlaps it (CSR: cell c holds
    /// members[offsets[c] .. offsets[c + 1])).
    struct Band {
        glm::dvec2 origin{0.0};
        double cell_m = 1.0, inverse_cell = 1.0;
        int columns = 0, rows = 0;
        std::vector<uint32_t> offsets, members;
    };
    /// z/D of crater c at s crater radii, and (with `slope`) dz/ds over D.
    double profile(const Crater& c, double s, double* slope = nullptr) const;
    /// Calls visit(crater, (x, y) − its centre, their distance) for each crater whose reach holds
    /// world (x, y), metres, until a call returns false.
    template <typename Visit>
    void each_near(double x, double y, Visit visit) const;

    std::vector<Crater> m_craters;
    CraterProfileTable m_table;
    int m_columns = 0;
    double m_steepest = 0.0;  // the steepest slope of any crater (tan)
    std::vector<Band> m_bands;
};

}  // namespace moonbot
