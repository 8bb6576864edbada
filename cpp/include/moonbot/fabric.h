// The bag's woven fabric (paper 3.3.2): a plain (over-under) weave evaluated analytically at a
// point of the fabric, with no texture files. It returns a linear-RGB albedo that the weave
// modulates by a few percent and a tangent-space normal from the yarn relief, both already
// prefiltered over the caller's footprint, so a bag far away (a pixel over many threads) gets
// the mean albedo and the flat normal instead of aliasing.
//
// Coordinates are metres of fabric: x along the warp (the tangent), y along the weft (the
// bitangent). On the bag, moonbot/scene/bag_mesh.py's uv_atlas() lays every face out at one
// scale, so fabric metres are atlas UV times that atlas's metres per UV unit (1.04 m for the
// default 0.32 × 0.20 × 0.12 m body: the belt's length, max(2(L + W), H + 2W)).
//
// The height field, in units of the relief and with a = πx/p, b = πy/p (p the thread pitch):
//
//   h(a, b) = ½ − ¼(cos 2a + cos 2b) + ⅛(sin 3a sin b − sin a sin 3b)
//
// It is the blend w·sin²b + (1 − w)·sin²a of a warp yarn of cross-section sin²b and a weft yarn
// of cross-section sin²a, weighted by w = (1 + sin a sin b)/2, which is 1 on the cells where the
// warp floats over the weft and 0 on the others (the checkerboard of a plain weave); expanding
// the products gives the trigonometric polynomial above. It spans [0, 1]: 1 at every cell
// centre, 0 where four cells meet; a warp-up cell's bump is flat along x (h = 1 − O(δ⁴)) and
// curved across it (1 − δ²), so each float is elongated along its own yarn. Its period is two
// threads (2p) both ways, and it has the plain weave's symmetry: swapping warp and weft is a
// shift by one thread, h(y, x) = h(x + p, y).
//
// Because h is a sum of a few sinusoids, the Gaussian prefilter is exact: a Gaussian of
// standard deviation σ multiplies a sinusoid of angular frequency m·π/p by
// g_m = exp(−½(mπσ/p)²) = g₁^(m²). σ is half the footprint width, so a sinusoid at the
// pixel's Nyquist frequency keeps 29 % of its amplitude and one at twice it 0.7 %.
#pragma once

#include <glm/glm.hpp>

namespace moonbot {

/// The weave's parameters. Defaults (docs/physics.md):
/// - `pitch_m` 1.5 mm, centre to centre of neighbouring yarns: a tightly woven cloth, finer than
///   the 10 × 10 tapes per inch (2.54 mm) of a common polypropylene sandbag; at the paper's
///   8192 px/m texture a thread spans 12 px, "fine, uniform" but resolved up close.
/// - `relief_m` 0.1 mm, the height of a float's crown over the pits between yarns (about two
///   slit-film tape thicknesses); the steepest facet is then 10° from the mean surface.
/// - `contrast` 0.04: albedo = mean·(1 + contrast·(2h − 1)), ±4 % between crowns and pits (the
///   "low-contrast, near-featureless" fabric of the paper; pits read darker, like the
///   ambient-occlusion map baked into its base colour).
/// - `albedo` the mean linear-RGB albedo, a tan fabric of mean 0.44 (§6: tan sandbag ≈ 0.35–0.5).
/// - `sheen` s in [0, 1], the weight of the tapes' glossy lobe (see "Sheen" below): the cloth's
///   BRDF is (1 − s)·albedo/π + s·f_tape. 0 (the default) is the matte weave, bit for bit.
/// - `sheen_along`, `sheen_across` in [0.01, 1]: the GGX roughness α of a tape along its length
///   (the over-under waviness of the float spreads its normals that way) and across it (a flat
///   slit-film tape is nearly smooth across its width).
struct FabricParams {
    double pitch_m = 1.5e-3;
    double relief_m = 1.0e-4;
    double contrast = 0.04;
    glm::dvec3 albedo{0.55, 0.45, 0.32};
    double sheen = 0.0;
    double sheen_along = 0.35;
    double sheen_across = 0.12;

    /// Throws std::invalid_argument naming the field: pitch_m > 0, relief_m ≥ 0,
    /// contrast in [0, 1], each albedo channel in [0, 1], sheen in [0, 1], the two roughnesses
    /// in [0.01, 1], all finite.
    void validate() const;
};

/// What the fabric looks like over one footprint.
struct FabricSample {
    glm::dvec3 albedo;  ///< linear RGB, within params.albedo·(1 ± contrast)
    glm::dvec3 normal;  ///< unit vector in the (tangent = +x warp, bitangent = +y weft, normal) frame
    /// The share of the footprint where the warp floats on top, in [0, 1]: ½(1 + sin a sin b)
    /// prefiltered (½ once the weave's checkerboard is filtered away).
    double warp_share = 0.5;
    /// The mean squared slope of the weave's relief that the prefilter removed, per axis (x, y):
    /// the normals inside the footprint that `normal` no longer shows, which widen the sheen's
    /// lobe instead (Toksvig 2005; LEAN mapping, Olano & Baker 2010).
    double lost_slope2_x = 0.0, lost_slope2_y = 0.0;
};

/// The weave at fabric point (x, y) metres, prefiltered with a Gaussian of σ = footprint_m / 2
/// (footprint_m ≥ 0: the width of fabric one sample stands for, metres; for an anisotropic
/// footprint pass its longer axis, which blurs rather than aliases). The albedo is the exact
/// Gaussian average of the albedo; the normal is the normal of the Gaussian-averaged height
/// field, which is (0, 0, 1) once the relief is filtered away. About 40 flops, one sin/cos per
/// axis and one exp. `params` must be valid (validate()); not checked here, per hit.
FabricSample fabric_eval(const FabricParams& params, double x, double y, double footprint_m);

// Sheen. Woven polypropylene is made of flat slit-film tapes, glossy where they float on top.
// No measured BRDF of such tape was found; we follow the structure of Irawan & Marschner's woven
// cloth model (2012: a specular lobe per yarn segment, oriented along the yarn) with a
// microfacet lobe per tape direction: an anisotropic GGX (Trowbridge-Reitz) distribution with
// Smith's height-correlated masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing
// Function in Microfacet-Based BRDFs", JCGT 3(2), eqs. 85 and 99 for the anisotropic D and Λ):
//
//   f_tape(ωi, ωo) = D(h)·G2(ωi, ωo) / (4·μi·μo),  G2 = 1/(1 + Λ(ωi) + Λ(ωo)),
//   D(h) = 1 / (π·αx·αy·((hx/αx)² + (hy/αy)² + hz²)²),
//   Λ(ω) = (−1 + √(1 + (αx²ωx² + αy²ωy²)/ωz²))/2,
//
// in the (warp, weft, normal) frame, with (αx, αy) = (along, across) where the warp floats and
// (across, along) where the weft does, mixed by the footprint's warp share. Without Fresnel
// (a white, perfect-mirror microsurface) its directional albedo ∫f_tape·μi dωi is ≤ 1 at every
// ωo (Smith's single-scattering energy loss makes it < 1 for rough lobes), so the cloth's
// (1 − s)·albedo/π + s·f_tape reflects at most (1 − s)·albedo + s ≤ 1.

/// The tape lobe f_tape (sr⁻¹) for unit directions wi, wo in the local (x, y, normal) frame with
/// roughness (ax, ay); 0 when either lies below the surface.
double tape_lobe(const glm::dvec3& wi, const glm::dvec3& wo, double ax, double ay);

/// The cloth's sheen f_sheen (sr⁻¹) over one footprint: warp_share·f_tape(along, across) +
/// (1 − warp_share)·f_tape(across, along), each α² widened by the lost slope variance of that
/// axis (so a distant, filtered weave keeps its highlight's energy in a broader lobe). Directions
/// are unit, in the (warp, weft, shading normal) frame.
double cloth_sheen(const FabricParams& params, const FabricSample& sample, const glm::dvec3& wi, const glm::dvec3& wo);

/// cloth_sheen at one footprint and one outgoing direction, for many incident directions (a
/// lobe of incident light read at many points): what depends on `wo` alone — each tape lobe's
/// roughness, its normalisation and Smith's Λ(wo) — is evaluated once, and every value is the
/// same as cloth_sheen's to the bit.
class ClothSheen {
public:
    /// `wo` unit, in the (warp, weft, shading normal) frame.
    ClothSheen(const FabricParams& params, const FabricSample& sample, const glm::dvec3& wo);
    /// f_sheen (sr⁻¹) for the unit incident direction `wi`, in the same frame.
    double operator()(const glm::dvec3& wi) const;

private:
    struct Lobe {
        double ax2, ay2;     // α² along x and y, widened by the lost slope variance
        double pi_alpha;     // π·αx·αy, D's normalisation
        double lambda_wo;    // Smith's Λ(wo)
    };
    double lobe(const Lobe& l, const glm::dvec3& wi, const glm::dvec3& h) const;

    glm::dvec3 m_wo;
    double m_warp_share;
    Lobe m_warp, m_weft;
};

/// The unfiltered height field h(a, b) in [0, 1] (see the top of this header), a = πx/p,
/// b = πy/p: exposed so tests and pictures can check the weave itself.
double weave_height(double a, double b);

}  // namespace moonbot
