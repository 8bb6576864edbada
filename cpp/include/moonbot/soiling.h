// Regolith dust on the bags: the "dust" stain mode, an alternative to the paper's stamp painting
// (stain.h, which stays as it is). Dust gathers where a bag touches the ground and where it is
// handled, and it is a powder: grainy at its edges rather than a liquid splat. Per bag, from its
// seed and its mesh (object frame, +z up: the face it lies on is its lowest), we keep
//
// - a contact band: coverage b·exp(−(z − z_min)/contact_height_m) on the bottom face and up the
//   lower edges, with b = 1 − exp(−N/30) growing with the deposit count N (0.39 at 15, 0.63 at
//   30, 0.95 at 90: the paper's seed sweep keeps its meaning, dirtier with more seeds);
// - N deposits, each a smooth bump α·(1 − d²/r²)² of object-space distance d from a centre on the
//   mesh's surface, so a deposit near an edge wraps over it. Centres are drawn area-weighted
//   over the triangles, a `handled_share` of them weighted by exp(−(z_max − z)/h) toward the top
//   (where hands grab a bag) and the rest by exp(−(z − z_min)/(2h)) toward the bottom (where it was
//   dragged and set down), h = contact_height_m; radii r = deposit_radius_m·(0.6 … 1.4);
// - a speckle ξ: regolith_texture.h's value noise over object-space points (cells 0.5–4 mm, unit
//   RMS, prefiltered over the footprint), which breaks the coverage c = min(1, band + Σ bumps)
//   into grains where it is partial: m = clamp(c + 2·speckle·ξ·c(1 − c), 0, 1). Clean cloth
//   (c = 0) and full cover (c = 1) are untouched by it, and far away (ξ filtered to 0) m = c.
//
// The bag's colour is then the area mix lerp(clean, dust, m): a dusted patch takes the dust's own
// albedo, with no extra darkening (the paper's lerp(clean, m·dirt, m) darkens as m², which reads
// as dark spots). Dust is matte and fills the weave: the renderer scales the cloth's sheen by
// 1 − m and flattens the weave's normal toward the mean surface by m. Deterministic:
// counter-based draws keyed by (seed, deposit index).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "moonbot/regolith_texture.h"

namespace moonbot {

/// Parameters of the dust mode (the count N and opacity α come from StainParams).
struct SoilingParams {
    int deposits = 0;                  ///< N ≥ 0 (StainParams::stamps); 0 = clean
    double opacity = 0.5;              ///< α in [0, 1], a deposit's coverage at its centre
    double contact_height_m = 0.025;   ///< h > 0: the contact band's e-folding height, metres
    double deposit_radius_m = 0.04;    ///< mean deposit radius, metres, > 0
    double handled_share = 0.25;       ///< share of deposits near the top, [0, 1]
    double speckle = 0.8;              ///< grain strength, [0, 2]

    /// Throws std::invalid_argument naming the field ("stain.<field>").
    void validate() const;
};

/// One bag's dust.
class Soiling {
public:
    /// Places the deposits over the mesh (`vertices` n×3 floats with the mesh's stride of 3,
    /// object frame, metres; `triangles` m×3 indices). Throws std::invalid_argument on invalid
    /// params or an empty mesh.
    Soiling(const SoilingParams& params, uint64_t seed, const float* vertices, size_t n_vertices,
            const uint32_t* triangles, size_t n_triangles);

    /// Dust cover m in [0, 1] at object-space point p (metres), prefiltered over footprint_m.
    double coverage(const glm::dvec3& p, double footprint_m) const;

    /// Coverage before the speckle, c in [0, 1] (its far-away value).
    double smooth_coverage(const glm::dvec3& p) const;

    struct Deposit {
        glm::dvec3 centre;  // object frame, metres, on the mesh
        double radius;      // metres
    };
    const std::vector<Deposit>& deposits() const { return m_deposits; }
    double band() const { return m_band; }

private:
    SoilingParams m_params;
    std::vector<Deposit> m_deposits;
    double m_zmin = 0.0, m_zmax = 0.0, m_band = 0.0;
    RegolithGrain m_speckle;
};

/// The dusted colour lerp(clean, dust, m), m clamped to [0, 1]; m = 0 returns `clean` exactly.
glm::dvec3 dusted_colour(const glm::dvec3& clean, double m, const glm::dvec3& dust);

}  // namespace moonbot
