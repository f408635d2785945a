// PCL's own filter classes behind plain functions: the baselines that benchmarks time
// and that tests hold the core to. Not part of the public algorithms.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "pcl_rg/points.hpp"
#include "pcl_rg/statistical_outlier_removal.hpp"
#include "pcl_rg/voxel_grid.hpp"

namespace pcl_rg {

/// pcl::VoxelGrid on the points minus `origin` (as float32); centroids are returned
/// plus `origin`, in float64, in PCL's output order. PCL's overflow refusal shows as
/// the input coming back unchanged, exactly as PCL does it.
std::vector<double> pcl_voxel_grid(PointsView points, const std::array<double, 3>& origin,
                                   const VoxelGridParams& params);

/// pcl::StatisticalOutlierRemoval on the points minus `origin` (as float32); fills
/// `inlier` (N entries).
void pcl_statistical_outlier_removal(PointsView points, const std::array<double, 3>& origin,
                                     const StatisticalOutlierRemovalParams& params, bool* inlier);

}  // namespace pcl_rg
