// VoxelGrid downsampling with the semantics of PCL 1.13's pcl::VoxelGrid, for any extent.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

struct VoxelGridParams {
    /// Voxel edge lengths along x, y, z (> 0, caller's units, m); PCL setLeafSize.
    /// No default: zero is rejected by validate().
    std::array<double, 3> leaf_size{0.0, 0.0, 0.0};
    /// Voxels holding fewer points are dropped (>= 1); PCL setMinimumPointsNumberPerVoxel.
    std::int64_t min_points_per_voxel = 1;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const VoxelGridParams& params);

struct VoxelGridResult {
    std::vector<double> centroids;     ///< 3 per kept voxel, mean of its points (caller's frame)
    std::vector<std::int64_t> counts;  ///< points per kept voxel
};

/// Voxel of p = floor(p / leaf) per axis in float64, the grid anchored at the world
/// origin. Kept voxels come out in PCL's order: by z index, then y, then x.
/// `voxel_of_point[i]` (N entries, filled) is the output row of point i's voxel, or
/// -1 when that voxel held fewer than min_points_per_voxel points.
VoxelGridResult voxel_grid(PointsView points, const VoxelGridParams& params,
                           std::int64_t* voxel_of_point);

}  // namespace pcl_rg
