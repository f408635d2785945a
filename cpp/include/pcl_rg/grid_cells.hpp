// Steps 1 and 2 of the grid ground filter: the points sorted into a CSR grid of cells,
// with their blocks. Part of grid_ground, split out to keep files small.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/grid_ground.hpp"
#include "pcl_rg/points.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

// Below this many points a call takes about 0.1 s on one core, and threads cost more
// than they save: every parallel loop ends in a barrier, which stalls whenever another
// process holds one of the cores.
constexpr std::size_t kGridParallelMin = 500000;

// A point in local coordinates (x, y, z together: one cache line per test).
struct Local {
    double x, y, z;
};

// A cell holding more points than this is crowded (a scanner's footprint, a pole of
// returns): an unset cell_size is at most two point spacings, so ordinary cells hold a
// few points. A crowded cell is always sorted by height, and the links bound the heights
// they scan in it by the XY box of its points (grid_links.cpp), so that a dense spot of
// distinct points is not quadratic.
constexpr std::size_t kCrowdedCell = 64;

// The XY box of a cell's points, local coordinates.
struct CellBox {
    double x0, x1, y0, y1;
};

// The points in cell order (a CSR grid) with everything the passes read.
struct CellGrid {
    // The arrays that build_grid writes in full (the scatter, the cells' starts band by
    // band, the block numbers and members) are not zero-filled when sized
    // (UnfilledVector): hundreds of MiB at 10M points, a serial pass otherwise.
    UnfilledVector<Local> p;                      // local coordinates, by sorted position
    UnfilledVector<std::uint32_t> id;             // input index of each position
    UnfilledVector<std::uint32_t> block;          // block number of each position
    UnfilledVector<std::uint32_t> cell;           // cell number of each position
    UnfilledVector<std::int32_t> snap_x, snap_y;  // XY on the final pass's grid (if asked)
    UnfilledVector<std::uint32_t> final_cell;     // the final pass's cell (if asked)
    UnfilledVector<std::size_t> start;            // positions of cell c: [start[c], start[c + 1])
    bool by_height = false;                       // a cell's points by (z, x, y), else input order
    std::vector<std::size_t> crowded;             // the crowded cells, ascending
    std::vector<CellBox> crowded_box;             // and the XY box of each one's points
    std::size_t blocks = 0;
    std::vector<std::size_t> block_start;        // members of block b: block_member[
    UnfilledVector<std::uint32_t> block_member;  //   block_start[b] .. block_start[b + 1])
    // Cell numbering: dense c = cy * width + cx, or the index in `occupied` (sorted).
    bool dense = true;
    std::int64_t width = 0, height = 0;
    std::vector<std::pair<std::int64_t, std::int64_t>> occupied;  // (cy, cx)

    std::size_t cells() const { return start.size() - 1; }

    bool is_crowded(std::size_t c) const { return start[c + 1] - start[c] > kCrowdedCell; }
    // Whether cell c's points are by (z, x, y): all cells with by_height, else the crowded.
    bool sorted_by_height(std::size_t c) const { return by_height || is_crowded(c); }
    // The XY box of crowded cell c.
    const CellBox& box_of_crowded(std::size_t c) const {
        return crowded_box[static_cast<std::size_t>(
            std::lower_bound(crowded.begin(), crowded.end(), c) - crowded.begin())];
    }

    // Whether the point at position s is a copy of the one before it. A point's copies
    // share its cell and, when the cells are sorted by height, lie next to it: every
    // verdict of the filter and every link is then the previous point's, so the passes
    // take it from there instead of testing the copy against its whole neighbourhood.
    bool copy_of_previous(std::size_t s) const {
        return s > 0 && p[s].x == p[s - 1].x && p[s].y == p[s - 1].y && p[s].z == p[s - 1].z;
    }

    std::pair<std::int64_t, std::int64_t> cell_xy(std::size_t c) const {
        if (dense)
            return {static_cast<std::int64_t>(c) % width, static_cast<std::int64_t>(c) / width};
        return {occupied[c].second, occupied[c].first};
    }

    // Cell number of (cx, cy), or -1 when no point lies in it.
    std::ptrdiff_t find(std::int64_t cx, std::int64_t cy) const {
        if (cx < 0 || cy < 0 || cx >= width || cy >= height) return -1;
        if (dense) {
            const auto c = static_cast<std::size_t>(cy * width + cx);
            return start[c] == start[c + 1] ? -1 : static_cast<std::ptrdiff_t>(c);
        }
        const auto key = std::make_pair(cy, cx);
        const auto it = std::lower_bound(occupied.begin(), occupied.end(), key);
        if (it == occupied.end() || *it != key) return -1;
        return it - occupied.begin();
    }

    // The occupied cells of the 3 x 3 neighbourhood of cell c; returns their count.
    int neighbours(std::size_t c, std::ptrdiff_t out[9]) const {
        const auto [cx, cy] = cell_xy(c);
        int count = 0;
        if (dense && cx > 0 && cy > 0 && cx + 1 < width && cy + 1 < height) {
            // Inside the grid: the 3 x 3 cells are c + du + dv * width, no bounds to test.
            const auto centre = static_cast<std::ptrdiff_t>(c);
            for (std::ptrdiff_t dv = -width; dv <= width; dv += width)
                for (std::ptrdiff_t other = centre + dv - 1; other <= centre + dv + 1; ++other)
                    if (start[other] != start[other + 1]) out[count++] = other;
            return count;
        }
        for (int dv = -1; dv <= 1; ++dv)
            for (int du = -1; du <= 1; ++du) {
                const std::ptrdiff_t other = find(cx + du, cy + dv);
                if (other >= 0) out[count++] = other;
            }
        return count;
    }
};

/// Steps 1 and 2: block and cell of every point (local coordinates l = p - origin),
/// and the counting sorts. `extent` is the largest l in x and y; `params` must have
/// cell_size set (grid_ground passes with_spacing(...)). With `snap` (the final pass's
/// frame, snap_frame), also each position's snapped XY (snap_x, snap_y, as
/// snap->grid_x and grid_y give them), so that the final pass needs no sort of its own;
/// with `final_cells` too, each position's cell on that lattice (final_cell, cx * rows +
/// cy as cell_of gives them; the caller checks final_cells_by_position).
CellGrid build_grid(PointsView points, const GridGroundParams& params,
                    const std::array<double, 3>& origin, const std::array<double, 2>& extent,
                    const SnappedPoints* snap = nullptr, const CellLattice* final_cells = nullptr);

}  // namespace pcl_rg
