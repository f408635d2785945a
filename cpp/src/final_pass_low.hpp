// Ground points far below their surroundings, left out of the final pass's TIN
// (final_pass.cpp, step 2, with final_low_depth). Private to cpp/src.
#pragma once

#include <cstdint>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg::final_pass_low {

// Cells on each side of a point's cell in the window of its surroundings: 7 x 7 cells,
// 21 m at ISPRS's 3 m final cells. A patch of low points is found while it covers less
// than half of the window's cells that hold ground.
constexpr std::int64_t kWindowReach = 3;

// A cluster of low points (multipath echoes under the terrain) holds the filters'
// low-outlier tests off, as its points vouch for each other, and becomes TIN vertices
// that pull the surface down to them. So before the TIN is built: kept[i] = ground[i]
// and z_i >= m_c - depth, with m_c the median of the lowest ground heights (z - z0 of
// `cells`) of the cells of the window around point i's cell c that hold ground, c
// included (an even count: the mean of the two middle heights). depth > 0. Both
// arrays hold points.size entries. Polls for interruption.
void keep_not_low(PointsView points, const CellLattice& cells, double depth, const bool* ground,
                  bool* kept);

}  // namespace pcl_rg::final_pass_low
