// The classic smoothness-constraint region growing of Rabbani et al., "Segmentation of
// point clouds using smoothness constraint", ISPRS Archives XXXVI-5, 2006, exactly as
// PCL 1.13 implements it (pcl::NormalEstimation + pcl::RegionGrowing): the baseline of
// seed 004's "traditional region growing algorithm".
//
// What PCL does (pcl/segmentation/impl/region_growing.hpp), for the record:
//   * it searches the k nearest neighbours of every point again (FLANN k-d tree), the
//     point itself included, independently of the normal estimation's search;
//   * seeds: (curvature, index) pairs sorted with std::sort on the curvature alone,
//     an unstable sort, so points of equal curvature (common: curvature is float32,
//     and exactly 0 on perfect planes) are taken in an order the sort leaves
//     unspecified; labels can depend on it, and on the input order;
//   * growth is breadth-first from the seed, which always grows; a neighbour q of the
//     current point p joins when |n_p . n_q| >= cos(theta) in float (a NaN normal
//     therefore always joins), and is queued as a further seed unless
//     curvature(q) > threshold (a NaN curvature therefore seeds);
//   * every point ends in some region; regions outside [min, max] size are dropped
//     afterwards, and the kept ones are listed in growth order.
// This wrapper only converts: float32 cloud after subtracting the float64 local origin,
// and labels numbered by each cluster's smallest member index.
#include "pcl_region_growing.hpp"

#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/region_growing.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "pcl_cloud.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

void validate(const NormalEstimationParams& params) {
    check::integer("k", params.k, check::at_least(3));
}

void validate(const RegionGrowingPclParams& params) {
    // PCL counts cluster sizes in pcl::uindex_t (uint32).
    check::integer("max_cluster_size", params.max_cluster_size,
                   {1.0, std::nullopt, 4294967295.0, std::nullopt});
    RegionGrowingParams common;
    common.k = params.k;
    common.smoothness_deg = params.smoothness_deg;
    common.curvature_threshold = params.curvature_threshold;
    common.min_cluster_size = params.min_cluster_size;
    common.max_cluster_size = params.max_cluster_size;
    // PCL's growth gates on the surface variation, which needs no quadric: k from 3.
    common.seed_measure = SeedMeasure::surface_variation;
    validate(common);
}

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Normals = pcl::PointCloud<pcl::Normal>;

void check_size(std::size_t n, int k) {
    check::fewer_than_points("k", k, n);
    check::indexable_by_int32(n);
    check_pcl_neighbour_work("k", k, n);
}

// The points in PCL's float32 frame, whose origin is float32_origin, with the minimum
// corner in that frame: PCL flips each normal towards its viewpoint, by default (0, 0, 0)
// of the frame, which was the minimum corner while the frame started there; it is set
// there, so that the normals keep that orientation.
struct Frame {
    Cloud::Ptr cloud;
    std::array<float, 3> corner;
};

Frame to_frame(PointsView points) {
    const std::array<double, 3> origin = float32_origin(points);
    const std::array<double, 3> lowest = local_origin(points);
    Frame frame{to_pcl_cloud(points, origin), {}};
    check_pcl_copies(*frame.cloud);
    for (int a = 0; a < 3; ++a) frame.corner[a] = static_cast<float>(lowest[a] - origin[a]);
    return frame;
}

Normals::Ptr estimate(const Frame& frame, const pcl::search::Search<pcl::PointXYZ>::Ptr& tree,
                      int k) {
    const Cloud::Ptr& cloud = frame.cloud;
    Normals::Ptr normals(new Normals);
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
    estimation.setSearchMethod(tree);
    estimation.setInputCloud(cloud);
    estimation.setKSearch(k);
    estimation.setViewPoint(frame.corner[0], frame.corner[1], frame.corner[2]);
    estimation.compute(*normals);
    return normals;
}

}  // namespace

void pcl_normal_estimation(PointsView points, const NormalEstimationParams& params, float* normal,
                           float* curvature) {
    validate(params);
    const std::size_t n = points.size;
    if (n == 0) return;
    check_size(n, params.k);
    const Frame frame = to_frame(points);
    poll_interrupt();  // PCL's classes cannot be interrupted: polls between their stages
    pcl::search::Search<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    const auto normals = estimate(frame, tree, params.k);
    poll_interrupt();
    for (std::size_t i = 0; i < n; ++i) {
        for (int a = 0; a < 3; ++a) normal[3 * i + a] = (*normals)[i].normal[a];
        curvature[i] = (*normals)[i].curvature;
    }
}

RegionGrowingTimings pcl_region_growing(PointsView points, const RegionGrowingPclParams& params,
                                        std::int32_t* labels) {
    validate(params);
    RegionGrowingTimings timings;
    const std::size_t n = points.size;
    if (n == 0) return timings;
    check_size(n, params.k);
    const Frame frame = to_frame(points);
    const Cloud::Ptr& cloud = frame.cloud;
    poll_interrupt();  // PCL's classes cannot be interrupted: polls between their stages

    const auto start = std::chrono::steady_clock::now();
    pcl::search::Search<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    const auto normals = estimate(frame, tree, params.k);
    poll_interrupt();
    timings.normals_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    const auto grow_start = std::chrono::steady_clock::now();
    pcl::RegionGrowing<pcl::PointXYZ, pcl::Normal> growing;
    growing.setMinClusterSize(static_cast<pcl::uindex_t>(params.min_cluster_size));
    growing.setMaxClusterSize(static_cast<pcl::uindex_t>(params.max_cluster_size));
    growing.setSearchMethod(tree);
    growing.setNumberOfNeighbours(static_cast<unsigned int>(params.k));
    growing.setInputCloud(cloud);
    growing.setInputNormals(normals);
    growing.setSmoothModeFlag(true);
    growing.setCurvatureTestFlag(true);
    growing.setResidualTestFlag(false);
    growing.setSmoothnessThreshold(static_cast<float>(params.smoothness_deg / 180.0 * M_PI));
    growing.setCurvatureThreshold(static_cast<float>(params.curvature_threshold));
    std::vector<pcl::PointIndices> clusters;
    growing.extract(clusters);
    poll_interrupt();

    // PCL lists each cluster's indices ascending (assembleRegions walks the points in
    // order); number the clusters by their first, i.e. smallest, member.
    std::sort(clusters.begin(), clusters.end(),
              [](const pcl::PointIndices& a, const pcl::PointIndices& b) {
                  return a.indices.front() < b.indices.front();
              });
    std::fill(labels, labels + n, -1);
    for (std::size_t c = 0; c < clusters.size(); ++c)
        for (const auto i : clusters[c].indices) labels[i] = static_cast<std::int32_t>(c);
    timings.growth_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - grow_start).count();
    return timings;
}

}  // namespace pcl_rg
