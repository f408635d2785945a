// Mean XY point spacing from the occupied cells of a square grid (see point_spacing.hpp).
#include "pcl_rg/point_spacing.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace pcl_rg {

double point_spacing(PointsView points) {
    if (points.size < 2) return std::numeric_limits<double>::quiet_NaN();
    const std::array<double, 3> lower = local_origin(points);
    return point_spacing(points, lower, upper_corner(points, lower));
}

namespace {

// The number of cells of side c, anchored at (xmin, ymin), that hold a point; c is at
// least max(w, h) / 2^31, so a cell's column and row fit 32 bits and its key 64.
std::uint64_t occupied_cells(PointsView points, double xmin, double ymin, double w, double h,
                             double c) {
    const std::size_t n = points.size;
    const auto nx = static_cast<std::uint64_t>(std::floor(w / c)) + 1;
    const auto ny = static_cast<std::uint64_t>(std::floor(h / c)) + 1;
    const auto key = [&](std::size_t i) {
        const auto ix = static_cast<std::uint64_t>(floor_to_int((points.coord(i, 0) - xmin) / c));
        const auto iy = static_cast<std::uint64_t>(floor_to_int((points.coord(i, 1) - ymin) / c));
        return ix * ny + iy;
    };
    std::uint64_t occupied = 0;
    if (nx * ny <= 16 * static_cast<std::uint64_t>(n) + 4096) {
        // The usual case (about N / 9 cells): one flag per cell, set in parallel (the
        // same flags whatever the threads), then counted.
        const std::size_t cells = nx * ny;
        std::vector<std::atomic<std::uint8_t>> seen(cells);
        const auto points_count = static_cast<std::ptrdiff_t>(n);
        const auto cell_count = static_cast<std::ptrdiff_t>(cells);
        const bool parallel = n > 65536;
#pragma omp parallel if (parallel)
        {
#pragma omp for schedule(static)
            for (std::ptrdiff_t k = 0; k < cell_count; ++k)
                seen[k].store(0, std::memory_order_relaxed);
#pragma omp for schedule(static)
            for (std::ptrdiff_t i = 0; i < points_count; ++i)
                seen[key(static_cast<std::size_t>(i))].store(1, std::memory_order_relaxed);
#pragma omp for schedule(static) reduction(+ : occupied)
            for (std::ptrdiff_t k = 0; k < cell_count; ++k)
                occupied += seen[k].load(std::memory_order_relaxed);
        }
    } else {
        // A slim, very uneven or mostly empty box: sort the keys instead.
        std::vector<std::uint64_t> keys(n);
        for (std::size_t i = 0; i < n; ++i) keys[i] = key(i);
        std::sort(keys.begin(), keys.end());
        occupied = static_cast<std::uint64_t>(std::unique(keys.begin(), keys.end()) - keys.begin());
    }
    return occupied;
}

// The coordinates of rank `trim` and n - 1 - `trim` (from 0, in ascending order) along
// `axis`: exact order statistics, O(N).
std::pair<double, double> ranked(PointsView points, int axis, std::size_t trim) {
    const std::size_t n = points.size;
    std::vector<double> values(n);
    for (std::size_t i = 0; i < n; ++i) values[i] = points.coord(i, axis);
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(trim),
                     values.end());
    const double low = values[trim];
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(n - 1 - trim),
                     values.end());
    return {low, values[n - 1 - trim]};
}

}  // namespace

double point_spacing(PointsView points, const std::array<double, 3>& lower,
                     const std::array<double, 3>& upper) {
    const std::size_t n = points.size;
    if (n < 2) return std::numeric_limits<double>::quiet_NaN();
    const double xmin = lower[0], xmax = upper[0], ymin = lower[1], ymax = upper[1];
    const double w = xmax - xmin, h = ymax - ymin;
    if (!std::isfinite(w) || !std::isfinite(h) || !std::isfinite(w * h))
        throw std::invalid_argument(
            "points: the XY extent is too large to measure the point spacing (its area is "
            "not finite in float64); a stray point far from the rest?");
    // No XY area (a vertical wall, a line along an axis): no density to measure.
    if (!(w * h > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    const auto count = static_cast<double>(n);
    // At most 65537 cells per axis (c >= max(w, h) / 65536).
    double c = std::max(3.0 * std::sqrt(w * h / count), std::max(w, h) / 65536.0);
    std::uint64_t occupied = occupied_cells(points, xmin, ymin, w, h, c);
    // A box less than a quarter occupied at this cell (more than 36 points per occupied
    // cell, against 9 when it is covered) may be set by a few points far from the rest:
    // then the cell follows the box of the bulk instead, from the 1st to the 99th
    // percentile on each axis, when that is less than a sixteenth of the box.
    const std::size_t trim = n / 100;
    if (count > 36.0 * static_cast<double>(occupied) && trim > 0) {
        const auto [xlow, xhigh] = ranked(points, 0, trim);
        const auto [ylow, yhigh] = ranked(points, 1, trim);
        const double bulk = (xhigh - xlow) * (yhigh - ylow);
        if (bulk > 0.0 && 16.0 * bulk < w * h) {
            c = std::max({3.0 * std::sqrt(bulk / count),
                          std::max(xhigh - xlow, yhigh - ylow) / 65536.0, std::max(w, h) / 0x1p31});
            occupied = occupied_cells(points, xmin, ymin, w, h, c);
        }
    }
    // sqrt(M c^2 / N) as defined. With one stray point some 1e154 away the box's area is
    // still finite but c^2 is not; c sqrt(M / N) is the same in exact arithmetic, and is
    // used only then, so every finite result keeps its rounding.
    const double spacing = std::sqrt(static_cast<double>(occupied) * c * c / count);
    return std::isfinite(spacing) ? spacing : c * std::sqrt(static_cast<double>(occupied) / count);
}

double spacing_or_one_metre(PointsView points) {
    const double spacing = point_spacing(points);
    return std::isnan(spacing) ? 1.0 : spacing;
}

double spacing_or_one_metre(PointsView points, const std::array<double, 3>& lower,
                            const std::array<double, 3>& upper) {
    const double spacing = point_spacing(points, lower, upper);
    return std::isnan(spacing) ? 1.0 : spacing;
}

}  // namespace pcl_rg
