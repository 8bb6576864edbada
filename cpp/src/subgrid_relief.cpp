#include "moonbot/subgrid_relief.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>

#include "moonbot/rng.h"

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;
// The grain's prefilter (regolith_texture.cpp): an octave whose Gaussian gain falls below this is
// dropped, and the weights are rescaled so that they stay continuous in the footprint.
constexpr double kGainCut = 0.01;
// roughness.py's `_lattice`: the cell's corners (i, j) hashed as mix(key ^ mix(i·φ ^ j)).
constexpr uint64_t kGolden = 0x9E3779B97F4A7C15ull;

void require(bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw std::invalid_argument("subgrid relief: " + field + ": " + what);
}

/// The lattice value at integer corner (i, j) of the octave keyed `key`: uniform on [−1, 1).
inline double lattice_value(uint64_t key, int64_t i, int64_t j) {
    const uint64_t h = mix64(key ^ mix64(static_cast<uint64_t>(i) * kGolden ^ static_cast<uint64_t>(j)));
    return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

/// The graded grid's spacing at coordinate x: linear between nodes, clamped at the ends (np.interp).
double interpolated(const GradedGrid& g, double x) {
    if (!(x > g.axis.front())) return g.spacing.front();
    if (!(x < g.axis.back())) return g.spacing.back();
    const auto upper = std::upper_bound(g.axis.begin(), g.axis.end(), x);
    const auto i = static_cast<size_t>(std::distance(g.axis.begin(), upper)) - 1;
    // np.interp's arithmetic, so the mesh's cells and these agree to the bit.
    const double slope = (g.spacing[i + 1] - g.spacing[i]) / (g.axis[i + 1] - g.axis[i]);
    return slope * (x - g.axis[i]) + g.spacing[i];
}

}  // namespace

SubgridRelief::SubgridRelief(std::vector<ReliefOctave> octaves, GradedGrid grid) : m_grid(std::move(grid)) {
    for (size_t k = 0; k < octaves.size(); ++k) {
        const ReliefOctave& o = octaves[k];
        const std::string name = "octave " + std::to_string(k);
        require(std::isfinite(o.wavelength_m) && o.wavelength_m > 0.0, name + ".wavelength_m",
                "must be a finite number > 0");
        require(std::isfinite(o.amplitude_m) && o.amplitude_m >= 0.0, name + ".amplitude_m",
                "must be a finite number >= 0");
        require(std::isfinite(o.angle_rad) && std::isfinite(o.offset.x) && std::isfinite(o.offset.y),
                name + ".angle_rad/offset", "must be finite");
        if (o.amplitude_m == 0.0) continue;  // nothing to give back
        const double slope = o.amplitude_m / o.wavelength_m;
        m_octaves.push_back({o, std::cos(o.angle_rad), std::sin(o.angle_rad), 1.0 / o.wavelength_m,
                             slope * slope * kQuinticNoiseSlopeVariance});
    }
    const GradedGrid& g = m_grid;
    require(g.axis.size() >= 2, "axis", "needs at least 2 nodes");
    require(g.spacing.size() == g.axis.size(), "spacing", "must have one value per axis node");
    for (size_t i = 0; i < g.axis.size(); ++i) {
        require(std::isfinite(g.axis[i]) && (i == 0 || g.axis[i] > g.axis[i - 1]), "axis",
                "must be finite and strictly ascending");
        require(std::isfinite(g.spacing[i]) && g.spacing[i] > 0.0, "spacing", "must be finite and > 0");
    }
}

double SubgridRelief::cell_m(double x, double y) const {
    return std::max(interpolated(m_grid, x), interpolated(m_grid, y));
}

double SubgridRelief::subgrid_weight(int k, double cell) const {
    const double held = m_octaves[static_cast<size_t>(k)].octave.wavelength_m / (2.0 * cell) - 1.0;
    return 1.0 - std::clamp(held, 0.0, 1.0);
}

double SubgridRelief::value_noise(const Octave& o, double u, double v, glm::dvec2* derivative) {
    const double fi = std::floor(u), fj = std::floor(v);
    const double fu = u - fi, fv = v - fj;
    const double su = fu * fu * fu * (fu * (fu * 6.0 - 15.0) + 10.0);
    const double sv = fv * fv * fv * (fv * (fv * 6.0 - 15.0) + 10.0);
    const auto i = static_cast<int64_t>(fi), j = static_cast<int64_t>(fj);
    const uint64_t key = o.octave.key;
    const double a = lattice_value(key, i, j), b = lattice_value(key, i + 1, j);
    const double c = lattice_value(key, i, j + 1), d = lattice_value(key, i + 1, j + 1);
    // roughness.py's value_noise, in its order of operations.
    const double bottom = a + su * (b - a), top = c + su * (d - c);
    if (derivative) {
        const double dsu = 30.0 * fu * fu * (fu - 1.0) * (fu - 1.0);
        const double dsv = 30.0 * fv * fv * (fv - 1.0) * (fv - 1.0);
        *derivative = {dsu * ((b - a) + sv * ((d - c) - (b - a))), dsv * (top - bottom)};
    }
    return bottom + sv * (top - bottom);
}

double SubgridRelief::height(double x, double y, double cell) const {
    double z = 0.0;
    for (size_t k = 0; k < m_octaves.size(); ++k) {
        const Octave& o = m_octaves[k];
        const double m = subgrid_weight(static_cast<int>(k), cell);
        if (m == 0.0) continue;
        const double u = (o.cos_angle * x + o.sin_angle * y) / o.octave.wavelength_m + o.octave.offset.x;
        const double v = (-o.sin_angle * x + o.cos_angle * y) / o.octave.wavelength_m + o.octave.offset.y;
        z += m * o.octave.amplitude_m * value_noise(o, u, v, nullptr);
    }
    return z;
}

ReliefSample SubgridRelief::eval(const glm::dvec3& p, double footprint_m) const {
    ReliefSample out;
    const double cell = cell_m(p.x, p.y);
    glm::dvec2 gradient(0.0);
    for (size_t k = 0; k < m_octaves.size(); ++k) {
        const Octave& o = m_octaves[k];
        const double m = subgrid_weight(static_cast<int>(k), cell);
        if (m == 0.0) continue;
        const double x = kPi * footprint_m / (2.0 * o.octave.wavelength_m);
        const double gain = std::exp(-0.5 * x * x);
        if (gain <= kGainCut) continue;
        const double w = (gain - kGainCut) * (1.0 / (1.0 - kGainCut));
        out.residual_slope_variance += w * w * (1.0 - w * w) * m * m * o.slope_variance;
        const double u = (o.cos_angle * p.x + o.sin_angle * p.y) / o.octave.wavelength_m + o.octave.offset.x;
        const double v = (-o.sin_angle * p.x + o.cos_angle * p.y) / o.octave.wavelength_m + o.octave.offset.y;
        glm::dvec2 d;
        value_noise(o, u, v, &d);
        // (∂u, ∂v)/∂(x, y) is the rotation over λ: back to the world by its transpose.
        const double scale = w * w * m * o.octave.amplitude_m * o.inverse_wavelength;
        gradient += scale * glm::dvec2(o.cos_angle * d.x - o.sin_angle * d.y, o.sin_angle * d.x + o.cos_angle * d.y);
    }
    out.gradient = {gradient.x, gradient.y, 0.0};
    return out;
}

}  // namespace moonbot
