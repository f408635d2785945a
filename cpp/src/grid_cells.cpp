// The cell grid of the grid ground filter (see grid_cells.hpp and grid_ground.cpp).
#include "pcl_rg/grid_cells.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

namespace {

// floor(local / size) as an integer: the quotient is below 2^40 in magnitude
// (grid_ground checks the extent), where floor_to_int is exact.
std::int64_t grid_index(double local, double size) { return floor_to_int(local / size); }

// The distinct values of `values`, ascending, as std::sort and std::unique give them:
// sorted in fixed chunks in parallel, each chunk's repeats dropped, then merged in pairs,
// polling for interruption between the steps (one std::sort of millions of cells held
// Ctrl-C off for seconds).
template <class T>
std::vector<T> sorted_distinct(std::vector<T> values, bool parallel) {
    const std::size_t n = values.size();
    const std::size_t chunks = parallel ? std::min<std::size_t>(64, n / 65536 + 1) : 1;
    std::vector<std::size_t> bound(chunks + 1), end(chunks);
    for (std::size_t c = 0; c <= chunks; ++c) bound[c] = n * c / chunks;
    const Interruption interruption;
    const auto chunk_count = static_cast<std::ptrdiff_t>(chunks);
#pragma omp parallel for schedule(dynamic, 1) if (parallel) firstprivate(interruption)
    for (std::ptrdiff_t c = 0; c < chunk_count; ++c) {
        if (interruption.requested()) continue;
        const auto first = values.begin() + static_cast<std::ptrdiff_t>(bound[c]);
        const auto last = values.begin() + static_cast<std::ptrdiff_t>(bound[c + 1]);
        std::sort(first, last);
        end[c] = static_cast<std::size_t>(std::unique(first, last) - values.begin());
    }
    interruption.check();
    // Each chunk's distinct values moved down to follow the previous chunk's.
    std::vector<std::size_t> start(chunks + 1, 0);
    for (std::size_t c = 0; c < chunks; ++c) {
        std::move(values.begin() + static_cast<std::ptrdiff_t>(bound[c]),
                  values.begin() + static_cast<std::ptrdiff_t>(end[c]),
                  values.begin() + static_cast<std::ptrdiff_t>(start[c]));
        start[c + 1] = start[c] + (end[c] - bound[c]);
    }
    values.resize(start[chunks]);
    for (std::size_t width = 1; width < chunks; width *= 2) {
        interruption.check_now();
        const auto pairs = static_cast<std::ptrdiff_t>((chunks + 2 * width - 1) / (2 * width));
#pragma omp parallel for schedule(dynamic, 1) if (parallel)
        for (std::ptrdiff_t k = 0; k < pairs; ++k) {
            const std::size_t left = static_cast<std::size_t>(k) * 2 * width;
            const std::size_t middle = std::min(left + width, chunks);
            const std::size_t right = std::min(left + 2 * width, chunks);
            std::inplace_merge(values.begin() + static_cast<std::ptrdiff_t>(start[left]),
                               values.begin() + static_cast<std::ptrdiff_t>(start[middle]),
                               values.begin() + static_cast<std::ptrdiff_t>(start[right]));
        }
    }
    values.erase(std::unique(values.begin(), values.end()), values.end());
    return values;
}

// out[i] = the position of values[i] in `sorted`, which holds it, in parallel; polled, as
// a binary search per point in millions of cells takes seconds.
template <class T>
void positions_in(const std::vector<T>& sorted, const std::vector<T>& values, std::uint32_t* out,
                  bool parallel) {
    const Interruption interruption;
    const auto count = static_cast<std::ptrdiff_t>(values.size());
#pragma omp parallel if (parallel) firstprivate(interruption)
    {
        bool stopped = false;
#pragma omp for schedule(static)
        for (std::ptrdiff_t i = 0; i < count; ++i) {
            if (i % 1024 == 0) stopped = stopped || interruption.requested();
            if (stopped) continue;
            out[i] = static_cast<std::uint32_t>(
                std::lower_bound(sorted.begin(), sorted.end(), values[i]) - sorted.begin());
        }
    }
    interruption.check();
}

}  // namespace

// Steps 1 and 2: block and cell of every point, and the counting sorts.
CellGrid build_grid(PointsView points, const GridGroundParams& params,
                    const std::array<double, 3>& origin, const std::array<double, 2>& extent,
                    const SnappedPoints* snap, const CellLattice* final_cells) {
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

    // Cell number, then block number, per input point (written in full before any read).
    UnfilledVector<std::uint32_t> key(n);
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
        grid.occupied = sorted_distinct(cell, parallel);
        cells = grid.occupied.size();
        positions_in(grid.occupied, cell, key.data(), parallel);
    }

    // The points by cell and, with the pre-filter or the low-outlier test, within a cell
    // by height, then x, then y (ties: input index): the pre-filter then meets a cell's
    // low points first and stops at the first one it cannot fail against, the links look
    // only at heights within reach, and copies of a point lie next to each other
    // (CellGrid::copy_of_previous: decided once by the pre-filter, the low-outlier test
    // and the links). Nothing else depends on the order within a cell (grid_ground.cpp);
    // without either it is the input order, but for crowded cells (kCrowdedCell), which
    // the links need by height. Two steps that each touch memory in order, not
    // a gather from the input (whose order may be random): (1) every point moves, in
    // input order, straight into the grid's arrays at its band of consecutive cells, a
    // stable counting sort per chunk of the input as spatial_order.cpp's radix pass
    // (counts per chunk, offsets band-major, chunk-minor); (2) each band, a few MB, is
    // sorted into its cells on its own through a per-thread buffer.
    // No copy of the cloud beside the grid's arrays: the buffer holds one band. The
    // chunk count depends on n only, and every step is a stable sort or a sort under a
    // total order: the layout does not depend on the threads.
    grid.by_height = params.filter_passes > 0 || params.outlier_depth > 0.0;
    // Bands of about kBandPoints points on average: few enough that the scatter writes to
    // few places at once (2,048 cells a band, 1,221 bands for 10M points, took 0.27 s
    // there, TLB and cache misses; 77 bands 0.15 s), small enough that a band's buffer
    // stays in the cache. Depends on n and the cell count only.
    constexpr std::size_t kBandPoints = 65536;
    const std::size_t wanted_bands = std::max<std::size_t>(1, n / kBandPoints);
    int band_shift = 0;
    while (((cells - 1) >> band_shift) + 1 > wanted_bands) ++band_shift;
    const std::size_t bands = ((cells - 1) >> band_shift) + 1;
    const auto chunks =
        static_cast<std::ptrdiff_t>(parallel ? std::min<std::size_t>(64, n / 65536 + 1) : 1);
    const auto chunk_begin = [&](std::ptrdiff_t c) {
        return static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(c) /
                                           static_cast<std::size_t>(chunks));
    };
    std::vector<std::size_t> offsets(static_cast<std::size_t>(chunks) * bands, 0);
    std::vector<std::size_t> band_start(bands + 1);
    grid.start.resize(cells + 1);
    grid.start[cells] = n;
    grid.id.resize(n);
    grid.p.resize(n);
    grid.cell.resize(n);
    if (snap) {
        grid.snap_x.resize(n);
        grid.snap_y.resize(n);
    }
    if (final_cells) grid.final_cell.resize(n);
    const CellOf final_cell_of(final_cells ? *final_cells : CellLattice{});
    const Interruption interruption;
    interruption.check_now();
#pragma omp parallel if (parallel) firstprivate(interruption)
    {
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < chunks; ++c) {
            std::size_t* counts = &offsets[static_cast<std::size_t>(c) * bands];
            for (std::ptrdiff_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i)
                ++counts[key[i] >> band_shift];
        }
#pragma omp single
        {
            std::size_t running = 0;
            for (std::size_t band = 0; band < bands; ++band) {
                band_start[band] = running;
                for (std::ptrdiff_t c = 0; c < chunks; ++c) {
                    std::size_t& slot = offsets[static_cast<std::size_t>(c) * bands + band];
                    const std::size_t size = slot;
                    slot = running;
                    running += size;
                }
            }
            band_start[bands] = running;
        }
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < chunks; ++c) {
            std::size_t* next = &offsets[static_cast<std::size_t>(c) * bands];
            for (std::ptrdiff_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i) {
                if (i % 4096 == 0 && interruption.requested()) break;
                const std::size_t s = next[key[i] >> band_shift]++;
                grid.p[s] = {points.coord(i, 0) - origin[0], points.coord(i, 1) - origin[1],
                             points.coord(i, 2) - origin[2]};
                grid.id[s] = static_cast<std::uint32_t>(i);
                grid.cell[s] = key[i];
                if (snap) {
                    grid.snap_x[s] = snap->grid_x(points, static_cast<std::size_t>(i));
                    grid.snap_y[s] = snap->grid_y(points, static_cast<std::size_t>(i));
                }
                if (final_cells) {
                    const auto [cx, cy] = final_cell_of(points, static_cast<std::size_t>(i));
                    grid.final_cell[s] = static_cast<std::uint32_t>(cx * final_cells->rows + cy);
                }
            }
        }
    }
    interruption.check();
    // The cell numbers' array becomes the block numbers' (written in full below): one
    // fresh array of N fewer to fault in.
    grid.block = std::move(key);
    // Per band, its crowded cells and their boxes (written by the band's thread).
    std::vector<std::vector<std::pair<std::size_t, CellBox>>> crowded_in_band(bands);
#pragma omp parallel if (parallel) firstprivate(interruption)
    {
        // A point's cell is not carried: the cells' runs give it back, and a record with
        // the final pass's cell stays at 40 bytes.
        struct Record {
            Local p;
            std::uint32_t id;
            std::int32_t snap_x, snap_y;
            std::uint32_t final_cell;
        };
        std::vector<std::size_t> fill;
        std::vector<Record> sorted;
#pragma omp for schedule(dynamic, 4)
        for (std::ptrdiff_t band = 0; band < static_cast<std::ptrdiff_t>(bands); ++band) {
            if (interruption.requested()) continue;
            const std::size_t first_cell = static_cast<std::size_t>(band) << band_shift;
            const std::size_t band_cells =
                std::min(cells, static_cast<std::size_t>(band + 1) << band_shift) - first_cell;
            const std::size_t begin = band_start[band], end = band_start[band + 1];
            fill.assign(band_cells + 1, 0);
            for (std::size_t s = begin; s < end; ++s) ++fill[grid.cell[s] - first_cell + 1];
            for (std::size_t k = 0; k < band_cells; ++k) {
                fill[k + 1] += fill[k];
                grid.start[first_cell + k] = begin + fill[k];
            }
            sorted.resize(end - begin);
            for (std::size_t s = begin; s < end; ++s) {
                Record& r = sorted[fill[grid.cell[s] - first_cell]++];
                r.p = grid.p[s];
                r.id = grid.id[s];
                if (snap) r.snap_x = grid.snap_x[s], r.snap_y = grid.snap_y[s];
                if (final_cells) r.final_cell = grid.final_cell[s];
            }
            for (std::size_t k = 0, from = 0; k < band_cells; from = fill[k++]) {
                const std::size_t size = fill[k] - from;
                if (size > kCrowdedCell) {
                    CellBox box{sorted[from].p.x, sorted[from].p.x, sorted[from].p.y,
                                sorted[from].p.y};
                    for (std::size_t r = from + 1; r < fill[k]; ++r) {
                        box.x0 = std::min(box.x0, sorted[r].p.x);
                        box.x1 = std::max(box.x1, sorted[r].p.x);
                        box.y0 = std::min(box.y0, sorted[r].p.y);
                        box.y1 = std::max(box.y1, sorted[r].p.y);
                    }
                    crowded_in_band[band].emplace_back(first_cell + k, box);
                }
                if (size > 1 && (grid.by_height || size > kCrowdedCell))
                    std::sort(sorted.begin() + static_cast<std::ptrdiff_t>(from),
                              sorted.begin() + static_cast<std::ptrdiff_t>(fill[k]),
                              [](const Record& a, const Record& b) {
                                  if (a.p.z != b.p.z) return a.p.z < b.p.z;
                                  if (a.p.x != b.p.x) return a.p.x < b.p.x;
                                  if (a.p.y != b.p.y) return a.p.y < b.p.y;
                                  return a.id < b.id;
                              });
            }
            for (std::size_t k = 0; k < end - begin; ++k) {
                const Record& r = sorted[k];
                grid.p[begin + k] = r.p;
                grid.id[begin + k] = r.id;
                if (snap) {
                    grid.snap_x[begin + k] = r.snap_x;
                    grid.snap_y[begin + k] = r.snap_y;
                }
                if (final_cells) grid.final_cell[begin + k] = r.final_cell;
            }
            for (std::size_t k = 0, from = 0; k < band_cells; from = fill[k++])
                std::fill(grid.cell.begin() + static_cast<std::ptrdiff_t>(begin + from),
                          grid.cell.begin() + static_cast<std::ptrdiff_t>(begin + fill[k]),
                          static_cast<std::uint32_t>(first_cell + k));
        }
    }
    interruption.check();
    for (const auto& band : crowded_in_band)  // bands in order: the cells ascend
        for (const auto& [c, box] : band) {
            grid.crowded.push_back(c);
            grid.crowded_box.push_back(box);
        }

    // Blocks, numbered densely unless the block grid is far larger than the cloud.
    const std::int64_t nbx = grid_index(extent[0], params.block_size[0]) + 1;
    const std::int64_t nby = grid_index(extent[1], params.block_size[1]) + 1;
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
        const std::vector<std::pair<std::int64_t, std::int64_t>> occupied =
            sorted_distinct(block, parallel);
        grid.blocks = occupied.size();
        positions_in(occupied, block, grid.block.data(), parallel);
    }
    // Members of each block in position order: a stable counting sort as above, per
    // chunk of positions (fewer chunks when there are many blocks, to bound the counts).
    interruption.check_now();
    const auto block_chunks = static_cast<std::ptrdiff_t>(
        parallel ? std::max<std::size_t>(
                       1, std::min({std::size_t{64}, n / 65536 + 1, 2 * n / (grid.blocks + 1)}))
                 : 1);
    const auto block_chunk_begin = [&](std::ptrdiff_t c) {
        return static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(c) /
                                           static_cast<std::size_t>(block_chunks));
    };
    offsets.assign(static_cast<std::size_t>(block_chunks) * grid.blocks, 0);
    grid.block_start.assign(grid.blocks + 1, 0);
    grid.block_member.resize(n);
#pragma omp parallel if (parallel) firstprivate(interruption)
    {
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < block_chunks; ++c) {
            std::size_t* counts = &offsets[static_cast<std::size_t>(c) * grid.blocks];
            for (std::ptrdiff_t s = block_chunk_begin(c); s < block_chunk_begin(c + 1); ++s)
                ++counts[grid.block[s]];
        }
#pragma omp single
        {
            std::size_t running = 0;
            for (std::size_t block = 0; block < grid.blocks; ++block) {
                grid.block_start[block] = running;
                for (std::ptrdiff_t c = 0; c < block_chunks; ++c) {
                    std::size_t& slot = offsets[static_cast<std::size_t>(c) * grid.blocks + block];
                    const std::size_t size = slot;
                    slot = running;
                    running += size;
                }
            }
            grid.block_start[grid.blocks] = running;
        }
#pragma omp for schedule(static)
        for (std::ptrdiff_t c = 0; c < block_chunks; ++c) {
            std::size_t* next = &offsets[static_cast<std::size_t>(c) * grid.blocks];
            for (std::ptrdiff_t s = block_chunk_begin(c); s < block_chunk_begin(c + 1); ++s)
                grid.block_member[next[grid.block[s]]++] = static_cast<std::uint32_t>(s);
        }
    }
    interruption.check();
    return grid;
}

}  // namespace pcl_rg
