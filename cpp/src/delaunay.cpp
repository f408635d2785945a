// Incremental Delaunay triangulation: Lawson, "Software for C1 surface interpolation",
// Mathematical Software III, 1977 (insertion by splitting and edge flips); point
// location by the visibility walk (Devillers, Pion and Teillaud, "Walking in a
// triangulation", IJFCS 13(2), 2002), which terminates on Delaunay triangulations.
// The TIN of Axelsson's progressive densification (tin_ground.cpp). Written for this
// project (BSD-3-Clause).
//
// Exactness. Vertices live on an integer grid, every coordinate in [0, 2^30]
// (GridFrame snaps metres to it with a power-of-two quantum, so the snap itself is
// an exact division followed by one rounding). Then, with |differences| <= 2^30:
//   * orient2d: two products of at most 2^60 each, their difference at most 2^61 in
//     magnitude: exact in int64 (bound 2^63).
//   * incircle: squared lengths at most 2^61, the 2x2 minors at most 2^61, so each
//     of the three products is at most 2^122 and their sum at most 3 * 2^122 < 2^124:
//     exact in signed __int128 (bound 2^127); the minors and lifts are exact in int64.
// No floating point is involved, hence no filter and no fallback are needed: every
// predicate is exact, and the triangulation is a true Delaunay triangulation of the
// snapped points, robust to duplicates, collinear and co-circular points alike.
//
// Degeneracies.
//   * Duplicates: a point equal to a vertex is located on it and not inserted.
//   * Points on an edge split both triangles of the edge (2 -> 4).
//   * Co-circular points: the in-circle test breaks ties by a symbolic perturbation
//     of the lifted heights (incircle_perturbed, delaunay.hpp), so among the valid
//     Delaunay triangulations one is chosen by the points' coordinates alone, whatever
//     the order of insertion; which is what lets insert_batch insert in parallel.
//   * Location: the walk answers for p + (eps, eps^2), eps -> 0+, a symbolic
//     perturbation that puts every point strictly inside exactly one triangle, so a
//     point on an edge or vertex gets the same triangle whichever way it is reached.
#include "pcl_rg/delaunay.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

std::int32_t GridFrame::grid_x(double x) const {
    return static_cast<std::int32_t>(std::nearbyint((x - lower_x) / quantum)) + 1;
}

std::int32_t GridFrame::grid_y(double y) const {
    return static_cast<std::int32_t>(std::nearbyint((y - lower_y) / quantum)) + 1;
}

GridFrame make_grid_frame(double lower_x, double lower_y, double upper_x, double upper_y) {
    if (!std::isfinite(lower_x) || !std::isfinite(lower_y) || !std::isfinite(upper_x) ||
        !std::isfinite(upper_y))
        throw std::invalid_argument("the XY bounds must be finite");
    if (upper_x < lower_x || upper_y < lower_y)
        throw std::invalid_argument("the XY bounds must satisfy lower <= upper");
    const double ex = upper_x - lower_x, ey = upper_y - lower_y;
    if (!std::isfinite(ex) || !std::isfinite(ey))
        throw std::invalid_argument("points: the XY extent is too large (not finite in float64)");
    // Smallest power of two q >= extent / 2^29 (and >= 2^-40 m): extent / q <= 2^29.
    const double target = std::ldexp(std::max(ex, ey), -29);
    double quantum = std::ldexp(1.0, -40);
    if (target > quantum) {
        int exponent = 0;
        const double mantissa = std::frexp(target, &exponent);  // target = m * 2^e, m in [0.5, 1)
        quantum = std::ldexp(1.0, mantissa == 0.5 ? exponent - 1 : exponent);
    }
    GridFrame frame;
    frame.lower_x = lower_x;
    frame.lower_y = lower_y;
    frame.quantum = quantum;
    frame.width = static_cast<std::int32_t>(std::nearbyint(ex / quantum)) + 2;
    frame.height = static_cast<std::int32_t>(std::nearbyint(ey / quantum)) + 2;
    return frame;
}

int morton_cell_shift(std::int32_t width, std::int32_t height) {
    int shift = 0;
    while ((std::max(width, height) >> shift) >= (1 << kMortonAxisBits)) ++shift;
    return shift;
}

namespace {

// The 16 low bits of v moved to the even bit positions 0, 2, ..., 30 (a Morton code's x).
std::uint64_t spread_bits_2d(std::uint32_t v) {
    std::uint64_t w = v & 0xffffu;
    w = (w | w << 8) & 0x00ff00ffu;
    w = (w | w << 4) & 0x0f0f0f0fu;
    w = (w | w << 2) & 0x33333333u;
    w = (w | w << 1) & 0x55555555u;
    return w;
}

// Bits of the index under a curve key of n points.
int curve_id_bits(std::size_t n) { return std::max(1, bit_width(n)); }

// Each point's key, its curve cell's Morton code above its index, sorted: the order of
// morton_order_2d. grid_xy(i) gives point i's grid (x, y) in the box [0, width] x
// [0, height]. The sort is stable, so points of one cell stay in index order.
template <class GridXY>
UnfilledVector<std::uint64_t> sorted_curve_keys(std::size_t n, std::int32_t width,
                                                std::int32_t height, GridXY grid_xy) {
    constexpr int kAxisBits = kMortonAxisBits;
    static_assert(kAxisBits == 16 && 2 * kAxisBits + 32 <= 64,
                  "spread_bits_2d spreads 16 bits; the code and a 32-bit index fill one word");
    const int shift = morton_cell_shift(width, height);
    const int id_bits = curve_id_bits(n);
    UnfilledVector<std::uint64_t> keys(n);  // written in full below
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) {
        const auto [x, y] = grid_xy(static_cast<std::size_t>(i));
        const std::uint64_t code = spread_bits_2d(static_cast<std::uint32_t>(x >> shift)) |
                                   spread_bits_2d(static_cast<std::uint32_t>(y >> shift)) << 1;
        keys[i] = code << id_bits | static_cast<std::uint64_t>(i);
    }
    radix_sort_bits(keys, id_bits, id_bits + 2 * kAxisBits);
    return keys;
}

}  // namespace

SnappedPoints snap_frame(const std::array<double, 3>& origin, const std::array<double, 3>& upper) {
    SnappedPoints out;
    out.origin = origin;
    out.upper = upper;
    out.frame = make_grid_frame(0.0, 0.0, upper[0] - origin[0], upper[1] - origin[1]);
    return out;
}

SnappedPoints snap_points(PointsView points, const std::array<double, 3>& origin,
                          const std::array<double, 3>& upper) {
    const std::size_t n = points.size;
    SnappedPoints out = snap_frame(origin, upper);
    const Interruption interruption;
    const GridFrame& frame = out.frame;
    // The curve's keys straight from the coordinates, and after the sort each point's
    // record read once (one scattered read per point, not one per array).
    const UnfilledVector<std::uint64_t> keys =
        sorted_curve_keys(n, frame.width, frame.height, [&](std::size_t i) {
            return std::pair{out.grid_x(points, i), out.grid_y(points, i)};
        });
    interruption.check_now();
    // Not zero-filled (UnfilledVector): the parallel loop below writes every entry, and
    // the first writes of fresh pages are shared by the threads.
    out.order.resize(n), out.x.resize(n), out.y.resize(n), out.z.resize(n);
    const int id_bits = curve_id_bits(n);
    const std::uint64_t id_mask = (std::uint64_t{1} << id_bits) - 1;
    // In blocks polled once each: the reads miss the cache, the sweep takes a while.
    constexpr std::size_t kBlock = 4096;
    const auto blocks = static_cast<std::ptrdiff_t>((n + kBlock - 1) / kBlock);
#pragma omp parallel for schedule(static) firstprivate(interruption)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        if (interruption.requested()) continue;
        const std::size_t begin = static_cast<std::size_t>(b) * kBlock;
        for (std::size_t s = begin; s < std::min(n, begin + kBlock); ++s) {
            const auto i = static_cast<std::uint32_t>(keys[s] & id_mask);
            out.order[s] = i;
            out.x[s] = out.grid_x(points, i);
            out.y[s] = out.grid_y(points, i);
            out.z[s] = points.coord(i, 2) - origin[2];
        }
    }
    interruption.check();
    return out;
}

namespace {

// Orientation of (a, b, p + (eps, eps^2)): the exact orientation when non-zero, else
// the sign of its eps term (ay - by), else of its eps^2 term (bx - ax). Never zero for
// a != b, and antisymmetric in (a, b), so the perturbed point is on one side of
// every edge.
int orient_perturbed(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                     std::int64_t px, std::int64_t py) {
    const std::int64_t o = orient2d(ax, ay, bx, by, px, py);
    if (o != 0) return o > 0 ? 1 : -1;
    if (ay != by) return ay > by ? 1 : -1;
    return bx > ax ? 1 : -1;
}

}  // namespace

std::vector<std::uint32_t> morton_order_2d(const std::int32_t* gx, const std::int32_t* gy,
                                           std::size_t n, std::int32_t width, std::int32_t height) {
    const UnfilledVector<std::uint64_t> keys =
        sorted_curve_keys(n, width, height, [&](std::size_t i) {
            return std::pair{gx[i], gy[i]};
        });
    std::vector<std::uint32_t> order(n);
    const std::uint64_t id_mask = (std::uint64_t{1} << curve_id_bits(n)) - 1;
#pragma omp parallel for schedule(static)
    for (std::int64_t k = 0; k < static_cast<std::int64_t>(n); ++k)
        order[k] = static_cast<std::uint32_t>(keys[k] & id_mask);
    return order;
}

Delaunay::Delaunay(std::int32_t width, std::int32_t height) {
    if (width < 2 || height < 2 || width > kMaxGridCoordinate || height > kMaxGridCoordinate)
        throw std::invalid_argument("Delaunay box must be within [2, 2^30] grid units, got " +
                                    std::to_string(width) + " x " + std::to_string(height));
    xy_ = {{0, 0}, {width, 0}, {width, height}, {0, height}};
    // (0, 1, 2) and (0, 2, 3), both counter-clockwise, sharing the diagonal 0-2.
    tri_ = {{{0, 1, 2}, {-1, 1, -1}, stamp_, 0}, {{0, 2, 3}, {-1, -1, 0}, stamp_, 0}};
    triangles_ = 2;
    vt_ = {0, 0, 0, 1};
}

void Delaunay::reserve(std::size_t vertices) {
    // A triangulation of V vertices whose hull is the 4 box corners has 2V - 6 triangles.
    xy_.reserve(vertices);
    vt_.reserve(vertices);
    tri_.reserve(2 * vertices);
}

void Delaunay::prepare_insertions(std::size_t points) {
    // Every insertion adds two triangle slots. Written here once, side by side, they are
    // not faulted in one page at a time by the serial insertions that follow.
    const std::size_t first = tri_.size(), last = triangles_ + 2 * points;
    if (last <= first) return;
    tri_.resize(last);  // not zero-filled (UnfilledVector)
    const auto count = static_cast<std::ptrdiff_t>(last - first);
#pragma omp parallel for schedule(static) if (count > 65536)
    for (std::ptrdiff_t k = 0; k < count; ++k) tri_[first + k] = Triangle{};
}

void Delaunay::write(std::int32_t t, std::int32_t a, std::int32_t b, std::int32_t c,
                     std::int32_t na, std::int32_t nb, std::int32_t nc) {
    Triangle& tr = tri_[t];
    if (tr.stamp != stamp_) touched_.push_back(t);
    tr = Triangle{{a, b, c}, {na, nb, nc}, stamp_, 0};
    // Every write puts the point being inserted first: only its entry is kept up to
    // date (see vertex_triangle), which spares two scattered stores per write.
    vt_[a] = t;
}

void Delaunay::relink(std::int32_t t, std::int32_t from, std::int32_t to) {
    if (t < 0) return;
    for (int k = 0; k < 3; ++k)
        if (tri_[t].n[k] == from) {
            tri_[t].n[k] = to;
            return;
        }
    throw std::logic_error("Delaunay: broken neighbour link");
}

std::int32_t Delaunay::new_slot() {
    if (triangles_ >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("Delaunay: too many triangles for 32-bit ids");
    const auto t = static_cast<std::int32_t>(triangles_);
    // Stamped stamp_ - 1, so that write() lists it as touched.
    const Triangle fresh{{-1, -1, -1}, {-1, -1, -1}, stamp_ - 1, 0};
    if (triangles_ < tri_.size())
        tri_[triangles_] = fresh;  // a slot prepare_insertions made
    else
        tri_.push_back(fresh);
    ++triangles_;
    return t;
}

std::int32_t Delaunay::locate(std::int32_t x, std::int32_t y, std::int32_t start) const {
    const auto triangles = static_cast<std::int32_t>(triangles_);
    // Slot 0 always holds a triangle; insert_batch's unused slots hold none.
    std::int32_t t = (start >= 0 && start < triangles && live(start)) ? start : 0;
    std::int32_t previous = -1;
    // Visibility walk: cross any edge that has the point strictly on its far side. On a
    // Delaunay triangulation this cannot cycle (Edelsbrunner's acyclicity of the
    // in-front relation), and the answer does not depend on the path.
    const std::int64_t limit = 4 * static_cast<std::int64_t>(triangles) + 64;
    for (std::int64_t step = 0; step < limit; ++step) {
        const Triangle& tr = tri_[t];
        int cross = -1;
        for (int e = 0; e < 3 && cross < 0; ++e) {
            if (tr.n[e] == previous) continue;  // the side we came from holds the point
            const Vertex a = xy_[tr.v[e == 2 ? 0 : e + 1]], b = xy_[tr.v[e == 0 ? 2 : e - 1]];
            if (orient_perturbed(a.x, a.y, b.x, b.y, x, y) < 0) cross = e;
        }
        if (cross < 0) return t;
        if (tr.n[cross] < 0) throw std::logic_error("Delaunay: point outside the box");
        previous = t;
        t = tr.n[cross];
    }
    throw std::logic_error("Delaunay: point location did not terminate");
}

bool Delaunay::holds(std::int32_t t, std::int32_t x, std::int32_t y) const {
    const Triangle& tr = tri_[t];
    for (int e = 0; e < 3; ++e) {
        const Vertex a = xy_[tr.v[e == 2 ? 0 : e + 1]], b = xy_[tr.v[e == 0 ? 2 : e - 1]];
        if (orient_perturbed(a.x, a.y, b.x, b.y, x, y) < 0) return false;
    }
    return true;
}

std::int32_t Delaunay::insert(std::int32_t x, std::int32_t y, std::int32_t start, bool* inserted) {
    if (broken_) throw std::logic_error("Delaunay: unusable after an interrupted batch");
    return insert_point(x, y, start, inserted);
}

std::int32_t Delaunay::insert_point(std::int32_t x, std::int32_t y, std::int32_t start,
                                    bool* inserted) {
    if (x <= 0 || y <= 0 || x >= xy_[2].x || y >= xy_[2].y)
        throw std::invalid_argument("Delaunay: a point must lie strictly inside the box");
    const std::int32_t t = locate(x, y, start);
    const Triangle tr = tri_[t];
    const Vertex p0 = xy_[tr.v[0]], p1 = xy_[tr.v[1]], p2 = xy_[tr.v[2]];
    // p + (eps, eps^2) is strictly inside t, so p is in its closure: o_k >= 0.
    const std::int64_t o[3] = {orient2d(p1.x, p1.y, p2.x, p2.y, x, y),
                               orient2d(p2.x, p2.y, p0.x, p0.y, x, y),
                               orient2d(p0.x, p0.y, p1.x, p1.y, x, y)};
    const int zeros = (o[0] == 0) + (o[1] == 0) + (o[2] == 0);
    if (zeros >= 2) {  // two edge lines meet only at their common vertex: p is a vertex
        *inserted = false;
        for (int k = 0; k < 3; ++k)
            if (o[k] != 0) return tr.v[k];
        throw std::logic_error("Delaunay: degenerate triangle");
    }
    if (xy_.size() >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("Delaunay: too many vertices for 32-bit ids");
    const auto p = static_cast<std::int32_t>(xy_.size());
    xy_.push_back({x, y});
    vt_.push_back(t);
    *inserted = true;

    if (zeros == 0) {  // strictly inside: split t into three, p first in each
        const std::int32_t v0 = tr.v[0], v1 = tr.v[1], v2 = tr.v[2];
        const std::int32_t n0 = tr.n[0], n1 = tr.n[1], n2 = tr.n[2];
        const std::int32_t a = t, b = new_slot(), c = new_slot();
        write(a, p, v0, v1, n2, b, c);
        write(b, p, v1, v2, n0, c, a);
        write(c, p, v2, v0, n1, a, b);
        relink(n0, t, b);
        relink(n1, t, c);
        stack_.clear();  // pushed one by one: assigning a list calls memmove
        stack_.push_back(a), stack_.push_back(b), stack_.push_back(c);
    } else {  // on the edge opposite vertex k of t: split t and its neighbour u
        const int k = o[0] == 0 ? 0 : (o[1] == 0 ? 1 : 2);
        const std::int32_t w0 = tr.v[k], w1 = tr.v[(k + 1) % 3], w2 = tr.v[(k + 2) % 3];
        const std::int32_t u = tr.n[k];
        const std::int32_t n1 = tr.n[(k + 1) % 3], n2 = tr.n[(k + 2) % 3];
        if (u < 0) throw std::logic_error("Delaunay: point on the box edge");
        const Triangle ur = tri_[u];
        int j = 0;
        while (ur.n[j] != t) ++j;
        const std::int32_t d = ur.v[j];
        // u = (d, w2, w1): its neighbour across (d, w2) is opposite w1, across (w1, d) opposite w2.
        std::int32_t m1 = -1, m2 = -1;
        for (int i = 0; i < 3; ++i) {
            if (ur.v[i] == w1) m1 = ur.n[i];
            if (ur.v[i] == w2) m2 = ur.n[i];
        }
        const std::int32_t t1 = t, t2 = new_slot(), u1 = u, u2 = new_slot();
        write(t1, p, w0, w1, n2, u2, t2);
        write(t2, p, w2, w0, n1, t1, u1);
        write(u1, p, d, w2, m1, t2, u2);
        write(u2, p, w1, d, m2, u1, t1);
        relink(n1, t, t2);
        relink(m2, u, u2);
        stack_.clear();
        stack_.push_back(t1), stack_.push_back(t2), stack_.push_back(u1), stack_.push_back(u2);
    }
    legalize(p);
    return p;
}

void Delaunay::legalize(std::int32_t p) {
    // Every triangle on the stack has p as vertex 0; check the edge opposite p.
    const Vertex pv = xy_[p];
    while (!stack_.empty()) {
        const std::int32_t t = stack_.back();
        stack_.pop_back();
        const Triangle tr = tri_[t];
        const std::int32_t a = tr.v[1], b = tr.v[2], u = tr.n[0];
        if (u < 0) continue;
        const Triangle ur = tri_[u];
        int j = 0;
        while (ur.n[j] != t) ++j;
        const std::int32_t d = ur.v[j];
        const Vertex av = xy_[a], bv = xy_[b], dv = xy_[d];
        if (incircle_perturbed(pv.x, pv.y, av.x, av.y, bv.x, bv.y, dv.x, dv.y) < 0) continue;
        // Flip a-b to p-d. Old t = (p, a, b), u = (d, b, a) up to rotation.
        const std::int32_t t_pa = tr.n[2], t_bp = tr.n[1];
        std::int32_t u_ad = -1, u_db = -1;
        for (int i = 0; i < 3; ++i) {
            if (ur.v[i] == b) u_ad = ur.n[i];
            if (ur.v[i] == a) u_db = ur.n[i];
        }
        write(t, p, a, d, u_ad, u, t_pa);
        write(u, p, d, b, u_db, t_bp, t);
        relink(u_ad, u, t);
        relink(t_bp, t, u);
        stack_.push_back(t);
        stack_.push_back(u);
    }
}

// --- insert_batch ------------------------------------------------------------------
//
// Why strips can run side by side. A strip owns the triangles whose three vertices lie
// in it (x in [lower, upper)). An owned triangle's neighbours share two of its vertices,
// so they are owned by the same strip or by none ("mixed"); two strips' owned triangles
// never touch. An insertion in a strip (place) walks and grows its cavity through owned
// triangles only, reading of a mixed triangle nothing but its vertices, which no strip
// rewrites; it writes its own triangles and, of a mixed neighbour, only the link across
// the edge it shares with the cavity, which no other strip's triangle borders. A slot
// keeps its owner: the triangles a strip writes have the cavity's vertices and a point
// of the strip. So a strip's insertions do not depend on another strip's, their order or
// their timing; what one cannot do alone (its walk or cavity reaches a mixed triangle)
// it leaves, and those points go in afterwards, in k order, serially. With
// incircle_perturbed the cavity of p, the triangles whose circumcircle holds p, is
// exactly what Lawson's flips (insert) replace, so both build the same triangulation.

// Ids a strip hands out: ranges [first, last) used from the front.
struct IdRanges {
    std::vector<std::pair<std::int32_t, std::int32_t>> ranges;
    std::size_t at = 0;

    std::int32_t take() {
        while (at < ranges.size() && ranges[at].first == ranges[at].second) ++at;
        if (at == ranges.size()) throw std::logic_error("Delaunay: batch ids exhausted");
        return ranges[at].first++;
    }
};

struct Delaunay::BatchZone {
    std::int32_t lower = std::numeric_limits<std::int32_t>::min();  // x range [lower, upper)
    std::int32_t upper = std::numeric_limits<std::int32_t>::max();
    bool any = false;        // the serial pass after the strips: every triangle is its own
    std::int32_t last = -1;  // the last triangle written, where a walk may start
    IdRanges slots, vertices;
    std::vector<std::uint32_t> points;    // batch positions k of this strip, ascending
    std::vector<std::uint32_t> deferred;  // of those, the ones left for the serial pass
    std::vector<std::int32_t> touched;    // slots this strip gave the current stamp
    // Scratch of place(): the cavity's triangles and its boundary edges (a, b, across).
    std::vector<std::int32_t> cavity;
    std::vector<std::array<std::int32_t, 3>> edges;
    std::vector<std::int32_t> made;  // the slot of each new triangle, by edge
};

bool Delaunay::owned(std::int32_t t, const BatchZone& zone) const {
    if (zone.any) return true;
    for (int k = 0; k < 3; ++k) {
        const std::int32_t v = tri_[t].v[k];  // a mixed triangle: its vertices, nothing else
        if (v < 0 || xy_[v].x < zone.lower || xy_[v].x >= zone.upper) return false;
    }
    return true;
}

bool Delaunay::in_conflict(std::int32_t t, std::int32_t x, std::int32_t y) const {
    const Vertex a = xy_[tri_[t].v[0]], b = xy_[tri_[t].v[1]], c = xy_[tri_[t].v[2]];
    return incircle_perturbed(a.x, a.y, b.x, b.y, c.x, c.y, x, y) > 0;
}

// Inserts (x, y) within `zone` (Bowyer-Watson): 1 inserted, 0 found on a vertex, -1 left
// for later (nothing written).
int Delaunay::place(std::int32_t x, std::int32_t y, std::int32_t start, std::int32_t hint,
                    BatchZone& zone, std::int32_t* vertex) {
    const auto triangles = static_cast<std::int32_t>(triangles_);
    // Of the zone's last triangle, `hint` (one the zone owns, or -1) and `start` (the
    // triangle that held p before the batch, so the zone's or mixed, never another
    // zone's, or -1), the one whose first vertex is nearest.
    const auto distance2 = [&](std::int32_t from) {
        const Vertex v = xy_[tri_[from].v[0]];
        const std::int64_t dx = v.x - std::int64_t{x}, dy = v.y - std::int64_t{y};
        return dx * dx + dy * dy;
    };
    std::int32_t t = zone.last >= 0 ? zone.last : (zone.any ? 0 : -1);  // slot 0: never empty
    if (hint >= 0 && (t < 0 || distance2(hint) < distance2(t))) t = hint;
    if (start >= 0 && start < triangles && live(start) && owned(start, zone) &&
        (t < 0 || distance2(start) < distance2(t)))
        t = start;
    if (t < 0) return -1;
    // The visibility walk of locate(), through the zone's triangles only.
    std::int32_t previous = -1;
    const std::int64_t limit = 4 * static_cast<std::int64_t>(triangles) + 64;
    for (std::int64_t step = 0;; ++step) {
        if (step == limit) throw std::logic_error("Delaunay: point location did not terminate");
        const Triangle& tr = tri_[t];
        int cross = -1;
        for (int e = 0; e < 3 && cross < 0; ++e) {
            if (tr.n[e] == previous) continue;
            const Vertex a = xy_[tr.v[e == 2 ? 0 : e + 1]], b = xy_[tr.v[e == 0 ? 2 : e - 1]];
            if (orient_perturbed(a.x, a.y, b.x, b.y, x, y) < 0) cross = e;
        }
        if (cross < 0) break;
        const std::int32_t next = tr.n[cross];
        if (next < 0) throw std::logic_error("Delaunay: point outside the box");
        if (!owned(next, zone)) return -1;
        previous = t;
        t = next;
    }
    zone.last = t;
    {
        const Triangle& tr = tri_[t];
        const Vertex p0 = xy_[tr.v[0]], p1 = xy_[tr.v[1]], p2 = xy_[tr.v[2]];
        const bool zero[3] = {orient2d(p1.x, p1.y, p2.x, p2.y, x, y) == 0,
                              orient2d(p2.x, p2.y, p0.x, p0.y, x, y) == 0,
                              orient2d(p0.x, p0.y, p1.x, p1.y, x, y) == 0};
        if (zero[0] + zero[1] + zero[2] >= 2) {  // on a vertex: the one off both lines
            for (int k = 0; k < 3; ++k)
                if (!zero[k]) {
                    *vertex = tr.v[k];
                    return 0;
                }
            throw std::logic_error("Delaunay: degenerate triangle");
        }
    }
    // The cavity: the triangles whose circumcircle holds p, connected, from t (which
    // holds p in its closure). Its boundary edges, counter-clockwise seen from inside.
    std::vector<std::int32_t>& cavity = zone.cavity;
    std::vector<std::array<std::int32_t, 3>>& edges = zone.edges;
    cavity.assign(1, t);
    edges.clear();
    for (std::size_t c = 0; c < cavity.size(); ++c) {
        const Triangle tr = tri_[cavity[c]];  // owned: this zone alone writes it
        for (int e = 0; e < 3; ++e) {
            const std::int32_t u = tr.n[e];
            if (u >= 0 && std::find(cavity.begin(), cavity.end(), u) != cavity.end()) continue;
            if (u >= 0 && in_conflict(u, x, y)) {
                if (!owned(u, zone)) return -1;
                cavity.push_back(u);
            } else {
                edges.push_back({tr.v[e == 2 ? 0 : e + 1], tr.v[e == 0 ? 2 : e - 1], u});
            }
        }
    }
    if (edges.size() != cavity.size() + 2) throw std::logic_error("Delaunay: cavity not a disc");
    // One new triangle (p, a, b) per boundary edge, in the cavity's slots and two more.
    const std::int32_t p = zone.vertices.take();
    std::vector<std::int32_t>& made = zone.made;
    made.assign(cavity.begin(), cavity.end());
    made.push_back(zone.slots.take());
    made.push_back(zone.slots.take());
    const auto slot_where = [&](int side, std::int32_t v) {  // the edge with edge[side] == v
        for (std::size_t j = 0; j < edges.size(); ++j)
            if (edges[j][side] == v) return made[j];
        throw std::logic_error("Delaunay: cavity boundary not a cycle");
    };
    xy_[p] = {x, y};
    for (std::size_t i = 0; i < edges.size(); ++i) {
        const auto [a, b, u] = edges[i];
        Triangle& tr = tri_[made[i]];
        // The last two are fresh slots, unwritten until now (UnfilledVector).
        if (i >= cavity.size() || tr.stamp != stamp_) zone.touched.push_back(made[i]);
        tr = Triangle{{p, a, b}, {u, slot_where(0, b), slot_where(1, a)}, stamp_, 0};
        if (u < 0) continue;
        // u's link across (a, b), found by its vertices: its other links are not ours.
        Triangle& across = tri_[u];
        int j = 0;
        while (j < 3 && (across.v[j] == a || across.v[j] == b)) ++j;
        if (j == 3 || std::find(cavity.begin(), cavity.end(), across.n[j]) == cavity.end())
            throw std::logic_error("Delaunay: broken neighbour link");
        across.n[j] = made[i];
    }
    vt_[p] = made[0];
    zone.last = made[0];
    *vertex = p;
    return 1;
}

void Delaunay::insert_batch(const std::int32_t* x, const std::int32_t* y, const std::int32_t* start,
                            std::size_t m, std::int32_t* vertex) {
    if (broken_) throw std::logic_error("Delaunay: unusable after an interrupted batch");
    for (std::size_t k = 0; k < m; ++k)
        if (x[k] <= 0 || y[k] <= 0 || x[k] >= xy_[2].x || y[k] >= xy_[2].y)
            throw std::invalid_argument("Delaunay: a point must lie strictly inside the box");
    // Until the end, an exception (an interruption, a failed allocation) leaves a part of
    // the batch inserted, or ids and slots counted but unwritten: the TIN is unusable.
    broken_ = true;
    const Interruption interruption;
    const auto start_of = [&](std::size_t k) { return start != nullptr ? start[k] : -1; };
    std::int32_t last = 0;
    const auto insert_serially = [&](std::size_t k, std::int32_t from) {
        interruption.check();
        bool inserted = false;
        vertex[k] = insert_point(x[k], y[k], from >= 0 ? from : last, &inserted);
        last = vertex_triangle(vertex[k]);
    };
    if (m < kBatchParallelMin) {
        prepare_insertions(m);
        for (std::size_t k = 0; k < m; ++k) insert_serially(k, start_of(k));
        broken_ = false;
        return;
    }
    // A sample first, serially, when the TIN is much coarser than the batch.
    const bool sampled = xy_.size() * kBatchSample < m;
    if (sampled) prepare_insertions((m + kBatchSample - 1) / kBatchSample);
    std::vector<std::uint32_t> rest;
    rest.reserve(m);
    for (std::size_t k = 0; k < m; ++k) {
        if (sampled && k % kBatchSample == 0)
            insert_serially(k, start_of(k));
        else
            rest.push_back(static_cast<std::uint32_t>(k));
    }
    // Strips of about equal counts of the rest, by x quantiles (the same whatever the
    // threads); equal quantiles merge strips.
    std::vector<std::int32_t> bounds;
    {
        std::vector<std::int32_t> xs(rest.size());
        for (std::size_t r = 0; r < rest.size(); ++r) xs[r] = x[rest[r]];
        for (int z = 1; z < kBatchZones; ++z) {
            const auto nth = xs.begin() + static_cast<std::ptrdiff_t>(xs.size() * z / kBatchZones);
            std::nth_element(xs.begin(), nth, xs.end());
            if (bounds.empty() || *nth > bounds.back()) bounds.push_back(*nth);
        }
    }
    std::vector<BatchZone> zones(bounds.size() + 1);
    for (std::size_t z = 0; z < zones.size(); ++z) {
        if (z > 0) zones[z].lower = bounds[z - 1];
        if (z < bounds.size()) zones[z].upper = bounds[z];
    }
    for (const std::uint32_t k : rest)
        zones[std::upper_bound(bounds.begin(), bounds.end(), x[k]) - bounds.begin()]
            .points.push_back(k);
    // Each point of the rest gets one vertex id and two slots, in its zone's ranges.
    if (xy_.size() + rest.size() >
        static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("Delaunay: too many vertices for 32-bit ids");
    if (triangles_ + 2 * rest.size() >=
        static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("Delaunay: too many triangles for 32-bit ids");
    auto next_vertex = static_cast<std::int32_t>(xy_.size());
    auto next_slot = static_cast<std::int32_t>(triangles_);
    const std::size_t first_slot = triangles_;  // the slots before the batch's
    // Not written here (UnfilledVector): each strip writes its own entries as it takes
    // them, side by side, and what none takes is marked empty at the end.
    xy_.resize(xy_.size() + rest.size());
    vt_.resize(xy_.size());
    triangles_ += 2 * rest.size();
    if (tri_.size() < triangles_) tri_.resize(triangles_);
    for (BatchZone& zone : zones) {
        const auto count = static_cast<std::int32_t>(zone.points.size());
        zone.vertices.ranges = {{next_vertex, next_vertex + count}};
        zone.slots.ranges = {{next_slot, next_slot + 2 * count}};
        next_vertex += count;
        next_slot += 2 * count;
    }
    // Where walks may start without a start (a sampled batch's starts are stale: the
    // sample rewrote their slots, maybe into another zone's triangles): per square of a coarse
    // lattice, about one vertex each, a triangle at a vertex in it that one zone owns,
    // with that zone. A zone reads only its own hints: no other zone writes their slots.
    int hint_shift = 0;
    const auto hint_side = [&](std::int32_t extent) {
        return static_cast<std::size_t>(extent >> hint_shift) + 1;
    };
    while (hint_side(xy_[2].x) * hint_side(xy_[2].y) > first_slot / 2 + 1) ++hint_shift;
    const auto hint_of = [&](std::int32_t hx, std::int32_t hy) {
        return static_cast<std::size_t>(hy >> hint_shift) * hint_side(xy_[2].x) +
               static_cast<std::size_t>(hx >> hint_shift);
    };
    const auto zone_of = [&](std::int32_t vx) {
        return static_cast<std::int32_t>(std::upper_bound(bounds.begin(), bounds.end(), vx) -
                                         bounds.begin());
    };
    std::vector<std::array<std::int32_t, 2>> hints;  // (slot, zone)
    if (sampled || start == nullptr) {
        hints.assign(hint_side(xy_[2].x) * hint_side(xy_[2].y), {-1, -1});
        for (std::size_t t = 0; t < first_slot; ++t) {
            const Triangle& tr = tri_[t];
            if (tr.v[0] < 0) continue;
            const std::int32_t z = zone_of(xy_[tr.v[0]].x);
            if (zone_of(xy_[tr.v[1]].x) == z && zone_of(xy_[tr.v[2]].x) == z)
                hints[hint_of(xy_[tr.v[0]].x, xy_[tr.v[0]].y)] = {static_cast<std::int32_t>(t), z};
        }
    }
    const auto hint_for = [&](std::uint32_t k, std::int32_t zone) {
        if (hints.empty()) return std::int32_t{-1};
        const auto [slot, owner] = hints[hint_of(x[k], y[k])];
        return zone < 0 || owner == zone ? slot : std::int32_t{-1};
    };
    // The strips side by side; in any number of threads, the same insertions.
    std::exception_ptr failure;
    const auto zone_count = static_cast<std::ptrdiff_t>(zones.size());
#pragma omp parallel for schedule(dynamic, 1) firstprivate(interruption)
    for (std::ptrdiff_t z = 0; z < zone_count; ++z) {
        BatchZone zone = std::move(zones[z]);  // a copy of its own: no false sharing
        try {
            for (const std::uint32_t k : zone.points) {
                if (interruption.requested()) break;  // then thrown below, outside
                if (place(x[k], y[k], sampled ? -1 : start_of(k),
                          hint_for(k, static_cast<std::int32_t>(z)), zone, &vertex[k]) < 0)
                    zone.deferred.push_back(k);
            }
        } catch (...) {
#pragma omp critical(pcl_rg_delaunay_batch_failure)
            if (!failure) failure = std::current_exception();
        }
        zones[z] = std::move(zone);
    }
    if (failure) std::rethrow_exception(failure);
    interruption.check();
    // The points the strips left, in k order, serially, with the ids the strips did
    // not use; what stays unused then belongs to points found on a vertex.
    BatchZone serial;
    serial.any = true;
    serial.last = last;
    std::vector<std::uint32_t> deferred;
    for (BatchZone& zone : zones) {
        touched_.insert(touched_.end(), zone.touched.begin(), zone.touched.end());
        deferred.insert(deferred.end(), zone.deferred.begin(), zone.deferred.end());
        serial.vertices.ranges.push_back(zone.vertices.ranges.front());
        serial.slots.ranges.push_back(zone.slots.ranges.front());
    }
    std::sort(deferred.begin(), deferred.end());
    for (const std::uint32_t k : deferred) {
        interruption.check();
        if (place(x[k], y[k], start_of(k), hint_for(k, -1), serial, &vertex[k]) < 0)
            throw std::logic_error("Delaunay: a point no zone holds was deferred");
    }
    touched_.insert(touched_.end(), serial.touched.begin(), serial.touched.end());
    for (const auto& [first, end] : serial.vertices.ranges) {
        dead_vertices_ += static_cast<std::size_t>(end - first);
        for (std::int32_t v = first; v < end; ++v) xy_[v] = {-1, -1}, vt_[v] = -1;
    }
    for (const auto& [first, end] : serial.slots.ranges)
        for (std::int32_t t = first; t < end; ++t)
            tri_[t] = Triangle{{-1, -1, -1}, {-1, -1, -1}, stamp_ - 1, 0};
    broken_ = false;
}

DelaunayTin::DelaunayTin(double lower_x, double lower_y, double upper_x, double upper_y)
    : frame(make_grid_frame(lower_x, lower_y, upper_x, upper_y)),
      upper_x(upper_x),
      upper_y(upper_y),
      tin(frame.width, frame.height) {}

std::vector<std::int32_t> DelaunayTin::to_grid(const double* xy, std::size_t m) const {
    std::vector<std::int32_t> g(2 * m);
    for (std::size_t i = 0; i < m; ++i) {
        const double x = xy[2 * i], y = xy[2 * i + 1];
        if (!(x >= frame.lower_x && x <= upper_x && y >= frame.lower_y && y <= upper_y))
            throw std::invalid_argument("xy row " + std::to_string(i) +
                                        " lies outside the bounds of the triangulation");
        g[2 * i] = frame.grid_x(x);
        g[2 * i + 1] = frame.grid_y(y);
    }
    return g;
}

void DelaunayTin::insert(const std::int32_t* grid, std::size_t m, std::int32_t* vertex) {
    for (std::size_t i = 0; i < m; ++i) {
        bool inserted = false;
        vertex[i] = tin.insert(grid[2 * i], grid[2 * i + 1], last, &inserted);
        last = tin.vertex_triangle(vertex[i]);
    }
}

void DelaunayTin::insert_batch(const std::int32_t* grid, std::size_t m, std::int32_t* vertex) {
    std::vector<std::int32_t> x(m), y(m);
    for (std::size_t i = 0; i < m; ++i) x[i] = grid[2 * i], y[i] = grid[2 * i + 1];
    tin.insert_batch(x.data(), y.data(), nullptr, m, vertex);
    if (m > 0) last = tin.vertex_triangle(vertex[m - 1]);
}

void DelaunayTin::locate(const std::int32_t* grid, std::size_t m, std::int32_t* triangle) const {
    if (tin.broken()) throw std::logic_error("Delaunay: unusable after an interrupted batch");
    const Interruption interruption;
    std::int32_t start = last;
    for (std::size_t i = 0; i < m; ++i) {
        interruption.check();
        start = triangle[i] = tin.locate(grid[2 * i], grid[2 * i + 1], start);
    }
}

std::vector<std::int64_t> delaunay_triangulate(const double* xy, std::size_t n) {
    std::vector<std::int64_t> triangles;
    if (n == 0) return triangles;
    double lo[2], hi[2];
    for (int a = 0; a < 2; ++a) {
        lo[a] = std::numeric_limits<double>::infinity();
        hi[a] = -lo[a];
        for (std::size_t i = 0; i < n; ++i) {
            lo[a] = std::min(lo[a], xy[2 * i + a]);
            hi[a] = std::max(hi[a], xy[2 * i + a]);
        }
    }
    const GridFrame frame = make_grid_frame(lo[0], lo[1], hi[0], hi[1]);
    std::vector<std::int32_t> gx(n), gy(n);
    for (std::size_t i = 0; i < n; ++i) {
        gx[i] = frame.grid_x(xy[2 * i]);
        gy[i] = frame.grid_y(xy[2 * i + 1]);
    }
    Delaunay tin(frame.width, frame.height);
    // In curve order, through insert_batch; of rows on one grid XY the first in that
    // order, the smallest (the curve's sort is stable), is the vertex's row.
    const std::vector<std::uint32_t> order =
        morton_order_2d(gx.data(), gy.data(), n, frame.width, frame.height);
    std::vector<std::int32_t> bx(n), by(n), vertex(n);
    for (std::size_t k = 0; k < n; ++k) bx[k] = gx[order[k]], by[k] = gy[order[k]];
    tin.insert_batch(bx.data(), by.data(), nullptr, n, vertex.data());
    std::vector<std::int64_t> point_of_vertex(tin.vertex_count(), -1);  // box corners: none
    for (std::size_t k = 0; k < n; ++k)
        if (point_of_vertex[vertex[k]] < 0) point_of_vertex[vertex[k]] = order[k];
    for (std::size_t t = 0; t < tin.triangle_count(); ++t) {
        if (!tin.live(static_cast<std::int32_t>(t))) continue;
        std::int64_t ids[3];
        bool virtual_corner = false;
        for (int k = 0; k < 3; ++k) {
            ids[k] = point_of_vertex[tin.triangle_vertex(static_cast<std::int32_t>(t), k)];
            virtual_corner = virtual_corner || ids[k] < 0;
        }
        if (!virtual_corner) triangles.insert(triangles.end(), ids, ids + 3);
    }
    return triangles;
}

}  // namespace pcl_rg
