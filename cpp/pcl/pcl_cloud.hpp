// The one conversion of our points to a PCL cloud: every wrapper of cpp/pcl/ goes
// through it, so all of PCL's classes see the same float32 local frame.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <array>
#include <cstddef>
#include <cstdint>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// The points minus `origin` (float64 subtraction, then float32) as a dense, unorganized
/// pcl::PointCloud<pcl::PointXYZ>.
pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(PointsView points,
                                                 const std::array<double, 3>& origin);

/// Bound on n * k for PCL's k-nearest searches, which we cannot make cheaper. Measured
/// on this project's machines (PCL 1.13, one thread), StatisticalOutlierRemoval took
/// 11.2 s with mean_k = 5000 on 20k points and 21.9 s with mean_k = 10000: about 1.1e-7 s
/// per n * k once k is large (not n * k^2: FLANN's result list shifts its entries in one
/// move). 1.2e9 is about two minutes of that (NormalEstimation searches the same way,
/// RegionGrowing searches twice); beyond it a call is refused rather than left to run
/// for minutes that cannot be interrupted (PCL's classes have no interruption points).
inline constexpr double kPclNeighbourWork = 1.2e9;

/// Throws std::invalid_argument when n * k passes kPclNeighbourWork: "<name> must be at
/// most <the largest that passes> for <n> points (PCL's k-nearest searches ...), got <k>"
/// (check::per_point_at_most).
void check_pcl_neighbour_work(const char* name, std::int64_t k, std::size_t n);

/// Bound on the sum over positions of copies^2 for PCL's k-nearest searches. FLANN's
/// k-d tree cannot split copies of one point, so each query among g copies compares all
/// g: measured on this project's machines (PCL 1.13, g identical points),
/// StatisticalOutlierRemoval and NormalEstimation took 5-7 ns per g^2 and
/// NormalEstimation + RegionGrowing 10-14 ns (40,000 copies: 11.6, 8.5 and 20.9 s).
/// 1e10 is one to two minutes of that, the bound kPclNeighbourWork keeps too.
inline constexpr double kPclCopiesWork = 1e10;

/// Throws std::invalid_argument when the cloud's copies (points equal in all three
/// float32 coordinates) pass kPclCopiesWork, naming the most copied position's count.
void check_pcl_copies(const pcl::PointCloud<pcl::PointXYZ>& cloud);

}  // namespace pcl_rg
