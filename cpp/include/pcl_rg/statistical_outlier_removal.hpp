// StatisticalOutlierRemoval with the semantics of PCL 1.13's pcl::StatisticalOutlierRemoval.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

struct StatisticalOutlierRemovalParams {
    /// Neighbours averaged per point, the point itself excluded (>= 1); PCL setMeanK.
    int mean_k = 50;
    /// Inlier when mean distance <= mu + std_mul * sigma (finite, >= 0); PCL setStddevMulThresh.
    double std_mul = 1.0;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const StatisticalOutlierRemovalParams& params);

struct StatisticalOutlierRemovalResult {
    /// d_i per point, in float32 as PCL keeps it (m); inf for far points (float32_frame).
    std::vector<float> mean_distance;
    /// Distance to the farthest of the mean_k neighbours (m): a caller that ran on a tile
    /// plus a buffer knows d_i is exact where this is below the distance to the buffer's
    /// edge. Inf for far points.
    std::vector<float> farthest_distance;
    double threshold = 0.0;  ///< mu + std_mul * sigma (m); NaN when sigma is
                             ///< not a number, in which case every point is kept
};

/// Fills `inlier[i]` for every point and returns the per-point statistics.
/// Throws std::invalid_argument when mean_k >= number of points (non-empty input).
/// `origin`, when given, is the float32 frame's origin instead of float32_origin(points)
/// (float32_frame): pcl_rg.batch's denoise passes the merged survey's, with the points
/// beyond its reach already left out (any that remain are framed anew, as far points
/// always are, and the origin then no longer applies to the others).
StatisticalOutlierRemovalResult statistical_outlier_removal(
    PointsView points, const StatisticalOutlierRemovalParams& params, bool* inlier,
    const std::array<double, 3>* origin = nullptr);

}  // namespace pcl_rg
