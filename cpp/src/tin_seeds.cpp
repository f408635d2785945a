// Seeds of the TIN ground filter (see tin_seeds.hpp and tin_ground.cpp's comment).
#include "pcl_rg/tin_seeds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg {

namespace {

// Column * ncy + row of point i in square cells of side `cell` anchored at the origin.
std::int64_t cell_key(PointsView points, const std::array<double, 3>& origin, double cell,
                      std::int64_t ncy, std::size_t i) {
    const auto cx = static_cast<std::int64_t>(std::floor((points.coord(i, 0) - origin[0]) / cell));
    const auto cy = static_cast<std::int64_t>(std::floor((points.coord(i, 1) - origin[1]) / cell));
    return cx * ncy + cy;
}

// Point a comes before point b: lower z, then smaller index.
bool lower(PointsView points, std::size_t a, std::size_t b) {
    const double za = points.coord(a, 2), zb = points.coord(b, 2);
    return za < zb || (za == zb && a < b);
}

// Lowest point (ties: smallest index) of every cell of a dense ncx x ncy grid of square
// cells anchored at the origin, row-major by x then y; -1 for an empty cell.
std::vector<std::int64_t> lowest_in_cells(PointsView points, const std::array<double, 3>& origin,
                                          double cell, std::int64_t ncx, std::int64_t ncy) {
    std::vector<std::int64_t> lowest(static_cast<std::size_t>(ncx * ncy), -1);
    const Interruption interruption;
    for (std::size_t i = 0; i < points.size; ++i) {
        if (i % 4096 == 0) interruption.check();
        std::int64_t& b = lowest[static_cast<std::size_t>(cell_key(points, origin, cell, ncy, i))];
        if (b < 0 || lower(points, i, static_cast<std::size_t>(b)))
            b = static_cast<std::int64_t>(i);
    }
    return lowest;
}

// The lowest point of every occupied cell, in index order: through the dense grid when
// it is small, else by sorting (cell, z, index), so that any cell size works.
std::vector<std::uint32_t> lowest_points(PointsView points, const std::array<double, 3>& origin,
                                         double cell, std::int64_t ncx, std::int64_t ncy) {
    const auto n = static_cast<std::int64_t>(points.size);
    std::vector<std::uint32_t> lowest;
    if (ncx <= (4 * n + 4096) / ncy) {
        for (const std::int64_t b : lowest_in_cells(points, origin, cell, ncx, ncy))
            if (b >= 0) lowest.push_back(static_cast<std::uint32_t>(b));
    } else {
        std::vector<std::pair<std::int64_t, std::uint32_t>> keyed(points.size);
        for (std::size_t i = 0; i < points.size; ++i)
            keyed[i] = {cell_key(points, origin, cell, ncy, i), static_cast<std::uint32_t>(i)};
        std::sort(keyed.begin(), keyed.end(), [&](const auto& a, const auto& b) {
            return a.first < b.first || (a.first == b.first && lower(points, a.second, b.second));
        });
        for (std::size_t k = 0; k < keyed.size(); ++k)
            if (k == 0 || keyed[k].first != keyed[k - 1].first) lowest.push_back(keyed[k].second);
    }
    std::sort(lowest.begin(), lowest.end());
    return lowest;
}

// Square min or max filter of half-width r over an ncx x ncy raster (+inf = no value,
// ignored; windows clipped at the border), separably by y then x: exact, as min and
// max are.
std::vector<double> square_filter(const std::vector<double>& a, std::int64_t ncx, std::int64_t ncy,
                                  std::int64_t r, bool take_max) {
    const double none = std::numeric_limits<double>::infinity();
    auto better = [take_max, none](double u, double v) {  // u replaces v
        if (u == none) return false;
        if (v == none) return true;
        return take_max ? u > v : u < v;
    };
    std::vector<double> along_y(a.size(), none), out(a.size(), none);
    // A window of r cells per side: polled once per column, which can take a while.
    const Interruption interruption;
#pragma omp parallel for schedule(static) firstprivate(interruption)
    for (std::int64_t x = 0; x < ncx; ++x) {
        if (interruption.requested()) continue;
        for (std::int64_t y = 0; y < ncy; ++y) {
            double v = none;
            for (std::int64_t k = std::max<std::int64_t>(0, y - r); k <= std::min(ncy - 1, y + r);
                 ++k)
                if (better(a[x * ncy + k], v)) v = a[x * ncy + k];
            along_y[x * ncy + y] = v;
        }
    }
    interruption.check();
#pragma omp parallel for schedule(static) firstprivate(interruption)
    for (std::int64_t x = 0; x < ncx; ++x) {
        if (interruption.requested()) continue;
        for (std::int64_t y = 0; y < ncy; ++y) {
            double v = none;
            for (std::int64_t k = std::max<std::int64_t>(0, x - r); k <= std::min(ncx - 1, x + r);
                 ++k)
                if (better(along_y[k * ncy + y], v)) v = along_y[k * ncy + y];
            out[x * ncy + y] = v;
        }
    }
    interruption.check();
    return out;
}

// The rank-th smallest (0-based) of the (2r+1)^2 values of each cell's square window,
// cells outside the raster and empty ones (+inf) included as +inf.
std::vector<double> rank_filter(const std::vector<double>& a, std::int64_t ncx, std::int64_t ncy,
                                std::int64_t r, std::size_t rank) {
    const double none = std::numeric_limits<double>::infinity();
    std::vector<double> out(a.size(), none);
    const Interruption interruption;
#pragma omp parallel firstprivate(interruption)
    {
        std::vector<double> window;
#pragma omp for schedule(static)
        for (std::int64_t x = 0; x < ncx; ++x) {
            if (interruption.requested()) continue;
            for (std::int64_t y = 0; y < ncy; ++y) {
                window.clear();
                for (std::int64_t i = x - r; i <= x + r; ++i)
                    for (std::int64_t j = y - r; j <= y + r; ++j)
                        window.push_back(i < 0 || j < 0 || i >= ncx || j >= ncy ? none
                                                                                : a[i * ncy + j]);
                std::nth_element(window.begin(), window.begin() + static_cast<std::ptrdiff_t>(rank),
                                 window.end());
                out[x * ncy + y] = window[rank];
            }
        }
    }
    interruption.check();
    return out;
}

// Zhao-style seeds (TinGroundParams::seed_cell): lowest points of seed_cell cells close
// to the grey opening of their heights, after dropping low outliers (rank test).
std::vector<std::uint32_t> morphological_seeds(PointsView points,
                                               const std::array<double, 3>& origin, double ex,
                                               double ey, const TinGroundParams& params) {
    const double cell = *params.seed_cell;
    const double limit = 4.0 * static_cast<double>(points.size) + 4194304.0;
    if (!((std::floor(ex / cell) + 1.0) * (std::floor(ey / cell) + 1.0) <= limit))
        throw std::invalid_argument(
            "seed_cell is too small for the XY extent (more than 4 cells "
            "per point), got " +
            check::format_value(cell));
    const auto ncx = static_cast<std::int64_t>(std::floor(ex / cell)) + 1;
    const auto ncy = static_cast<std::int64_t>(std::floor(ey / cell)) + 1;
    const std::vector<std::int64_t> lowest = lowest_in_cells(points, origin, cell, ncx, ncy);
    const double none = std::numeric_limits<double>::infinity();
    std::vector<double> height(lowest.size(), none);
    for (std::size_t k = 0; k < lowest.size(); ++k)
        if (lowest[k] >= 0)
            height[k] = points.coord(static_cast<std::size_t>(lowest[k]), 2) - origin[2];
    if (params.outlier_depth > 0.0) {
        // Low outliers: a cell more than outlier_depth below the 9th lowest of the 25
        // cells of its 5 x 5 window (empty ones counting as +inf) loses its seed; repeat
        // until none is found, so that clusters of outliers are peeled from the rim in.
        for (bool changed = true; changed;) {
            const std::vector<double> ninth = rank_filter(height, ncx, ncy, 2, 8);
            changed = false;
            for (std::size_t k = 0; k < height.size(); ++k)
                if (height[k] != none && ninth[k] != none &&
                    height[k] < ninth[k] - params.outlier_depth) {
                    height[k] = none;
                    changed = true;
                }
        }
    }
    const auto r = static_cast<std::int64_t>(std::floor(params.max_building_size / (2.0 * cell)));
    const std::vector<double> opened =
        square_filter(square_filter(height, ncx, ncy, r, false), ncx, ncy, r, true);
    std::vector<std::uint32_t> seeds;
    for (std::size_t k = 0; k < height.size(); ++k)
        if (height[k] != none && height[k] - opened[k] <= params.seed_tolerance)
            seeds.push_back(static_cast<std::uint32_t>(lowest[k]));
    std::sort(seeds.begin(), seeds.end());
    return seeds;
}

}  // namespace

std::vector<std::uint32_t> tin_seeds(PointsView points, const TinGroundParams& params,
                                     const std::array<double, 3>& origin,
                                     const std::array<double, 3>& upper) {
    const double ex = upper[0] - origin[0], ey = upper[1] - origin[1];
    const double cell = params.max_building_size;
    if (!(ex / cell < 0x1p31) || !(ey / cell < 0x1p31))
        throw std::invalid_argument(
            "max_building_size is too small for the XY extent (more than "
            "2^31 seed cells per axis), got " +
            check::format_value(cell));
    // The seed cells (of seed_cell, else of max_building_size) on the world lattice of
    // their size: their corner at or below the minimum corner; z stays the minimum.
    const double seed_size = *params.seed_cell > 0.0 ? *params.seed_cell : cell;
    const std::array<double, 3> seed_origin{lattice_floor(origin[0], seed_size),
                                            lattice_floor(origin[1], seed_size), origin[2]};
    const double sex = upper[0] - seed_origin[0], sey = upper[1] - seed_origin[1];
    if (!std::isfinite(sex) || !std::isfinite(sey))
        throw std::invalid_argument("points: the XY extent is too large (not finite in float64)");
    return *params.seed_cell > 0.0
               ? morphological_seeds(points, seed_origin, sex, sey, params)
               : lowest_points(points, seed_origin, cell,
                               static_cast<std::int64_t>(std::floor(sex / cell)) + 1,
                               static_cast<std::int64_t>(std::floor(sey / cell)) + 1);
}

}  // namespace pcl_rg
