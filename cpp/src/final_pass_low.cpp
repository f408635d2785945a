// Ground points far below their surroundings: see final_pass_low.hpp.
#include "final_pass_low.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg::final_pass_low {

namespace {

constexpr std::size_t kWindowCells = (2 * kWindowReach + 1) * (2 * kWindowReach + 1);
constexpr double kNotLow = -std::numeric_limits<double>::infinity();

// An occupied cell by place, with a value: its lowest ground height (`occupied`) or its
// threshold (`low`).
struct Cell {
    std::int64_t cx, cy;
    double value;
};

bool by_place(const Cell& a, const Cell& b) { return a.cx < b.cx || (a.cx == b.cx && a.cy < b.cy); }

// The threshold of a cell whose lowest ground height is z, given its window's heights
// (values[0, count), reordered): median - depth when z lies below it, else kNotLow.
// Most cells are no lower than their surroundings, and a count decides that without the
// median: z < fl(median - depth) needs z < fl(v - depth) for the middle value v (odd
// count) or the upper middle one (even: the mean of the two middles is at most that),
// so for at least half of the values, fl(v - depth) being monotone in v.
double threshold(double z, double depth, double* values, std::size_t count) {
    std::size_t above = 0;
    for (std::size_t k = 0; k < count; ++k) above += z < values[k] - depth ? 1 : 0;
    if (above < (count + 1) / 2) return kNotLow;
    double* middle = values + count / 2;
    std::nth_element(values, middle, values + count);
    const double median =
        count % 2 == 1 ? *middle : (*std::max_element(values, middle) + *middle) / 2.0;
    return z < median - depth ? median - depth : kNotLow;
}

// Per cell of the raster, its threshold (kNotLow: no point of it is dropped), from each
// cell's lowest ground point (`lowest`, lowest_in_cells's, -1: none). Polls.
std::vector<double> raster_thresholds(PointsView points, const CellLattice& cells, double depth,
                                      const std::vector<std::int64_t>& lowest) {
    const Interruption interruption;
    const std::int64_t rows = cells.rows;
    const std::int64_t stride = window_stride(cells.size);
    const auto count = static_cast<std::ptrdiff_t>(lowest.size());
    std::vector<double> height(lowest.size());
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t c = 0; c < count; ++c)
        height[c] = lowest[c] >= 0 ? points.coord(static_cast<std::size_t>(lowest[c]), 2) - cells.z0
                                   : std::numeric_limits<double>::quiet_NaN();
    std::vector<double> threshold_of(lowest.size(), kNotLow);
#pragma omp parallel for schedule(static) if (count > 65536) firstprivate(interruption)
    for (std::ptrdiff_t c = 0; c < count; ++c) {
        if (lowest[c] < 0 || interruption.requested()) continue;
        const std::int64_t cx = c / rows, cy = c % rows;
        std::array<double, kWindowCells> window;
        std::size_t size = 0;
        for (std::int64_t dx = -kWindowReach; dx <= kWindowReach; ++dx) {
            const std::int64_t x = cx + dx * stride;
            if (x < 0 || x >= cells.columns) continue;
            for (std::int64_t dy = -kWindowReach; dy <= kWindowReach; ++dy) {
                const std::int64_t y = cy + dy * stride;
                if (y >= 0 && y < rows && lowest[x * rows + y] >= 0)
                    window[size++] = height[x * rows + y];
            }
        }
        threshold_of[c] = threshold(height[c], depth, window.data(), size);
    }
    interruption.check();
    return threshold_of;
}

// Each cell's lowest kept point, in index order: its lowest ground point (`lowest`, as
// raster_thresholds took it) where it has no threshold, as that point is then kept;
// else the least (lower_in_cell) of its kept points, the set bits of `marked` (cleared),
// for each of which place(bit) gives the cell and the point's index. A cell has a
// threshold only when its lowest ground point lies below it, dropped.
template <class Place>
std::vector<std::uint32_t> lowest_kept(std::vector<std::int64_t> lowest,
                                       const std::vector<double>& threshold_of,
                                       std::vector<std::uint64_t>& marked, PointsView points,
                                       double z0, std::size_t n, Place place) {
    for (std::size_t c = 0; c < threshold_of.size(); ++c)
        if (threshold_of[c] != kNotLow) lowest[c] = -1;
    std::vector<std::uint32_t> bits;
    take_marked(marked, bits);
    for (const std::uint32_t bit : bits) {
        const auto [cell, i] = place(bit);
        std::int64_t& best = lowest[cell];
        if (best < 0 || lower_in_cell(points, z0, i, static_cast<std::size_t>(best))) best = i;
    }
    return raster_in_index_order(lowest, n);
}

// keep_not_low on points by position (lowest_by_position's case with a depth): ground and
// kept by position; returns the lowest kept point of each cell (input indices, in index
// order), reading the points' coordinates only for those.
std::vector<std::uint32_t> keep_not_low_by_position(PointsView points, const SnappedPoints& snapped,
                                                    const CellLattice& cells, double depth,
                                                    const unsigned char* ground,
                                                    unsigned char* kept) {
    const std::size_t n = snapped.order.size();
    const auto cell_count = static_cast<std::size_t>(cells.columns * cells.rows);
    std::vector<std::int64_t> lowest = lowest_in_cells(snapped.cell.data(), snapped.z.data(),
                                                       snapped.order.data(), ground, n, cell_count);
    const std::vector<double> threshold_of = raster_thresholds(points, cells, depth, lowest);
    // The kept positions of the cells with a threshold, marked by any thread: the
    // candidates for those cells' lowest kept points.
    std::vector<std::uint64_t> in_threshold_cell((n + 63) / 64, 0);
    const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t s = 0; s < count; ++s) {
        kept[s] = ground[s];
        if (!ground[s]) continue;
        const double t = threshold_of[snapped.cell[s]];
        if (t == kNotLow) continue;
        if (snapped.z[s] < t)
            kept[s] = 0;
        else
            mark(in_threshold_cell, static_cast<std::uint32_t>(s));
    }
    poll_interrupt();
    return lowest_kept(
        std::move(lowest), threshold_of, in_threshold_cell, points, cells.z0, n,
        [&](std::uint32_t s) {
            return std::pair{static_cast<std::size_t>(snapped.cell[s]), snapped.order[s]};
        });
}

}  // namespace

std::optional<std::vector<std::uint32_t>> keep_not_low(PointsView points, const CellLattice& cells,
                                                       double depth, const bool* ground,
                                                       bool* kept) {
    const std::size_t n = points.size;
    const Interruption interruption;
    const std::int64_t rows = cells.rows;
    const std::int64_t stride = window_stride(cells.size);
    const std::int64_t reach = kWindowReach * stride;  // in cells, on each side
    const auto z_of = [&](std::size_t i) { return points.coord(i, 2) - cells.z0; };
    // Per cell, its threshold (kNotLow: no point of it is dropped), through a raster of
    // the cells' lowest heights where the lattice is at most a few cells per point (as
    // lowest_points), else through the occupied cells sorted by place.
    std::vector<double> raster_threshold;
    std::vector<std::int64_t> lowest;  // raster: each cell's lowest ground point, -1: none
    std::vector<Cell> low;             // sparse: the cells with points to drop, by place
    if (fits_raster(cells, n)) {
        lowest = lowest_in_cells(points, cells, ground);
        raster_threshold = raster_thresholds(points, cells, depth, lowest);
    } else {
        std::vector<Cell> occupied;
        for (const std::uint32_t i : lowest_points(points, cells, ground)) {
            const auto [cx, cy] = cell_of(points, cells, i);
            occupied.push_back({cx, cy, z_of(i)});
        }
        std::sort(occupied.begin(), occupied.end(), by_place);
        interruption.check_now();
        const auto count = static_cast<std::ptrdiff_t>(occupied.size());
        std::vector<double> cell_threshold(occupied.size());
#pragma omp parallel for schedule(static) if (count > 4096) firstprivate(interruption)
        for (std::ptrdiff_t k = 0; k < count; ++k) {
            if (interruption.requested()) continue;
            std::array<double, kWindowCells> window;
            std::size_t size = 0;
            const Cell& c = occupied[k];
            for (std::int64_t cx = c.cx - reach; cx <= c.cx + reach; cx += stride) {
                auto at = std::lower_bound(occupied.begin(), occupied.end(),
                                           Cell{cx, c.cy - reach, 0.0}, by_place);
                for (; at != occupied.end() && at->cx == cx && at->cy <= c.cy + reach; ++at)
                    if ((at->cy - c.cy) % stride == 0) window[size++] = at->value;
            }
            cell_threshold[k] = threshold(c.value, depth, window.data(), size);
        }
        interruption.check();
        for (std::size_t k = 0; k < occupied.size(); ++k)
            if (cell_threshold[k] != kNotLow)
                low.push_back({occupied[k].cx, occupied[k].cy, cell_threshold[k]});
    }
    // A point is dropped only below its cell's threshold. Raster: a column of cells
    // without a threshold (a small array of flags) tells its points' fate after a
    // division, without the raster's scattered reads; in a column with one, each ground
    // point's cell is found, and the kept points of a cell with a threshold are the
    // candidates for its lowest kept point. Sparse: most points lie above the highest
    // threshold.
    double highest = kNotLow;
    std::vector<std::uint8_t> column_has_threshold;
    if (!raster_threshold.empty()) {
        column_has_threshold.assign(static_cast<std::size_t>(cells.columns), 0);
        for (std::size_t c = 0; c < raster_threshold.size(); ++c)
            if (raster_threshold[c] != kNotLow)
                column_has_threshold[c / static_cast<std::size_t>(rows)] = 1;
    }
    for (const Cell& c : low) highest = std::max(highest, c.value);
    // Raster: the kept points of the cells with a threshold, marked by any thread.
    std::vector<std::uint64_t> in_threshold_cell;
    if (!raster_threshold.empty()) in_threshold_cell.assign((n + 63) / 64, 0);
    const auto m = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static) if (m > 65536)
    for (std::ptrdiff_t i = 0; i < m; ++i) {
        kept[i] = ground[i];
        if (!ground[i]) continue;
        const auto p = static_cast<std::size_t>(i);
        const double z = z_of(p);
        if (!raster_threshold.empty()) {
            // cell_of's column, then its row only where the column holds a threshold.
            const std::int64_t cx = floor_to_int((points.coord(p, 0) - cells.x0) / cells.size);
            if (!column_has_threshold[static_cast<std::size_t>(cx)]) continue;
            const std::int64_t cy = floor_to_int((points.coord(p, 1) - cells.y0) / cells.size);
            const double t = raster_threshold[static_cast<std::size_t>(cx * rows + cy)];
            if (t == kNotLow) continue;
            if (z < t)
                kept[i] = false;
            else
                mark(in_threshold_cell, static_cast<std::uint32_t>(p));
            continue;
        }
        if (!(z < highest)) continue;
        const auto [cx, cy] = cell_of(points, cells, p);
        const auto at = std::lower_bound(low.begin(), low.end(), Cell{cx, cy, 0.0}, by_place);
        if (at != low.end() && at->cx == cx && at->cy == cy && z < at->value) kept[i] = false;
    }
    if (raster_threshold.empty()) return std::nullopt;
    return lowest_kept(std::move(lowest), raster_threshold, in_threshold_cell, points, cells.z0, n,
                       [&](std::uint32_t i) {
                           const auto [cx, cy] = cell_of(points, cells, i);
                           return std::pair{static_cast<std::size_t>(cx * rows + cy), i};
                       });
}

std::vector<std::uint32_t> lowest_by_position(PointsView points, const SnappedPoints& snapped,
                                              const CellLattice& cells, double depth,
                                              const bool* ground,
                                              std::vector<unsigned char>& vertex_ground) {
    const std::size_t n = snapped.order.size();
    std::vector<unsigned char> ground_at(n);
    const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t s = 0; s < count; ++s) ground_at[s] = ground[snapped.order[s]];
    if (depth > 0.0) {
        vertex_ground.resize(n);
        return keep_not_low_by_position(points, snapped, cells, depth, ground_at.data(),
                                        vertex_ground.data());
    }
    std::vector<std::uint32_t> lowest = raster_in_index_order(
        lowest_in_cells(snapped.cell.data(), snapped.z.data(), snapped.order.data(),
                        ground_at.data(), n, static_cast<std::size_t>(cells.columns * cells.rows)),
        n);
    vertex_ground = std::move(ground_at);
    return lowest;
}

}  // namespace pcl_rg::final_pass_low
