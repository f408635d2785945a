// Thin wrappers over pcl::VoxelGrid and pcl::StatisticalOutlierRemoval (PCL 1.13),
// used only as baselines (see pcl_filters_baseline.hpp).
#include "pcl_rg/pcl_filters_baseline.hpp"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <stdexcept>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(PointsView points,
                                                 const std::array<double, 3>& origin) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(points.size);
    for (std::size_t i = 0; i < points.size; ++i)
        (*cloud)[i] = pcl::PointXYZ(static_cast<float>(points.coord(i, 0) - origin[0]),
                                    static_cast<float>(points.coord(i, 1) - origin[1]),
                                    static_cast<float>(points.coord(i, 2) - origin[2]));
    cloud->width = static_cast<std::uint32_t>(points.size);
    cloud->height = 1;
    cloud->is_dense = true;
    return cloud;
}

}  // namespace

std::vector<double> pcl_voxel_grid(PointsView points, const std::array<double, 3>& origin,
                                   const VoxelGridParams& params) {
    validate(params);
    // PCL's classes cannot be interrupted: polls between their stages only.
    const auto cloud = to_pcl_cloud(points, origin);
    poll_interrupt();
    pcl::VoxelGrid<pcl::PointXYZ> filter;
    filter.setInputCloud(cloud);
    filter.setLeafSize(static_cast<float>(params.leaf_size[0]),
                       static_cast<float>(params.leaf_size[1]),
                       static_cast<float>(params.leaf_size[2]));
    filter.setMinimumPointsNumberPerVoxel(static_cast<unsigned int>(params.min_points_per_voxel));
    pcl::PointCloud<pcl::PointXYZ> output;
    filter.filter(output);
    poll_interrupt();
    std::vector<double> centroids(3 * output.size());
    for (std::size_t i = 0; i < output.size(); ++i) {
        centroids[3 * i + 0] = output[i].x + origin[0];
        centroids[3 * i + 1] = output[i].y + origin[1];
        centroids[3 * i + 2] = output[i].z + origin[2];
    }
    return centroids;
}

void pcl_statistical_outlier_removal(PointsView points, const std::array<double, 3>& origin,
                                     const StatisticalOutlierRemovalParams& params, bool* inlier) {
    validate(params);
    // PCL reads past its neighbour buffers when mean_k >= N: refuse, as the core does.
    if (points.size > 0 && static_cast<std::size_t>(params.mean_k) >= points.size)
        throw std::invalid_argument("mean_k must be < the number of points");
    const auto cloud = to_pcl_cloud(points, origin);
    poll_interrupt();
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> filter;
    filter.setInputCloud(cloud);
    filter.setMeanK(params.mean_k);
    filter.setStddevMulThresh(params.std_mul);
    pcl::Indices kept;
    filter.filter(kept);
    poll_interrupt();
    std::fill(inlier, inlier + points.size, false);
    for (const auto i : kept) inlier[i] = true;
}

}  // namespace pcl_rg
