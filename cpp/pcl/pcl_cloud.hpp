// The one conversion of our points to a PCL cloud: every wrapper of cpp/pcl/ goes
// through it, so all of PCL's classes see the same float32 local frame.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <array>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// The points minus `origin` (float64 subtraction, then float32) as a dense, unorganized
/// pcl::PointCloud<pcl::PointXYZ>.
pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(PointsView points,
                                                 const std::array<double, 3>& origin);

}  // namespace pcl_rg
