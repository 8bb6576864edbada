// Filling the voids of a height grid (a DEM window) with a harmonic interpolant of the data
// around them. Heights in metres (any unit works: the fill is linear); grids are row-major,
// width × height, with NaN or ±Inf marking a void.
#pragma once

#include <cstdint>
#include <vector>

namespace moonbot {

/// Fills the NaN cells of a row-major width×height grid in place with a discrete harmonic
/// (Laplace) interpolant of the finite cells: each connected void region is seeded with the mean
/// of its finite neighbours and relaxed by successive over-relaxation until no cell moves more
/// than 1e-9 m in a sweep. A linear surface is reproduced exactly (to that tolerance) inside a
/// void enclosed by finite cells; at the grid's edge the fill has zero normal slope. Returns the
/// number of cells filled. Throws std::invalid_argument if no cell is finite.
int64_t fill_voids(std::vector<double>& grid, int width, int height);

}  // namespace moonbot
