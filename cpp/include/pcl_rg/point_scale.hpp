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
/// A neighbourhood is a surface, and its residual counts as noise, when its RMS
/// thickness sqrt(lambda0) is at most this times its second spread sqrt(lambda1).
/// On a plane sampled at spacing s, 16 neighbours spread sqrt(lambda1) ~ 1.1 s, so
/// noise of up to about a third of the spacing is still measured (a raw Kinect frame:
/// 0.5 mm on 1.5 mm); thicker neighbourhoods (tree canopy, shrubs, scattered sparse
/// points) are volumes, whose thickness is structure, not sensor noise.
inline constexpr double kPointScaleSurfaceRatio = 0.3;

struct PointScale {
    double spacing = 0.0;  ///< median distance from a point to its nearest other point
    double noise = 0.0;    ///< median RMS distance from their plane of surface neighbourhoods
    std::int64_t far_points = 0;  ///< far points left out of both
};

/// At the points i = 0, s, 2s, ... (s = max(1, N / kPointScaleSamples)), over the
/// kPointScaleNeighbours nearest points (float32 k-d tree, as normals.hpp): spacing,
/// the float64 distance to the second nearest (the first other point); noise,
/// sqrt(max(lambda0, 0)) with lambda0 <= lambda1 the two smallest eigenvalues of the
/// float64 covariance (divided by the count) of the neighbours relative to the point,
/// taken only where the neighbourhood is a surface: sqrt(max(lambda0, 0)) <=
/// kPointScaleSurfaceRatio x sqrt(max(lambda1, 0)). Each is the lower median over the
/// measured points (the ((m - 1) / 2)-th smallest of the m values in sample order).
/// Fewer than kPointScaleNeighbours + 1 points: both NaN; no surface neighbourhood:
/// noise NaN.
PointScale point_scale(PointsView points);

/// point_scale(points) with float32_frame(points) already made: convex_segmentation
/// needs the frame first and so makes it once.
PointScale point_scale(PointsView points, const Float32Frame& frame);

}  // namespace pcl_rg
