// Thin wrapper over pcl::ProgressiveMorphologicalFilter (PCL 1.13), after Zhang et al.,
// "A progressive morphological filter for removing nonground measurements from airborne
// LIDAR data", IEEE TGRS 41(4), 2003. Used only as a benchmark baseline for the ground
// filters (see pcl_pmf_baseline.hpp).
#include "pcl_rg/pcl_pmf_baseline.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/progressive_morphological_filter.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

void validate(const PclProgressiveMorphologicalFilterParams& params) {
    if (params.max_window_size < 1)
        throw std::invalid_argument("max_window_size must be >= 1, got " +
                                    std::to_string(params.max_window_size));
    const auto non_negative = [](const char* name, double value) {
        if (!std::isfinite(value) || value < 0.0)
            throw std::invalid_argument(std::string(name) + " must be finite and >= 0, got " +
                                        std::to_string(value));
    };
    non_negative("slope", params.slope);
    non_negative("initial_distance", params.initial_distance);
    non_negative("max_distance", params.max_distance);
    if (!std::isfinite(params.cell_size) || params.cell_size <= 0.0)
        throw std::invalid_argument("cell_size must be finite and > 0, got " +
                                    std::to_string(params.cell_size));
    if (!std::isfinite(params.base) || params.base <= 0.0)
        throw std::invalid_argument("base must be finite and > 0, got " +
                                    std::to_string(params.base));
}

void pcl_progressive_morphological_filter(PointsView points, const std::array<double, 3>& origin,
                                          const PclProgressiveMorphologicalFilterParams& params,
                                          bool* ground) {
    validate(params);
    std::fill(ground, ground + points.size, false);
    if (points.size == 0) return;
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(points.size);
    for (std::size_t i = 0; i < points.size; ++i)
        (*cloud)[i] = pcl::PointXYZ(static_cast<float>(points.coord(i, 0) - origin[0]),
                                    static_cast<float>(points.coord(i, 1) - origin[1]),
                                    static_cast<float>(points.coord(i, 2) - origin[2]));
    cloud->width = static_cast<std::uint32_t>(points.size);
    cloud->height = 1;
    cloud->is_dense = true;
    poll_interrupt();  // PCL's filter itself cannot be interrupted

    pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> filter;
    filter.setInputCloud(cloud);
    filter.setMaxWindowSize(params.max_window_size);
    filter.setSlope(static_cast<float>(params.slope));
    filter.setInitialDistance(static_cast<float>(params.initial_distance));
    filter.setMaxDistance(static_cast<float>(params.max_distance));
    filter.setCellSize(static_cast<float>(params.cell_size));
    filter.setBase(static_cast<float>(params.base));
    filter.setExponential(params.exponential);
    pcl::Indices indices;
    filter.extract(indices);
    poll_interrupt();
    for (const auto i : indices) ground[i] = true;
}

}  // namespace pcl_rg
