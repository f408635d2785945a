// Incremental 2-D Delaunay triangulation with exact integer predicates: the TIN of the
// progressive TIN densification ground filter (tin_ground.hpp), usable on its own.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pcl_rg/points.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg {

/// Largest grid coordinate a Delaunay vertex may have; every coordinate lies in
/// [0, kMaxGridCoordinate], which keeps the predicates exact (see delaunay.cpp).
inline constexpr std::int32_t kMaxGridCoordinate = std::int32_t{1} << 30;

/// std::nearbyint(v) in the default rounding mode (to nearest, ties to even), up to the
/// sign of a zero, without a call: the x86-64 baseline has no rounding instruction, so
/// std::nearbyint is a call into libm, two per point snapped. Adding then subtracting
/// 2^52 rounds a v below 2^52 in magnitude to a whole number in that mode (the sum's
/// last place is 1); from 2^52 on v is whole already.
inline double nearest_whole(double v) {
    constexpr double kWhole = 0x1p52;
    if (!(std::fabs(v) < kWhole)) return v;
    return v >= 0.0 ? (v + kWhole) - kWhole : (v - kWhole) + kWhole;
}

/// Maps XY coordinates in [lower, upper] (metres, float64) to the integer grid of a
/// Delaunay box: g = rint((v - lower) / quantum) + 1, so every point of the extent
/// lies strictly inside the box [0, width] x [0, height].
struct GridFrame {
    double lower_x = 0.0;     ///< x of the extent's lower corner (m)
    double lower_y = 0.0;     ///< y of the extent's lower corner (m)
    double quantum = 1.0;     ///< grid step (m): a power of two, at most extent / 2^29
    std::int32_t width = 2;   ///< box corner x (grid units): rint(extent_x / quantum) + 2
    std::int32_t height = 2;  ///< box corner y (grid units): rint(extent_y / quantum) + 2

    std::int32_t grid_x(double x) const {
        return static_cast<std::int32_t>(nearest_whole((x - lower_x) / quantum)) + 1;
    }
    std::int32_t grid_y(double y) const {
        return static_cast<std::int32_t>(nearest_whole((y - lower_y) / quantum)) + 1;
    }
};

/// Frame of the extent [lower_x, upper_x] x [lower_y, upper_y] (m). The quantum is the
/// smallest power of two >= max(extent) / 2^29 and >= 2^-40 m. Throws
/// std::invalid_argument when the bounds are not finite or not ordered.
GridFrame make_grid_frame(double lower_x, double lower_y, double upper_x, double upper_y);

/// Points on the grid of a frame over their extent, in Morton order: what the ground
/// filters build their TINs from (tin_ground.cpp, final_pass.cpp), prepared once.
struct SnappedPoints {
    std::array<double, 3> origin{};  ///< local_origin(points), the minimum corner
    std::array<double, 3> upper{};   ///< upper_corner(points, origin)
    GridFrame frame;                 ///< make_grid_frame(0, 0, upper - origin) in XY
    // Not zero-filled when sized (UnfilledVector): whoever sizes them writes every entry.
    UnfilledVector<std::uint32_t> order;  ///< morton_order_2d of the grid XY (index order)
    UnfilledVector<std::int32_t> x, y;    ///< grid XY of point order[s], by sorted position s
    UnfilledVector<double> z;             ///< z - origin[2] of point order[s]
    /// Optional (grid_ground fills it while building its grid; empty otherwise): the final
    /// pass's cell of position s, cx * rows + cy on final_cells(*this, cell_size), so that
    /// the pass scans the points in this order instead of finding each one's cell again.
    UnfilledVector<std::uint32_t> cell;
    double cell_size = 0.0;  ///< the final cell (m) that `cell` numbers

    /// Point i's grid x or y on `frame` (as snap_points snaps it).
    std::int32_t grid_x(PointsView points, std::size_t i) const {
        return frame.grid_x(points.coord(i, 0) - origin[0]);
    }
    std::int32_t grid_y(PointsView points, std::size_t i) const {
        return frame.grid_y(points.coord(i, 1) - origin[1]);
    }
};

/// The frame snap_points snaps points to on the bounding box `origin`, `upper` (upper -
/// origin finite): origin, upper and frame set, no points yet (for a caller that snaps
/// them in an order of its own, as grid_ground while building its grid).
SnappedPoints snap_frame(const std::array<double, 3>& origin, const std::array<double, 3>& upper);

/// The points (N > 0) snapped and sorted, `origin` and `upper` being their bounding box
/// (upper - origin finite). In parallel; polls for interruption.
SnappedPoints snap_points(PointsView points, const std::array<double, 3>& origin,
                          const std::array<double, 3>& upper);

/// Twice the signed area of (a, b, c): > 0 counter-clockwise, 0 collinear. Exact for
/// coordinates in [0, kMaxGridCoordinate] (see delaunay.cpp for the bounds).
inline std::int64_t orient2d(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                             std::int64_t cx, std::int64_t cy) {
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

/// Orientation of (a, b, p + (eps, eps^2)): the exact orientation when non-zero, else
/// the sign of its eps term (ay - by), else of its eps^2 term (bx - ax). Never zero for
/// a != b, and antisymmetric in (a, b), so the perturbed point is on one side of
/// every edge.
inline int orient_perturbed(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                            std::int64_t px, std::int64_t py) {
    const std::int64_t o = orient2d(ax, ay, bx, by, px, py);
    if (o != 0) return o > 0 ? 1 : -1;
    if (ay != by) return ay > by ? 1 : -1;
    return bx > ax ? 1 : -1;
}

/// > 0 when d lies strictly inside the circumcircle of the counter-clockwise triangle
/// (a, b, c), 0 on it, < 0 outside. Exact for coordinates in [0, kMaxGridCoordinate].
inline int incircle(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                    std::int64_t cx, std::int64_t cy, std::int64_t dx, std::int64_t dy) {
    const std::int64_t adx = ax - dx, ady = ay - dy;
    const std::int64_t bdx = bx - dx, bdy = by - dy;
    const std::int64_t cdx = cx - dx, cdy = cy - dy;
    const std::int64_t alift = adx * adx + ady * ady;
    const std::int64_t blift = bdx * bdx + bdy * bdy;
    const std::int64_t clift = cdx * cdx + cdy * cdy;
    const __int128 det = static_cast<__int128>(alift) * (bdx * cdy - bdy * cdx) +
                         static_cast<__int128>(blift) * (cdx * ady - cdy * adx) +
                         static_cast<__int128>(clift) * (adx * bdy - ady * bdx);
    return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

/// incircle with its ties broken by a symbolic perturbation (never 0 for a
/// counter-clockwise (a, b, c) and d distinct from them): each point's lifted height
/// x^2 + y^2 is raised by eps^r, r its rank in (x, y) lexicographic order, smallest
/// first, eps -> 0+. Where four points are co-circular the sign is that of the
/// coefficient of the lowest-ranked point's eps term: for a, b, c the orientation of
/// the other three taken in the cyclic order (b, c, d), (c, a, d), (a, b, d); for d,
/// -orient(a, b, c), never 0. A triangulation whose flips follow this test is the one
/// Delaunay triangulation of the perturbed points, whatever the order of insertion
/// (Edelsbrunner and Muecke, "Simulation of simplicity", ACM TOG 9(1), 1990).
inline int incircle_perturbed(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                              std::int64_t cx, std::int64_t cy, std::int64_t dx, std::int64_t dy) {
    const int exact = incircle(ax, ay, bx, by, cx, cy, dx, dy);
    if (exact != 0) return exact;
    struct Term {
        std::int64_t x, y, coefficient;
    };
    const Term terms[4] = {{ax, ay, orient2d(bx, by, cx, cy, dx, dy)},
                           {bx, by, orient2d(cx, cy, ax, ay, dx, dy)},
                           {cx, cy, orient2d(ax, ay, bx, by, dx, dy)},
                           {dx, dy, -orient2d(ax, ay, bx, by, cx, cy)}};
    const auto before = [](const Term& u, const Term& v) {
        return u.x < v.x || (u.x == v.x && u.y < v.y);
    };
    // The lowest-ranked point with a non-zero coefficient decides; d's never is zero.
    const Term* decider = &terms[3];
    for (const Term& term : terms)
        if (term.coefficient != 0 && before(term, *decider)) decider = &term;
    return decider->coefficient > 0 ? 1 : -1;
}

/// Bits per axis of morton_order_2d's curve: a 65536 x 65536 lattice of cells over the
/// box, centimetres for kilometre tiles, so that a cell rarely holds two points of a
/// survey (within a cell the order is the points', which spatial walks do not like:
/// 10 bits left about 10 points per cell at 10M points, and tin_ground ~10 % slower).
/// With the point index (32 bits at most) below the 32-bit code, a key is one 64-bit word.
inline constexpr int kMortonAxisBits = 16;

/// The cells of morton_order_2d's curve in the box [0, width] x [0, height]: grid points
/// (x, y) and (x', y') share a cell when x >> shift == x' >> shift and y >> shift ==
/// y' >> shift, for the returned shift.
int morton_cell_shift(std::int32_t width, std::int32_t height);

/// Point order along a 2-D Morton (Z-order) curve of the cells (morton_cell_shift) of
/// grid coordinates in the box [0, width] x [0, height], stable (points of one cell stay
/// in index order): neighbours in XY end up close in memory and in walking distance.
std::vector<std::uint32_t> morton_order_2d(const std::int32_t* gx, const std::int32_t* gy,
                                           std::size_t n, std::int32_t width, std::int32_t height);

/// Delaunay triangulation of integer points inside the box [0, width] x [0, height],
/// built by incremental insertion (Lawson flips) with exact predicates.
///
/// Vertices 0..3 are the box corners (0,0), (width,0), (width,height), (0,height);
/// they make the convex hull (with any vertices insert_on_border adds on its sides), so
/// every point of the box lies in some triangle.
/// Triangles are counter-clockwise vertex triples; neighbour i lies across the edge
/// opposite vertex i (-1 on the box). Triangle slots are never freed: an insertion
/// rewrites the slots it destroys and appends the rest, so a slot id stays a valid
/// (and nearby) place to start a walk. Every slot an insertion writes records the current
/// stamp and is listed in touched() (prepare_insertions' slots are neither, until then).
class Delaunay {
   public:
    Delaunay(std::int32_t width, std::int32_t height);

    /// Back to the empty box [0, width] x [0, height], as constructed, with the memory of
    /// its arrays kept: for another TIN built after this one is done with, whose arrays
    /// then reuse pages already in place instead of faulting in fresh ones (the kernel
    /// zeroes each, and a host may have to back it first).
    void reset(std::int32_t width, std::int32_t height);

    /// The triangle containing p + (eps, eps^2) for an infinitesimal eps > 0: the one
    /// triangle holding p in its closure that is chosen the same way whatever the walk,
    /// so points on edges and vertices are located deterministically. Walks from
    /// `start` (any slot; from slot 0 if it holds no triangle). p must lie strictly inside the box.
    std::int32_t locate(std::int32_t x, std::int32_t y, std::int32_t start) const;

    /// Whether triangle t holds p + (eps, eps^2) (see locate): then locate returns t.
    /// Inline: the filters' classifications ask it for nearly every point.
    bool holds(std::int32_t t, std::int32_t x, std::int32_t y) const {
        const Triangle& tr = tri_[t];
        for (int e = 0; e < 3; ++e) {
            const Vertex a = xy_[tr.v[e == 2 ? 0 : e + 1]], b = xy_[tr.v[e == 0 ? 2 : e - 1]];
            if (orient_perturbed(a.x, a.y, b.x, b.y, x, y) < 0) return false;
        }
        return true;
    }

    /// Inserts p (strictly inside the box) and restores the Delaunay property; returns
    /// its vertex id. A point equal to an existing vertex is not inserted: that
    /// vertex's id is returned and *inserted is set to false.
    std::int32_t insert(std::int32_t x, std::int32_t y, std::int32_t start, bool* inserted);

    /// Inserts p, a point of the box's border (x in {0, width} or y in {0, height}),
    /// splitting the triangle on that stretch of the border in two, and restores the
    /// Delaunay property; returns its vertex id (an existing vertex's, with *inserted
    /// false, when p is one). The triangle is looked for among the few linked to `start`
    /// (the last one's vertex_triangle, for points each next to the last), else among all:
    /// for the virtual vertices of a border, before the points go in.
    std::int32_t insert_on_border(std::int32_t x, std::int32_t y, std::int32_t start,
                                  bool* inserted);

    /// Inserts the m grid points (x[k], y[k]), each strictly inside the box, and writes
    /// each one's vertex id to vertex[k]: the triangulation insert() builds from them in
    /// any order (incircle_perturbed makes it unique), with vertex ids and triangle slots
    /// that depend neither on the threads nor on the timing. New vertices get ids from
    /// vertex_count() before the call on; points of one XY share one vertex, the first
    /// such point's in k order (or an existing vertex). start[k] (start may be null) is
    /// -1 or the triangle holding point k before the call (as locate() gives it), where
    /// its walk begins; the points in curve order walk least. Polls for interruption.
    ///
    /// How: a large batch is split into kBatchZones vertical strips of about equal counts,
    /// inserted side by side, each strip changing only triangles whose three vertices lie
    /// in it (a Bowyer-Watson insertion that checks its cavity before writing); a point
    /// whose walk or cavity reaches further is inserted afterwards, serially. Into a TIN
    /// much coarser than the batch, every kBatchSample-th point goes in first, serially,
    /// so that the strips' cavities are small. The ids of points found on a vertex stay
    /// unused (dead_vertex_count()), as do their slots (live()).
    void insert_batch(const std::int32_t* x, const std::int32_t* y, const std::int32_t* start,
                      std::size_t m, std::int32_t* vertex);

    /// Makes room for `vertices` vertices in all (the box corners included) and their
    /// triangles, so that the arrays are not copied while the triangulation grows.
    void reserve(std::size_t vertices);

    /// Readies the triangle slots of the next `points` insertions, writing their memory
    /// in parallel: for a serial run of insertions, which would otherwise fault the fresh
    /// pages in one at a time. Changes no result.
    void prepare_insertions(std::size_t points);

    /// Vertex ids in use, dead ones (insert_batch) included.
    std::size_t vertex_count() const { return xy_.size(); }
    /// Whether an insert_batch was interrupted (or failed) before it ended, which leaves
    /// the triangulation unusable: insert and insert_batch then throw std::logic_error.
    bool broken() const { return broken_; }
    /// Vertex ids that insert_batch left without a vertex (points on existing vertices).
    std::size_t dead_vertex_count() const { return dead_vertices_; }
    /// Whether slot t (< triangle_count()) holds a triangle; insert_batch's unused slots
    /// do not, and no neighbour link leads to them.
    bool live(std::int32_t t) const { return tri_[t].v[0] >= 0; }
    std::size_t triangle_count() const { return triangles_; }
    std::int32_t vertex_x(std::int32_t v) const { return xy_[v].x; }
    std::int32_t vertex_y(std::int32_t v) const { return xy_[v].y; }
    /// Vertex k (0..2) of triangle t, counter-clockwise.
    std::int32_t triangle_vertex(std::int32_t t, int k) const { return tri_[t].v[k]; }
    /// Triangle across the edge opposite vertex k of t, or -1 on the box.
    std::int32_t neighbour(std::int32_t t, int k) const { return tri_[t].n[k]; }
    /// A triangle near v, to start a walk from: one having v as a vertex when insert()
    /// returned v (later insertions may rewrite it; it stays a valid id).
    std::int32_t vertex_triangle(std::int32_t v) const { return vt_[v]; }
    /// The stamp recorded on every slot written from now on; also empties touched().
    void set_stamp(std::int32_t stamp) {
        stamp_ = stamp;
        touched_.clear();
    }
    /// Slots given new vertices since the last set_stamp(), each once, in order.
    const std::vector<std::int32_t>& touched() const { return touched_; }

    /// Batches from this size on are inserted in strips (insert_batch).
    static constexpr std::size_t kBatchParallelMin = 32768;
    /// The strips of a parallel batch: fixed, so the result does not depend on the threads.
    static constexpr int kBatchZones = 4;
    /// Every kBatchSample-th point of a batch goes in first when the TIN is coarser.
    static constexpr std::size_t kBatchSample = 32;

   private:
    struct BatchZone;  // a strip of insert_batch, with its ids and scratch (delaunay_batch.cpp)
    // insert() without its broken() check, for insert_batch, which sets broken_ while it runs.
    std::int32_t insert_point(std::int32_t x, std::int32_t y, std::int32_t start, bool* inserted);
    // locate()'s walk from slot t; with a zone, only through the zone's triangles (-1
    // where it would leave them).
    std::int32_t walk(std::int32_t x, std::int32_t y, std::int32_t t, const BatchZone* zone) const;
    bool owned(std::int32_t t, const BatchZone& zone) const;
    bool in_conflict(std::int32_t t, std::int32_t x, std::int32_t y) const;
    int place(std::int32_t x, std::int32_t y, std::int32_t start, std::int32_t hint,
              BatchZone& zone, std::int32_t* vertex);
    void write(std::int32_t t, std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t na,
               std::int32_t nb, std::int32_t nc);
    void relink(std::int32_t t, std::int32_t from, std::int32_t to);
    std::int32_t new_slot();
    void legalize(std::int32_t t);

    struct Vertex {
        std::int32_t x, y;  // grid coordinates
    };
    // 32 bytes, aligned: one record never straddles two cache lines.
    struct alignas(32) Triangle {
        std::int32_t v[3];    // vertices, counter-clockwise
        std::int32_t n[3];    // n[k]: across the edge opposite v[k]
        std::int32_t stamp;   // the stamp when last written
        std::int32_t unused;  // padding
    };
    // Interleaved so that a walk step touches one cache line per record.
    // Not zero-filled when sized (UnfilledVector): insert_batch writes what it sizes.
    UnfilledVector<Vertex> xy_;
    UnfilledVector<std::int32_t> vt_;  // a nearby triangle per vertex (vertex_triangle)
    // Slots [0, triangles_) hold the triangles; beyond them, up to tri_.size(), slots that
    // prepare_insertions wrote ahead for the coming insertions.
    UnfilledVector<Triangle> tri_;
    std::size_t triangles_ = 0;
    std::vector<std::int32_t> stack_;    // edges to legalize
    std::vector<std::int32_t> touched_;  // slots written under the current stamp
    std::int32_t stamp_ = 0;
    std::size_t dead_vertices_ = 0;
    bool broken_ = false;  // an insert_batch threw midway (see broken())
};

/// A coarse lattice over a width x height grid box, of squares 2^shift grid steps wide,
/// as fine as at most `squares` squares allow. One triangle kept per square gives a walk
/// that would start far away a start near its point (final_pass, Delaunay::insert_batch).
struct HintLattice {
    HintLattice(std::int32_t width, std::int32_t height, std::size_t squares) {
        const auto side = [&](std::int32_t extent) {
            return static_cast<std::size_t>(extent >> shift) + 1;
        };
        while (side(width) * side(height) > std::max<std::size_t>(squares, 1)) ++shift;
        columns = side(width);
        rows = side(height);
    }
    std::size_t size() const { return columns * rows; }
    /// The square of grid point (x, y), both in [0, extent].
    std::size_t of(std::int32_t x, std::int32_t y) const {
        return static_cast<std::size_t>(y >> shift) * columns +
               static_cast<std::size_t>(x >> shift);
    }
    int shift = 0;
    std::size_t columns = 1, rows = 1;
};

/// A Delaunay TIN over the box [lower, upper] (metres) with the GridFrame that snaps to
/// it: the triangulation driven point by point, as tests of the triangulation use it.
struct DelaunayTin {
    GridFrame frame;
    double upper_x, upper_y;  ///< the box's upper corner (m)
    Delaunay tin;
    std::int32_t last = 0;  ///< where the next walk starts

    /// Throws std::invalid_argument when the bounds are not finite or not ordered.
    DelaunayTin(double lower_x, double lower_y, double upper_x, double upper_y);

    /// Grid coordinates (2 * m, x and y interleaved) of the m rows of `xy` (x, y in
    /// metres); throws std::invalid_argument naming the first row outside the bounds.
    std::vector<std::int32_t> to_grid(const double* xy, std::size_t m) const;
    /// Inserts the m grid points of `grid` in order; `vertex` (m) receives the vertex id
    /// of each (an existing one for a duplicate).
    void insert(const std::int32_t* grid, std::size_t m, std::int32_t* vertex);
    /// Inserts the m grid points of `grid`, each on the box's border, in order, through
    /// Delaunay::insert_on_border; `vertex` (m) receives the vertex id of each.
    void insert_on_border(const std::int32_t* grid, std::size_t m, std::int32_t* vertex);
    /// As insert, through Delaunay::insert_batch (the same triangulation, other ids).
    void insert_batch(const std::int32_t* grid, std::size_t m, std::int32_t* vertex);
    /// `triangle` (m) receives the triangle holding each grid point, perturbed by
    /// (eps, eps^2) (see Delaunay::locate). Polls for interruption.
    void locate(const std::int32_t* grid, std::size_t m, std::int32_t* triangle) const;
};

/// Delaunay triangles (3 * T) of the n points `xy` (x, y interleaved, metres), as
/// counter-clockwise row indices (duplicates: the first row), without the triangles of
/// the virtual box corners. Points are inserted in Morton order; polls for interruption.
std::vector<std::int64_t> delaunay_triangulate(const double* xy, std::size_t n);

}  // namespace pcl_rg
