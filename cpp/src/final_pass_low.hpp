// Ground points far below their surroundings, left out of the final pass's TIN
// (final_pass.cpp, step 2, with final_low_depth). Private to cpp/src.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg::final_pass_low {

// The window of a point's surroundings: 7 x 7 cells, kWindowReach on each side of the
// point's own, taken every window_stride(size) = k cells, the least k >= 1 for which
// the window's 6k + 1 cells span at least kWindowMetres: 14-24 m whatever the final
// cell (21 and 28 m at the presets' 3 and 4 m final cells, where k is 1). A patch of
// low points is found while it covers less than half of the window's cells that hold
// ground; the densification often leaves a ring of terrain a few metres wide around a
// patch as object, which a window of 7 adjacent cells of tin_ground's 1.6 m cells at 4
// points per m^2 (11 m) did not see past, and one of 14 m did.
constexpr std::int64_t kWindowReach = 3;
constexpr double kWindowMetres = 14.0;

// The least k >= 1 with (6k + 1) x size >= kWindowMetres, at most 2^40 (a lattice's
// bound on cells per axis, so that no absurdly small cell overflows the conversion);
// the NumPy reference computes it with the same operations.
inline std::int64_t window_stride(double size) {
    const double k = std::ceil((kWindowMetres / size - 1.0) / (2 * kWindowReach));
    return std::max<std::int64_t>(1, static_cast<std::int64_t>(std::min(k, 0x1p40)));
}

// A cluster of low points (multipath echoes under the terrain) holds the filters'
// low-outlier tests off, as its points vouch for each other, and becomes TIN vertices
// that pull the surface down to them. So before the TIN is built: kept[i] = ground[i]
// and z_i >= m_c - depth, with m_c the median of the lowest ground heights (z - z0 of
// `cells`) of the cells of the window around point i's cell c that hold ground, c
// included (an even count: the mean of the two middle heights). depth > 0. Both
// arrays hold points.size entries. Polls for interruption.
// Where it works through a raster of the cells (fits_raster), it also returns what
// lowest_points(points, cells, kept) would, the lowest kept point of each cell (index
// order): it has every cell's lowest ground point at hand, which is kept unless its
// cell has a threshold, so only the few cells with one need their points. Elsewhere it
// returns nothing, and the caller finds them.
std::optional<std::vector<std::uint32_t>> keep_not_low(PointsView points, const CellLattice& cells,
                                                       double depth, const bool* ground,
                                                       bool* kept);

// For points in a SnappedPoints' order with their cells (snapped.cell on `cells`, where
// final_cells_by_position holds): the ground that may give vertices, by position, in
// `vertex_ground` (with depth > 0 keep_not_low's kept points, else the ground), and
// the lowest of it in each cell (input indices, in index order), as lowest_points or
// keep_not_low give them. Every scan of the points reads the snapped arrays in order;
// `ground` is by input index, and the coordinates are read only for the lowest points.
std::vector<std::uint32_t> lowest_by_position(PointsView points, const SnappedPoints& snapped,
                                              const CellLattice& cells, double depth,
                                              const bool* ground,
                                              std::vector<unsigned char>& vertex_ground);

}  // namespace pcl_rg::final_pass_low
