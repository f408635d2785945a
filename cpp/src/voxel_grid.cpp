// Voxel-grid downsampling (PCL's pcl::VoxelGrid; the simplification step of seed 004,
// "point cloud simplification" by voxel centroids).
//
// Same result as PCL 1.13 where PCL works: one point per occupied voxel at the mean
// of its points, voxels ordered by (z, y, x) index. Differences, all deliberate:
//   * voxel indices are computed in float64 on the caller's coordinates, so tiles
//     and subsets agree; PCL multiplies float32 coordinates by a float32 1/leaf;
//   * keys are 64-bit (with an exact fallback beyond that), so any extent works
//     where PCL warns and returns its input unchanged once nx*ny*nz > 2^31 - 1;
//   * a stable radix sort keeps each voxel's points in index order, so centroids
//     (summed in float64) are the same on every run.
#include "pcl_rg/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

void validate(const VoxelGridParams& params) {
    for (const double leaf : params.leaf_size) check::real("leaf_size", leaf, check::positive());
    check::integer("min_points_per_voxel", params.min_points_per_voxel, check::at_least(1));
}

namespace {

struct AxisRange {
    std::int64_t low = 0;
    std::uint64_t cells = 1;  // number of voxel indices spanned on this axis
};

std::int64_t voxel_index(double coordinate, double leaf) {
    return static_cast<std::int64_t>(std::floor(coordinate / leaf));
}

}  // namespace

VoxelGridResult voxel_grid(PointsView points, const VoxelGridParams& params,
                           std::int64_t* voxel_of_point) {
    validate(params);
    VoxelGridResult result;
    const std::size_t n = points.size;
    if (n == 0) return result;
    if (n > std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument("points: at most 2^32 - 1 points are supported, got " +
                                    std::to_string(n));

    // Bounding box in one parallel pass.
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) lo[a] = hi[a] = points.coord(0, a);
#pragma omp parallel
    {
        double tlo[3] = {lo[0], lo[1], lo[2]}, thi[3] = {hi[0], hi[1], hi[2]};
#pragma omp for schedule(static) nowait
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
            for (int a = 0; a < 3; ++a) {
                tlo[a] = std::min(tlo[a], points.coord(i, a));
                thi[a] = std::max(thi[a], points.coord(i, a));
            }
#pragma omp critical
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], tlo[a]);
            hi[a] = std::max(hi[a], thi[a]);
        }
    }

    const Interruption interruption;  // polled between the steps (the radix sort: per pass)
    interruption.check_now();

    // Index range per axis; refuse indices that do not fit a signed 64-bit integer.
    std::array<AxisRange, 3> range;
    for (int a = 0; a < 3; ++a) {
        const double limit = 0x1p62;
        if (std::abs(lo[a] / params.leaf_size[a]) >= limit ||
            std::abs(hi[a] / params.leaf_size[a]) >= limit)
            throw std::invalid_argument(
                "leaf_size is too small for the coordinates: voxel indices "
                "exceed 2^62 on axis " +
                std::to_string(a));
        range[a].low = voxel_index(lo[a], params.leaf_size[a]);
        range[a].cells =
            static_cast<std::uint64_t>(voxel_index(hi[a], params.leaf_size[a]) - range[a].low) + 1;
    }

    // Linear key x + nx * (y + ny * z): ordering by key is PCL's (z, y, x) order.
    const unsigned __int128 total =
        static_cast<unsigned __int128>(range[0].cells) * range[1].cells * range[2].cells;
    const auto key_of = [&](std::size_t i) {
        std::uint64_t cell[3];
        for (int a = 0; a < 3; ++a)
            cell[a] = static_cast<std::uint64_t>(
                voxel_index(points.coord(i, a), params.leaf_size[a]) - range[a].low);
        return cell[0] + range[0].cells * (cell[1] + range[1].cells * cell[2]);
    };
    const int id_bits = std::max(1, bit_width(n - 1));
    const int key_bits = total <= std::numeric_limits<std::uint64_t>::max()
                             ? bit_width(static_cast<std::uint64_t>(total - 1))
                             : 65;

    std::vector<std::uint32_t> order(n);
    std::vector<std::uint64_t> keys(n);
    if (key_bits + id_bits <= 64) {
        // The common case: key above index in one word, sorted on the key bits only
        // (stable, so each voxel's points stay in index order).
        UnfilledVector<std::uint64_t> packed(n);  // written in full below
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
            packed[i] = key_of(i) << id_bits | static_cast<std::uint64_t>(i);
        radix_sort_bits(packed, id_bits, id_bits + key_bits);
        const std::uint64_t id_mask = (std::uint64_t{1} << id_bits) - 1;
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t s = 0; s < static_cast<std::ptrdiff_t>(n); ++s) {
            order[s] = static_cast<std::uint32_t>(packed[s] & id_mask);
            keys[s] = packed[s] >> id_bits;
        }
    } else if (key_bits <= 64) {
        // Keys too wide to share a word with the index: sort (key, index) pairs.
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
            keys[i] = key_of(i);
            order[i] = static_cast<std::uint32_t>(i);
        }
        radix_sort_pairs(keys, order, key_bits);
    } else {
        // Beyond 2^64 voxels (absurd extents or leaves): sort the index triples
        // directly, then number the distinct triples as keys.
        std::vector<std::array<std::int64_t, 3>> cell(n);
        for (std::size_t i = 0; i < n; ++i)
            for (int a = 0; a < 3; ++a)
                cell[i][a] = voxel_index(points.coord(i, a), params.leaf_size[a]);
        std::iota(order.begin(), order.end(), 0u);
        std::stable_sort(order.begin(), order.end(), [&](std::uint32_t p, std::uint32_t q) {
            return std::tie(cell[p][2], cell[p][1], cell[p][0]) <
                   std::tie(cell[q][2], cell[q][1], cell[q][0]);
        });
        std::uint64_t key = 0;
        for (std::size_t s = 0; s < n; ++s) {
            if (s > 0 && cell[order[s]] != cell[order[s - 1]]) ++key;
            keys[s] = key;
        }
    }

    interruption.check_now();

    // Runs of equal keys are voxels; keep those with enough points.
    std::vector<std::size_t> run_start;
    run_start.reserve(n / 4 + 1);
    for (std::size_t s = 0; s < n; ++s)
        if (s == 0 || keys[s] != keys[s - 1]) run_start.push_back(s);
    run_start.push_back(n);
    const std::size_t runs = run_start.size() - 1;
    std::vector<std::int64_t> row_of_run(runs);
    std::int64_t kept = 0;
    for (std::size_t r = 0; r < runs; ++r) {
        const auto size = static_cast<std::int64_t>(run_start[r + 1] - run_start[r]);
        row_of_run[r] = size >= params.min_points_per_voxel ? kept++ : -1;
    }
    interruption.check_now();

    result.centroids.assign(3 * static_cast<std::size_t>(kept), 0.0);
    result.counts.assign(static_cast<std::size_t>(kept), 0);
    // Blocks of runs, polled once each (the gathers miss the cache).
    constexpr std::size_t kBlock = 4096;
#pragma omp parallel for schedule(dynamic, 1) firstprivate(interruption)
    for (std::ptrdiff_t b = 0; b < static_cast<std::ptrdiff_t>((runs + kBlock - 1) / kBlock); ++b) {
        if (interruption.requested()) continue;
        const std::size_t block_end = std::min(runs, (static_cast<std::size_t>(b) + 1) * kBlock);
        for (std::size_t r = static_cast<std::size_t>(b) * kBlock; r < block_end; ++r) {
            const std::int64_t row = row_of_run[r];
            const std::size_t begin = run_start[r], end = run_start[r + 1];
            if (row >= 0) {
                // Sum offsets from the voxel's first point: exact for UTM-sized coordinates.
                const std::size_t first = order[begin];
                double sum[3] = {0.0, 0.0, 0.0};
                for (std::size_t s = begin; s < end; ++s)
                    for (int a = 0; a < 3; ++a)
                        sum[a] += points.coord(order[s], a) - points.coord(first, a);
                const double count = static_cast<double>(end - begin);
                for (int a = 0; a < 3; ++a)
                    result.centroids[3 * row + a] = points.coord(first, a) + sum[a] / count;
                result.counts[row] = static_cast<std::int64_t>(end - begin);
            }
            for (std::size_t s = begin; s < end; ++s) voxel_of_point[order[s]] = row;
        }
    }
    interruption.check();
    return result;
}

}  // namespace pcl_rg
