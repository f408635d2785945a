// Scale-free smooth-patch growth followed by a convexity merge on the region graph: the
// idea of LCCP (Stein et al., CVPR 2014) on the regions of curvature-seeded growth.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

struct ConvexSegmentationParams {
    /// Segment a voxel grid of leaf noise_leaves x noise (point_scale.hpp) when that
    /// leaf is larger than the point spacing, and give every point its voxel's label
    /// (finite, >= 0; 0: never). Dense, noisy scans (a raw Kinect frame) are then
    /// segmented at the scale their noise allows, and sparser data as it is.
    double noise_leaves = 10.0;
    /// Neighbours per point, the point itself included (>= 6, < N), for the normals,
    /// the curvatures, the growth and the region graph. The defaults were chosen by
    /// leave-one-scene-out cross-validation over the mOSD and airborne studies, RESULTS.md.
    int k = 15;
    /// A neighbour joins a patch when the angle between the unoriented normals is <=
    /// this, in degrees, in (0, 180).
    double smoothness_deg = 10.0;
    /// A joined point grows further when curvedness x r <= this (finite, >= 0, no
    /// unit), r the distance to the point's k-th neighbour: curvature in units of the
    /// neighbourhood radius, the same at every point spacing.
    double curvature_threshold = 0.8;
    /// Two adjacent patches merge when each one's centroid lies at most this far
    /// above the other's mean plane, as an elevation angle in degrees, in [0, 90).
    double concavity_tolerance_deg = 0.0;
    /// Patches with fewer points take no part in the convexity test: each joins the
    /// merged segment it shares most neighbour pairs with (>= 1); a segment that
    /// ends smaller is dropped.
    std::int64_t min_cluster_size = 20;
    /// Sensor position (caller's coordinates, finite): normals are turned towards it.
    /// Unset: default_viewpoint() of the points.
    std::optional<std::array<double, 3>> viewpoint;
};

/// A sensor's own frame (Kinect, terrestrial scan) has the sensor at its origin, next
/// to its points: the origin is the viewpoint when its distance from the points'
/// bounding box is at most this many box diagonals. Farther, as on a tile in UTM
/// coordinates, every line of sight from the origin crosses the data within a
/// fraction of a degree: a direction, not a sensor.
inline constexpr double kSensorFrameReach = 100.0;

/// The viewpoint used when none is given: the origin when it lies within
/// kSensorFrameReach diagonals of the points' bounding box without stray points (x and
/// y: fenced_box, points.hpp; z: within the box's XY diagonal, or 4 interquartile
/// ranges if more, of the z quartiles); otherwise an airborne sensor, one diagonal
/// above the top of that box over its centre ((x_min + x_max) / 2, (y_min + y_max) / 2,
/// z_max + diagonal). Empty input: the origin.
std::array<double, 3> default_viewpoint(PointsView points);

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const ConvexSegmentationParams& params);

/// Wall-clock seconds of the phases, and what the call chose.
struct ConvexSegmentationTimings {
    double leaf = 0.0;             ///< leaf of the voxel grid used, 0 for none
    double normals_seconds = 0.0;  ///< neighbours, normals and curvatures
    double growth_seconds = 0.0;   ///< patch growth
    double merge_seconds = 0.0;    ///< region graph, convexity test, merge
    /// The viewpoint used (the given one, or default_viewpoint() of the input).
    std::array<double, 3> viewpoint{0.0, 0.0, 0.0};
    std::int64_t far_points = 0;  ///< far points of the input left out (labelled -1)
};

/// The merge step alone on given patches. `neighbours` (n x k, row-major), unit
/// `normals` (3n, any orientation; NaN allowed), `patches` (n, ids in [0, n) or -1).
/// 1. Normals are turned towards the viewpoint v (flipped when n . (v - x) < 0; unset:
///    default_viewpoint() of these points).
/// 2. Per patch: point count, centroid c, and m, the normalized sum of its finite
///    oriented normals.
/// 3. Patches a != b are adjacent when a point of one lists a point of the other; the
///    weight of the pair is the number of such (point, listed point) entries.
/// 4. An adjacent pair of patches with >= min_cluster_size points each is convex when
///    (c_b - c_a) . m_a <= sin(tol) |c_b - c_a| and (c_a - c_b) . m_b <= sin(tol) |c_a -
///    c_b|; segments are the connected components over convex pairs.
/// 5. A smaller patch joins the segment of its heaviest adjacent large patch (ties: the
///    smaller segment id); with none it gets -1. Segments below min_cluster_size points
///    get -1; the others are numbered 0, 1, ... by their smallest point index.
void merge_convex(PointsView points, std::size_t k, const std::uint32_t* neighbours,
                  const double* normals, const std::int32_t* patches,
                  const ConvexSegmentationParams& params, std::int32_t* labels);

/// Far points (float32_frame, points.hpp) are left out of every step below and get -1.
/// The viewpoint, when unset, is default_viewpoint() of the input points (not of a
/// grid's centroids). When noise_leaves x noise > spacing (point_scale()), the steps
/// below run on the centroids of a voxel grid of that leaf (voxel_grid.hpp) and each
/// point takes its voxel's label. Steps: normals and curvatures (normals.hpp), the measure
/// curvedness x r per point, patch growth (grow_regions with that measure, the gate
/// curvature_threshold and no size limit), then merge_convex(). Fills `labels` (N
/// entries), numbered by smallest point index. Throws std::invalid_argument when k is
/// not below the number of points segmented (non-empty input).
ConvexSegmentationTimings convex_segmentation(PointsView points,
                                              const ConvexSegmentationParams& params,
                                              std::int32_t* labels);

}  // namespace pcl_rg
