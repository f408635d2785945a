// Curvature-seeded region growing (seed 004; algorithms.md section 5, steps 3 and 4).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Curvedness sqrt((k1^2 + k2^2) / 2) from the mean and Gaussian curvatures:
/// (k1^2 + k2^2) / 2 = H^2 + max(H^2 - K, 0), the same value without the square root of
/// k1,2, whose rounding is amplified near umbilics (k1 = k2).
inline double curvedness(double mean, double gaussian) {
    return std::sqrt(mean * mean + std::max(mean * mean - gaussian, 0.0));
}

/// Per-point measure that orders the seeds and gates further seeds.
enum class SeedMeasure {
    curvedness,         ///< sqrt((k1^2 + k2^2) / 2) (1/m)
    gaussian,           ///< |K| (1/m^2)
    mean,               ///< |H| (1/m)
    surface_variation,  ///< lambda0 / (lambda0 + lambda1 + lambda2), PCL's curvature
    /// max(H_v, 0) (1/m), H_v the mean curvature with the normal turned towards the
    /// viewpoint: > 0 where the surface is concave as seen from the sensor. Not in the
    /// seed's definition: an option that lets growth run over convex edges (box faces)
    /// but stops it in concave creases (object on a table).
    concavity,
};

struct RegionGrowingParams {
    /// Neighbours per point, the point itself included (>= 3, < N); used for the
    /// normals, the curvatures and the growth; PCL setNumberOfNeighbours / setKSearch.
    /// Defaults chosen on the mOSD learn scenes (3-8 mm voxels), see RESULTS.md.
    int k = 15;
    /// A neighbour joins when the angle between the unoriented normals is <= this, in
    /// degrees, in (0, 180); PCL setSmoothnessThreshold (which takes radians).
    double smoothness_deg = 16.0;
    /// A joined point is pushed as a further seed when its seed measure is <= this
    /// (finite, >= 0; unit of the measure, scale dependent: 1/m for curvedness);
    /// PCL setCurvatureThreshold.
    double curvature_threshold = 80.0;
    /// Regions with fewer points are dropped (>= 1); PCL setMinClusterSize.
    std::int64_t min_cluster_size = 20;
    /// Regions with more points are dropped (>= min_cluster_size); PCL setMaxClusterSize.
    std::int64_t max_cluster_size = std::numeric_limits<std::uint32_t>::max();
    /// Seed order and seed gate (PCL: surface variation).
    SeedMeasure seed_measure = SeedMeasure::curvedness;
    /// Sensor position for SeedMeasure::concavity (caller's coordinates, finite); PCL
    /// NormalEstimation::setViewPoint, whose default is also the origin.
    std::array<double, 3> viewpoint{0.0, 0.0, 0.0};
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const RegionGrowingParams& params);

/// Wall-clock seconds of the two phases.
struct RegionGrowingTimings {
    double normals_seconds = 0.0;  ///< neighbours, normals and curvatures
    double growth_seconds = 0.0;   ///< seed sort, growth, size filter, numbering
    std::int64_t far_points = 0;   ///< far points left out (normals()), not a timing
};

/// Steps 3 and 4 on precomputed data: `neighbours` (n x k, row-major, each row the
/// point's k nearest, itself included), unit `normals` (3 * n) and the per-point seed
/// `measure` (n; NaN sorts last and never seeds further). Seeds in increasing
/// (measure, index) order; from each, breadth-first: a neighbour q of a region point p
/// joins when |n_p . n_q| >= cos(smoothness), and is queued as a further seed when
/// measure[q] <= curvature_threshold (the first seed always grows). Regions outside
/// [min, max] cluster size get -1; the others are numbered by their smallest member
/// index. Fills `labels` (n entries). Throws std::invalid_argument on an out-of-range
/// neighbour index.
void grow_regions(std::size_t n, std::size_t k, const std::uint32_t* neighbours,
                  const double* normals, const double* measure, const RegionGrowingParams& params,
                  std::int32_t* labels);

/// Normals and curvatures (see normals.hpp) with k = params.k, the seed measure of
/// every point, then grow_regions(). Fills `labels` (N entries).
/// Throws std::invalid_argument when k >= N (non-empty input).
RegionGrowingTimings region_growing(PointsView points, const RegionGrowingParams& params,
                                    std::int32_t* labels);

}  // namespace pcl_rg
