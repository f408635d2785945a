// Grid region-growing ground filter after the seed 000 blog post ("point cloud filtering
// based on region growing", reproducing "LiDAR point cloud data filtering based on
// regional growth" with the slope rule of G. Vosselman, "Slope based filtering of laser
// altimetry data", IAPRS 33(B3), 2000); the exact definition is algorithms.md section 3:
//   1. split the XY extent into blocks of dx by dy, anchored at multiples of dx, dy in
//      world coordinates so that tiles of a survey share one lattice;
//   2. grid the points into cells of bx by by from the same corner, so neighbours are
//      found in O(1) (cells line up across tiles too when dx, dy are whole multiples
//      of bx, by);
//   3. the seed of a block is its lowest point (ties: lowest index);
//   4. p, q of one block are linked when q lies in p's cell or one of the 8 around it and
//      |z_p - z_q| <= S * d_xy(p, q) + t; ground is the seed's connected component.
// Options measured on the ISPRS samples (benchmarks/studies/ground_isprs.py), each off in the
// definition: a robust seed (the lowest point whose component is large enough, against
// low outliers), growth across block borders, and Vosselman's slope filter as a
// pre-filter (a point far above a neighbour is an object point and never links),
// repeated against the previous pass's ground so low outliers stop masking terrain; and
// the final pass (final_pass.hpp) repeated on its own ground (final_passes), as
// TerraScan's ground routines are run again on their result: where the growth took an
// object point as the lowest ground point of a final cell, the first round may have
// found a lower ground point there, and the next round's TIN runs under the object.
//
// Exactness: links are symmetric, so the components do not depend on the visiting order
// and the NumPy reference (scipy connected_components) agrees point for point. Both
// take the same origin (x, y: lattice_floor(min, block size), the block corner at or
// below the minimum corner; z: the minimum) and evaluate every index and test in float64
// on l = p - origin with the same operations in the same order (CMake sets
// -ffp-contract=off, so no FMA changes a rounding). A tile and the merged cloud differ in
// the origin by whole blocks, so their indices of a point differ by one constant, except
// where float64 rounding of l / size decides (a point within a few ulps of a boundary).
//
// Speed: the points sorted into a flat CSR cell grid (dense, or sorted occupied cells
// when the extent is far larger than the cloud) by a parallel two-step counting sort
// (grid_cells.cpp), so a point's 3 x 3 cells are found in O(1), each cell's points
// rising in height; then the pre-filter in parallel over cells (it reads a cell's points
// from the lowest up and stops at the first within the tolerance of the point, which is
// exact: no later test in that cell can fail), and the link tests in parallel over
// blocks feeding a lock-free union-find (Afforest: most pairs are never tested); seeds
// are picked per block in parallel. The components, not a BFS from each seed, are
// computed because the robust seed needs their sizes and growth across blocks merges
// them. A pre-filter pass that only adds candidates (pass 2 always: pass 1 tested
// against every point) adds their links to the last pass's components instead of
// labelling anew. The final pass classifies the points in the grid's order, snapped
// while the grid is built, instead of sorting them once more; their final cells are
// found there too, so that its scans of every point read the grid's arrays in order.
#include "pcl_rg/grid_ground.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pcl_rg/check.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/final_pass.hpp"
#include "pcl_rg/grid_cells.hpp"
#include "pcl_rg/grid_links.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/point_spacing.hpp"
#include "pcl_rg/timer.hpp"

namespace pcl_rg {

void validate(const GridGroundParams& params) {
    static const char* const axis_name[2] = {"x", "y"};
    for (const double block : params.block_size)
        check::real("block_size", block, check::positive());
    if (params.cell_size) {
        const std::array<double, 2>& cell_size = *params.cell_size;
        for (const double cell : cell_size) check::real("cell_size", cell, check::positive());
        for (int a = 0; a < 2; ++a)
            check::relation(cell_size[a] <= params.block_size[a], "cell_size",
                            "<= block_size (" + check::format_value(params.block_size[a]) +
                                ") on " + axis_name[a],
                            cell_size[a]);
    }
    check::real("slope", params.slope, check::non_negative());
    check::real("height_tolerance", params.height_tolerance, check::non_negative());
    check::integer("min_seed_component", params.min_seed_component, check::at_least(1));
    check::real("outlier_depth", params.outlier_depth, check::non_negative());
    const auto max_passes = static_cast<double>(kGridMaxPasses);
    check::integer("filter_passes", params.filter_passes,
                   {0.0, std::nullopt, max_passes, std::nullopt});
    check::real("filter_slope", params.filter_slope, check::non_negative());
    check::real("filter_tolerance", params.filter_tolerance, check::non_negative());
    validate(final_pass_params(params));
    check::integer("final_passes", params.final_passes,
                   {1.0, std::nullopt, max_passes, std::nullopt});
}

namespace {

// Cell and block indices stay below this on every axis, so floor() results are exact
// integers and neighbour arithmetic cannot overflow.
constexpr double kMaxIndex = 0x1p40;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// Calls visit(c, around, k) for every cell c, in parallel, with the k cells of the
// 3 x 3 block around c (c included); polls for interruption.
template <class Visit>
void for_each_cell_and_cells_around(const CellGrid& grid, Visit visit) {
    const bool parallel = grid.p.size() >= kGridParallelMin;
    const auto cells = static_cast<std::ptrdiff_t>(grid.cells());
    const Interruption interruption;
#pragma omp parallel for schedule(dynamic, 256) if (parallel) firstprivate(interruption)
    for (std::ptrdiff_t c = 0; c < cells; ++c) {
        if (interruption.requested()) continue;
        std::ptrdiff_t around[9];
        const int k = grid.neighbours(static_cast<std::size_t>(c), around);
        visit(static_cast<std::size_t>(c), around, k);
    }
    interruption.check();
}

// Calls visit(s, around, k) for every point s, in parallel over cells, with the k cells
// of the 3 x 3 block around s's cell (its own included).
template <class Visit>
void for_each_point_and_cells_around(const CellGrid& grid, Visit visit) {
    for_each_cell_and_cells_around(grid, [&](std::size_t c, const std::ptrdiff_t* around, int k) {
        for (std::size_t s = grid.start[c]; s < grid.start[c + 1]; ++s) visit(s, around, k);
    });
}

// Pre-filter: candidate[s] = 0 when s lies higher than a point q of its 3 x 3 cells with
// against[q] set by more than filter_slope * d + filter_tolerance. Points with
// kept_by_all[s] set passed against every point, so they pass against any subset too and
// are not tested again (null: test everything).
void slope_filter(const CellGrid& grid, const GridGroundParams& params,
                  const std::vector<unsigned char>& against,
                  const std::vector<unsigned char>* kept_by_all,
                  std::vector<unsigned char>& candidate) {
    const double slope = params.filter_slope, tolerance = params.filter_tolerance;
    for_each_point_and_cells_around(grid, [&](std::size_t s, const std::ptrdiff_t* around, int k) {
        if (kept_by_all && (*kept_by_all)[s]) {
            candidate[s] = 1;
            return;
        }
        if (grid.copy_of_previous(s)) {  // decided just before, in this cell's loop
            candidate[s] = candidate[s - 1];
            return;
        }
        const double sx = grid.p[s].x, sy = grid.p[s].y, sz = grid.p[s].z;
        bool keep = true;
        for (int a = 0; a < k && keep; ++a) {
            const std::ptrdiff_t other = around[a];
            // A cell's points rise (grid_cells.cpp sorts them whenever the filter
            // runs), and a test can fail only when sz - z_q > tolerance, as
            // slope * d + tolerance >= tolerance holds after rounding too (rounding
            // is monotone): past the first q with sz - z_q <= tolerance none can fail.
            for (std::size_t q = grid.start[other]; q < grid.start[other + 1]; ++q) {
                if (!(sz - grid.p[q].z > tolerance)) break;
                if (!against[q]) continue;
                const double dx = sx - grid.p[q].x, dy = sy - grid.p[q].y;
                const double d = std::sqrt(dx * dx + dy * dy);
                if (sz - grid.p[q].z > slope * d + tolerance) {
                    keep = false;
                    break;
                }
            }
        }
        candidate[s] = keep ? 1 : 0;
    });
}

// Low outliers: outlier[s] = 1 when some point q at another position lies in the 3 x 3
// cells of s and every such q has z_q - z_s > depth (the reference's test, in the same
// arithmetic). Copies of s are not counted, so that duplicating a cloud changes nothing.
// Needs the cells by (z, x, y) (grid.by_height): a point's copies, all in its cell, are
// then one run, decided once, and the q with z_q - z_s <= depth come first in each cell,
// so each cell of the block is decided by its first point that is not a copy: a run
// costs its own length and 9 looks, not the whole block (thousands of copies of one
// point made this quadratic).
void low_outliers(const CellGrid& grid, double depth, std::vector<unsigned char>& outlier) {
    if (!grid.by_height) throw std::logic_error("low_outliers: cells not sorted by height");
    for_each_cell_and_cells_around(grid, [&](std::size_t c, const std::ptrdiff_t* around, int k) {
        std::size_t in_block = 0;  // points in the 3 x 3 cells
        for (int a = 0; a < k; ++a) in_block += grid.start[around[a] + 1] - grid.start[around[a]];
        const std::size_t end = grid.start[c + 1];
        for (std::size_t s = grid.start[c], copies_end; s < end; s = copies_end) {
            const Local& self = grid.p[s];
            copies_end = s + 1;
            while (copies_end < end && grid.copy_of_previous(copies_end)) ++copies_end;
            bool near = false;
            for (int a = 0; a < k && !near; ++a)
                for (std::size_t q = grid.start[around[a]]; q < grid.start[around[a] + 1]; ++q) {
                    if (q == s) {  // the run of s and its copies
                        q = copies_end - 1;
                        continue;
                    }
                    if (grid.p[q].z - self.z > depth) break;  // and so are all after it
                    near = true;
                    break;
                }
            const bool alone = in_block == copies_end - s;
            std::fill(outlier.begin() + static_cast<std::ptrdiff_t>(s),
                      outlier.begin() + static_cast<std::ptrdiff_t>(copies_end),
                      !alone && !near ? 1 : 0);
        }
    });
}

// Whether a pre-filter pass grows the last pass's components (`before`: its candidates)
// by the links of the points it adds (add_to_components) instead of labelling anew; both
// give the same components. Only when it loses none of them (always after pass
// 1, whose filter tested against every point), and while the added points have few
// cell-mates (points in their 3 x 3 cells): growth tests each added point against every
// cell-mate within reach, where labelling anew samples two links per point and tests
// all neighbours only outside the giant component. The two break even near 40
// cell-mates per point of the cloud (isprs_like_scene at 20 points per m^2, cells of
// 0.75-3 m; 3 m cells: 1.5 s anew, 3.4 s growing).
bool worth_growing(const CellGrid& grid, const std::vector<unsigned char>& candidate,
                   const std::vector<unsigned char>& before, bool parallel) {
    constexpr std::int64_t kCellMatesPerPoint = 32;
    const auto cells = static_cast<std::ptrdiff_t>(grid.cells());
    bool superset = true;
    std::int64_t cell_mates = 0;  // summed over the added points
#pragma omp parallel for schedule(static) reduction(&& : superset) reduction(+ : cell_mates) \
    if (parallel)
    for (std::ptrdiff_t c = 0; c < cells; ++c) {
        std::int64_t added = 0;
        for (std::size_t s = grid.start[c]; s < grid.start[c + 1]; ++s) {
            superset = superset && (!before[s] || candidate[s]);
            added += candidate[s] && !before[s];
        }
        if (added == 0) continue;
        std::ptrdiff_t around[9];
        const int k = grid.neighbours(static_cast<std::size_t>(c), around);
        for (int a = 0; a < k; ++a)
            cell_mates += added * static_cast<std::int64_t>(grid.start[around[a] + 1] -
                                                            grid.start[around[a]]);
    }
    return superset && cell_mates <= kCellMatesPerPoint * static_cast<std::int64_t>(grid.p.size());
}

// Per-position arrays that every pass of grow() overwrites in full before reading them:
// allocated once per call, as each fresh array of N entries costs a page fault per 4 KiB
// (about a tenth of grid_ground's time at 10M points went to faulting in fresh pages).
struct GrowScratch {
    UnfilledVector<std::uint32_t> root;
    // Component sizes: neighbouring positions mostly share a root, so each thread adds
    // runs of one root at a time (integer sums: the same whatever the sharing).
    UnfilledVector<std::atomic<std::uint32_t>> size;
    UnfilledVector<unsigned char> seeded;
};

// Steps 3 and 4 on the candidates: components of the link graph, one seed per block,
// ground[s] = 1 for the members of the seeds' components. `before` (or null): the
// candidates whose components `sets` already holds (add_to_components).
void grow(const CellGrid& grid, const GridGroundParams& params,
          const std::vector<unsigned char>& candidate, const std::vector<unsigned char>* before,
          ConcurrentDisjointSets& sets, GrowScratch& scratch, std::vector<unsigned char>& ground) {
    const std::size_t n = grid.p.size();
    const auto count = static_cast<std::ptrdiff_t>(n);
    const bool parallel = n >= kGridParallelMin;
    UnfilledVector<std::uint32_t>& root = scratch.root;
    if (before)
        add_to_components(grid, params, candidate, *before, sets);
    else
        label_components(grid, params, candidate, sets, root);
    poll_interrupt();
    // Both written in full by the first loop below. Atomics cannot be moved, so the
    // sizes' array is made once, not resized.
    root.resize(n);
    if (scratch.size.size() != n) scratch.size = UnfilledVector<std::atomic<std::uint32_t>>(n);
    UnfilledVector<std::atomic<std::uint32_t>>& size = scratch.size;
#pragma omp parallel if (parallel)
    {
#pragma omp for schedule(static)
        for (std::ptrdiff_t s = 0; s < count; ++s) {
            root[s] = sets.find(static_cast<std::uint32_t>(s));
            size[s].store(0, std::memory_order_relaxed);
        }
        std::uint32_t run_root = kNone, run = 0;
#pragma omp for schedule(static)
        for (std::ptrdiff_t s = 0; s < count; ++s) {
            if (!candidate[s]) continue;
            if (root[s] != run_root) {
                if (run) size[run_root].fetch_add(run, std::memory_order_relaxed);
                run_root = root[s], run = 0;
            }
            ++run;
        }
        if (run) size[run_root].fetch_add(run, std::memory_order_relaxed);
    }

    // Step 3, robust: the lowest candidate (ties: lowest input index) whose component
    // is large enough, else the lowest candidate.
    const auto min_size = static_cast<std::uint64_t>(params.min_seed_component);
    std::vector<std::uint32_t> seed(grid.blocks, kNone);
#pragma omp parallel for schedule(dynamic, 64) if (parallel)
    for (std::ptrdiff_t b = 0; b < static_cast<std::ptrdiff_t>(grid.blocks); ++b) {
        std::uint32_t lowest = kNone, lowest_large = kNone;
        const auto lower = [&](std::uint32_t s, std::uint32_t than) {
            return than == kNone || grid.p[s].z < grid.p[than].z ||
                   (grid.p[s].z == grid.p[than].z && grid.id[s] < grid.id[than]);
        };
        for (std::size_t m = grid.block_start[b]; m < grid.block_start[b + 1]; ++m) {
            const std::uint32_t s = grid.block_member[m];
            if (!candidate[s]) continue;
            if (lower(s, lowest)) lowest = s;
            if (size[root[s]].load(std::memory_order_relaxed) >= min_size && lower(s, lowest_large))
                lowest_large = s;
        }
        seed[b] = lowest_large != kNone ? lowest_large : lowest;
    }
    UnfilledVector<unsigned char>& seeded = scratch.seeded;  // zeroed by the threads, not by one
    seeded.resize(n);
#pragma omp parallel for schedule(static) if (parallel)
    for (std::ptrdiff_t s = 0; s < count; ++s) seeded[s] = 0;
    for (const std::uint32_t s : seed)
        if (s != kNone) seeded[root[s]] = 1;
#pragma omp parallel for schedule(guided) if (parallel)
    for (std::ptrdiff_t s = 0; s < count; ++s) ground[s] = candidate[s] && seeded[root[s]] ? 1 : 0;
}

}  // namespace

GridGroundParams with_spacing(const GridGroundParams& params, double spacing) {
    GridGroundParams resolved = params;
    if (!resolved.cell_size) {
        // Whole cells per block, so that cells line up with the blocks and across tiles.
        std::array<double, 2> cell_size{};
        for (int a = 0; a < 2; ++a)
            cell_size[a] =
                params.block_size[a] /
                std::max(1.0, std::ceil(params.block_size[a] / (kGridCellPerSpacing * spacing)));
        resolved.cell_size = cell_size;
    }
    return resolved;
}

void grid_ground(PointsView points, const GridGroundParams& given, bool* ground,
                 GridGroundStats* stats_out) {
    validate(given);
    const std::size_t n = points.size;
    GridGroundStats unwanted;
    GridGroundStats& stats = stats_out ? *stats_out : unwanted;
    // What an empty input reports: no spacing measured, the given cell size.
    stats = GridGroundStats{};
    stats.cell_size = given.cell_size.value_or(std::array<double, 2>{});
    if (n == 0) return;
    auto clock = std::chrono::steady_clock::now();
    // An unset cell size from the spacing of these points (measured only then).
    // The bounding box, scanned once for the spacing, the extent and the final pass.
    const std::array<double, 3> lower = local_origin(points);
    const std::array<double, 3> upper = upper_corner(points, lower);
    const double spacing = given.cell_size ? std::numeric_limits<double>::quiet_NaN()
                                           : spacing_or_one_metre(points, lower, upper);
    const GridGroundParams params = with_spacing(given, spacing);
    stats.point_spacing = spacing;
    stats.cell_size = *params.cell_size;
    check::indexable_by_int32(n);
    // Blocks and cells anchored at the world lattice of blocks: the block corner at or
    // below the minimum corner, so l >= 0 and every index is >= 0.
    std::array<double, 3> origin = lower;
    for (int a = 0; a < 2; ++a) origin[a] = lattice_floor(origin[a], params.block_size[a]);
    const bool parallel = n >= kGridParallelMin;
    // The largest x - origin[0] of the points: rounding is monotonic, so it is the
    // largest x minus origin[0].
    const std::array<double, 2> extent{upper[0] - origin[0], upper[1] - origin[1]};
    for (int a = 0; a < 2; ++a)
        if (!(extent[a] / (*params.cell_size)[a] < kMaxIndex)) {
            const std::string axis = a == 0 ? "x" : "y";
            if (given.cell_size)
                throw std::invalid_argument(
                    "cell_size is too small for the extent of points: more than 2^40 cells on " +
                    axis);
            // Unset, the cell follows the points: it is their extent that is too large.
            throw std::invalid_argument(
                "points: the extent on " + axis + " (" + check::format_value(extent[a]) +
                " m from the block corner) is more than 2^40 cells of " +
                check::format_value((*params.cell_size)[a]) +
                " m (cell_size unset: from the point spacing); a stray point far from the "
                "rest? drop it, or set cell_size");
        }

    // The final pass's frame (snap_frame), so that build_grid snaps the points for it:
    // the pass then classifies them in the grid's order, whose neighbours lie close
    // together as in a Morton order, instead of sorting them once more.
    // And each point's final cell, so that the pass's scans of every point read the
    // grid's arrays in order instead of the input with a cell found per point.
    const bool final_pass_runs = params.final_cell > 0.0;
    SnappedPoints snapped;
    std::optional<CellLattice> final_lattice;
    if (final_pass_runs) {
        check_final_pass_extent(lower, upper);
        snapped = snap_frame(lower, upper);
        const CellLattice lattice = final_cells(snapped, params.final_cell);
        if (final_cells_by_position(lattice, n)) final_lattice = lattice;
    }
    poll_interrupt();
    CellGrid grid = build_grid(points, params, origin, extent, final_pass_runs ? &snapped : nullptr,
                               final_lattice ? &*final_lattice : nullptr);
    stats.prepare_seconds = seconds_since(clock);
    clock = std::chrono::steady_clock::now();
    std::vector<unsigned char> candidate(n, 1), against(n, 1), result(n, 0), kept_by_all, before;
    std::vector<unsigned char> outlier(n, 0);
    const auto count = static_cast<std::ptrdiff_t>(n);
    if (params.outlier_depth > 0.0) {
        low_outliers(grid, params.outlier_depth, outlier);
#pragma omp parallel for schedule(static) if (parallel)
        for (std::ptrdiff_t s = 0; s < count; ++s) candidate[s] = against[s] = !outlier[s];
    }
    ConcurrentDisjointSets sets;  // reset by the first labelling
    GrowScratch scratch;
    const std::int64_t passes = std::max<std::int64_t>(params.filter_passes, 1);
    for (std::int64_t pass = 0; pass < passes; ++pass) {
        poll_interrupt();
        if (params.filter_passes > 0) stats.filter_passes_run = pass + 1;
        if (params.filter_passes > 0) {
            if (pass > 0) against.swap(result);  // test only against the last ground
            slope_filter(grid, params, against, pass > 0 ? &kept_by_all : nullptr, candidate);
#pragma omp parallel for schedule(static) if (parallel)
            for (std::ptrdiff_t s = 0; s < count; ++s) candidate[s] = candidate[s] && !outlier[s];
            if (pass == 0 && passes > 1) kept_by_all = candidate;
        }
        const bool grows = pass > 0 && worth_growing(grid, candidate, before, parallel);
        grow(grid, params, candidate, grows ? &before : nullptr, sets, scratch, result);
        // The ground the last pass tested against came back: every later pass would too.
        if (pass > 0 && result == against) break;
        if (pass + 1 < passes) before = candidate;
    }
#pragma omp parallel for schedule(guided) if (parallel)
    for (std::ptrdiff_t s = 0; s < count; ++s) ground[grid.id[s]] = result[s] != 0;
    stats.growth_seconds = seconds_since(clock);
    if (!final_pass_runs) return;
    clock = std::chrono::steady_clock::now();
    // The points as snap_points leaves them, but in the grid's order: z - lower[2] is
    // grid.p's z (the grid's origin has the same z).
    std::vector<std::uint32_t> outliers;  // input indices
    if (params.outlier_depth > 0.0)
        for (std::ptrdiff_t s = 0; s < count; ++s)
            if (outlier[s]) outliers.push_back(grid.id[s]);
    snapped.z.resize(n);
#pragma omp parallel for schedule(static) if (parallel)
    for (std::ptrdiff_t s = 0; s < count; ++s) snapped.z[s] = grid.p[s].z;
    snapped.order = std::move(grid.id);
    snapped.x = std::move(grid.snap_x);
    snapped.y = std::move(grid.snap_y);
    if (final_lattice) {
        snapped.cell = std::move(grid.final_cell);
        snapped.cell_size = params.final_cell;
    }
    grid = CellGrid{};
    std::vector<unsigned char> last_round;  // the ground a round started from
    // What a round leaves for the next, which then locates again only the points near
    // the triangles that are new (final_pass.hpp).
    FinalPassRounds rounds;
    for (std::int64_t round = 0; round < params.final_passes; ++round) {
        poll_interrupt();
        stats.final_passes_run = round + 1;
        if (round + 1 < params.final_passes) last_round.assign(ground, ground + n);
        // The final pass sees every point: not the low outliers.
        final_pass(points, final_pass_params(params), snapped, ground,
                   params.final_passes > 1 ? &rounds : nullptr, outliers);
        // A round that gives back the ground it started from: every later one would too.
        if (round + 1 < params.final_passes && std::equal(ground, ground + n, last_round.begin()))
            break;
    }
    stats.final_pass_seconds = seconds_since(clock);
}

}  // namespace pcl_rg
