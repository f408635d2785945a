// The lowest point of each cell of a square grid (see cell_lowest.hpp).
#include "pcl_rg/cell_lowest.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

namespace {

// Column and row of point i's cell.
std::pair<std::int64_t, std::int64_t> cell_of(PointsView points, const CellLattice& lattice,
                                              std::size_t i) {
    return {
        static_cast<std::int64_t>(std::floor((points.coord(i, 0) - lattice.x0) / lattice.size)),
        static_cast<std::int64_t>(std::floor((points.coord(i, 1) - lattice.y0) / lattice.size))};
}

// Point a comes before point b: lower z - z0, then smaller index. z0 is subtracted, not
// left out, because the subtraction can round two heights to one.
bool lower(PointsView points, double z0, std::size_t a, std::size_t b) {
    const double za = points.coord(a, 2) - z0, zb = points.coord(b, 2) - z0;
    return za < zb || (za == zb && a < b);
}

}  // namespace

std::vector<std::int64_t> lowest_in_cells(PointsView points, const CellLattice& lattice,
                                          const bool* take) {
    // Each cell keeps its lowest point's height next to its index, so that a comparison
    // reads no other point (the points of a cell are scattered over the input).
    struct Lowest {
        double z;
        std::int64_t i;  // -1: none yet
    };
    const auto cells = static_cast<std::size_t>(lattice.columns * lattice.rows);
    std::vector<Lowest> lowest(cells, Lowest{0.0, -1});
    auto keep_lower = [](Lowest& b, const Lowest& p) {
        if (b.i < 0 || p.z < b.z || (p.z == b.z && p.i < b.i)) b = p;
    };
    const auto n = static_cast<std::int64_t>(points.size);
    const Interruption interruption;
#pragma omp parallel if (cells <= points.size / 8 && n > 65536) firstprivate(interruption)
    {
        std::vector<Lowest> mine(cells, Lowest{0.0, -1});
        bool stop = false;
#pragma omp for schedule(static) nowait
        for (std::int64_t i = 0; i < n; ++i) {
            if (i % 4096 == 0) stop = interruption.requested();
            if (stop || (take && !take[i])) continue;
            const auto [cx, cy] = cell_of(points, lattice, static_cast<std::size_t>(i));
            keep_lower(mine[static_cast<std::size_t>(cx * lattice.rows + cy)],
                       Lowest{points.coord(static_cast<std::size_t>(i), 2) - lattice.z0, i});
        }
#pragma omp critical(pcl_rg_lowest_in_cells)
        for (std::size_t k = 0; k < cells; ++k)
            if (mine[k].i >= 0) keep_lower(lowest[k], mine[k]);
    }
    interruption.check();
    std::vector<std::int64_t> index(cells);
    for (std::size_t k = 0; k < cells; ++k) index[k] = lowest[k].i;
    return index;
}

std::vector<std::uint32_t> lowest_points(PointsView points, const CellLattice& lattice,
                                         const bool* take) {
    const auto n = static_cast<std::int64_t>(points.size);
    std::vector<std::uint32_t> lowest;
    if (lattice.columns <= (4 * n + 4096) / lattice.rows) {
        for (const std::int64_t b : lowest_in_cells(points, lattice, take))
            if (b >= 0) lowest.push_back(static_cast<std::uint32_t>(b));
    } else {
        // By (column, row) pairs: up to 2^40 cells per axis, more than one key holds.
        std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, std::uint32_t>> keyed;
        for (std::size_t i = 0; i < points.size; ++i)
            if (!take || take[i])
                keyed.emplace_back(cell_of(points, lattice, i), static_cast<std::uint32_t>(i));
        std::sort(keyed.begin(), keyed.end(), [&](const auto& a, const auto& b) {
            return a.first < b.first ||
                   (a.first == b.first && lower(points, lattice.z0, a.second, b.second));
        });
        for (std::size_t k = 0; k < keyed.size(); ++k)
            if (k == 0 || keyed[k].first != keyed[k - 1].first) lowest.push_back(keyed[k].second);
    }
    std::sort(lowest.begin(), lowest.end());
    return lowest;
}

}  // namespace pcl_rg
