// Locally convex connected patches (Stein et al., "Object partitioning using local
// convexity", CVPR 2014) on voxel cloud connectivity segmentation supervoxels (Papon et
// al., CVPR 2013), exactly as PCL 1.13 implements them: pcl::SupervoxelClustering, then
// pcl::LCCPSegmentation on its supervoxels and their adjacency.
//
// What PCL does, for the record (pcl/segmentation/impl/*.hpp):
//   * the points are binned in an adjacency octree of voxel_resolution; each voxel's
//     normal is fitted to the centroids of its neighbouring voxels;
//   * seeds are voxels picked on a seed_resolution grid, and supervoxels grow from them
//     by a distance that weighs space and normal by their importances;
//   * LCCP labels the edge between two adjacent supervoxels convex when the angle of
//     their normals against the line joining their centroids says so, or when it is
//     concave by less than the concavity tolerance; the step test cuts edges whose
//     patches lie too far apart; segments are the components of convex edges, and
//     segments of fewer than min_segment_size supervoxels join their largest neighbour.
// This wrapper only converts: float32 cloud after subtracting the float64 viewpoint (PCL
// flips normals towards the origin of its frame), and per point labels numbered by each
// segment's smallest point index.
#include "pcl_lccp.hpp"

#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "pcl_cloud.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/timer.hpp"

namespace pcl_rg {

void validate(const LccpParams& params) {
    check::real("voxel_resolution", params.voxel_resolution, check::positive());
    check::real("seed_resolution", params.seed_resolution, check::positive());
    check::relation(params.seed_resolution >= params.voxel_resolution, "seed_resolution",
                    ">= voxel_resolution (" + check::format_value(params.voxel_resolution) + ")",
                    params.seed_resolution);
    check::real("spatial_importance", params.spatial_importance, check::non_negative());
    check::real("normal_importance", params.normal_importance, check::non_negative());
    check::integer("refinement_iterations", params.refinement_iterations,
                   {0.0, std::nullopt, 100.0, std::nullopt});
    check::real("concavity_tolerance_deg", params.concavity_tolerance_deg,
                {0.0, std::nullopt, std::nullopt, 180.0});
    check::real("smoothness_threshold", params.smoothness_threshold, check::non_negative());
    check::integer("k_factor", params.k_factor, {0.0, std::nullopt, 1.0, std::nullopt});
    // PCL counts segment sizes in std::uint32_t.
    check::integer("min_segment_size", params.min_segment_size,
                   {0.0, std::nullopt, 4294967295.0, std::nullopt});
    for (const double coordinate : params.viewpoint)
        check::real("viewpoint", coordinate, check::any());
}

namespace {

// float32 carries 24 bits: within 2^20 voxels of the frame's origin a coordinate is off
// by at most 1/16 of a voxel.
constexpr double max_voxels_from_viewpoint = 1048576.0;

void check_reach(PointsView points, const LccpParams& params) {
    double farthest = 0.0;
    for (std::size_t i = 0; i < points.size; ++i)
        for (int axis = 0; axis < 3; ++axis)
            farthest = std::max(farthest, std::abs(points.coord(i, axis) - params.viewpoint[axis]));
    if (farthest / params.voxel_resolution > max_voxels_from_viewpoint)
        throw std::invalid_argument(
            "viewpoint must lie within 2^20 voxels (" +
            check::format_value(max_voxels_from_viewpoint * params.voxel_resolution) +
            " m) of every point, got a point " + check::format_value(farthest) +
            " m away on an axis");
}

// PCL's classes take these as float32: beyond its range a resolution trips an octree
// assertion (abort) and an importance becomes inf (a silently degenerate result).
void check_float32_range(const LccpParams& params) {
    const std::pair<const char*, double> values[] = {
        {"voxel_resolution", params.voxel_resolution},
        {"seed_resolution", params.seed_resolution},
        {"spatial_importance", params.spatial_importance},
        {"normal_importance", params.normal_importance},
        {"smoothness_threshold", params.smoothness_threshold}};
    for (const auto& [name, value] : values) {
        const auto single = static_cast<float>(value);
        if (!std::isfinite(single) || (value > 0.0 && single < std::numeric_limits<float>::min()))
            throw std::invalid_argument(std::string(name) +
                                        ": PCL computes in float32, which cannot hold " +
                                        check::format_value(value));
    }
}

}  // namespace

LccpTimings pcl_lccp(PointsView points, const LccpParams& params, std::int32_t* labels) {
    validate(params);
    LccpTimings timings;
    const std::size_t n = points.size;
    if (n == 0) return timings;
    check::indexable_by_int32(n);
    check_float32_range(params);
    check_reach(points, params);
    const auto cloud = to_pcl_cloud(points, params.viewpoint);
    poll_interrupt();  // PCL's classes cannot be interrupted: polls between their stages

    const auto start = std::chrono::steady_clock::now();
    pcl::SupervoxelClustering<pcl::PointXYZ> supervoxels(
        static_cast<float>(params.voxel_resolution), static_cast<float>(params.seed_resolution));
    supervoxels.setUseSingleCameraTransform(false);
    supervoxels.setInputCloud(cloud);
    supervoxels.setColorImportance(0.0f);
    supervoxels.setSpatialImportance(static_cast<float>(params.spatial_importance));
    supervoxels.setNormalImportance(static_cast<float>(params.normal_importance));
    std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr> clusters;
    supervoxels.extract(clusters);
    if (params.refinement_iterations > 0)
        supervoxels.refineSupervoxels(params.refinement_iterations, clusters);
    std::multimap<std::uint32_t, std::uint32_t> adjacency;
    supervoxels.getSupervoxelAdjacency(adjacency);
    const auto labeled = supervoxels.getLabeledCloud();
    timings.supervoxel_seconds = seconds_since(start);
    poll_interrupt();

    const auto segment_start = std::chrono::steady_clock::now();
    pcl::LCCPSegmentation<pcl::PointXYZ> lccp;
    lccp.setConcavityToleranceThreshold(static_cast<float>(params.concavity_tolerance_deg));
    lccp.setSanityCheck(params.sanity_check);
    lccp.setSmoothnessCheck(true, static_cast<float>(params.voxel_resolution),
                            static_cast<float>(params.seed_resolution),
                            static_cast<float>(params.smoothness_threshold));
    lccp.setKFactor(static_cast<std::uint32_t>(params.k_factor));
    lccp.setMinSegmentSize(static_cast<std::uint32_t>(params.min_segment_size));
    lccp.setInputSupervoxels(clusters, adjacency);
    lccp.segment();
    std::map<std::uint32_t, std::uint32_t> segment_of_supervoxel;
    lccp.getSupervoxelToSegmentMap(segment_of_supervoxel);
    timings.segmentation_seconds = seconds_since(segment_start);
    poll_interrupt();

    // Supervoxel label 0 marks a voxel no supervoxel took. Segments are numbered in the
    // order of their first point, i.e. by their smallest point index.
    std::unordered_map<std::uint32_t, std::int32_t> number_of_segment;
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t supervoxel = (*labeled)[i].label;
        const auto found = segment_of_supervoxel.find(supervoxel);
        if (supervoxel == 0 || found == segment_of_supervoxel.end()) {
            labels[i] = -1;
            continue;
        }
        const auto next = static_cast<std::int32_t>(number_of_segment.size());
        labels[i] = number_of_segment.emplace(found->second, next).first->second;
    }
    return timings;
}

}  // namespace pcl_rg
