// Local-origin handling shared by every algorithm (see points.hpp).
#include "pcl_rg/points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pcl_rg {

std::array<double, 3> local_origin(PointsView points) {
    if (points.size == 0) return {0.0, 0.0, 0.0};
    std::array<double, 3> lo;
    lo.fill(std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < points.size; ++i)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], points.coord(i, a));
    return lo;
}

double lattice_floor(double low, double size) {
    const double quotient = low / size;
    if (!(std::fabs(quotient) < 0x1p52)) return low;
    double k = std::floor(quotient);
    double corner = k * size;
    while (corner > low) corner = (k -= 1.0) * size;  // at most once for |k| < 2^52
    return corner;
}

std::vector<float> to_local_float(PointsView points, const std::array<double, 3>& origin) {
    std::vector<float> local(3 * points.size);
    const auto n = static_cast<std::ptrdiff_t>(points.size);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a)
            local[3 * i + a] = static_cast<float>(points.coord(i, a) - origin[a]);
    return local;
}

}  // namespace pcl_rg
