// Step 2 of progressive TIN densification: the seed points the first TIN is built on
// (LiDAR360's lowest point per cell, or the morphological seeds of
// TinGroundParams::seed_cell). Part of tin_ground, split out to keep files small.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "pcl_rg/points.hpp"
#include "pcl_rg/tin_ground.hpp"

namespace pcl_rg {

/// The seeds of tin_ground, sorted by index: the lowest point of each max_building_size
/// cell, or the morphological seeds when params.seed_cell > 0; the cells lie on the world
/// lattice of their size. `origin` (the minimum corner) and `upper` bound the points' box.
/// `params` must have seed_cell set (tin_ground passes with_spacing(...)). The
/// morphological seeds' raster leaves out long empty runs of cells when the full one
/// would exceed 4 cells per point (a few points far from the rest), which changes no
/// seed; it throws std::invalid_argument when even that raster is too large, unless it
/// is a corridor's (at most 2^25 / opening_rank cells, 1 % of them holding a point).
std::vector<std::uint32_t> tin_seeds(PointsView points, const TinGroundParams& params,
                                     const std::array<double, 3>& origin,
                                     const std::array<double, 3>& upper);

/// `error`, a refusal of tin_seeds with seed_cell left unset, told with the rule that set
/// seed_cell from `spacing` (m, the measured point spacing) and what to do about it.
std::invalid_argument unset_seed_cell_error(const std::invalid_argument& error, double spacing);

}  // namespace pcl_rg
