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
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

Delaunay::Delaunay(std::int32_t width, std::int32_t height) { reset(width, height); }

void Delaunay::reset(std::int32_t width, std::int32_t height) {
    if (width < 2 || height < 2 || width > kMaxGridCoordinate || height > kMaxGridCoordinate)
        throw std::invalid_argument("Delaunay box must be within [2, 2^30] grid units, got " +
                                    std::to_string(width) + " x " + std::to_string(height));
    // Emptied and refilled, not reassigned, so that each array keeps its memory.
    stamp_ = 0;
    xy_.clear();
    for (const Vertex corner :
         {Vertex{0, 0}, Vertex{width, 0}, Vertex{width, height}, Vertex{0, height}})
        xy_.push_back(corner);
    // (0, 1, 2) and (0, 2, 3), both counter-clockwise, sharing the diagonal 0-2.
    tri_.clear();
    tri_.push_back({{0, 1, 2}, {-1, 1, -1}, stamp_, 0});
    tri_.push_back({{0, 2, 3}, {-1, -1, 0}, stamp_, 0});
    triangles_ = 2;
    vt_.clear();
    for (const std::int32_t t : {0, 0, 0, 1}) vt_.push_back(t);
    stack_.clear();
    touched_.clear();
    dead_vertices_ = 0;
    broken_ = false;
}

void Delaunay::reserve(std::size_t vertices) {
    // A triangulation of V vertices with h on the box's border has 2V - h - 2 triangles,
    // at most 2V - 6.
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
    // Slot 0 always holds a triangle; insert_batch's unused slots hold none.
    const bool usable = start >= 0 && start < static_cast<std::int32_t>(triangles_) && live(start);
    return walk(x, y, usable ? start : 0, nullptr);
}

std::int32_t Delaunay::walk(std::int32_t x, std::int32_t y, std::int32_t t,
                            const BatchZone* zone) const {
    std::int32_t previous = -1;
    // Visibility walk: cross any edge that has the point strictly on its far side. On a
    // Delaunay triangulation this cannot cycle (Edelsbrunner's acyclicity of the
    // in-front relation), and the answer does not depend on the path.
    const std::int64_t limit = 4 * static_cast<std::int64_t>(triangles_) + 64;
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
        if (zone != nullptr && !owned(tr.n[cross], *zone)) return -1;
        previous = t;
        t = tr.n[cross];
    }
    throw std::logic_error("Delaunay: point location did not terminate");
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

std::int32_t Delaunay::insert_on_border(std::int32_t x, std::int32_t y, std::int32_t start,
                                        bool* inserted) {
    if (broken_) throw std::logic_error("Delaunay: unusable after an interrupted batch");
    const std::int32_t width = xy_[2].x, height = xy_[2].y;
    const bool on_side = (x == 0 || x == width) ? (y >= 0 && y <= height)
                                                : ((y == 0 || y == height) && x > 0 && x < width);
    if (!on_side) throw std::invalid_argument("Delaunay: a border point must lie on the box");
    // Of triangle t's border edges (no neighbour across), the index k of the vertex
    // opposite the one holding p strictly inside, or -1; sets *vertex when p is an end.
    const auto border_edge = [&](std::int32_t t, std::int32_t* vertex) {
        const Triangle& tr = tri_[t];
        for (int k = 0; k < 3; ++k) {
            if (tr.n[k] >= 0) continue;
            const std::int32_t w1 = tr.v[(k + 1) % 3], w2 = tr.v[(k + 2) % 3];
            const Vertex a = xy_[w1], b = xy_[w2];
            if (orient2d(a.x, a.y, b.x, b.y, x, y) != 0) continue;
            if (x == a.x && y == a.y) *vertex = w1;
            if (x == b.x && y == b.y) *vertex = w2;
            if (*vertex >= 0) return -1;
            const bool between = a.x == b.x ? (std::min(a.y, b.y) < y && y < std::max(a.y, b.y))
                                            : (std::min(a.x, b.x) < x && x < std::max(a.x, b.x));
            if (between) return k;
        }
        return -1;
    };
    // The triangle: first among the few nearest `start` through neighbour links (the
    // next point along a side lies next to the last one's), else among all of them.
    constexpr std::size_t kNearby = 64;
    std::int32_t found = -1, k = -1, vertex = -1;
    if (start >= 0 && start < static_cast<std::int32_t>(triangles_) && live(start)) {
        std::vector<std::int32_t> seen{start};
        for (std::size_t i = 0; i < seen.size() && seen.size() < kNearby && found < 0; ++i) {
            k = border_edge(seen[i], &vertex);
            if (vertex >= 0) break;
            if (k >= 0) found = seen[i];
            for (const std::int32_t u : tri_[seen[i]].n)
                if (u >= 0 && std::find(seen.begin(), seen.end(), u) == seen.end())
                    seen.push_back(u);
        }
    }
    for (std::size_t slot = 0; slot < triangles_ && found < 0 && vertex < 0; ++slot) {
        const auto t = static_cast<std::int32_t>(slot);
        if (!live(t)) continue;
        k = border_edge(t, &vertex);
        if (k >= 0) found = t;
    }
    if (vertex >= 0) {
        *inserted = false;
        return vertex;
    }
    if (found < 0) throw std::logic_error("Delaunay: no border edge holds the point");
    if (xy_.size() >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("Delaunay: too many vertices for 32-bit ids");
    const std::int32_t t = found;
    const Triangle tr = tri_[t];
    const std::int32_t w0 = tr.v[k], w1 = tr.v[(k + 1) % 3], w2 = tr.v[(k + 2) % 3];
    const auto p = static_cast<std::int32_t>(xy_.size());
    xy_.push_back({x, y});
    vt_.push_back(t);
    *inserted = true;
    // (w0, w1, p) and (w0, p, w2), p first in each; their sides on the border have no
    // neighbour.
    const std::int32_t n1 = tr.n[(k + 1) % 3], n2 = tr.n[(k + 2) % 3];
    const std::int32_t t1 = t, t2 = new_slot();
    write(t1, p, w0, w1, n2, -1, t2);
    write(t2, p, w2, w0, n1, t1, -1);
    relink(n1, t, t2);
    stack_.clear();
    stack_.push_back(t1), stack_.push_back(t2);
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

void DelaunayTin::insert_on_border(const std::int32_t* grid, std::size_t m, std::int32_t* vertex) {
    for (std::size_t i = 0; i < m; ++i) {
        bool inserted = false;
        vertex[i] = tin.insert_on_border(grid[2 * i], grid[2 * i + 1], last, &inserted);
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
