// Final pass of a ground filter: classify every point by its height above a TIN of the
// filter's ground. TerraScan (Terrasolid, "Classify by distance to ground TIN" after its
// ground routine) adds the points close to the final ground TIN, so that ground is
// complete where the densification stopped early; the threshold grows with the TIN's
// gradient as in Zhao et al., "Improved progressive TIN densification filtering algorithm
// for airborne LiDAR data in forested areas", ISPRS J. Photogrammetry and Remote Sensing
// 117, 2016 (slope-adaptive thresholds). Here the TIN is built from the lowest ground
// point of each cell, so a filter whose ground holds low objects (a grid grower's) gets
// a lower, smoother surface, and every point, the filter's ground included, is classified
// again by its height above it.
//
// The steps, and the choices that make the result exact (the NumPy reference in
// pcl_rg/reference/_final_pass.py implements the same):
//   1. XY is snapped to the integer grid of a GridFrame over the extent (delaunay.hpp),
//      from the minimum corner, as tin_ground.cpp does; z is float64 from the minimum z.
//      tin_ground hands over its own snapped, Morton-ordered points (snap_points), so
//      they are not prepared twice; grid_ground its bounding box.
//   2. Cells of `cell` metres, anchored at multiples of `cell` in world coordinates
//      (lattice_floor, points.hpp); the lowest ground point of each (ties: smallest
//      index) is a vertex. Of vertices on one snapped XY, the lowest (ties: index) stays.
//      With low_depth, a ground point more than that below the median of the lowest
//      ground heights of the 7 x 7 cells around its own is no candidate
//      (final_pass_low.hpp). grid_ground hands over each point's cell in its grid's
//      order (SnappedPoints::cell, where cells hold 8 points or more on average): the
//      scans of every point for step 2 and the side vertices then read its compact
//      arrays in order (cell, height, index and ground: 17 bytes a point, after one
//      gather of the ground) instead of each point's coordinates in input order (24
//      bytes and two divisions): at 10M points its two rounds took 0.47 instead of
//      0.58 s, and its grid 0.39 instead of 0.36 s to build (medians of 40 calls).
//   3. Delaunay TIN of the vertices inside the frame's box, whose four corners are
//      virtual vertices at the height of their nearest vertex (exact squared grid
//      distance, ties: the lowest), and whose sides hold one virtual vertex for each
//      vertex of a cell on that side, its height continuing a rise from inwards
//      (final_pass_border.cpp).
//   4. Each point p is located in the triangle holding p + (eps, eps^2) (unique whatever
//      the walk); with the triangle's vertices counter-clockwise from the
//      lexicographically smallest (x, y), v0, v1, v2 in metres, n = (v1 - v0) x (v2 - v0):
//        z_TIN = z0 - (nx * (px - x0) + ny * (py - y0)) / nz,
//        grad  = sqrt(nx * nx + ny * ny) / nz,
//      and p is ground when z_p - z_TIN >= -below and z_p - z_TIN <= above + slope * grad.
// The TIN does not depend on the insertion order, co-circular vertices included (the
// in-circle test breaks their ties by coordinates, delaunay.hpp), and it is built in
// parallel strips (Delaunay::insert_batch); the tests run in parallel and write
// only their own point's entry.
// Rounds (grid_ground's final_passes): a round after another builds its TIN anew but
// locates again only the points in squares of a coarse lattice that a new triangle's
// box overlaps (FinalPassRounds); the others keep the last round's verdict, which a
// triangle of both TINs gives them again. Between rounds few vertices change (627 of
// 156,752 on the 10M-point synthetic scene), so a later round costs about half a first.
#include "pcl_rg/final_pass.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "final_pass_border.hpp"
#include "final_pass_low.hpp"
#include "ground_tin.hpp"
#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/index_bitmap.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

void validate(const FinalPassParams& params) {
    check::real("final_cell", params.cell, check::non_negative());
    check::real("final_above", params.above, check::non_negative());
    check::real("final_below", params.below, check::non_negative());
    check::real("final_slope", params.slope, check::non_negative());
    check::real("final_low_depth", params.low_depth, check::non_negative());
}

namespace {

using final_pass_border::border_vertices;
using final_pass_border::by_place;
using final_pass_border::rim_points;
using final_pass_border::Vertex;

// A closed box on the grid: the bounding box of a vertex's triangles (its star).
using GridBox = std::array<std::int32_t, 4>;  // x0, y0, x1, y1

// Per vertex id of `tin`: the bounding box of its star.
std::vector<GridBox> star_boxes(const Delaunay& tin) {
    constexpr std::int32_t kLow = std::numeric_limits<std::int32_t>::min();
    constexpr std::int32_t kHigh = std::numeric_limits<std::int32_t>::max();
    std::vector<GridBox> star(tin.vertex_count(), GridBox{kHigh, kHigh, kLow, kLow});
    for (std::int32_t t = 0; t < static_cast<std::int32_t>(tin.triangle_count()); ++t) {
        if (!tin.live(t)) continue;
        GridBox box{kHigh, kHigh, kLow, kLow};
        for (int k = 0; k < 3; ++k) {
            const std::int32_t v = tin.triangle_vertex(t, k);
            box[0] = std::min(box[0], tin.vertex_x(v)), box[2] = std::max(box[2], tin.vertex_x(v));
            box[1] = std::min(box[1], tin.vertex_y(v)), box[3] = std::max(box[3], tin.vertex_y(v));
        }
        for (int k = 0; k < 3; ++k) {
            GridBox& around = star[tin.triangle_vertex(t, k)];
            around[0] = std::min(around[0], box[0]), around[2] = std::max(around[2], box[2]);
            around[1] = std::min(around[1], box[1]), around[3] = std::max(around[3], box[3]);
        }
    }
    return star;
}

// Sets the squares of `lattice` that `box` overlaps (grid coordinates lie in [0, width]
// x [0, height], the lattice's range).
void mark_squares(const GridBox& box, const HintLattice& lattice,
                  std::vector<std::uint8_t>& dirty) {
    if (box[0] > box[2]) return;  // a vertex without triangles (none in a TIN: defensive)
    const auto c0 = static_cast<std::size_t>(box[0] >> lattice.shift);
    const auto c1 = static_cast<std::size_t>(box[2] >> lattice.shift);
    for (auto r = static_cast<std::size_t>(box[1] >> lattice.shift);
         r <= static_cast<std::size_t>(box[3] >> lattice.shift); ++r)
        std::fill(dirty.begin() + static_cast<std::ptrdiff_t>(r * lattice.columns + c0),
                  dirty.begin() + static_cast<std::ptrdiff_t>(r * lattice.columns + c1 + 1), 1);
}

}  // namespace

void final_pass(PointsView points, const FinalPassParams& params, bool* ground) {
    if (points.size == 0) return;
    const std::array<double, 3> origin = local_origin(points);
    const std::array<double, 3> upper = upper_corner(points, origin);
    check_final_pass_extent(origin, upper);
    final_pass(points, params, snap_points(points, origin, upper), ground);
}

void check_final_pass_extent(const std::array<double, 3>& origin,
                             const std::array<double, 3>& upper) {
    if (!std::isfinite(upper[0] - origin[0]) || !std::isfinite(upper[1] - origin[1]) ||
        !std::isfinite(upper[2] - origin[2]))
        throw std::invalid_argument("points: the extent is too large (not finite in float64)");
}

CellLattice final_cells(const SnappedPoints& snapped, double cell) {
    const std::array<double, 3>& origin = snapped.origin;
    const std::array<double, 3>& upper = snapped.upper;
    const double x0 = lattice_floor(origin[0], cell), y0 = lattice_floor(origin[1], cell);
    if (!((upper[0] - x0) / cell < 0x1p40 && (upper[1] - y0) / cell < 0x1p40))
        throw std::invalid_argument(
            "final_cell is too small for the extent of points: more than 2^40 cells per axis");
    return {x0,
            y0,
            origin[2],
            cell,
            static_cast<std::int64_t>(std::floor((upper[0] - x0) / cell)) + 1,
            static_cast<std::int64_t>(std::floor((upper[1] - y0) / cell)) + 1};
}

void final_pass(PointsView points, const FinalPassParams& params, const SnappedPoints& snapped,
                bool* ground, FinalPassRounds* rounds,
                const std::vector<std::uint32_t>& never_ground, Delaunay* tin_memory) {
    const std::size_t n = points.size;
    if (n == 0) return;
    if (rounds && rounds->ran && rounds->points != n)
        throw std::logic_error("final_pass: `rounds` holds a round of another cloud");
    const Interruption interruption;
    const std::array<double, 3>& origin = snapped.origin;
    const GridFrame& frame = snapped.frame;
    auto z_of = [&](std::size_t i) { return points.coord(i, 2) - origin[2]; };

    // --- 2. the lowest ground point of each cell ------------------------------------
    const CellLattice cells = final_cells(snapped, params.cell);
    // The vertices with their snapped XY and height. Many (tin_ground's dense cells): by
    // a scan of the snapped points, sequential reads, for tin_ground already in curve
    // order; few (grid_ground's): read from the input, one scattered read each, cheaper
    // than the scan. The order below does not depend on which.
    // With low_depth, the ground that may give vertices (and side vertices) is the
    // filter's without its points far below their surroundings; every point, those
    // included, is classified as always.
    // With the points' cells at hand in the snapped order (grid_ground's), the scans of
    // every point below run in that order over those arrays (ground and vertex ground by
    // position), not over the input with a cell found per point.
    const bool by_position = snapped.cell.size() == n && snapped.cell_size == params.cell;
    std::unique_ptr<bool[]> not_low;
    std::vector<unsigned char> vertex_ground_at;               // by position
    std::optional<std::vector<std::uint32_t>> lowest_not_low;  // keep_not_low's, if it has them
    if (by_position) {
        lowest_not_low = final_pass_low::lowest_by_position(
            points, snapped, cells, params.low_depth, ground, vertex_ground_at);
    } else if (params.low_depth > 0.0) {
        not_low.reset(new bool[n]);
        lowest_not_low =
            final_pass_low::keep_not_low(points, cells, params.low_depth, ground, not_low.get());
    }
    // By input index (by position: vertex_ground_at instead).
    const bool* vertex_ground = by_position ? nullptr : not_low ? not_low.get() : ground;
    std::vector<Vertex> candidates;
    {
        // The lowest point of each cell of the vertex ground.
        const std::vector<std::uint32_t> lowest = lowest_not_low
                                                      ? std::move(*lowest_not_low)
                                                      : lowest_points(points, cells, vertex_ground);
        lowest_not_low.reset();
        const auto count = static_cast<std::ptrdiff_t>(lowest.size());
        if (lowest.size() < n / 16) {
            candidates.resize(lowest.size());
#pragma omp parallel for schedule(static) if (count > 65536)
            for (std::ptrdiff_t k = 0; k < count; ++k) {
                const std::uint32_t i = lowest[k];
                candidates[k] = {snapped.grid_x(points, i), snapped.grid_y(points, i), z_of(i), i};
            }
        } else {
            std::vector<std::uint64_t> is_vertex((n + 63) / 64, 0);
            for (const std::uint32_t i : lowest) mark(is_vertex, i);
            keep_in_order(
                n, [&](std::size_t s) { return marked(is_vertex, snapped.order[s]); },
                [&](std::size_t m) { candidates.resize(m); },
                [&](std::size_t k, std::size_t s) {
                    candidates[k] = {snapped.x[s], snapped.y[s], snapped.z[s], snapped.order[s]};
                });
        }
    }
    if (candidates.empty()) {  // no ground in: no ground out
        std::fill(ground, ground + n, false);
        if (rounds) rounds->ran = false;
        return;
    }
    // The insertion order: along the Morton curve of the TIN's box (short walks), within
    // one of the curve's cells by (x, y). Of vertices on one snapped XY (always in one
    // cell), the lowest stays, ties by the smallest index. The curve's sort is stable, so
    // each cell's vertices come together and only those few are sorted, by (x, y, z,
    // index).
    std::vector<Vertex> vertices;
    vertices.reserve(candidates.size());
    {
        std::vector<std::int32_t> cx(candidates.size()), cy(candidates.size());
        for (std::size_t k = 0; k < candidates.size(); ++k)
            cx[k] = candidates[k].x, cy[k] = candidates[k].y;
        const std::vector<std::uint32_t> curve =
            morton_order_2d(cx.data(), cy.data(), candidates.size(), frame.width, frame.height);
        const int shift = morton_cell_shift(frame.width, frame.height);
        const auto same_cell = [shift](const Vertex& a, const Vertex& b) {
            return a.x >> shift == b.x >> shift && a.y >> shift == b.y >> shift;
        };
        const auto by_xy_z_index = [](const Vertex& a, const Vertex& b) {
            return a.x < b.x ||
                   (a.x == b.x &&
                    (a.y < b.y || (a.y == b.y && (a.z < b.z || (a.z == b.z && a.i < b.i)))));
        };
        std::vector<Vertex> cell;
        for (std::size_t k = 0; k < curve.size();) {
            cell.clear();
            do cell.push_back(candidates[curve[k++]]);
            while (k < curve.size() && same_cell(candidates[curve[k]], cell.front()));
            std::sort(cell.begin(), cell.end(), by_xy_z_index);
            for (std::size_t c = 0; c < cell.size(); ++c)
                if (c == 0 || cell[c].x != cell[c - 1].x || cell[c].y != cell[c - 1].y)
                    vertices.push_back(cell[c]);
        }
    }
    interruption.check_now();
    // The virtual vertices on the sides (in insertion order), and by place for `rounds`.
    std::vector<BorderVertex> border;
    {
        std::vector<std::array<std::int64_t, 2>> vertex_cells(vertices.size());
        for (std::size_t k = 0; k < vertices.size(); ++k)
            std::tie(vertex_cells[k][0], vertex_cells[k][1]) =
                cell_of(points, cells, vertices[k].i);
        const std::vector<std::uint32_t> rim =
            by_position ? rim_points(snapped, vertex_ground_at.data(), cells)
                        : rim_points(points, vertex_ground, cells);
        border = border_vertices(vertices, vertex_cells, rim, points, cells, snapped);
    }
    std::vector<std::size_t> border_by_place(border.size());
    for (std::size_t b = 0; b < border.size(); ++b) border_by_place[b] = b;
    std::sort(border_by_place.begin(), border_by_place.end(),
              [&](std::size_t a, std::size_t b) { return by_place(border[a], border[b]); });
    // The last round's vertices and border vertices again (the border's heights depend on
    // other ground points too): the same TIN, so the same result.
    if (rounds && rounds->ran && vertices.size() == rounds->vertices.size() &&
        std::equal(vertices.begin(), vertices.end(), rounds->vertices.begin(),
                   [](const Vertex& v, std::uint32_t i) { return v.i == i; }) &&
        border.size() == rounds->border.size() &&
        std::equal(border_by_place.begin(), border_by_place.end(), rounds->border.begin(),
                   [&](std::size_t b, const BorderVertex& last) {
                       return border[b].x == last.x && border[b].y == last.y &&
                              border[b].z == last.z;
                   }))
        return;

    // --- 3. the TIN: virtual corners, the vertices, then the side vertices ------------
    std::vector<GridBox> vertex_star;  // for `rounds`: the star of vertices[k]
    std::array<GridBox, 4> corner_star{};
    std::vector<GridBox> border_star;  // for `rounds`: the star of border[b], border by place
    const std::array<std::size_t, 4> nearest = ground_tin::nearest_to_corners(
        frame, vertices.size(), [&](std::size_t k) { return vertices[k].x; },
        [&](std::size_t k) { return vertices[k].y; }, [&](std::size_t k) { return vertices[k].z; },
        [&](std::size_t k) { return vertices[k].i; });
    std::optional<Delaunay> own_tin;
    if (tin_memory)
        tin_memory->reset(frame.width, frame.height);
    else
        own_tin.emplace(frame.width, frame.height);
    Delaunay& tin = tin_memory ? *tin_memory : *own_tin;
    UnfilledVector<double> vz;  // each vertex's height
    for (const std::size_t k : nearest) vz.push_back(vertices[k].z);
    tin.reserve(vertices.size() + 4 + border.size());
    const std::size_t vertex_count = vertices.size();
    std::vector<std::int32_t> id(vertex_count);
    {
        std::vector<std::int32_t> vx(vertex_count), vy(vertex_count);
        for (std::size_t k = 0; k < vertex_count; ++k) vx[k] = vertices[k].x, vy[k] = vertices[k].y;
        tin.insert_batch(vx.data(), vy.data(), nullptr, vertex_count, id.data());
        vz.resize(tin.vertex_count(), 0.0);
        for (std::size_t k = 0; k < vertex_count; ++k) vz[id[k]] = vertices[k].z;  // distinct XY
    }
    // The side vertices after the vertices (the TIN is the same in any order), by halves
    // of their run around the box: the middle one, then those halfway between two in, and
    // so on. Vertices a grid step from a side leave slivers between them and the side
    // that fan out to the corners; a side vertex inserted next to the last one along the
    // side would flip the whole rest of its fan each time (8,000 per side: 8 s), while
    // one inserted between two earlier ones flips only what lies between them. Each is
    // looked for from the point a grid step inside it, walked to from the earlier one
    // before it in the run (or the first corner).
    const auto first_side = static_cast<std::int32_t>(tin.vertex_count());
    std::vector<std::int32_t> border_id(border.size());
    std::size_t step = 1;
    while (step * 2 <= border.size()) step *= 2;
    for (; step >= 1; step /= 2)
        for (std::size_t b = step - 1; b < border.size(); b += 2 * step) {
            const std::int32_t before = b >= step ? border_id[b - step] : 0;
            // The triangle at the point a grid step inside lies next to the one on the
            // side (the earlier vertex's own triangles may be a long fan away: 16,000 per
            // side took 3.7 s from there, 0.19 s from here).
            const std::int32_t inside_x = std::clamp(border[b].x, 1, frame.width - 1);
            const std::int32_t inside_y = std::clamp(border[b].y, 1, frame.height - 1);
            bool inserted = false;
            border_id[b] = tin.insert_on_border(
                border[b].x, border[b].y,
                tin.locate(inside_x, inside_y, tin.vertex_triangle(before)), &inserted);
            if (!inserted)  // distinct places on the sides, none a corner nor a vertex
                throw std::logic_error("final_pass: a side vertex was not inserted");
        }
    vz.resize(tin.vertex_count(), 0.0);
    for (std::size_t b = 0; b < border.size(); ++b) vz[border_id[b]] = border[b].z;
    if (rounds) {
        const std::vector<GridBox> star = star_boxes(tin);
        vertex_star.resize(vertex_count);
        for (std::size_t k = 0; k < vertex_count; ++k) vertex_star[k] = star[id[k]];
        for (int c = 0; c < 4; ++c) corner_star[c] = star[c];
        // The side vertices by place, for the next round to compare with its own.
        std::vector<BorderVertex> sorted_border;
        for (const std::size_t b : border_by_place) {
            sorted_border.push_back(border[b]);
            border_star.push_back(star[border_id[b]]);
        }
        border = std::move(sorted_border);
    }
    std::vector<std::uint64_t> is_vertex;  // for `rounds`: bit i, point i is a vertex
    if (rounds) {
        is_vertex.assign((n + 63) / 64, 0);
        for (const Vertex& v : vertices) mark(is_vertex, v.i);
    }

    // --- 4. classify every point, in Morton order so that walks are short -------------
    // Where to start a walk far from the last triangle (a thread's next chunk, a new row
    // of grid_ground's cells): a triangle at a vertex in the same square of a coarse
    // lattice, about one vertex per square. Only the walk's length depends on it.
    const HintLattice lattice(frame.width, frame.height, tin.vertex_count());
    // For a round after another, the squares where a point may lie in a triangle that the
    // last round's TIN does not have (empty: every point is classified). Such a triangle
    // lies in the last TIN's star of a vertex it lost (removing a vertex changes only its
    // star), or in this TIN's star of a vertex it gained (inserting one changes only
    // triangles that then have it as a vertex), or has a virtual corner whose height
    // changed, so it lies in one of those stars' boxes. Side vertices count as vertices
    // by place and height: one whose height changed is lost and gained.
    std::vector<std::uint8_t> dirty;
    if (rounds && rounds->ran) {
        dirty.assign(lattice.size(), 0);
        for (std::size_t k = 0; k < rounds->vertices.size(); ++k)
            if (!marked(is_vertex, rounds->vertices[k]))
                mark_squares(rounds->vertex_star[k], lattice, dirty);
        for (std::size_t k = 0; k < vertices.size(); ++k)
            if (!marked(rounds->is_vertex, vertices[k].i))
                mark_squares(vertex_star[k], lattice, dirty);
        for (int c = 0; c < 4; ++c)
            if (rounds->corner_z[c] != vz[c]) mark_squares(corner_star[c], lattice, dirty);
        // A side vertex lost or gained, or moved in height (both lists by place).
        const std::vector<BorderVertex>& last_border = rounds->border;
        for (std::size_t a = 0, b = 0; a < last_border.size() || b < border.size();) {
            if (b == border.size() ||
                (a < last_border.size() && by_place(last_border[a], border[b]))) {
                mark_squares(rounds->border_star[a++], lattice, dirty);
            } else if (a == last_border.size() || by_place(border[b], last_border[a])) {
                mark_squares(border_star[b++], lattice, dirty);
            } else {
                if (last_border[a].z != border[b].z) {
                    mark_squares(rounds->border_star[a], lattice, dirty);
                    mark_squares(border_star[b], lattice, dirty);
                }
                ++a, ++b;
            }
        }
    }
    std::vector<std::int32_t> hint(lattice.size(), -1);
    for (std::int32_t t = 0; t < static_cast<std::int32_t>(tin.triangle_count()); ++t)
        for (int k = 0; k < 3 && tin.live(t); ++k) {
            const std::int32_t v = tin.triangle_vertex(t, k);
            if (v >= 4 && v < first_side)  // a vertex, not a corner nor on a side
                hint[lattice.of(tin.vertex_x(v), tin.vertex_y(v))] = t;
        }
    const std::int64_t near = std::int64_t{2} << lattice.shift;
    const double q = frame.quantum;
    constexpr std::ptrdiff_t kChunk = 4096;
    constexpr std::ptrdiff_t kAhead = 32;  // prefetch distance, in points
    const auto m = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel firstprivate(interruption)
    {
        // The last two triangles this thread located, with their planes and gradients
        // (in Morton order, or in a cell of grid_ground's grid that straddles an edge,
        // whose points come by height, not place, the next point often lies in one).
        struct Surface {
            ground_tin::Plane f;
            double gradient;
        };
        ground_tin::RecentTriangles<Surface> recent;
#pragma omp for schedule(dynamic, 1)
        for (std::ptrdiff_t chunk = 0; chunk < (m + kChunk - 1) / kChunk; ++chunk) {
            if (interruption.requested()) continue;
            const std::ptrdiff_t end = std::min(m, (chunk + 1) * kChunk);
            for (std::ptrdiff_t s = chunk * kChunk; s < end; ++s) {
                // The verdicts go to scattered places: fetch the line a little ahead (a
                // later round, which skips most points, would fetch for nothing).
                if (dirty.empty() && s + kAhead < m)
                    __builtin_prefetch(&ground[snapped.order[s + kAhead]], 1);
                const std::int32_t gx = snapped.x[s], gy = snapped.y[s];
                // The same triangle as in the last round: the same verdict, in `ground`.
                if (!dirty.empty() && !dirty[lattice.of(gx, gy)]) continue;
                // Walk from the last triangle, or from the hint when that is far.
                const auto locate = [&](std::int32_t start) {
                    const std::int32_t corner =
                        start >= 0 ? tin.triangle_vertex(start, 0) : std::int32_t{0};
                    if (start < 0 || std::abs(std::int64_t{tin.vertex_x(corner)} - gx) > near ||
                        std::abs(std::int64_t{tin.vertex_y(corner)} - gy) > near) {
                        const std::int32_t h = hint[lattice.of(gx, gy)];
                        start = h >= 0 ? h : std::max(start, std::int32_t{0});
                    }
                    return tin.locate(gx, gy, start);
                };
                const auto surface_of = [&](std::int32_t t) {
                    const ground_tin::Plane plane = ground_tin::plane_of(tin, vz, q, t);
                    return Surface{plane,
                                   std::sqrt(plane.nx * plane.nx + plane.ny * plane.ny) / plane.nz};
                };
                const Surface& found = recent.find(tin, gx, gy, locate, surface_of).data;
                const ground_tin::Plane& f = found.f;
                const double gradient = found.gradient;
                const double px = static_cast<double>(gx - 1) * q;
                const double py = static_cast<double>(gy - 1) * q;
                const double surface =
                    f.z[0] - (f.nx * (px - f.x[0]) + f.ny * (py - f.y[0])) / f.nz;
                const double dz = snapped.z[s] - surface;
                ground[snapped.order[s]] =
                    dz >= -params.below && dz <= params.above + params.slope * gradient;
            }
        }
    }
    interruption.check();
    for (const std::uint32_t i : never_ground) ground[i] = false;
    if (rounds) {
        rounds->ran = true;
        rounds->points = n;
        rounds->vertices.resize(vertices.size());
        for (std::size_t k = 0; k < vertices.size(); ++k) rounds->vertices[k] = vertices[k].i;
        rounds->vertex_star = std::move(vertex_star);
        rounds->is_vertex = std::move(is_vertex);
        for (int c = 0; c < 4; ++c) rounds->corner_z[c] = vz[c];
        rounds->border = std::move(border);
        rounds->border_star = std::move(border_star);
    }
}

}  // namespace pcl_rg
