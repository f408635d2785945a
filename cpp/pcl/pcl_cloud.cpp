// Our float64 points -> PCL's float32 cloud, after subtracting the local origin.
#include "pcl_cloud.hpp"

#include <cmath>
#include <cstdint>

namespace pcl_rg {

pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(PointsView points,
                                                 const std::array<double, 3>& origin) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(points.size);
    bool overflow = false;
    for (std::size_t i = 0; i < points.size; ++i) {
        const pcl::PointXYZ local(static_cast<float>(points.coord(i, 0) - origin[0]),
                                  static_cast<float>(points.coord(i, 1) - origin[1]),
                                  static_cast<float>(points.coord(i, 2) - origin[2]));
        (*cloud)[i] = local;
        overflow = overflow || std::isinf(local.x) || std::isinf(local.y) || std::isinf(local.z);
    }
    if (overflow) throw_float32_overflow();
    cloud->width = static_cast<std::uint32_t>(points.size);
    cloud->height = 1;
    cloud->is_dense = true;
    return cloud;
}

}  // namespace pcl_rg
