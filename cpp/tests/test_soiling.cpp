#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.h"
#include "moonbot/rng.h"
#include "moonbot/soiling.h"

using namespace moonbot;

namespace {

/// A closed box [−0.16, 0.16] × [−0.10, 0.10] × [−0.06, 0.06] m, like the default bag's body.
struct Box {
    std::vector<float> v = {-0.16f, -0.10f, -0.06f, 0.16f, -0.10f, -0.06f, 0.16f, 0.10f, -0.06f, -0.16f, 0.10f, -0.06f,
                            -0.16f, -0.10f, 0.06f,  0.16f, -0.10f, 0.06f,  0.16f, 0.10f, 0.06f,  -0.16f, 0.10f, 0.06f};
    std::vector<uint32_t> t = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                               1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
};

Soiling make(int deposits, uint64_t seed, double handled = 0.25, double speckle = 0.8) {
    static const Box box;
    SoilingParams p;
    p.deposits = deposits;
    p.handled_share = handled;
    p.speckle = speckle;
    return Soiling(p, seed, box.v.data(), 8, box.t.data(), 12);
}

/// Points scattered on the box's surface (face by face, deterministic).
std::vector<glm::dvec3> surface_points(int n) {
    std::vector<glm::dvec3> out;
    for (int i = 0; i < n; ++i) {
        const double u = uniform01(5, i, 0, 0), w = uniform01(5, i, 0, 1);
        switch (i % 6) {
            case 0: out.push_back({-0.16 + 0.32 * u, -0.10 + 0.20 * w, -0.06}); break;
            case 1: out.push_back({-0.16 + 0.32 * u, -0.10 + 0.20 * w, 0.06}); break;
            case 2: out.push_back({-0.16 + 0.32 * u, -0.10, -0.06 + 0.12 * w}); break;
            case 3: out.push_back({-0.16 + 0.32 * u, 0.10, -0.06 + 0.12 * w}); break;
            case 4: out.push_back({-0.16, -0.10 + 0.20 * u, -0.06 + 0.12 * w}); break;
            default: out.push_back({0.16, -0.10 + 0.20 * u, -0.06 + 0.12 * w}); break;
        }
    }
    return out;
}

}  // namespace

TEST_CASE(no_deposits_no_dust) {
    const Soiling s = make(0, 1);
    CHECK(s.deposits().empty());
    CHECK(s.band() == 0.0);
    for (const glm::dvec3& p : surface_points(600)) CHECK(s.coverage(p, 0.0) == 0.0);
    CHECK(dusted_colour({0.5, 0.4, 0.3}, 0.0, {0.1, 0.1, 0.1}) == glm::dvec3(0.5, 0.4, 0.3));
    CHECK(dusted_colour({0.5, 0.4, 0.3}, 1.0, {0.1, 0.1, 0.1}) == glm::dvec3(0.1, 0.1, 0.1));
}

TEST_CASE(dust_gathers_at_the_bottom_and_where_handled) {
    // The band's strength follows 1 − exp(−N/30); with no handling every deposit is in the lower
    // half far more often than not, and handled deposits favour the top.
    CHECK_NEAR(make(90, 1).band(), 1 - std::exp(-3.0), 1e-15);
    const Soiling low = make(200, 2, 0.0), high = make(200, 2, 1.0);
    int low_below = 0, high_above = 0;
    for (const auto& d : low.deposits()) low_below += d.centre.z < 0.0;
    for (const auto& d : high.deposits()) high_above += d.centre.z > 0.0;
    CHECK(low_below > 150);
    CHECK(high_above > 150);
    // Every centre is on the box's surface, and radii are 0.6–1.4 × 4 cm.
    for (const auto& d : low.deposits()) {
        const bool on_face = std::abs(std::abs(d.centre.x) - 0.16) < 1e-6 ||
                             std::abs(std::abs(d.centre.y) - 0.10) < 1e-6 ||
                             std::abs(std::abs(d.centre.z) - 0.06) < 1e-6;
        CHECK(on_face);
        CHECK(d.radius >= 0.024 && d.radius <= 0.056);
    }
    // The bottom face is dustier than the top on average (smooth cover).
    const Soiling s = make(30, 3);
    double bottom = 0, top = 0;
    for (int i = 0; i < 500; ++i) {
        const double u = uniform01(9, i, 0, 0) * 0.32 - 0.16, w = uniform01(9, i, 0, 1) * 0.2 - 0.1;
        bottom += s.smooth_coverage({u, w, -0.06}) / 500;
        top += s.smooth_coverage({u, w, 0.06}) / 500;
    }
    CHECK(bottom > 2 * top);
    CHECK(bottom >= s.band() - 1e-12);
}

TEST_CASE(dust_is_deterministic_and_keyed_by_seed) {
    const Soiling a = make(40, 7), b = make(40, 7), c = make(40, 8);
    int differ = 0;
    for (size_t k = 0; k < a.deposits().size(); ++k) {
        CHECK(a.deposits()[k].centre == b.deposits()[k].centre);
        differ += a.deposits()[k].centre != c.deposits()[k].centre;
    }
    CHECK(differ == 40);
    for (const glm::dvec3& p : surface_points(300)) CHECK(a.coverage(p, 1e-3) == b.coverage(p, 1e-3));
}

TEST_CASE(speckle_is_grain_at_partial_cover_and_filtered_away_far_off) {
    const Soiling s = make(90, 4);
    double spread = 0.0, mean_difference = 0.0;
    int partial = 0;
    for (const glm::dvec3& p : surface_points(6000)) {
        const double c = s.smooth_coverage(p);
        // Far off (a footprint over the coarsest speckle cell) the cover is the smooth one, exactly.
        CHECK(s.coverage(p, 0.01) == c);
        const double m = s.coverage(p, 0.0);
        CHECK(m >= 0.0 && m <= 1.0);
        if (c == 0.0 || c == 1.0) CHECK(m == c);
        if (c > 0.2 && c < 0.8) {
            ++partial;
            spread += (m - c) * (m - c);
            mean_difference += m - c;
        }
    }
    CHECK(partial > 300);
    // Grainy where partial: RMS departure of several percent, averaging out to ~0.
    CHECK(std::sqrt(spread / partial) > 0.05);
    CHECK(std::abs(mean_difference / partial) < 0.02);
    // speckle 0: smooth everywhere.
    const Soiling smooth = make(90, 4, 0.25, 0.0);
    for (const glm::dvec3& p : surface_points(300)) CHECK(smooth.coverage(p, 0.0) == smooth.smooth_coverage(p));
}

TEST_CASE(dust_params_name_the_field) {
    SoilingParams p;
    p.contact_height_m = 0.0;
    try {
        p.validate();
        CHECK(false);
    } catch (const std::invalid_argument& e) {
        CHECK(std::string(e.what()).find("stain.contact_height_m") == 0);
    }
    p = SoilingParams{};
    p.speckle = 3.0;
    CHECK_THROWS(std::invalid_argument, p.validate());
}
