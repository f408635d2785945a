// The lowest point of each cell of a square grid: the seeds of tin_ground (tin_seeds.cpp)
// and the vertices of the ground filters' final pass (final_pass.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Where the cells lie: square cells of side `size` (m, > 0) with the corner of cell
/// (0, 0) at (x0, y0), a point (x, y) in cell (floor((x - x0) / size), floor((y - y0) /
/// size)); `columns` x `rows` cells cover the points. Heights compare as z - z0 (z0 = 0:
/// as stored), ties by the smaller index.
struct CellLattice {
    double x0 = 0.0, y0 = 0.0, z0 = 0.0;
    double size = 1.0;
    std::int64_t columns = 1, rows = 1;
};

/// Whether a dense raster of the lattice's cells holds at most about 4 cells per point
/// of n: then lowest_points and the final pass's window (final_pass_low.cpp) use one,
/// else they sort the occupied cells, so that any cell size works.
inline bool fits_raster(const CellLattice& lattice, std::size_t n) {
    return lattice.columns <= (4 * static_cast<std::int64_t>(n) + 4096) / lattice.rows;
}

/// Point a comes before point b in its cell: lower z - z0, then smaller index (the order
/// of lowest_in_cells and lowest_points). z0 is subtracted, not left out, because the
/// subtraction can round two heights to one.
inline bool lower_in_cell(PointsView points, double z0, std::size_t a, std::size_t b) {
    const double za = points.coord(a, 2) - z0, zb = points.coord(b, 2) - z0;
    return za < zb || (za == zb && a < b);
}

/// Column and row of point i's cell.
inline std::pair<std::int64_t, std::int64_t> cell_of(PointsView points, const CellLattice& lattice,
                                                     std::size_t i) {
    return {floor_to_int((points.coord(i, 0) - lattice.x0) / lattice.size),
            floor_to_int((points.coord(i, 1) - lattice.y0) / lattice.size)};
}

/// cell_of for loops over every point: the quotient through a multiplication by the
/// reciprocal of the cell size, which needs no division. Where both are finite and
/// below 2^40, the two quotients differ by a few units in the last place at most (each
/// rounding is relatively within 2^-53), so their floors differ only when a whole
/// number lies that close; within a relative 2^-40 of one, and wherever the product is
/// not such a number (a subnormal size, whose reciprocal is infinite), the division
/// decides. So the same cells as cell_of, bit for bit.
class CellOf {
   public:
    explicit CellOf(const CellLattice& lattice) : lattice_(lattice), inverse_(1.0 / lattice.size) {}

    std::pair<std::int64_t, std::int64_t> operator()(PointsView points, std::size_t i) const {
        return {index(points.coord(i, 0) - lattice_.x0), index(points.coord(i, 1) - lattice_.y0)};
    }

   private:
    std::int64_t index(double offset) const {
        const double q = offset * inverse_;
        if (!(std::fabs(q) < 0x1p40)) return floor_to_int(offset / lattice_.size);
        const double below = static_cast<double>(floor_to_int(q));
        const double margin = 0x1p-40 * std::fabs(q);
        if (q - below < margin || (below + 1.0) - q < margin)
            return floor_to_int(offset / lattice_.size);
        return static_cast<std::int64_t>(below);
    }

    CellLattice lattice_;
    double inverse_;
};

/// Lowest point (then smallest index) of every cell, row-major by column then row
/// (cell cx * rows + cy); -1 for a cell with no point. Only the points i with take[i]
/// count (all when take is null). In parallel beyond 65536 points: with at most N / 8
/// cells each thread keeps the lowest of its share of the points in a grid of its own,
/// merged at the end; with more, every point's cell first, then each thread keeps the
/// lowest of its own range of cells. The lowest under a total order does not depend on
/// the sharing. Polls for interruption.
std::vector<std::int64_t> lowest_in_cells(PointsView points, const CellLattice& lattice,
                                          const bool* take = nullptr);

/// lowest_in_cells for entries in another order (grid_ground's, SnappedPoints::cell):
/// entry s of n is point id[s], in cell cell[s] (< cells) at height z[s] (z - z0), and
/// counts when take[s] is set. Each thread keeps the lowest of its share in a raster of
/// its own, merged at the end, so it is meant for at most about n / 8 cells; the lowest
/// (z, then smallest id) does not depend on the sharing. Polls for interruption.
std::vector<std::int64_t> lowest_in_cells(const std::uint32_t* cell, const double* z,
                                          const std::uint32_t* id, const unsigned char* take,
                                          std::size_t n, std::size_t cells);

/// The points of a raster of lowest points (lowest_in_cells's; -1: an empty cell) of a
/// cloud of n points, in index order.
std::vector<std::uint32_t> raster_in_index_order(const std::vector<std::int64_t>& lowest,
                                                 std::size_t n);

/// An entry's (column, row) cell and its id (a point's index or sorted position).
using CellKeyed = std::pair<std::pair<std::int64_t, std::int64_t>, std::uint32_t>;

/// The id of the lowest entry of each cell of `keyed`, cells in (column, row) order, by
/// sorting: the path for lattices too large for a raster (any cell count works).
/// `lower(a, b)`: id a is lower than id b, a total order.
template <class Lower>
std::vector<std::uint32_t> lowest_by_sorting(std::vector<CellKeyed> keyed, Lower lower) {
    std::sort(keyed.begin(), keyed.end(), [&](const CellKeyed& a, const CellKeyed& b) {
        return a.first < b.first || (a.first == b.first && lower(a.second, b.second));
    });
    std::vector<std::uint32_t> lowest;
    for (std::size_t k = 0; k < keyed.size(); ++k)
        if (k == 0 || keyed[k].first != keyed[k - 1].first) lowest.push_back(keyed[k].second);
    return lowest;
}

/// The lowest point of every occupied cell (as lowest_in_cells), sorted by index: through
/// the dense grid when it holds at most about 4 cells per point, else by sorting
/// (cell, height, index), so that any cell size works.
std::vector<std::uint32_t> lowest_points(PointsView points, const CellLattice& lattice,
                                         const bool* take = nullptr);

}  // namespace pcl_rg
