// Our float64 points -> PCL's float32 cloud, after subtracting the local origin.
#include "pcl_cloud.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

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

void check_pcl_copies(const pcl::PointCloud<pcl::PointXYZ>& cloud) {
    // Below kPclCopiesWork's square root no group can pass it: most calls sort nothing.
    const std::size_t n = cloud.size();
    if (static_cast<double>(n) * static_cast<double>(n) <= kPclCopiesWork) return;
    std::vector<std::array<float, 3>> xyz(n);
    for (std::size_t i = 0; i < n; ++i) xyz[i] = {cloud[i].x, cloud[i].y, cloud[i].z};
    std::sort(xyz.begin(), xyz.end());
    double work = 0.0;
    std::size_t most = 0;
    for (std::size_t start = 0, end = 0; start < n; start = end) {
        while (end < n && xyz[end] == xyz[start]) ++end;
        const auto copies = static_cast<double>(end - start);
        work += copies * copies;
        most = std::max(most, end - start);
    }
    if (work > kPclCopiesWork)
        throw std::invalid_argument(
            "points: up to " + std::to_string(most) +
            " copies of one position: PCL's k-d tree cannot split copies, and its search, "
            "which cannot be interrupted, would compare each copy with every other for "
            "minutes; drop the copies, or use pcl_rg's own function, whose search handles "
            "them");
}

}  // namespace pcl_rg
