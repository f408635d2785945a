// Mean XY point spacing from the occupied cells of a square grid (see point_spacing.hpp).
#include "pcl_rg/point_spacing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace pcl_rg {

double point_spacing(PointsView points) {
    const std::size_t n = points.size;
    if (n < 2) return std::numeric_limits<double>::quiet_NaN();
    double xmin = points.coord(0, 0), xmax = xmin, ymin = points.coord(0, 1), ymax = ymin;
    for (std::size_t i = 1; i < n; ++i) {
        xmin = std::min(xmin, points.coord(i, 0));
        xmax = std::max(xmax, points.coord(i, 0));
        ymin = std::min(ymin, points.coord(i, 1));
        ymax = std::max(ymax, points.coord(i, 1));
    }
    const double w = xmax - xmin, h = ymax - ymin;
    // No XY area (a vertical wall, a line along an axis): no density to measure.
    if (!(w * h > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    const auto count = static_cast<double>(n);
    const double c = std::max(3.0 * std::sqrt(w * h / count), std::max(w, h) / 65536.0);
    // At most 65537 cells per axis (c >= max(w, h) / 65536): keys fit 64 bits.
    const auto nx = static_cast<std::uint64_t>(std::floor(w / c)) + 1;
    const auto ny = static_cast<std::uint64_t>(std::floor(h / c)) + 1;
    const auto key = [&](std::size_t i) {
        const auto ix = static_cast<std::uint64_t>(std::floor((points.coord(i, 0) - xmin) / c));
        const auto iy = static_cast<std::uint64_t>(std::floor((points.coord(i, 1) - ymin) / c));
        return ix * ny + iy;
    };
    std::uint64_t occupied = 0;
    if (nx * ny <= 64 * static_cast<std::uint64_t>(n) + 4096) {
        // The usual case (about N / 9 cells): one flag per cell.
        std::vector<std::uint8_t> seen(nx * ny, 0);
        for (std::size_t i = 0; i < n; ++i) {
            std::uint8_t& flag = seen[key(i)];
            occupied += flag == 0;
            flag = 1;
        }
    } else {
        // A slim or very uneven cloud: sort the keys instead.
        std::vector<std::uint64_t> keys(n);
        for (std::size_t i = 0; i < n; ++i) keys[i] = key(i);
        std::sort(keys.begin(), keys.end());
        occupied = static_cast<std::uint64_t>(std::unique(keys.begin(), keys.end()) - keys.begin());
    }
    return std::sqrt(static_cast<double>(occupied) * c * c / count);
}

double spacing_or_one_metre(PointsView points) {
    const double spacing = point_spacing(points);
    return std::isnan(spacing) ? 1.0 : spacing;
}

}  // namespace pcl_rg
