// The cell grid of the grid ground filter (see grid_cells.hpp and grid_ground.cpp).
#include "pcl_rg/grid_cells.hpp"

#include <algorithm>
#include <cmath>

#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

namespace {

std::int64_t grid_index(double local, double size) {
    return static_cast<std::int64_t>(std::floor(local / size));
}

}  // namespace

// Steps 1 and 2: block and cell of every point, and the counting sorts.
CellGrid build_grid(PointsView points, const GridGroundParams& params,
                    const std::array<double, 3>& origin, const std::array<double, 2>& extent) {
    const std::size_t n = points.size;
    const auto count = static_cast<std::ptrdiff_t>(n);
    const bool parallel = n >= kGridParallelMin;
    const std::array<double, 2>& cell_size = *params.cell_size;  // set by grid_ground
    CellGrid grid;
    grid.width = grid_index(extent[0], cell_size[0]) + 1;
    grid.height = grid_index(extent[1], cell_size[1]) + 1;
    // Dense numbering while the grid is at most a few times the cloud (or 2^20).
    const double limit = std::max(4.0 * static_cast<double>(n), 1048576.0);
    grid.dense = static_cast<double>(grid.width) * static_cast<double>(grid.height) <= limit;

    std::vector<std::uint32_t> key(n);  // cell number, then block number, per input point
    std::size_t cells;
    if (grid.dense) {
        cells = static_cast<std::size_t>(grid.width * grid.height);
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t i = 0; i < count; ++i) {
            const std::int64_t cx = grid_index(points.coord(i, 0) - origin[0], cell_size[0]);
            const std::int64_t cy = grid_index(points.coord(i, 1) - origin[1], cell_size[1]);
            key[i] = static_cast<std::uint32_t>(cy * grid.width + cx);
        }
    } else {
        std::vector<std::pair<std::int64_t, std::int64_t>> cell(n);
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t i = 0; i < count; ++i)
            cell[i] = {grid_index(points.coord(i, 1) - origin[1], cell_size[1]),
                       grid_index(points.coord(i, 0) - origin[0], cell_size[0])};
        grid.occupied = cell;
        std::sort(grid.occupied.begin(), grid.occupied.end());
        grid.occupied.erase(std::unique(grid.occupied.begin(), grid.occupied.end()),
                            grid.occupied.end());
        cells = grid.occupied.size();
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t i = 0; i < count; ++i)
            key[i] = static_cast<std::uint32_t>(
                std::lower_bound(grid.occupied.begin(), grid.occupied.end(), cell[i]) -
                grid.occupied.begin());
    }

    // Stable counting sort by cell: within a cell, input order (for now). Serial sweeps that miss
    // the cache: polled every few thousand points.
    const Interruption interruption;
    interruption.check_now();
    grid.start.assign(cells + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
        if (i % 4096 == 0) interruption.check();
        ++grid.start[key[i] + 1];
    }
    for (std::size_t c = 0; c < cells; ++c) grid.start[c + 1] += grid.start[c];
    grid.id.resize(n);
    {
        std::vector<std::size_t> fill(grid.start.begin(), grid.start.end() - 1);
        for (std::size_t i = 0; i < n; ++i) {
            if (i % 4096 == 0) interruption.check();
            grid.id[fill[key[i]]++] = static_cast<std::uint32_t>(i);
        }
    }
    grid.p.resize(n);
    grid.cell.resize(n);
    // The gathers miss the cache too: in blocks of points, polled once each.
    constexpr std::ptrdiff_t kBlock = 4096;
#pragma omp parallel for schedule(guided) if (parallel) firstprivate(interruption)
    for (std::ptrdiff_t b = 0; b < (count + kBlock - 1) / kBlock; ++b) {
        if (interruption.requested()) continue;
        for (std::ptrdiff_t s = b * kBlock; s < std::min(count, (b + 1) * kBlock); ++s) {
            const std::size_t i = grid.id[s];
            grid.p[s] = {points.coord(i, 0) - origin[0], points.coord(i, 1) - origin[1],
                         points.coord(i, 2) - origin[2]};
            grid.cell[s] = key[i];
        }
    }
    interruption.check();

    // Within a cell, by height (ties: input index), for the slope pre-filter: it then
    // meets a cell's low points first and stops at the first one it cannot fail against
    // (and the links look only at heights within reach). Nothing else depends on the
    // order within a cell (grid_ground.cpp). Sorted on the gathered copies, which lie
    // together; without the pre-filter the sort costs more than it saves.
    grid.by_height = params.filter_passes > 0;
    const auto cell_count = static_cast<std::ptrdiff_t>(grid.by_height ? cells : 0);
#pragma omp parallel if (parallel && grid.by_height)
    {
        std::vector<std::uint32_t> rank;
        std::vector<Local> p;
        std::vector<std::uint32_t> id;
#pragma omp for schedule(dynamic, 1024)
        for (std::ptrdiff_t c = 0; c < cell_count; ++c) {
            const std::size_t begin = grid.start[c], size = grid.start[c + 1] - begin;
            if (size < 2) continue;
            rank.resize(size);
            for (std::size_t k = 0; k < size; ++k) rank[k] = static_cast<std::uint32_t>(k);
            const Local* local = grid.p.data() + begin;
            const std::uint32_t* index = grid.id.data() + begin;
            std::sort(rank.begin(), rank.end(), [&](std::uint32_t a, std::uint32_t b) {
                return local[a].z < local[b].z || (local[a].z == local[b].z && index[a] < index[b]);
            });
            p.assign(local, local + size);
            id.assign(index, index + size);
            for (std::size_t k = 0; k < size; ++k) {
                grid.p[begin + k] = p[rank[k]];
                grid.id[begin + k] = id[rank[k]];
            }
        }
    }

    // Blocks, numbered densely unless the block grid is far larger than the cloud.
    const std::int64_t nbx = grid_index(extent[0], params.block_size[0]) + 1;
    const std::int64_t nby = grid_index(extent[1], params.block_size[1]) + 1;
    grid.block.resize(n);
    if (static_cast<double>(nbx) * static_cast<double>(nby) <= limit) {
        grid.blocks = static_cast<std::size_t>(nbx * nby);
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t s = 0; s < count; ++s)
            grid.block[s] =
                static_cast<std::uint32_t>(grid_index(grid.p[s].y, params.block_size[1]) * nbx +
                                           grid_index(grid.p[s].x, params.block_size[0]));
    } else {
        std::vector<std::pair<std::int64_t, std::int64_t>> block(n);
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t s = 0; s < count; ++s)
            block[s] = {grid_index(grid.p[s].y, params.block_size[1]),
                        grid_index(grid.p[s].x, params.block_size[0])};
        std::vector<std::pair<std::int64_t, std::int64_t>> occupied(block);
        std::sort(occupied.begin(), occupied.end());
        occupied.erase(std::unique(occupied.begin(), occupied.end()), occupied.end());
        grid.blocks = occupied.size();
#pragma omp parallel for schedule(guided) if (parallel)
        for (std::ptrdiff_t s = 0; s < count; ++s)
            grid.block[s] = static_cast<std::uint32_t>(
                std::lower_bound(occupied.begin(), occupied.end(), block[s]) - occupied.begin());
    }
    interruption.check_now();
    grid.block_start.assign(grid.blocks + 1, 0);
    for (std::size_t s = 0; s < n; ++s) {
        if (s % 4096 == 0) interruption.check();
        ++grid.block_start[grid.block[s] + 1];
    }
    for (std::size_t b = 0; b < grid.blocks; ++b) grid.block_start[b + 1] += grid.block_start[b];
    grid.block_member.resize(n);
    {
        std::vector<std::size_t> fill(grid.block_start.begin(), grid.block_start.end() - 1);
        for (std::size_t s = 0; s < n; ++s) {
            if (s % 4096 == 0) interruption.check();
            grid.block_member[fill[grid.block[s]]++] = static_cast<std::uint32_t>(s);
        }
    }
    return grid;
}

}  // namespace pcl_rg
