// The points tin_ground's densification tests with densify_cell (see tin_densified.hpp).
#include "pcl_rg/tin_densified.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg {

std::vector<std::uint64_t> tin_densified(const SnappedPoints& snapped,
                                         const TinGroundParams& params) {
    if (!(params.densify_cell.value_or(0.0) > 0.0) || !(params.final_cell.value_or(0.0) > 0.0))
        return {};
    const double size = densify_cell(params);  // 0 for a subnormal final cell: refused below
    const std::array<double, 3>& origin = snapped.origin;
    const std::array<double, 3>& upper = snapped.upper;
    const double x0 = lattice_floor(origin[0], size), y0 = lattice_floor(origin[1], size);
    if (!((upper[0] - x0) / size < 0x1p40 && (upper[1] - y0) / size < 0x1p40))
        throw std::invalid_argument(
            "densify_cell is too small for the extent of points: its cells, of side "
            "min(densify_cell, final_cell / 2), would number more than 2^40 per axis");
    // A point's place is its TIN grid position, origin + (grid - 1) x quantum (exact but
    // for the sum's rounding, as the reference computes it): so the cells follow the
    // Morton order of the sorted points, and each update lands near the one before,
    // where the stored coordinates, read in input order, scattered them over the raster.
    const double q = snapped.frame.quantum;
    const auto column = [&](std::int32_t grid) {
        return floor_to_int((origin[0] + static_cast<double>(grid - 1) * q - x0) / size);
    };
    const auto row = [&](std::int32_t grid) {
        return floor_to_int((origin[1] + static_cast<double>(grid - 1) * q - y0) / size);
    };
    // Grid positions run from 1 to width - 1 (height - 1): the last cells are theirs.
    const CellLattice lattice{
        x0, y0, 0.0, size, column(snapped.frame.width - 1) + 1, row(snapped.frame.height - 1) + 1};
    const std::size_t n = snapped.order.size();
    // Point s before point t: lower z - origin z, then smaller input index.
    const auto lower = [&](std::size_t s, std::size_t t) {
        return snapped.z[s] < snapped.z[t] ||
               (snapped.z[s] == snapped.z[t] && snapped.order[s] < snapped.order[t]);
    };
    const Interruption interruption;
    std::vector<std::uint64_t> tested((n + 63) / 64, 0);
    if (fits_raster(lattice, n)) {
        constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
        std::vector<std::uint32_t> lowest(static_cast<std::size_t>(lattice.columns * lattice.rows),
                                          kNone);
        // Each thread takes a run of sorted positions, a compact patch of the Morton
        // curve, so only cells on the patches' rims are shared; a cell keeps the least of
        // its points under a total order by compare-and-swap, which no interleaving of the
        // updates changes.
        const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel if (count > 65536) firstprivate(interruption)
        {
            bool stopped = false;
#pragma omp for schedule(static)
            for (std::ptrdiff_t s = 0; s < count; ++s) {
                if (s % 4096 == 0) stopped = stopped || interruption.requested();
                if (stopped) continue;
                std::uint32_t* best = &lowest[static_cast<std::size_t>(
                    column(snapped.x[s]) * lattice.rows + row(snapped.y[s]))];
                std::uint32_t current = __atomic_load_n(best, __ATOMIC_RELAXED);
                while ((current == kNone || lower(static_cast<std::size_t>(s), current)) &&
                       !__atomic_compare_exchange_n(best, &current, static_cast<std::uint32_t>(s),
                                                    false, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
                }
            }
        }
        interruption.check();
        for (const std::uint32_t s : lowest)
            if (s != kNone) mark(tested, s);
    } else {
        // By (column, row) pairs: up to 2^40 cells per axis, more than one key holds.
        std::vector<CellKeyed> keyed(n);
        for (std::size_t s = 0; s < n; ++s)
            keyed[s] = {{column(snapped.x[s]), row(snapped.y[s])}, static_cast<std::uint32_t>(s)};
        interruption.check();
        for (const std::uint32_t s : lowest_by_sorting(std::move(keyed), lower)) mark(tested, s);
    }
    return tested;
}

}  // namespace pcl_rg
