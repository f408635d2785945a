// Seeds of the TIN ground filter (see tin_seeds.hpp and tin_ground.cpp's comment).
#include "pcl_rg/tin_seeds.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg {

namespace {

// The minimum (or maximum) of every window [i - r, i + r] of the line of `length`
// values in[i * stride], clipped at its ends, written to out[i * stride]: van Herk's
// algorithm (van Herk, "A fast algorithm for local minimum and maximum filters on
// rectangular and octagonal kernels", Pattern Recognition Letters 13(7), 1992; Gil and
// Werman 1993), three comparisons per value whatever r. The line is padded with r
// identities at each end, so every window covers 2r + 1 slots and spans at most two
// blocks of 2r + 1: its minimum is that of the suffix minimum in the first block and
// the prefix minimum in the second. Exact, as min and max are, so equal to scanning
// each window. `prefix` and `suffix` are scratch.
template <class Take>
void window_extreme(const double* in, double* out, std::int64_t length, std::ptrdiff_t stride,
                    std::int64_t r, double identity, Take take, std::vector<double>& prefix,
                    std::vector<double>& suffix) {
    r = std::min(r, length - 1);  // a wider window already covers the whole line
    const std::int64_t w = 2 * r + 1, padded = length + 2 * r;
    prefix.resize(static_cast<std::size_t>(padded));
    suffix.resize(static_cast<std::size_t>(padded));
    auto value = [&](std::int64_t j) {
        return j >= r && j < r + length ? in[(j - r) * stride] : identity;
    };
    for (std::int64_t j = 0; j < padded; ++j)
        prefix[j] = j % w == 0 ? value(j) : take(prefix[j - 1], value(j));
    for (std::int64_t j = padded - 1; j >= 0; --j)
        suffix[j] = j % w == w - 1 || j == padded - 1 ? value(j) : take(suffix[j + 1], value(j));
    for (std::int64_t i = 0; i < length; ++i) out[i * stride] = take(suffix[i], prefix[i + 2 * r]);
}

// Square min or max filter of half-width r over an ncx x ncy raster (+inf = no value,
// ignored; windows clipped at the border), separably by y then x (window_extreme):
// exact, as min and max are. +inf is the identity of min; for max the empty cells are
// read as -inf, and a window of empty cells gives +inf again.
std::vector<double> square_filter(const std::vector<double>& a, std::int64_t ncx, std::int64_t ncy,
                                  std::int64_t r, bool take_max) {
    const double none = std::numeric_limits<double>::infinity();
    std::vector<double> source = a;
    if (take_max)
        for (double& v : source)
            if (v == none) v = -none;
    std::vector<double> along_y(a.size()), out(a.size());
    const auto lower = [](double u, double v) { return v < u ? v : u; };
    const auto higher = [](double u, double v) { return v > u ? v : u; };
    const double identity = take_max ? -none : none;
    const Interruption interruption;  // polled once per line
#pragma omp parallel firstprivate(interruption)
    {
        std::vector<double> prefix, suffix;
#pragma omp for schedule(static)
        for (std::int64_t x = 0; x < ncx; ++x) {
            if (interruption.requested()) continue;
            if (take_max)
                window_extreme(&source[x * ncy], &along_y[x * ncy], ncy, 1, r, identity, higher,
                               prefix, suffix);
            else
                window_extreme(&source[x * ncy], &along_y[x * ncy], ncy, 1, r, identity, lower,
                               prefix, suffix);
        }
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ncy; ++y) {
            if (interruption.requested()) continue;
            if (take_max)
                window_extreme(&along_y[y], &out[y], ncx, ncy, r, identity, higher, prefix, suffix);
            else
                window_extreme(&along_y[y], &out[y], ncx, ncy, r, identity, lower, prefix, suffix);
        }
    }
    interruption.check();
    if (take_max)
        for (double& v : out)
            if (v == -none) v = none;
    return out;
}

// The `rank` lowest values of the union of two lists of them, each sorted ascending and
// padded with +inf: a merge, so exact. Taking the rank lowest is associative, so the
// prefix and suffix scans of van Herk's algorithm apply to such lists as to a minimum.
void merge_lowest(const double* a, const double* b, double* out, std::int64_t rank) {
    std::int64_t i = 0, j = 0;
    for (std::int64_t k = 0; k < rank; ++k) out[k] = b[j] < a[i] ? b[j++] : a[i++];
}

// The `rank` lowest values of every window [i - r, i + r] of a line of `length` lists
// (in[i * stride], `width` values each: 1 for single heights, `rank` for lists from a
// first pass), clipped at its ends, written as lists of `rank` to out[i * out_stride]:
// van Herk's scans as in window_extreme, on lists. `prefix` and `suffix` are scratch.
void window_lowest(const double* in, std::int64_t width, std::ptrdiff_t stride, double* out,
                   std::ptrdiff_t out_stride, std::int64_t length, std::int64_t r,
                   std::int64_t rank, std::vector<double>& prefix, std::vector<double>& suffix) {
    const double none = std::numeric_limits<double>::infinity();
    r = std::min(r, length - 1);
    const std::int64_t w = 2 * r + 1, padded = length + 2 * r;
    prefix.resize(static_cast<std::size_t>(padded * rank));  // every slot written below
    suffix.resize(static_cast<std::size_t>(padded * rank));
    std::vector<double> value(static_cast<std::size_t>(rank));
    const auto load = [&](std::int64_t j) {  // slot j's list, +inf outside the line
        std::fill(value.begin(), value.end(), none);
        if (j >= r && j < r + length)
            for (std::int64_t k = 0; k < std::min(width, rank); ++k)
                value[k] = in[(j - r) * stride + k];
        return value.data();
    };
    for (std::int64_t j = 0; j < padded; ++j) {
        double* at = &prefix[j * rank];  // merged straight in: it overlaps neither list
        if (j % w == 0)
            std::copy_n(load(j), rank, at);
        else
            merge_lowest(at - rank, load(j), at, rank);
    }
    for (std::int64_t j = padded - 1; j >= 0; --j) {
        double* at = &suffix[j * rank];
        if (j % w == w - 1 || j == padded - 1)
            std::copy_n(load(j), rank, at);
        else
            merge_lowest(at + rank, load(j), at, rank);
    }
    // A window that starts a block is that block: its suffix alone (a list, unlike a
    // minimum, must not take the same values twice).
    for (std::int64_t i = 0; i < length; ++i)
        if (i % w == 0)
            std::copy_n(&suffix[i * rank], rank, &out[i * out_stride]);
        else
            merge_lowest(&suffix[i * rank], &prefix[(i + 2 * r) * rank], &out[i * out_stride],
                         rank);
}

// Erosion by the `rank`-th lowest value (rank >= 2) of the square window of half-width r
// over an ncx x ncy raster, empty cells (+inf) and cells outside the raster counted as
// +inf; where a window holds fewer than `rank` finite values, its lowest (so an isolated
// cell keeps its height). Separably: the rank lowest of each column window, then of the
// row of those lists. Exact, as selections are.
std::vector<double> rank_erosion(const std::vector<double>& a, std::int64_t ncx, std::int64_t ncy,
                                 std::int64_t r, std::int64_t rank) {
    const double none = std::numeric_limits<double>::infinity();
    // The column windows' lists: `rank` heights per cell, the option's memory.
    std::vector<double> along_y(a.size() * static_cast<std::size_t>(rank)), out(a.size());
    const Interruption interruption;
#pragma omp parallel firstprivate(interruption)
    {
        std::vector<double> prefix, suffix, line;
#pragma omp for schedule(static)
        for (std::int64_t x = 0; x < ncx; ++x) {
            if (interruption.requested()) continue;
            window_lowest(&a[x * ncy], 1, 1, &along_y[x * ncy * rank], rank, ncy, r, rank, prefix,
                          suffix);
        }
#pragma omp for schedule(static)
        for (std::int64_t y = 0; y < ncy; ++y) {
            if (interruption.requested()) continue;
            line.resize(static_cast<std::size_t>(ncx * rank));
            window_lowest(&along_y[y * rank], rank, ncy * rank, line.data(), rank, ncx, r, rank,
                          prefix, suffix);
            for (std::int64_t x = 0; x < ncx; ++x) {
                const double kth = line[x * rank + rank - 1];
                out[x * ncy + y] = kth != none ? kth : line[x * rank];
            }
        }
    }
    interruption.check();
    return out;
}

// Whether cell (x, y) of height h (finite) lies more than `depth` below the 9th lowest
// of the 25 cells of its 5 x 5 window, cells outside the raster and empty ones (+inf)
// included as +inf: h < v9 - depth. As v - depth is non-decreasing in v, that holds
// exactly when v9 is finite (at least 9 finite cells) and at most 8 cells have
// v - depth <= h: a count, in the same floating-point arithmetic, instead of a selection.
bool low_outlier(const std::vector<double>& a, std::int64_t ncx, std::int64_t ncy, std::int64_t x,
                 std::int64_t y, double depth) {
    const double none = std::numeric_limits<double>::infinity();
    const double h = a[x * ncy + y];
    int finite = 0, low = 0;
    for (std::int64_t i = std::max<std::int64_t>(0, x - 2); i <= std::min(ncx - 1, x + 2); ++i)
        for (std::int64_t j = std::max<std::int64_t>(0, y - 2); j <= std::min(ncy - 1, y + 2);
             ++j) {
            const double v = a[i * ncy + j];
            if (v == none) continue;
            ++finite;
            low += v - depth <= h;
        }
    return finite >= 9 && low <= 8;
}

// Drops (sets to +inf) the low outliers of `height` (low_outlier), repeatedly until none
// is found, each round judged on the heights the round began with, so that clusters of
// outliers are peeled from the rim in. After the first round only the cells whose window
// holds a cell dropped in the previous round can change their verdict.
void drop_low_outliers(std::vector<double>& height, std::int64_t ncx, std::int64_t ncy,
                       double depth) {
    const double none = std::numeric_limits<double>::infinity();
    std::vector<std::uint8_t> candidate(height.size(), 0);
    std::vector<std::int64_t> cells, dropped;
    const Interruption interruption;
    std::vector<std::uint8_t> out(height.size(), 0);
#pragma omp parallel for schedule(static) firstprivate(interruption)
    for (std::int64_t x = 0; x < ncx; ++x) {
        if (interruption.requested()) continue;
        for (std::int64_t y = 0; y < ncy; ++y)
            out[x * ncy + y] =
                height[x * ncy + y] != none && low_outlier(height, ncx, ncy, x, y, depth);
    }
    interruption.check();
    for (std::size_t k = 0; k < out.size(); ++k)
        if (out[k]) dropped.push_back(static_cast<std::int64_t>(k));
    while (!dropped.empty()) {
        interruption.check();
        for (const std::int64_t k : dropped) height[k] = none;
        // The cells within 2 of a dropped one, each once.
        cells.clear();
        for (const std::int64_t k : dropped) {
            const std::int64_t x = k / ncy, y = k % ncy;
            for (std::int64_t i = std::max<std::int64_t>(0, x - 2); i <= std::min(ncx - 1, x + 2);
                 ++i)
                for (std::int64_t j = std::max<std::int64_t>(0, y - 2);
                     j <= std::min(ncy - 1, y + 2); ++j)
                    if (height[i * ncy + j] != none && !candidate[i * ncy + j]) {
                        candidate[i * ncy + j] = 1;
                        cells.push_back(i * ncy + j);
                    }
        }
        dropped.clear();
        for (const std::int64_t k : cells) {
            candidate[k] = 0;
            if (low_outlier(height, ncx, ncy, k / ncy, k % ncy, depth)) dropped.push_back(k);
        }
    }
}

// The share of a corridor's raster cells that hold a point, at least (closed_raster):
// a 50 m wide strip at 45 degrees and 1 m cells holds 1 % at 10 km long.
constexpr double kCorridorOccupancy = 0.01;

// The seed cells as a raster of ncx x ncy cells, row-major by column then row, with the
// lowest point (ties: smallest index) of each, -1 where empty.
struct SeedRaster {
    std::int64_t ncx = 0, ncy = 0;
    std::vector<std::int64_t> lowest;
};

// The occupied columns (or rows) `occupied`, sorted, distinct and >= 0, renumbered with
// every run of more than `reach` empty ones cut to `reach` + 1 steps, the run before
// the first (from column 0, the full raster's border) included; `place[j]` is
// occupied[j]'s new number.
std::vector<std::int64_t> close_gaps(const std::vector<std::int64_t>& occupied,
                                     std::int64_t reach) {
    std::vector<std::int64_t> place(occupied.size(), 0);
    for (std::size_t j = 0; j < occupied.size(); ++j)
        place[j] =
            (j ? place[j - 1] : 0) + std::min(occupied[j] - (j ? occupied[j - 1] : 0), reach + 1);
    return place;
}

// The seed raster with its empty gaps closed (close_gaps), for points whose box is
// mostly empty, such as a cloud with a few points far from the rest, whose full raster
// would not fit in memory. A cell's verdict (the low-outlier test, the opening) reads
// only the cells within `reach` columns and rows of it, and close_gaps keeps each
// occupied cell's offset to every occupied cell within that reach, and keeps the others
// beyond it, so every occupied cell sees the same neighbourhood as in the full raster:
// the seeds are the same. Empty = too large: ncx * ncy > limit, unless it is a
// corridor's raster (kCorridorOccupancy of its cells hold a point) of at most
// corridor_limit cells.
SeedRaster closed_raster(PointsView points, const std::array<double, 3>& origin, double cell,
                         std::int64_t reach, double limit, double corridor_limit) {
    const std::size_t n = points.size;
    std::vector<std::int64_t> column(n), row(n);
    for (std::size_t i = 0; i < n; ++i) {
        column[i] = floor_to_int((points.coord(i, 0) - origin[0]) / cell);
        row[i] = floor_to_int((points.coord(i, 1) - origin[1]) / cell);
    }
    const auto distinct = [](std::vector<std::int64_t> values) {
        std::sort(values.begin(), values.end());
        values.erase(std::unique(values.begin(), values.end()), values.end());
        return values;
    };
    const Interruption interruption;
    interruption.check_now();
    const std::vector<std::int64_t> columns = distinct(column), rows = distinct(row);
    interruption.check_now();
    const std::vector<std::int64_t> column_place = close_gaps(columns, reach);
    const std::vector<std::int64_t> row_place = close_gaps(rows, reach);
    SeedRaster raster;
    raster.ncx = column_place.back() + 1;
    raster.ncy = row_place.back() + 1;
    const auto place = [](const std::vector<std::int64_t>& values,
                          const std::vector<std::int64_t>& places, std::int64_t value) {
        return places[std::lower_bound(values.begin(), values.end(), value) - values.begin()];
    };
    const double cells = static_cast<double>(raster.ncx) * static_cast<double>(raster.ncy);
    if (!(cells <= limit)) {
        if (!(cells <= corridor_limit)) return SeedRaster{};
        // A corridor: at least kCorridorOccupancy of its cells hold a point. A cloud too
        // sparse for its cells, or many copies at a few positions, holds far fewer, and
        // is refused with the advice that follows.
        std::vector<std::int64_t> occupied(n);
        for (std::size_t i = 0; i < n; ++i)
            occupied[i] = place(columns, column_place, column[i]) * raster.ncy +
                          place(rows, row_place, row[i]);
        std::sort(occupied.begin(), occupied.end());
        const auto distinct_cells =
            static_cast<double>(std::unique(occupied.begin(), occupied.end()) - occupied.begin());
        if (!(distinct_cells >= kCorridorOccupancy * cells)) return SeedRaster{};
    }
    raster.lowest.assign(static_cast<std::size_t>(raster.ncx * raster.ncy), -1);
    for (std::size_t i = 0; i < n; ++i) {
        if (i % 65536 == 0) interruption.check_now();
        std::int64_t& lowest = raster.lowest[static_cast<std::size_t>(
            place(columns, column_place, column[i]) * raster.ncy + place(rows, row_place, row[i]))];
        // Lowest z, then smallest index, as lowest_in_cells (z0 = 0) keeps it.
        if (lowest < 0 || points.coord(i, 2) < points.coord(static_cast<std::size_t>(lowest), 2))
            lowest = static_cast<std::int64_t>(i);
    }
    return raster;
}

// Zhao-style seeds (TinGroundParams::seed_cell): lowest points of seed_cell cells close
// to the grey opening of their heights, after dropping low outliers (rank test).
std::vector<std::uint32_t> morphological_seeds(PointsView points,
                                               const std::array<double, 3>& origin, double ex,
                                               double ey, const TinGroundParams& params) {
    const double cell = *params.seed_cell;
    const double limit = 4.0 * static_cast<double>(points.size) + 4194304.0;
    // A corridor across the axes (a road or power line surveyed at 45 degrees) fills
    // every row and column of its box, which no closing of gaps shortens: its raster is
    // taken up to 2^25 cells, divided by opening_rank, whose erosion keeps that many
    // heights per cell (1.6 GB at rank 1, measured on an 8 km strip at 45 degrees), if
    // enough of its cells hold a point (closed_raster).
    const double corridor_limit =
        std::max(limit, 0x1p25 / static_cast<double>(params.opening_rank));
    // Half-width of the opening's windows, in cells; beyond 2^40 (wider than any raster
    // that fits) the result is the same, and the cast stays defined.
    const auto r = static_cast<std::int64_t>(
        std::min(std::floor(params.max_building_size / (2.0 * cell)), 0x1p40));
    SeedRaster raster;
    if ((std::floor(ex / cell) + 1.0) * (std::floor(ey / cell) + 1.0) <= limit) {
        raster.ncx = static_cast<std::int64_t>(std::floor(ex / cell)) + 1;
        raster.ncy = static_cast<std::int64_t>(std::floor(ey / cell)) + 1;
        raster.lowest = lowest_in_cells(
            points, CellLattice{origin[0], origin[1], 0.0, cell, raster.ncx, raster.ncy});
    } else {
        // The opening reads 2r cells away (an erosion, then a dilation), the outlier test 2;
        // columns and rows beyond 2^62 would not fit the cells' numbers.
        const std::int64_t reach = std::max<std::int64_t>(2 * r, 2);
        if (ex / cell < 0x1p62 && ey / cell < 0x1p62)
            raster = closed_raster(points, origin, cell, reach, limit, corridor_limit);
        if (raster.lowest.empty())
            throw std::invalid_argument(
                "seed_cell is too small for the XY extent of the points (" +
                check::format_value(ex) + " x " + check::format_value(ey) +
                " m: more than 4 cells per point, even with the empty rows and columns of "
                "cells between them cut short, and not a corridor of at most 2^25 / "
                "opening_rank cells, 1 % of them holding a point), got " +
                check::format_value(cell) + "; set a larger seed_cell");
    }
    const std::int64_t ncx = raster.ncx, ncy = raster.ncy;
    const std::vector<std::int64_t>& lowest = raster.lowest;
    const double none = std::numeric_limits<double>::infinity();
    std::vector<double> height(lowest.size());
    const auto cells = static_cast<std::ptrdiff_t>(lowest.size());
#pragma omp parallel for schedule(static) if (cells > 65536)
    for (std::ptrdiff_t k = 0; k < cells; ++k)  // scattered reads, distinct writes
        height[k] = lowest[k] >= 0
                        ? points.coord(static_cast<std::size_t>(lowest[k]), 2) - origin[2]
                        : none;
    if (params.outlier_depth > 0.0) {
        // Low outliers: a cell more than outlier_depth below the 9th lowest of the 25
        // cells of its 5 x 5 window (empty ones counting as +inf) loses its seed; repeat
        // until none is found, so that clusters of outliers are peeled from the rim in.
        drop_low_outliers(height, ncx, ncy, params.outlier_depth);
    }
    // The opening: an erosion (by the opening_rank-th lowest cell of each window, so that
    // fewer low cells than that cannot lower the surface around them), then a dilation.
    const std::vector<double> eroded = params.opening_rank > 1
                                           ? rank_erosion(height, ncx, ncy, r, params.opening_rank)
                                           : square_filter(height, ncx, ncy, r, false);
    const std::vector<double> opened = square_filter(eroded, ncx, ncy, r, true);
    std::vector<std::uint32_t> seeds;
    for (std::size_t k = 0; k < height.size(); ++k)
        if (height[k] != none && height[k] - opened[k] <= params.seed_tolerance)
            seeds.push_back(static_cast<std::uint32_t>(lowest[k]));
    return in_index_order(std::move(seeds), points.size);
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
               : lowest_points(points,
                               CellLattice{seed_origin[0], seed_origin[1], 0.0, cell,
                                           static_cast<std::int64_t>(std::floor(sex / cell)) + 1,
                                           static_cast<std::int64_t>(std::floor(sey / cell)) + 1});
}

std::invalid_argument unset_seed_cell_error(const std::invalid_argument& error, double spacing) {
    // An unset seed_cell follows the measured spacing, which counts every point: many at
    // one XY position (copies, poles, a scanner's footprint) make it tiny. Or, on a cloud
    // far sparser than airborne LiDAR, its cap binds.
    const std::string unset =
        " (seed_cell was left unset: a rung of its ladder at most the least of " +
        check::format_value(kTinSeedCellCap) + " m and " +
        check::format_value(kTinSeedCellPerSpacing) + " x the measured point spacing, " +
        check::format_value(spacing) + " m, ";
    if (kTinSeedCellPerSpacing * spacing > kTinSeedCellCap)
        return std::invalid_argument(std::string(error.what()) + unset +
                                     "so the cap, made for airborne densities; at this "
                                     "spacing set seed_cell to about " +
                                     check::format_value(kTinSeedCellPerSpacing * spacing) + " m)");
    return std::invalid_argument(std::string(error.what()) + unset +
                                 "which many points at one XY position make small)");
}

}  // namespace pcl_rg
