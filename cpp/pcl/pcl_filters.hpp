// PCL's own filter classes, unmodified, behind plain functions on our points: the
// baselines of pcl_rg.voxel_grid and pcl_rg.statistical_outlier_removal (pcl_rg.pcl).
#pragma once

#include <cstdint>
#include <vector>

#include "pcl_rg/points.hpp"
#include "pcl_rg/statistical_outlier_removal.hpp"
#include "pcl_rg/voxel_grid.hpp"

namespace pcl_rg {

/// What pcl_voxel_grid returns: PCL's centroids and the assignment PCL made.
struct PclVoxelGridResult {
    std::vector<double> centroids;     ///< 3 * M, PCL's float32 centroids + origin (m)
    std::vector<std::int64_t> counts;  ///< M, points of each kept voxel
};

/// pcl::VoxelGrid on the points minus their local origin snapped down to a multiple of
/// the leaf size per axis (so the voxels are those of the caller's frame), as float32;
/// centroids come back plus that origin, in float64, in PCL's output order. PCL does not report
/// which voxel holds a point: it is recomputed with PCL's own expression (float32 floor(p * (1 /
/// leaf)) in the local frame) and PCL's order (z, then y, then x index), filling `voxel_of_point`
/// (N entries, -1 for dropped voxels) and the counts. Throws std::invalid_argument where PCL would
/// warn and return its input unchanged (more than 2^31 - 1 voxels in the bounding box).
PclVoxelGridResult pcl_voxel_grid(PointsView points, const VoxelGridParams& params,
                                  std::int64_t* voxel_of_point);

/// pcl::StatisticalOutlierRemoval on the points minus their local origin (as float32);
/// fills `inlier` (N entries). Throws std::invalid_argument when mean_k >= N (non-empty
/// input), where PCL reads past its neighbour buffers.
void pcl_statistical_outlier_removal(PointsView points,
                                     const StatisticalOutlierRemovalParams& params, bool* inlier);

}  // namespace pcl_rg
