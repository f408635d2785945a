// Pieces shared by the TINs of the ground filters, the densification's
// (tin_ground.cpp, tin_acceptance.hpp) and the final pass's (final_pass.cpp): the plane
// of a triangle, the virtual vertices of the box (corners and border points) with their
// heights, and the last two triangles a thread located. Inline, in a header private to
// cpp/src, as they run in the hot loops.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/unfilled_vector.hpp"

namespace pcl_rg::ground_tin {

// A triangle with its vertices counter-clockwise from the lexicographically smallest
// (x, y), so that the floating-point results do not depend on how it is stored, and its
// normal n = (v1 - v0) x (v2 - v0) (nz > 0).
struct Plane {
    std::array<std::int32_t, 3> v;
    double x[3], y[3], z[3];  // metres, local frame
    double nx, ny, nz;
};

// The plane of triangle t of `tin`, vertex heights `vz`, grid step `quantum` (m).
inline Plane plane_of(const Delaunay& tin, const UnfilledVector<double>& vz, double quantum,
                      std::int32_t t) {
    Plane f;
    const std::int32_t stored[3] = {tin.triangle_vertex(t, 0), tin.triangle_vertex(t, 1),
                                    tin.triangle_vertex(t, 2)};
    int first = 0;
    for (int k = 1; k < 3; ++k) {
        const std::int32_t a = stored[k], b = stored[first];
        if (tin.vertex_x(a) < tin.vertex_x(b) ||
            (tin.vertex_x(a) == tin.vertex_x(b) && tin.vertex_y(a) < tin.vertex_y(b)))
            first = k;
    }
    // Rotated by hand: std::rotate on three ints calls memmove, once per facet.
    f.v = {stored[first], stored[(first + 1) % 3], stored[(first + 2) % 3]};
    for (int k = 0; k < 3; ++k) {
        f.x[k] = static_cast<double>(tin.vertex_x(f.v[k]) - 1) * quantum;
        f.y[k] = static_cast<double>(tin.vertex_y(f.v[k]) - 1) * quantum;
        f.z[k] = vz[f.v[k]];
    }
    const double ux = f.x[1] - f.x[0], uy = f.y[1] - f.y[0], uz = f.z[1] - f.z[0];
    const double wx = f.x[2] - f.x[0], wy = f.y[2] - f.y[0], wz = f.z[2] - f.z[0];
    f.nx = uy * wz - uz * wy;
    f.ny = uz * wx - ux * wz;
    f.nz = ux * wy - uy * wx;
    return f;
}

// Of `count` candidates (grid XY gx(k), gy(k), height z(k), point index index(k)), the
// one nearest to each corner of `frame`'s box, (0, 0), (width, 0), (width, height),
// (0, height): exact squared grid distance, ties by the lowest height, then by the
// smallest index. Returns the k of each. The corner takes the height, which so does
// not depend on the order of the points: only candidates of one height tie on.
template <class GridX, class GridY, class Height, class Index>
std::array<std::size_t, 4> nearest_to_corners(const GridFrame& frame, std::size_t count, GridX gx,
                                              GridY gy, Height z, Index index) {
    const std::int64_t corner_x[4] = {0, frame.width, frame.width, 0};
    const std::int64_t corner_y[4] = {0, 0, frame.height, frame.height};
    const auto d2 = [&](int c, std::size_t k) {
        const std::int64_t dx = gx(k) - corner_x[c], dy = gy(k) - corner_y[c];
        return dx * dx + dy * dy;
    };
    // k before j for corner c: nearer, then lower, then smaller index (a total order).
    const auto before = [&](int c, std::size_t k, std::size_t j) {
        const std::int64_t dk = d2(c, k), dj = d2(c, j);
        if (dk != dj) return dk < dj;
        const double zk = z(k), zj = z(j);
        return zk < zj || (zk == zj && index(k) < index(j));
    };
    // Each fixed block's nearest, in parallel, then the nearest of those: the minimum
    // under a total order, whatever the threads.
    constexpr std::size_t kBlock = 65536;
    const auto blocks = static_cast<std::ptrdiff_t>((count + kBlock - 1) / kBlock);
    std::vector<std::array<std::size_t, 4>> block_nearest(static_cast<std::size_t>(blocks));
#pragma omp parallel for schedule(static) if (blocks > 1)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        const std::size_t first = static_cast<std::size_t>(b) * kBlock;
        std::array<std::size_t, 4>& best = block_nearest[b];
        best.fill(first);
        for (std::size_t k = first + 1; k < std::min(count, first + kBlock); ++k)
            for (int c = 0; c < 4; ++c)
                if (before(c, k, best[c])) best[c] = k;
    }
    std::array<std::size_t, 4> nearest{};
    for (std::ptrdiff_t b = 0; b < blocks; ++b)
        for (int c = 0; c < 4; ++c)
            if (b == 0 || before(c, block_nearest[b][c], nearest[c]))
                nearest[c] = block_nearest[b][c];
    return nearest;
}

// A point of the TIN's integer grid.
struct GridPoint {
    std::int32_t x, y;
};

// The most parts border_points cuts a side into (a corridor 2,600 km long at 40 m).
inline constexpr std::int64_t kMaxBorderParts = 65536;

// The virtual vertices on the sides of `frame`'s box besides its corners. The sides along
// x are cut into parts = min(max(floor(extent_x / spacing), 1), kMaxBorderParts) equal
// parts, at grid x = floor(j * width / parts), j = 1 .. parts - 1, and so the sides along
// y (extents and spacing in metres, spacing > 0): vertices at least `spacing` and less
// than twice it apart (further where the cap binds; on a grid too coarse for the cuts,
// some fall on one position, which the insertion keeps once), none on a side shorter
// than twice it (a tile about square gets none, and only the long sides of a box get
// any). In the order of their cuts j, those of the two opposite sides in turn, (x_j, 0),
// (x_j, height), ..., then (0, y_j), (width, y_j), ...: each insertion then changes a few
// triangles next to the last one's (side by side, the flips of each vertex of the second
// side would sweep a fan over all of the first's).
inline std::vector<GridPoint> border_points(const GridFrame& frame, double extent_x,
                                            double extent_y, double spacing) {
    std::vector<GridPoint> out;
    const auto parts_of = [&](double extent) {
        const double parts = std::floor(extent / spacing);
        if (!(parts >= 1.0)) return std::int64_t{1};
        return parts >= static_cast<double>(kMaxBorderParts) ? kMaxBorderParts
                                                             : static_cast<std::int64_t>(parts);
    };
    const std::int64_t along_x = parts_of(extent_x), along_y = parts_of(extent_y);
    for (std::int64_t j = 1; j < along_x; ++j)
        for (const std::int32_t y : {std::int32_t{0}, frame.height})
            out.push_back({static_cast<std::int32_t>(j * frame.width / along_x), y});
    for (std::int64_t j = 1; j < along_y; ++j)
        for (const std::int32_t x : {std::int32_t{0}, frame.width})
            out.push_back({x, static_cast<std::int32_t>(j * frame.height / along_y)});
    return out;
}

// Of `count` candidates (as for nearest_to_corners), the k of the one nearest to each of
// `targets`, points of the box's sides (border_points), by the order of
// nearest_to_corners. Candidates sorted along the side are scanned outwards from the
// target until the distance along it alone exceeds the nearest so far: a corridor's
// side vertices each look at the candidates across the corridor near them, not at all.
template <class GridX, class GridY, class Height, class Index>
std::vector<std::size_t> nearest_to_border(const GridFrame& frame,
                                           const std::vector<GridPoint>& targets, std::size_t count,
                                           GridX gx, GridY gy, Height z, Index index) {
    std::vector<std::size_t> nearest(targets.size(), 0);
    if (targets.empty() || count == 0) return nearest;
    // Candidates by grid x (for the sides y = 0 and y = height) and by grid y, each key
    // the coordinate above the candidate's k.
    std::vector<std::uint64_t> by_axis[2];
    for (int axis = 0; axis < 2; ++axis) {
        const bool used = std::any_of(targets.begin(), targets.end(), [&](const GridPoint& p) {
            return axis == 0 ? (p.y == 0 || p.y == frame.height) && p.x != 0 && p.x != frame.width
                             : (p.x == 0 || p.x == frame.width);
        });
        if (!used) continue;
        by_axis[axis].resize(count);
        for (std::size_t k = 0; k < count; ++k) {
            const std::int64_t u = axis == 0 ? gx(k) : gy(k);
            by_axis[axis][k] = static_cast<std::uint64_t>(u) << 32 | static_cast<std::uint64_t>(k);
        }
        std::sort(by_axis[axis].begin(), by_axis[axis].end());
    }
    const auto total = static_cast<std::ptrdiff_t>(targets.size());
#pragma omp parallel for schedule(dynamic, 16) if (total > 64)
    for (std::ptrdiff_t t = 0; t < total; ++t) {
        const GridPoint p = targets[t];
        const int axis = (p.x == 0 || p.x == frame.width) ? 1 : 0;
        const std::vector<std::uint64_t>& keys = by_axis[axis];
        const std::int64_t along = axis == 0 ? p.x : p.y;
        const auto d2 = [&](std::size_t k) {
            const std::int64_t dx = gx(k) - p.x, dy = gy(k) - p.y;
            return dx * dx + dy * dy;
        };
        // k before j: nearer, then lower, then smaller index (nearest_to_corners's order).
        const auto before = [&](std::size_t k, std::size_t j) {
            const std::int64_t dk = d2(k), dj = d2(j);
            if (dk != dj) return dk < dj;
            const double zk = z(k), zj = z(j);
            return zk < zj || (zk == zj && index(k) < index(j));
        };
        std::size_t best = count;  // none yet
        const auto consider = [&](std::uint64_t key) {
            const auto k = static_cast<std::size_t>(key & 0xffffffffu);
            const std::int64_t du = static_cast<std::int64_t>(key >> 32) - along;
            if (best < count && du * du > d2(best)) return false;  // and so every further one
            if (best == count || before(k, best)) best = k;
            return true;
        };
        const auto first =
            std::lower_bound(keys.begin(), keys.end(), static_cast<std::uint64_t>(along) << 32);
        for (auto it = first; it != keys.end() && consider(*it); ++it) {
        }
        for (auto it = first; it != keys.begin() && consider(*(it - 1)); --it) {
        }
        nearest[t] = best;
    }
    return nearest;
}

// The last two triangles a thread located, each with what the thread derived from it
// (a facet, a plane): the next point in curve order often lies in one of them (the curve
// crosses edges back and forth), and a point's triangle is unique (Delaunay::locate), so
// they are checked first and their data reused.
template <class Data>
class RecentTriangles {
   public:
    struct Entry {
        std::int32_t t = -1;  // -1: none yet
        Data data{};
    };

    /// The triangle holding grid point (x, y) with its data: one of the two when it holds
    /// the point, else t = locate(the newest triangle, or -1) and data = derive(t), in
    /// place of the older one.
    template <class Locate, class Derive>
    const Entry& find(const Delaunay& tin, std::int32_t x, std::int32_t y, Locate locate,
                      Derive derive) {
        if (holds(tin, entry_[newest_], x, y)) return entry_[newest_];
        Entry& other = entry_[1 - newest_];
        if (!holds(tin, other, x, y)) {
            other.t = locate(entry_[newest_].t);
            other.data = derive(other.t);
        }
        newest_ = 1 - newest_;
        return other;
    }

   private:
    static bool holds(const Delaunay& tin, const Entry& e, std::int32_t x, std::int32_t y) {
        return e.t >= 0 && tin.holds(e.t, x, y);
    }

    Entry entry_[2];
    int newest_ = 0;  // entry_[newest_]: the last one found
};

}  // namespace pcl_rg::ground_tin
