// Thin wrappers over pcl::VoxelGrid and pcl::StatisticalOutlierRemoval (PCL 1.13),
// the baselines of pcl_rg.pcl (see pcl_filters.hpp).
#include "pcl_filters.hpp"

#include <pcl/common/common.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "pcl_cloud.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

PclVoxelGridResult pcl_voxel_grid(PointsView points, const VoxelGridParams& params,
                                  std::int64_t* voxel_of_point) {
    validate(params);
    PclVoxelGridResult result;
    const std::size_t n = points.size;
    if (n == 0) return result;
    // PCL's own voxel expression (voxel_grid.hpp, applyFilter): float32 products with
    // the float32 inverse leaf size, floored.
    const float inverse[3] = {1.0f / static_cast<float>(params.leaf_size[0]),
                              1.0f / static_cast<float>(params.leaf_size[1]),
                              1.0f / static_cast<float>(params.leaf_size[2])};
    // A leaf whose float32 inverse is not finite would put every point in one voxel.
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(inverse[a]))  // also a leaf that float32 rounds to 0
            throw std::invalid_argument(
                "leaf_size: pcl::VoxelGrid computes in float32, which "
                "cannot hold the inverse of " +
                check::format_value(params.leaf_size[a]));
    // The float32 frame's origin (the minimum corner, unless a stray point lies far
    // below the rest: then the rest keep their millimetres) snapped down to the voxel
    // lattice: PCL anchors its grid at the origin of the frame it sees, so the voxels
    // stay those of the caller's frame, as in pcl_rg::voxel_grid.
    const auto corner = float32_origin(points);
    auto origin = corner;
    for (int a = 0; a < 3; ++a)
        origin[a] = std::floor(origin[a] / params.leaf_size[a]) * params.leaf_size[a];
    // PCL's classes cannot be interrupted: polls between their stages only.
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
    try {
        cloud = to_pcl_cloud(points, origin);
    } catch (const std::invalid_argument&) {
        // Points within float32's reach of their corner but not of the lattice point
        // below it: the leaf, not a stray point, moved the frame that far.
        bool leaf_moved_it = true;
        try {
            to_pcl_cloud(points, corner);
        } catch (const std::invalid_argument&) {
            leaf_moved_it = false;
        }
        if (!leaf_moved_it) throw;
        throw std::invalid_argument(
            "leaf_size: pcl::VoxelGrid anchors its voxels at multiples of the leaf, and the "
            "one below the points lies beyond float32's reach of them (2^24 x 0.1 = "
            "1677721.6); give a smaller leaf, or use pcl_rg.voxel_grid");
    }
    poll_interrupt();

    // PCL's overflow refusal (warn, return the input) becomes an error here, and so does
    // the overflow it misses: it counts trunc(extent / leaf) + 1 voxels per axis, but
    // numbers them from floor(min / leaf) to floor(max / leaf), which can be one more
    // per axis, in a 32-bit product that then wraps and merges voxels. Both counted in
    // double: PCL's own int64 product wraps for tiny leaves, and then passes.
    if (params.min_points_per_voxel > std::numeric_limits<unsigned int>::max())
        throw std::invalid_argument(
            "min_points_per_voxel: pcl::VoxelGrid counts in 32 bits, at most 4294967295, got " +
            std::to_string(params.min_points_per_voxel));
    Eigen::Vector4f min_p, max_p;
    pcl::getMinMax3D(*cloud, min_p, max_p);
    double voxels = 1.0, numbered = 1.0;  // PCL's count, and the range of its numbers
    for (int a = 0; a < 3; ++a) {
        voxels *= std::floor(static_cast<double>((max_p[a] - min_p[a]) * inverse[a])) + 1.0;
        numbered *= static_cast<double>(std::floor(max_p[a] * inverse[a])) -
                    static_cast<double>(std::floor(min_p[a] * inverse[a])) + 1.0;
    }
    voxels = std::max(voxels, numbered);
    if (voxels > std::numeric_limits<std::int32_t>::max())
        throw std::invalid_argument(
            "leaf_size: pcl::VoxelGrid numbers the voxels of the bounding box in 32 bits, at "
            "most 2^31 - 1 of them (beyond, it refuses them or its numbers wrap), got " +
            check::format_value(voxels) + " (pcl_rg.voxel_grid has no such limit)");

    pcl::VoxelGrid<pcl::PointXYZ> filter;
    filter.setInputCloud(cloud);
    filter.setLeafSize(static_cast<float>(params.leaf_size[0]),
                       static_cast<float>(params.leaf_size[1]),
                       static_cast<float>(params.leaf_size[2]));
    filter.setMinimumPointsNumberPerVoxel(static_cast<unsigned int>(params.min_points_per_voxel));
    pcl::PointCloud<pcl::PointXYZ> output;
    filter.filter(output);
    poll_interrupt();

    // Voxel of each point, as (z, y, x) index triples: PCL sorts its voxels by
    // x + y * dx + z * dx * dy, i.e. by z, then y, then x.
    std::vector<std::array<std::int64_t, 3>> key(n);
    for (std::size_t i = 0; i < n; ++i) {
        const pcl::PointXYZ& p = (*cloud)[i];
        key[i] = {static_cast<std::int64_t>(std::floor(p.z * inverse[2])),
                  static_cast<std::int64_t>(std::floor(p.y * inverse[1])),
                  static_cast<std::int64_t>(std::floor(p.x * inverse[0]))};
    }
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return key[a] < key[b]; });
    const auto min_points = static_cast<std::size_t>(params.min_points_per_voxel);
    std::fill(voxel_of_point, voxel_of_point + n, -1);
    for (std::size_t begin = 0; begin < n;) {
        std::size_t end = begin + 1;
        while (end < n && key[order[end]] == key[order[begin]]) ++end;
        if (end - begin >= min_points) {
            const auto row = static_cast<std::int64_t>(result.counts.size());
            for (std::size_t j = begin; j < end; ++j) voxel_of_point[order[j]] = row;
            result.counts.push_back(static_cast<std::int64_t>(end - begin));
        }
        begin = end;
    }
    if (result.counts.size() != output.size())  // PCL and the recount must agree
        throw std::logic_error("pcl_voxel_grid: PCL returned " + std::to_string(output.size()) +
                               " voxels, the recount found " +
                               std::to_string(result.counts.size()));

    result.centroids.resize(3 * output.size());
    for (std::size_t i = 0; i < output.size(); ++i) {
        result.centroids[3 * i + 0] = output[i].x + origin[0];
        result.centroids[3 * i + 1] = output[i].y + origin[1];
        result.centroids[3 * i + 2] = output[i].z + origin[2];
    }
    return result;
}

void pcl_statistical_outlier_removal(PointsView points,
                                     const StatisticalOutlierRemovalParams& params, bool* inlier) {
    validate(params);
    std::fill(inlier, inlier + points.size, false);
    if (points.size == 0) return;
    // PCL reads past its neighbour buffers when mean_k >= N: refuse, as the core does.
    check::fewer_than_points("mean_k", params.mean_k, points.size);
    check_pcl_neighbour_work("mean_k", params.mean_k, points.size);
    const auto cloud = to_pcl_cloud(points, float32_origin(points));
    check_pcl_copies(*cloud);
    poll_interrupt();
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> filter;
    filter.setInputCloud(cloud);
    filter.setMeanK(params.mean_k);
    filter.setStddevMulThresh(params.std_mul);
    pcl::Indices kept;
    filter.filter(kept);
    poll_interrupt();
    for (const auto i : kept) inlier[i] = true;
}

}  // namespace pcl_rg
