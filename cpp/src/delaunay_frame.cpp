// The integer grid of the Delaunay TIN (delaunay.hpp): GridFrame, the snapping of points
// to it, and the Morton order in which the ground filters process and insert them.
// Apart from delaunay.cpp, which holds the triangulation itself, as delaunay_batch.cpp
// holds its parallel insertion. Written for this project (BSD-3-Clause).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

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
    constexpr std::size_t kAhead = 16;  // prefetch distance, in points
    const auto blocks = static_cast<std::ptrdiff_t>((n + kBlock - 1) / kBlock);
#pragma omp parallel for schedule(static) firstprivate(interruption)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) {
        if (interruption.requested()) continue;
        const std::size_t begin = static_cast<std::size_t>(b) * kBlock;
        for (std::size_t s = begin; s < std::min(n, begin + kBlock); ++s) {
            if (s + kAhead < n) {  // a point's 24 bytes may straddle two cache lines
                const double* ahead = points.xyz + 3 * (keys[s + kAhead] & id_mask);
                __builtin_prefetch(ahead), __builtin_prefetch(ahead + 2);
            }
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

}  // namespace pcl_rg
