// The lowest point of each cell of a square grid (see cell_lowest.hpp).
#include "pcl_rg/cell_lowest.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

namespace {

// A cell's lowest point so far: its height next to its index, so that a comparison
// reads no other point (the points of a cell are scattered over the input).
struct Lowest {
    double z;
    std::int64_t i;  // -1: none yet
};

// b becomes p when p is lower (then of smaller index): a total order, so the lowest
// does not depend on the order the points come in.
void keep_lower(Lowest& b, const Lowest& p) {
    if (b.i < 0 || p.z < b.z || (p.z == b.z && p.i < b.i)) b = p;
}

// Merges a thread's raster into the shared one (in a critical section: one at a time).
void merge_lowest(UnfilledVector<Lowest>& lowest, const UnfilledVector<Lowest>& mine) {
#pragma omp critical(pcl_rg_lowest_in_cells)
    for (std::size_t k = 0; k < lowest.size(); ++k)
        if (mine[k].i >= 0) keep_lower(lowest[k], mine[k]);
}

// Each cell's lowest point's index (-1: none).
std::vector<std::int64_t> indices_of(const UnfilledVector<Lowest>& lowest) {
    std::vector<std::int64_t> index(lowest.size());
    const auto count = static_cast<std::ptrdiff_t>(lowest.size());
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t k = 0; k < count; ++k) index[k] = lowest[k].i;
    return index;
}

}  // namespace

std::vector<std::int64_t> lowest_in_cells(PointsView points, const CellLattice& lattice,
                                          const bool* take) {
    const auto cells = static_cast<std::size_t>(lattice.columns * lattice.rows);
    UnfilledVector<Lowest> lowest(cells, Lowest{0.0, -1});
    const auto n = static_cast<std::int64_t>(points.size);
    const Interruption interruption;
    auto cell_index = [&](std::int64_t i) {
        const auto [cx, cy] = cell_of(points, lattice, static_cast<std::size_t>(i));
        return cx * lattice.rows + cy;
    };
    constexpr std::uint32_t kSkipped = std::numeric_limits<std::uint32_t>::max();
    if (n <= 65536 || cells >= kSkipped) {
        for (std::int64_t i = 0; i < n; ++i) {
            if (i % 4096 == 0) interruption.check();
            if (take && !take[i]) continue;
            keep_lower(lowest[static_cast<std::size_t>(cell_index(i))],
                       Lowest{points.coord(static_cast<std::size_t>(i), 2) - lattice.z0, i});
        }
    } else if (cells <= points.size / 8) {
        // Few cells: each thread keeps the lowest of its share of the points in a grid of
        // its own, merged at the end (the merge costs little next to the points).
#pragma omp parallel firstprivate(interruption)
        {
            UnfilledVector<Lowest> mine(cells, Lowest{0.0, -1});
            bool stop = false;
            // By batches: the cells of a batch first, each prefetched, then the updates, so
            // that the cache misses of scattered points overlap instead of queueing.
            constexpr std::int64_t kBatch = 64;
#pragma omp for schedule(static) nowait
            for (std::int64_t batch = 0; batch < (n + kBatch - 1) / kBatch; ++batch) {
                const std::int64_t first = batch * kBatch, last = std::min(n, first + kBatch);
                if (first % 4096 == 0) stop = interruption.requested();
                if (stop) continue;
                std::uint32_t cell[kBatch];  // cells < kSkipped here
                for (std::int64_t i = first; i < last; ++i)
                    if (!take || take[i]) {
                        cell[i - first] = static_cast<std::uint32_t>(cell_index(i));
                        __builtin_prefetch(&mine[cell[i - first]], 1);
                    }
                for (std::int64_t i = first; i < last; ++i)
                    if (!take || take[i])
                        keep_lower(
                            mine[cell[i - first]],
                            Lowest{points.coord(static_cast<std::size_t>(i), 2) - lattice.z0, i});
            }
            merge_lowest(lowest, mine);
        }
    } else {
        // Many cells, where a grid per thread would cost more than the points: first
        // every point's cell, in parallel; then each thread scans them all for the points
        // of its own range of cells (no merge). Either way the lowest under a total order
        // does not depend on how the work is shared.
        // Not zero-filled: written in full below. A stop leaves entries unwritten, and
        // then every thread sees it (the flag is sticky) and leaves the scan before
        // reading any.
        UnfilledVector<std::uint32_t> cell(static_cast<std::size_t>(n));
#pragma omp parallel firstprivate(interruption)
        {
            bool stopped = false;
#pragma omp for schedule(static)
            for (std::int64_t i = 0; i < n; ++i) {
                if (i % 4096 == 0) stopped = stopped || interruption.requested();
                if (stopped) continue;
                cell[i] = take && !take[i] ? kSkipped : static_cast<std::uint32_t>(cell_index(i));
            }
#ifdef _OPENMP
            const auto threads = static_cast<std::size_t>(omp_get_num_threads());
            const auto thread = static_cast<std::size_t>(omp_get_thread_num());
#else
            const std::size_t threads = 1, thread = 0;
#endif
            const auto first = static_cast<std::uint32_t>(cells * thread / threads);
            const auto last = static_cast<std::uint32_t>(cells * (thread + 1) / threads);
            bool stop = false;
            // The updates land on scattered cells: each is fetched a few points ahead, so
            // that the cache misses overlap instead of queueing.
            constexpr std::int64_t kAhead = 32;  // prefetch distance, in points
            for (std::int64_t i = 0; i < n && !stop; ++i) {
                if (i % 65536 == 0 && (stop = interruption.requested())) break;
                if (i + kAhead < n) {
                    const std::uint32_t ahead = cell[i + kAhead];
                    if (ahead >= first && ahead < last) __builtin_prefetch(&lowest[ahead], 1);
                }
                const std::uint32_t c = cell[i];
                if (c >= first && c < last)  // kSkipped is never inside [first, last)
                    keep_lower(
                        lowest[c],
                        Lowest{points.coord(static_cast<std::size_t>(i), 2) - lattice.z0, i});
            }
        }
    }
    interruption.check();
    return indices_of(lowest);
}

std::vector<std::int64_t> lowest_in_cells(const std::uint32_t* cell, const double* z,
                                          const std::uint32_t* id, const unsigned char* take,
                                          std::size_t n, std::size_t cells) {
    UnfilledVector<Lowest> lowest(cells, Lowest{0.0, -1});
    const auto count = static_cast<std::ptrdiff_t>(n);
    const Interruption interruption;
#pragma omp parallel if (n > 65536) firstprivate(interruption)
    {
        // The entries come in place order, so their cells are read and written in runs.
        UnfilledVector<Lowest> mine(cells, Lowest{0.0, -1});
        bool stop = false;
#pragma omp for schedule(static) nowait
        for (std::ptrdiff_t s = 0; s < count; ++s) {
            if (s % 4096 == 0) stop = stop || interruption.requested();
            if (stop || !take[s]) continue;
            keep_lower(mine[cell[s]], Lowest{z[s], id[s]});
        }
        merge_lowest(lowest, mine);
    }
    interruption.check();
    return indices_of(lowest);
}

std::vector<std::uint32_t> raster_in_index_order(const std::vector<std::int64_t>& lowest,
                                                 std::size_t n) {
    std::vector<std::uint32_t> points;
    for (const std::int64_t b : lowest)
        if (b >= 0) points.push_back(static_cast<std::uint32_t>(b));
    return in_index_order(std::move(points), n);
}

std::vector<std::uint32_t> lowest_points(PointsView points, const CellLattice& lattice,
                                         const bool* take) {
    if (fits_raster(lattice, points.size))
        return raster_in_index_order(lowest_in_cells(points, lattice, take), points.size);
    // By (column, row) pairs: up to 2^40 cells per axis, more than one key holds.
    std::vector<CellKeyed> keyed;
    for (std::size_t i = 0; i < points.size; ++i)
        if (!take || take[i])
            keyed.emplace_back(cell_of(points, lattice, i), static_cast<std::uint32_t>(i));
    return in_index_order(lowest_by_sorting(std::move(keyed),
                                            [&](std::uint32_t a, std::uint32_t b) {
                                                return lower_in_cell(points, lattice.z0, a, b);
                                            }),
                          points.size);
}

}  // namespace pcl_rg
