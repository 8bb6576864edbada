// fill_voids (see void_fill.h): breadth-first void regions, each relaxed by successive
// over-relaxation.
#include "moonbot/void_fill.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <stdexcept>

namespace moonbot {

namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

int64_t fill_voids(std::vector<double>& grid, int width, int height) {
    if (width < 1 || height < 1 || grid.size() != static_cast<size_t>(width) * static_cast<size_t>(height))
        throw std::invalid_argument("grid: size must be width × height");
    const size_t n = grid.size();
    std::vector<uint8_t> is_void(n);
    size_t voids = 0;
    for (size_t i = 0; i < n; ++i) {
        is_void[i] = !std::isfinite(grid[i]);
        voids += is_void[i];
    }
    if (voids == n) throw std::invalid_argument("grid: every cell is void");
    if (voids == 0) return 0;

    const auto W = static_cast<size_t>(width);
    std::vector<uint8_t> seen(n, 0);
    std::vector<size_t> cells;
    std::deque<size_t> queue;
    for (size_t start = 0; start < n; ++start) {
        if (!is_void[start] || seen[start]) continue;
        // One 4-connected void region, gathered breadth-first.
        cells.clear();
        queue.push_back(start);
        seen[start] = 1;
        while (!queue.empty()) {
            const size_t c = queue.front();
            queue.pop_front();
            cells.push_back(c);
            const size_t x = c % W, y = c / W;
            const size_t nb[4] = {x > 0 ? c - 1 : n, x + 1 < W ? c + 1 : n, y > 0 ? c - W : n,
                                  y + 1 < static_cast<size_t>(height) ? c + W : n};
            for (size_t m : nb)
                if (m != n && is_void[m] && !seen[m]) {
                    seen[m] = 1;
                    queue.push_back(m);
                }
        }
        // Raster order makes the sweep a plain lexicographic Gauss-Seidel, independent of the
        // breadth-first order.
        std::sort(cells.begin(), cells.end());
        size_t xmin = W, xmax = 0, ymin = n, ymax = 0;
        double seed = 0.0;
        size_t seeds = 0;
        for (size_t c : cells) {
            const size_t x = c % W, y = c / W;
            xmin = std::min(xmin, x), xmax = std::max(xmax, x), ymin = std::min(ymin, y), ymax = std::max(ymax, y);
            const size_t nb[4] = {x > 0 ? c - 1 : n, x + 1 < W ? c + 1 : n, y > 0 ? c - W : n,
                                  y + 1 < static_cast<size_t>(height) ? c + W : n};
            for (size_t m : nb)
                if (m != n && !is_void[m]) seed += grid[m], ++seeds;
        }
        // A maximal void region that is not the whole grid borders a finite cell, so seeds > 0.
        seed /= static_cast<double>(seeds);
        for (size_t c : cells) grid[c] = seed;
        // Successive over-relaxation with the optimal factor for a square of side L (Young):
        // ω = 2 / (1 + sin(π/(L+1))); it cuts the sweeps from O(L²) (Gauss-Seidel) to O(L).
        const double L = static_cast<double>(std::max(xmax - xmin, ymax - ymin) + 1);
        const double omega = 2.0 / (1.0 + std::sin(kPi / (L + 1.0)));
        const int max_sweeps = static_cast<int>(100.0 * L) + 1000;
        for (int sweep = 0; sweep < max_sweeps; ++sweep) {
            double moved = 0.0;
            for (size_t c : cells) {
                const size_t x = c % W, y = c / W;
                double sum = 0.0;
                int count = 0;
                // At the grid's edge only the neighbours inside count: zero normal slope there.
                if (x > 0) sum += grid[c - 1], ++count;
                if (x + 1 < W) sum += grid[c + 1], ++count;
                if (y > 0) sum += grid[c - W], ++count;
                if (y + 1 < static_cast<size_t>(height)) sum += grid[c + W], ++count;
                const double step = omega * (sum / count - grid[c]);
                grid[c] += step;
                moved = std::max(moved, std::abs(step));
            }
            if (moved < 1e-9) break;
        }
    }
    return static_cast<int64_t>(voids);
}

}  // namespace moonbot
