// Delaunay::insert_batch: many points into the TIN of delaunay.cpp at once, in
// vertical strips side by side, with the triangulation, vertex ids and slots that do
// not depend on the threads. Written for this project (BSD-3-Clause).
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
#include <algorithm>
#include <array>
#include <cstdint>
#include <exception>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

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
    t = walk(x, y, t, &zone);  // locate()'s walk, through the zone's triangles only
    if (t < 0) return -1;
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
    const HintLattice lattice(xy_[2].x, xy_[2].y, first_slot / 2 + 1);
    const auto zone_of = [&](std::int32_t vx) {
        return static_cast<std::int32_t>(std::upper_bound(bounds.begin(), bounds.end(), vx) -
                                         bounds.begin());
    };
    std::vector<std::array<std::int32_t, 2>> hints;  // (slot, zone)
    if (sampled || start == nullptr) {
        hints.assign(lattice.size(), {-1, -1});
        for (std::size_t t = 0; t < first_slot; ++t) {
            const Triangle& tr = tri_[t];
            if (tr.v[0] < 0) continue;
            const std::int32_t z = zone_of(xy_[tr.v[0]].x);
            if (zone_of(xy_[tr.v[1]].x) == z && zone_of(xy_[tr.v[2]].x) == z)
                hints[lattice.of(xy_[tr.v[0]].x, xy_[tr.v[0]].y)] = {static_cast<std::int32_t>(t),
                                                                     z};
        }
    }
    const auto hint_for = [&](std::uint32_t k, std::int32_t zone) {
        if (hints.empty()) return std::int32_t{-1};
        const auto [slot, owner] = hints[lattice.of(x[k], y[k])];
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

}  // namespace pcl_rg
