// Progressive TIN densification: Axelsson, "DEM generation from laser scanner data
// using adaptive TIN models", International Archives of Photogrammetry and Remote
// Sensing XXXIII-B4, 2000; with the parameters of LiDAR360's "Classify Ground Points"
// (seed 002), which follows Zhao et al., "Improved progressive TIN densification
// filtering algorithm for airborne LiDAR data in forested areas", ISPRS J.
// Photogrammetry and Remote Sensing 117, 2016. Definition: docs/algorithms.md section 4.
//
// The steps, and the choices that make the result exact and order-independent (the
// NumPy reference in pcl_rg/reference/tin_ground.py and _tin_seeds.py does the same):
//   1. XY is snapped to the integer grid of a GridFrame over the extent (delaunay.hpp;
//      quantum <= extent / 2^29, micrometres for kilometre tiles), in which the TIN's
//      predicates are exact. Heights stay float64 relative to the minimum corner.
//   2. Seeds: the lowest point (ties: smallest index) of each max_building_size cell,
//      cells anchored at multiples of max_building_size in world coordinates
//      (lattice_floor, points.hpp), so that tiles of a survey share one lattice. The
//      four corners of the extent, one grid step outside it, are virtual vertices at
//      the height of their nearest seed (exact squared grid distance, ties: the lowest,
//      so the height does not depend on the order of the points), so every point lies
//      inside the TIN; with border_vertices, so are points along the box's long sides
//      (ground_tin.hpp: border_points, nearest_to_border), inserted on the box's border
//      before the seeds. Seeds are ground; of seeds sharing an XY, the smallest index is
//      inserted.
//   3. Each iteration tests every unclassified point against the TIN as it was when
//      the iteration began, in the triangle holding p + (eps, eps^2) (delaunay.hpp):
//        d = distance from p to the triangle's plane,
//        accepted when d <= iteration_distance, d <= sin(limit) * |p - v_i| for each
//        vertex (that is asin(d / |p - v_i|) <= limit), limit = iteration_angle, times
//        L / reduce_angle_edge when the longest XY edge L is shorter than
//        reduce_angle_edge, and none of the triangles (p, v_i, v_j) with non-zero XY
//        area is steeper than max_terrain_angle (the triangles p would form if
//        inserted into its triangle; a steep point stays unclassified for now).
//      In a triangle with L < stop_edge every accepted point becomes ground, none is
//      inserted. In any other triangle only the accepted point with the smallest d
//      (ties: smallest index) becomes ground and is inserted, as Axelsson adds one
//      point per facet per iteration; the other accepted points are tested again in
//      the next iteration, against the densified TIN. Then the chosen points are
//      inserted (a point equal in XY to a vertex is ground but not inserted).
//   4. Stop when an iteration adds no ground point.
// The floating-point formulas take each triangle's vertices counter-clockwise from the
// lexicographically smallest (x, y), so the result does not depend on how a triangle is
// stored; sin/cos come from the C library, as Python's math module does.
//
// Improvements, each off in LiDAR360's set and, but for opening_rank, on in the defaults,
// for data such as the ISPRS samples:
//   * near_vertex_distance: |p - v_i| counts as at least this in the angle test, so a
//     point (nearly) above a vertex, common where XY is coarse or repeated, is judged
//     by its distance to the plane rather than an angle of ~90 deg minus the slope.
//   * seed_cell: seeds are the lowest points of small cells lying within
//     seed_tolerance of the grey opening of those heights by a max_building_size
//     window (Zhao et al.'s morphological seeds): dense on open terrain, none on roofs.
//   * outlier_depth: before the opening, cells far below the 9th lowest of their 5 x 5
//     window are dropped, repeatedly, so clusters of low outliers give no seeds.
//   * opening_rank: the opening's erosion takes the opening_rank-th lowest cell of each
//     window (rank-order morphology), so a few low cells cannot drag the opened surface
//     down, and drop the seeds, across a whole window.
//   * border_vertices: virtual vertices along the box's long sides too, so that along a
//     corridor the border triangles do not reach to corners kilometres away, across the
//     strip by the uphill side that the seeds' clipped opening leaves without seeds.
//   * final_cell: a final pass (final_pass.cpp, shared with grid_ground) classifies every
//     point again by its height above a TIN of the lowest ground point of each cell.
//   * densify_cell: with the final pass, only the lowest point of each densify_cell cell
//     (at most final_cell / 2; ties: smallest index, as the seeds) is tested in step 3
//     (tin_densified.cpp); the final pass classifies every point.
//
// Grids and tiles: the grids that decide which points are seeds are anchored on the
// world lattice of the seed cells (seed_cell when > 0, else max_building_size): the
// cells themselves, and the opening's and the outlier test's windows, which are counted
// in those cells around each cell (clipping them at the raster's border is the same as
// empty cells there). So a tile cut at a seed-cell boundary gets the seed cells of the
// merged cloud, and the same seeds away from the cut (the windows of cells near it lose
// the cells on the other side). Left at the minimum corner: the snapping frame of step
// 1, whose quantum depends on the extent, so no anchor could make a tile's the merged
// cloud's (it moves a point by at most half a quantum, micrometres, and changes a
// verdict only where that rounding decides it), and the Morton order built on it, which
// speeds up point location and orders the insertions, which changes no result: the
// in-circle test breaks the ties of co-circular vertices by their coordinates
// (incircle_perturbed, delaunay.hpp), so the TIN is the same in any order. The TIN
// itself spans the whole input, so a tile's result differs from the merged cloud's near
// the tile's border whatever the grids.
//
// Speed: points are processed in Morton order; each unclassified point sits in a list
// of the triangle slot it was last tested in, and only the points of slots an
// insertion rewrote (Delaunay::touched) and the accepted-but-not-chosen ones are
// tested again: a failed test against a triangle that is still there would fail
// again. The points to test are gathered through a bitmap, so each iteration tests
// them in Morton order (neighbouring points and triangles one after another). Location
// walks from the point's previous slot; tests run in parallel, write only their own
// point's entries and, by atomic operations whose outcome does not depend on their
// order, push a rejected point onto its slot's list and pick each triangle's chosen
// point (a minimum under a total order); insertions are serial in Morton order, so the
// result does not depend on the number of threads. The TIN's arrays are reserved for
// every point up front (no copying as they grow).
#include "pcl_rg/tin_ground.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "ground_tin.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/final_pass.hpp"
#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/point_spacing.hpp"
#include "pcl_rg/timer.hpp"
#include "pcl_rg/tin_densified.hpp"
#include "pcl_rg/tin_seeds.hpp"
#include "pcl_rg/unfilled_vector.hpp"
#include "tin_acceptance.hpp"
#include "tin_idle_iterations.hpp"

namespace pcl_rg {

namespace {

using namespace tin_acceptance;  // Limits, Facet, Verdict, facet, evaluate, kDegToRad

}  // namespace

TinGroundStats tin_ground(PointsView points, const TinGroundParams& given, bool* ground) {
    validate(given);
    TinGroundStats stats;
    const std::size_t n = points.size;
    if (n == 0) return stats;
    auto clock = std::chrono::steady_clock::now();
    // The unset lengths from the spacing of these points (measured only when needed).
    // The bounding box, scanned once for the spacing, the frame and the final pass.
    const std::array<double, 3> origin = local_origin(points);
    const std::array<double, 3> upper = upper_corner(points, origin);
    stats.point_spacing = std::numeric_limits<double>::quiet_NaN();
    // densify_cell alone needs none without a final pass, which switches it off.
    if (!given.stop_edge || !given.near_vertex_distance || !given.seed_cell || !given.final_cell ||
        (!given.densify_cell && *given.final_cell > 0.0))
        stats.point_spacing = spacing_or_one_metre(points, origin, upper);
    const TinGroundParams params = with_spacing(given, stats.point_spacing);
    stats.stop_edge = *params.stop_edge;
    stats.near_vertex_distance = *params.near_vertex_distance;
    stats.seed_cell = *params.seed_cell;
    stats.final_cell = *params.final_cell;
    stats.densify_cell = densify_cell(params);
    if (n < 3)
        throw std::invalid_argument("points must hold at least 3 points for a TIN, got " +
                                    std::to_string(n));
    if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) - 8)
        throw std::invalid_argument("points: at most 2^31 - 9 points are supported, got " +
                                    std::to_string(n));
    std::fill(ground, ground + n, false);
    const Interruption interruption;  // polled between the steps and in the long loops

    // --- 1. local frame and integer grid -------------------------------------------
    const double ex = upper[0] - origin[0], ey = upper[1] - origin[1];
    if (!std::isfinite(upper[2] - origin[2]))
        throw std::invalid_argument("points: the z extent is too large (not finite in float64)");
    if (!std::isfinite(ex) || !std::isfinite(ey))
        throw std::invalid_argument("points: the XY extent is too large (not finite in float64)");
    // The points snapped and in Morton order, by sorted position (the final pass reuses
    // them): neighbours in XY are neighbours in memory.
    const SnappedPoints snapped = snap_points(points, origin, upper);
    const GridFrame& frame = snapped.frame;
    const UnfilledVector<std::uint32_t>& order = snapped.order;
    const UnfilledVector<std::int32_t>&sx = snapped.x, &sy = snapped.y;
    const UnfilledVector<double>& sz = snapped.z;

    // A TIN needs three points not on one line (exact test on the grid).
    {
        std::size_t second = 0;
        while (second < n && sx[second] == sx[0] && sy[second] == sy[0]) ++second;
        bool spread = false;
        for (std::size_t k = second + 1; k < n && second < n && !spread; ++k)
            spread = orient2d(sx[0], sy[0], sx[second], sy[second], sx[k], sy[k]) != 0;
        if (!spread)
            throw std::invalid_argument(
                "points are all collinear in XY (or fewer than 3 distinct XY positions on "
                "the TIN's grid, whose step is the power of two at or above the XY extent / "
                "2^29: " +
                check::format_value(frame.quantum) +
                " m here; points far from the rest coarsen it): a TIN needs 3 points not "
                "on one line");
    }
    // With border_vertices, the virtual vertices along the box's long sides (their
    // heights come with the seeds): the TIN's ids must hold them too.
    std::vector<ground_tin::GridPoint> border;
    if (params.border_vertices)
        border = ground_tin::border_points(frame, ex, ey,
                                           std::max(params.max_building_size, std::min(ex, ey)));
    if (n + border.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) - 8)
        throw std::invalid_argument("points: at most 2^31 - 9 points less the " +
                                    std::to_string(border.size()) +
                                    " border vertices of this box are supported, got " +
                                    std::to_string(n) + " (or set border_vertices to false)");
    interruption.check_now();

    // --- 2. seeds: lowest point per max_building_size cell --------------------------
    std::vector<std::uint32_t> seeds;
    try {
        seeds = tin_seeds(points, params, origin, upper);
    } catch (const std::invalid_argument& error) {
        if (given.seed_cell) throw;
        throw unset_seed_cell_error(error, stats.point_spacing);
    }
    interruption.check_now();
    stats.seeds = static_cast<std::int64_t>(seeds.size());
    for (const std::uint32_t s : seeds) ground[s] = true;
    // Per sorted position: whether the point is ground (so far: a seed).
    const auto count = static_cast<std::ptrdiff_t>(n);
    UnfilledVector<std::uint8_t> is_ground(n);  // written in full below
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t s = 0; s < count; ++s) is_ground[s] = ground[order[s]];
    std::vector<std::int32_t> seed_x(seeds.size()), seed_y(seeds.size());
    const auto seed_count = static_cast<std::ptrdiff_t>(seeds.size());
#pragma omp parallel for schedule(static) if (seed_count > 65536)
    for (std::ptrdiff_t k = 0; k < seed_count; ++k) {  // scattered reads, distinct writes
        seed_x[k] = snapped.grid_x(points, seeds[k]);
        seed_y[k] = snapped.grid_y(points, seeds[k]);
    }

    // The virtual vertices' heights, each its nearest seed's (exact squared grid distance,
    // ties: the lowest, then the smallest index): the corners', one grid step outside the
    // extent, then, with border_vertices, those along the box's long sides.
    UnfilledVector<double> vz(4);  // each vertex's height, written as it comes in
    vz.reserve(n + 4 + border.size());
    std::vector<double> border_z;
    {
        const auto gx = [&](std::size_t k) { return seed_x[k]; };
        const auto gy = [&](std::size_t k) { return seed_y[k]; };
        const auto z = [&](std::size_t k) { return points.coord(seeds[k], 2); };
        const auto index = [&](std::size_t k) { return seeds[k]; };
        const std::array<std::size_t, 4> corners =
            ground_tin::nearest_to_corners(frame, seeds.size(), gx, gy, z, index);
        for (int c = 0; c < 4; ++c) vz[c] = z(corners[c]) - origin[2];
        for (const std::size_t k :
             ground_tin::nearest_to_border(frame, border, seeds.size(), gx, gy, z, index))
            border_z.push_back(z(k) - origin[2]);
    }
    stats.prepare_seconds = seconds_since(clock);
    clock = std::chrono::steady_clock::now();

    // --- 3. initial TIN: virtual corners, border vertices, then the seeds --------------
    Delaunay tin(frame.width, frame.height);
    tin.reserve(n + 4 + border.size());  // every point may become a vertex: the arrays never move
    for (std::size_t b = 0, last = 0; b < border.size(); ++b) {  // each next to the last
        bool inserted = false;
        const std::int32_t v =
            tin.insert_on_border(border[b].x, border[b].y, tin.vertex_triangle(last), &inserted);
        if (inserted) vz.push_back(border_z[b]);
        last = static_cast<std::size_t>(v);
    }
    // Inserts the points at sorted positions `batch` (in sorted order) into the TIN and
    // gives each new vertex its point's height: of points of one grid XY, which share a
    // vertex, the first in that order, which keeps them in index order (a stable sort by
    // position), so the smallest index; a point on an older vertex adds nothing.
    // start_of(sorted position): -1, or the triangle holding the point now (its test's,
    // as Delaunay::insert_batch requires).
    std::vector<std::int32_t> batch_x, batch_y, batch_start, batch_vertex;
    const auto insert_points = [&](const auto& batch, const auto& start_of) {
        const std::size_t m = batch.size();
        batch_x.resize(m), batch_y.resize(m), batch_start.resize(m), batch_vertex.resize(m);
        for (std::size_t k = 0; k < m; ++k) {
            const std::uint32_t s = batch[k];
            batch_x[k] = sx[s], batch_y[k] = sy[s];
            batch_start[k] = start_of(s);
        }
        const auto older = static_cast<std::int32_t>(tin.vertex_count());
        tin.insert_batch(batch_x.data(), batch_y.data(), batch_start.data(), m,
                         batch_vertex.data());
        vz.resize(tin.vertex_count(), 0.0);
        for (std::size_t k = m; k-- > 0;)  // backwards: the first point of a vertex wins
            if (batch_vertex[k] >= older) vz[batch_vertex[k]] = sz[batch[k]];
    };
    {
        UnfilledVector<std::uint32_t> seeded;
        keep_in_order(
            n, [&](std::size_t s) { return is_ground[s] != 0; },
            [&](std::size_t m) { seeded.resize(m); },
            [&](std::size_t k, std::size_t s) { seeded[k] = static_cast<std::uint32_t>(s); });
        insert_points(seeded, [](std::uint32_t) { return std::int32_t{-1}; });
    }
    stats.triangulation_seconds += seconds_since(clock);

    // --- 4. densification -------------------------------------------------------------
    clock = std::chrono::steady_clock::now();  // its set-up counts as preparation
    const Limits lim{frame.quantum,
                     params.iteration_distance,
                     params.iteration_angle,
                     params.reduce_angle_edge,
                     *params.stop_edge,
                     *params.near_vertex_distance,
                     std::sin(params.iteration_angle * kDegToRad),
                     std::cos(params.max_terrain_angle * kDegToRad)};
    // Per sorted position: ground flag, the triangle slot the point was last located in,
    // its verdict there, and its place in the singly linked list of the unclassified
    // points of that slot. A point is tested again only when its slot was rewritten
    // (its triangle is gone) or it was accepted but not chosen: a failed test against
    // a triangle that is still there would fail again. The points to test are gathered
    // through a bitmap, so they stay in sorted (Morton) order: consecutive tests read
    // neighbouring points and triangles, and the chosen points come out sorted.
    UnfilledVector<std::uint8_t> accepted, stop;
    UnfilledVector<std::int32_t> tri, next;
    UnfilledVector<double> dist;
    // Filled side by side: each fill writes over fresh pages, serially.
#pragma omp parallel sections
    {
#pragma omp section
        accepted.assign(n, 0), stop.assign(n, 0), next.assign(n, -1);
#pragma omp section
        tri.assign(n, -1);
#pragma omp section
        dist.assign(n, 0.0);
    }
    std::vector<std::uint64_t> retest((n + 63) / 64, 0);       // bit s: test point s again
    std::vector<std::uint64_t> chosen_bits((n + 63) / 64, 0);  // bit s: insert point s
    std::vector<std::int32_t> head;              // per triangle slot: first unclassified point
    std::vector<std::int32_t> best_of;           // per triangle slot: chosen point
    UnfilledVector<std::uint32_t> work, chosen;  // filled in full when sized: not zeroed first
    std::vector<std::uint32_t> waiting;          // skip_idle_iterations's
    std::int64_t idle_iterations = 0;            // iterations of the definition it did
    // The first work: every point that is not a seed (with densify_cell, of those the
    // lowest of their densify cells only), in sorted order.
    // Bit s (sorted position): tested; empty: every point.
    const std::vector<std::uint64_t> densified = tin_densified(snapped, params);
    keep_in_order(
        n,
        [&](std::size_t s) {
            return is_ground[s] == 0 && (densified.empty() || marked(densified, s));
        },
        [&](std::size_t m) { work.resize(m); },
        [&](std::size_t k, std::size_t s) { work[k] = static_cast<std::uint32_t>(s); });
    // Point a before point b as the choice of a triangle: smallest d, then smallest index.
    auto better = [&](std::int32_t a, std::int32_t b) {
        return dist[a] < dist[b] || (dist[a] == dist[b] && order[a] < order[b]);
    };

    // Points not yet ground: none left ends the loop without an iteration of its own.
    auto unclassified = static_cast<std::int64_t>(work.size());
    stats.prepare_seconds += seconds_since(clock);
    for (std::int32_t iteration = 0; unclassified > 0; ++iteration) {
        interruption.check_now();
        clock = std::chrono::steady_clock::now();
        std::exception_ptr failure;
        const auto m = static_cast<std::ptrdiff_t>(work.size());
        constexpr std::ptrdiff_t kChunk = 1024;  // tests per chunk, shared dynamically
        // Small iterations (most of them, late on) run serially: on a shared machine a
        // parallel region can wait a whole time slice for a descheduled thread.
        constexpr std::ptrdiff_t kParallelTests = 65536;
        // Each test also does what needs no other point's verdict: a rejected point is
        // pushed onto its slot's list (atomically; the lists are only ever read as sets,
        // so their order does not matter), and an accepted one in a densifiable triangle
        // competes for the triangle's choice, smallest d then smallest index, by a
        // compare-and-swap that retries while it is still better: the minimum under a
        // total order does not depend on the order of the updates.
        best_of.resize(tin.triangle_count(), -1);
        head.resize(tin.triangle_count(), -1);
#pragma omp parallel if (m > kParallelTests) firstprivate(interruption)
        {
            // The last two triangles this thread located, with their facets.
            std::int32_t last = 0;
            ground_tin::RecentTriangles<Facet> recent;
#pragma omp for schedule(dynamic, 1)
            for (std::ptrdiff_t chunk = 0; chunk < (m + kChunk - 1) / kChunk; ++chunk) {
                // Polled per chunk, not per test: a test costs only a few hundred cycles.
                if (interruption.requested()) continue;  // then thrown below, outside the region
                for (std::ptrdiff_t k = chunk * kChunk; k < std::min(m, (chunk + 1) * kChunk);
                     ++k) {
                    const std::uint32_t s = work[k];
                    try {
                        const auto& found = recent.find(
                            tin, sx[s], sy[s],
                            [&](std::int32_t) {
                                return tin.locate(sx[s], sy[s], tri[s] >= 0 ? tri[s] : last);
                            },
                            [&](std::int32_t t) { return facet(tin, vz, lim, t); });
                        const std::int32_t t = found.t;
                        const Verdict verdict = evaluate(tin, found.data, lim, sx[s], sy[s], sz[s]);
                        last = tri[s] = t;
                        accepted[s] = verdict.accepted;
                        stop[s] = verdict.stop;
                        dist[s] = verdict.d;
                        const auto self = static_cast<std::int32_t>(s);
                        if (!verdict.accepted) {
                            next[s] = __atomic_exchange_n(&head[t], self, __ATOMIC_RELAXED);
                        } else if (!verdict.stop) {
                            // Release: whoever loads this id also sees dist[s].
                            std::int32_t best = __atomic_load_n(&best_of[t], __ATOMIC_ACQUIRE);
                            while ((best < 0 || better(self, best)) &&
                                   !__atomic_compare_exchange_n(&best_of[t], &best, self, false,
                                                                __ATOMIC_ACQ_REL,
                                                                __ATOMIC_ACQUIRE)) {
                            }
                        }
                    } catch (...) {
#pragma omp critical(pcl_rg_tin_ground_failure)
                        if (!failure) failure = std::current_exception();
                    }
                }
            }
        }
        if (failure) std::rethrow_exception(failure);
        interruption.check();
        stats.tests += m;

        // Stop-edge acceptances and chosen points become ground; accepted points not
        // chosen are tested again on the denser TIN. The chosen points are gathered
        // through a bitmap, in sorted order.
        std::int64_t added = 0;
#pragma omp parallel for schedule(static) reduction(+ : added) if (m > 4 * kParallelTests)
        for (std::ptrdiff_t k = 0; k < m; ++k) {
            const std::uint32_t s = work[k];
            if (!accepted[s]) continue;
            if (stop[s] || best_of[tri[s]] == static_cast<std::int32_t>(s)) {
                is_ground[s] = 1;
                ++added;
                if (!stop[s]) mark(chosen_bits, s);
            } else {
                mark(retest, s);
            }
        }
        chosen.clear();
        take_marked(chosen_bits, chosen);
        for (const std::uint32_t s : chosen) best_of[tri[s]] = -1;
        if (!chosen.empty() && std::all_of(chosen.begin(), chosen.end(), [&](std::uint32_t s) {
                return on_vertex(tin, tri[s], sx[s], sy[s]);
            })) {
            waiting.clear();
            for (std::ptrdiff_t k = 0; k < m; ++k) {
                const std::uint32_t s = work[k];
                if (accepted[s] && !stop[s] && !is_ground[s]) waiting.push_back(s);
            }
            const IdleIterations idle = skip_idle_iterations(tin, sx, sy, tri, dist, order, waiting,
                                                             retest, is_ground, chosen);
            added += idle.ground;
            idle_iterations += idle.iterations;
        }
        stats.classification_seconds += seconds_since(clock);
        stats.iterations = iteration + 1 + idle_iterations;
        if (added == 0) break;
        unclassified -= added;

        // Insert the chosen points in Morton order, each walking from its own triangle.
        clock = std::chrono::steady_clock::now();
        tin.set_stamp(iteration + 1);
        insert_points(chosen, [&](std::uint32_t s) { return tri[s]; });
        stats.triangulation_seconds += seconds_since(clock);

        // Next work, in sorted order: the points of rewritten slots, and the marked ones.
        clock = std::chrono::steady_clock::now();
        head.resize(tin.triangle_count(), -1);
        const std::vector<std::int32_t>& touched = tin.touched();
        const auto rewritten = static_cast<std::ptrdiff_t>(touched.size());
#pragma omp parallel for schedule(static) if (rewritten > kParallelTests)
        for (std::ptrdiff_t k = 0; k < rewritten; ++k) {
            const std::int32_t t = touched[k];
            for (std::int32_t s = head[t]; s >= 0; s = next[s])
                mark(retest, static_cast<std::uint32_t>(s));
            head[t] = -1;
        }
        work.clear();
        take_marked(retest, work);
        stats.classification_seconds += seconds_since(clock);
    }
    // Scattered writes of distinct entries: in parallel, the result is the same.
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t s = 0; s < count; ++s) ground[order[s]] = is_ground[s] != 0;
    stats.tin_vertices = static_cast<std::int64_t>(tin.vertex_count() - tin.dead_vertex_count());
    if (*params.final_cell > 0.0) {
        clock = std::chrono::steady_clock::now();
        // Its TIN is built in the densification's, done with here, whose pages are in
        // place: fresh ones cost the kernel's zeroing, and sometimes the host's backing
        // (the pass's TIN of about 1.1M vertices on 10M points: 0.2 s of system time).
        final_pass(points, final_pass_params(params), snapped, ground, nullptr, {}, &tin);
        stats.classification_seconds += seconds_since(clock);
    }
    return stats;
}

}  // namespace pcl_rg
