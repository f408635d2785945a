// Thin wrappers over pcl::ProgressiveMorphologicalFilter and
// pcl::ApproximateProgressiveMorphologicalFilter (PCL 1.13), after Zhang et al., "A
// progressive morphological filter for removing nonground measurements from airborne
// LIDAR data", IEEE TGRS 41(4), 2003: the ground-filter baseline (see pcl_pmf.hpp).
#include "pcl_pmf.hpp"

#include <pcl/segmentation/approximate_progressive_morphological_filter.h>
#include <pcl/segmentation/progressive_morphological_filter.h>

#include <algorithm>

#include "pcl_cloud.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

void validate(const ProgressiveMorphologicalFilterParams& params) {
    check::integer("max_window_size", params.max_window_size, check::at_least(1));
    check::real("slope", params.slope, check::non_negative());
    check::real("initial_distance", params.initial_distance, check::non_negative());
    check::real("max_distance", params.max_distance, check::non_negative());
    check::real("cell_size", params.cell_size, check::positive());
    check::real("base", params.base, check::positive());
}

namespace {

template <class Filter>
void run(Filter& filter, const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud,
         const ProgressiveMorphologicalFilterParams& params, pcl::Indices& indices) {
    filter.setInputCloud(cloud);
    filter.setMaxWindowSize(params.max_window_size);
    filter.setSlope(static_cast<float>(params.slope));
    filter.setInitialDistance(static_cast<float>(params.initial_distance));
    filter.setMaxDistance(static_cast<float>(params.max_distance));
    filter.setCellSize(static_cast<float>(params.cell_size));
    filter.setBase(static_cast<float>(params.base));
    filter.setExponential(params.exponential);
    filter.extract(indices);
}

}  // namespace

void pcl_progressive_morphological_filter(PointsView points,
                                          const ProgressiveMorphologicalFilterParams& params,
                                          bool* ground) {
    validate(params);
    std::fill(ground, ground + points.size, false);
    if (points.size == 0) return;
    const auto cloud = to_pcl_cloud(points, local_origin(points));
    poll_interrupt();  // PCL's filters themselves cannot be interrupted

    pcl::Indices indices;
    if (params.approximate) {
        pcl::ApproximateProgressiveMorphologicalFilter<pcl::PointXYZ> filter;
        run(filter, cloud, params, indices);
    } else {
        pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> filter;
        run(filter, cloud, params, indices);
    }
    poll_interrupt();
    for (const auto i : indices) ground[i] = true;
}

}  // namespace pcl_rg
