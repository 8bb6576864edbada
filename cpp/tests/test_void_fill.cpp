// Harmonic void filling against closed forms: a plane is reproduced inside an enclosed void, and a
// void at the grid's edge stays within the range of the data around it.
#include <cmath>
#include <stdexcept>
#include <vector>

#include "check.h"
#include "moonbot/void_fill.h"

using namespace moonbot;

TEST_CASE(void_fill_reproduces_a_plane) {
    const int w = 40, h = 30;
    auto plane = [](int x, int y) { return 0.3 * x - 0.2 * y + 5.0; };
    std::vector<double> z(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) z[static_cast<size_t>(y) * w + x] = plane(x, y);
    int holes = 0;
    for (int y = 8; y < 20; ++y)
        for (int x = 5; x < 17; ++x, ++holes) z[static_cast<size_t>(y) * w + x] = NAN;
    z[static_cast<size_t>(25) * w + 30] = INFINITY;  // a lone non-finite sample is a void too
    ++holes;
    CHECK(fill_voids(z, w, h) == holes);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) CHECK_NEAR(z[static_cast<size_t>(y) * w + x], plane(x, y), 1e-7);
}

TEST_CASE(void_fill_at_the_edge_stays_within_the_data) {
    const int w = 12, h = 9;
    std::vector<double> z(static_cast<size_t>(w) * h);
    for (size_t i = 0; i < z.size(); ++i) z[i] = static_cast<double>(i % w);
    for (int y = 0; y < h; ++y) z[static_cast<size_t>(y) * w + (w - 1)] = NAN;  // the east column
    z[0] = NAN;  // and a corner
    CHECK(fill_voids(z, w, h) == h + 1);
    for (double v : z) CHECK(std::isfinite(v) && v >= 0.0 && v <= w - 2.0);
    std::vector<double> none(6, NAN);
    CHECK_THROWS(std::invalid_argument, fill_voids(none, 3, 2));
}
