// PCL's own pcl::NormalEstimation and pcl::RegionGrowing, unmodified, behind plain
// functions: the baseline the curvature-seeded method is compared with (pcl_rg.pcl).
#pragma once

#include <cstdint>
#include <limits>

#include "pcl_rg/points.hpp"
#include "pcl_rg/region_growing.hpp"

namespace pcl_rg {

struct NormalEstimationParams {
    /// Neighbours of each normal, the point itself included (>= 3, < N); setKSearch.
    int k = 15;
};

struct RegionGrowingPclParams {
    /// Neighbours for the normals and the growth, the point itself included (>= 3, < N);
    /// NormalEstimation::setKSearch and RegionGrowing::setNumberOfNeighbours.
    int k = 15;
    /// Smoothness angle in degrees, in (0, 180); setSmoothnessThreshold (radians, float).
    double smoothness_deg = 16.0;
    /// Surface-variation gate for further seeds (finite, >= 0); setCurvatureThreshold.
    /// Tuned on the mOSD learn scenes at k 15, 16 deg, as pcl_rg's default (RESULTS.md).
    double curvature_threshold = 0.025;
    /// Regions with fewer points are dropped (>= 1); setMinClusterSize.
    std::int64_t min_cluster_size = 20;
    /// Regions with more points are dropped (>= min_cluster_size, <= 2^32 - 1);
    /// setMaxClusterSize.
    std::int64_t max_cluster_size = std::numeric_limits<std::uint32_t>::max();
};

/// Throw std::invalid_argument naming the parameter when a value is out of range.
void validate(const NormalEstimationParams& params);
void validate(const RegionGrowingPclParams& params);

/// pcl::NormalEstimation (k-NN on a pcl::search::KdTree) on the points minus their local
/// origin as float32: `normal` (3 * N) and `curvature` (N, surface variation) receive
/// PCL's float32 results, normals flipped towards the viewpoint (0, 0, 0) of the local
/// frame, i.e. the local origin. Throws std::invalid_argument when k >= N (non-empty).
void pcl_normal_estimation(PointsView points, const NormalEstimationParams& params, float* normal,
                           float* curvature);

/// pcl::NormalEstimation as above and pcl::RegionGrowing (smooth mode, curvature test on,
/// residual test off). Fills `labels` (N entries, -1 for points of dropped regions,
/// clusters numbered by smallest member index). Throws std::invalid_argument when
/// k >= N (non-empty input).
RegionGrowingTimings pcl_region_growing(PointsView points, const RegionGrowingPclParams& params,
                                        std::int32_t* labels);

}  // namespace pcl_rg
