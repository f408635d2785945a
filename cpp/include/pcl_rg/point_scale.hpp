// The scale of a cloud measured from the data: point spacing and surface noise, the
// units in which scale-free defaults express lengths (convex_segmentation, the pipeline's
// automatic voxel size).
#pragma once

#include <cstddef>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Neighbours (the point itself included) of each measurement.
inline constexpr std::size_t kPointScaleNeighbours = 16;
/// At most about this many points are measured, every (N / this)-th in input order.
inline constexpr std::size_t kPointScaleSamples = 20000;

struct PointScale {
    double spacing = 0.0;  ///< median distance from a point to its nearest other point
    double noise = 0.0;    ///< median RMS distance of a neighbourhood from its plane
};

/// At the points i = 0, s, 2s, ... (s = max(1, N / kPointScaleSamples)), over the
/// kPointScaleNeighbours nearest points (float32 k-d tree, as normals.hpp): spacing,
/// the float64 distance to the second nearest (the first other point); noise,
/// sqrt(max(lambda0, 0)) with lambda0 the smallest eigenvalue of the float64
/// covariance (divided by the count) of the neighbours relative to the point. Each
/// is the lower median over the measured points (the ((m - 1) / 2)-th smallest).
/// Fewer than kPointScaleNeighbours + 1 points: both NaN.
PointScale point_scale(PointsView points);

}  // namespace pcl_rg
