// Our float64 points -> PCL's float32 cloud, after subtracting the local origin.
#include "pcl_cloud.hpp"

#include <cmath>
#include <cstdint>

#include "pcl_rg/check.hpp"

namespace pcl_rg {

pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(PointsView points,
                                                 const std::array<double, 3>& origin) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(points.size);
    bool beyond = false;
    for (std::size_t i = 0; i < points.size; ++i) {
        double local[3];
        for (int a = 0; a < 3; ++a) {
            local[a] = points.coord(i, a) - origin[a];
            beyond = beyond || !(std::fabs(local[a]) <= kFloat32Reach);
        }
        (*cloud)[i] = pcl::PointXYZ(static_cast<float>(local[0]), static_cast<float>(local[1]),
                                    static_cast<float>(local[2]));
    }
    if (beyond) throw_beyond_float32_reach();
    cloud->width = static_cast<std::uint32_t>(points.size);
    cloud->height = 1;
    cloud->is_dense = true;
    return cloud;
}

void check_pcl_neighbour_work(const char* name, std::int64_t k, std::size_t n) {
    check::per_point_at_most(name, k, n, kPclNeighbourWork,
                             "PCL's k-nearest searches, which cannot be interrupted, take "
                             "about two minutes from N * k = 1.2e9 on");
}

}  // namespace pcl_rg
