// Step 3's first work list of tin_ground with densify_cell: the lowest point of each cell
// (tin_ground.hpp: TinGroundParams::densify_cell). Part of tin_ground, split out to keep
// files small.
#pragma once

#include <cstdint>
#include <vector>

#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/tin_ground.hpp"

namespace pcl_rg {

/// The points tin_ground's densification tests when densify_cell(params) (tin_ground.hpp;
/// every length set) is > 0: the lowest (least z, then smallest index) of the points whose
/// TIN grid positions (origin + (grid - 1) x quantum) fall in each cell of that side on the
/// world lattice of that size, as a bitmap over the sorted positions s of `snapped`
/// (index_bitmap.hpp). Otherwise empty: every point is tested. Throws
/// std::invalid_argument when those cells would number more than 2^40 per axis.
std::vector<std::uint64_t> tin_densified(const SnappedPoints& snapped,
                                         const TinGroundParams& params);

}  // namespace pcl_rg
