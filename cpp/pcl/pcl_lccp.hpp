// PCL's pcl::SupervoxelClustering + pcl::LCCPSegmentation (locally convex connected
// patches), unmodified, behind a plain function: the second segmentation baseline of
// pcl_rg.pcl, on XYZ only.
#pragma once

#include <array>
#include <cstdint>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Defaults are those of PCL's LCCP example (apps: example_lccp_segmentation), which
/// are sized for Kinect frames in metres; colour is not used (XYZ only).
struct LccpParams {
    /// Voxel edge of the supervoxel octree (m, > 0); SupervoxelClustering's
    /// voxel_resolution.
    double voxel_resolution = 0.0075;
    /// Spacing of the supervoxel seeds (m, >= voxel_resolution); seed_resolution.
    double seed_resolution = 0.03;
    /// Weight of the spatial distance in supervoxel growth (>= 0); setSpatialImportance.
    double spatial_importance = 1.0;
    /// Weight of the normal difference in supervoxel growth (>= 0); setNormalImportance.
    double normal_importance = 4.0;
    /// Supervoxel refinement passes (>= 0, at most 100); refineSupervoxels.
    int refinement_iterations = 0;
    /// Concave edges flatter than this count as convex (deg, [0, 180));
    /// setConcavityToleranceThreshold.
    double concavity_tolerance_deg = 10.0;
    /// Step test: patches further apart than expected + this x voxel_resolution are not
    /// joined (>= 0); setSmoothnessCheck(true, ...).
    double smoothness_threshold = 0.1;
    /// Extended convexity: a convex edge needs this many common neighbours convex to both
    /// (0 or 1); setKFactor.
    int k_factor = 0;
    /// Cut singular (sanity-violating) convex connections; setSanityCheck.
    bool sanity_check = false;
    /// Segments of fewer supervoxels are merged into their largest neighbour (>= 0);
    /// setMinSegmentSize.
    std::int64_t min_segment_size = 0;
    /// Where the sensor was, in the caller's coordinates (m, finite). PCL flips every
    /// normal towards the origin of the frame it sees, and convexity is judged with those
    /// normals, so that frame is centred here; (0, 0, 0) is a Kinect frame's camera.
    std::array<double, 3> viewpoint{0.0, 0.0, 0.0};
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const LccpParams& params);

/// Stage times of a run (wall clock).
struct LccpTimings {
    double supervoxel_seconds = 0.0;
    double segmentation_seconds = 0.0;
};

/// SupervoxelClustering then LCCPSegmentation on the points minus the viewpoint (as
/// float32). Fills `labels` (N entries): the segment of each point's voxel, -1 where the
/// voxel has no supervoxel, numbered 0, 1, ... by each segment's smallest point index.
/// Throws std::invalid_argument when a point lies more than 2^20 voxels from the viewpoint,
/// where float32 no longer resolves a voxel.
LccpTimings pcl_lccp(PointsView points, const LccpParams& params, std::int32_t* labels);

}  // namespace pcl_rg
