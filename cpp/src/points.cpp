// Local-origin handling shared by every algorithm (see points.hpp).
#include "pcl_rg/points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace pcl_rg {

namespace {

// Per axis the least (take_max false) or greatest coordinate of the points and `start`,
// in parallel: min and max are exact, so the sharing out does not matter, except for the
// sign of a zero result, which the serial fold from `start` in index order settles (the
// first zero met wins), as it has always been.
std::array<double, 3> corner(PointsView points, bool take_max, const std::array<double, 3>& start) {
    std::array<double, 3> out = start;
    double x = start[0], y = start[1], z = start[2];
    const auto n = static_cast<std::ptrdiff_t>(points.size);
    if (take_max) {
#pragma omp parallel for schedule(static) reduction(max : x, y, z) if (n > 65536)
        for (std::ptrdiff_t i = 0; i < n; ++i) {
            x = std::max(x, points.coord(i, 0));
            y = std::max(y, points.coord(i, 1));
            z = std::max(z, points.coord(i, 2));
        }
    } else {
#pragma omp parallel for schedule(static) reduction(min : x, y, z) if (n > 65536)
        for (std::ptrdiff_t i = 0; i < n; ++i) {
            x = std::min(x, points.coord(i, 0));
            y = std::min(y, points.coord(i, 1));
            z = std::min(z, points.coord(i, 2));
        }
    }
    const double found[3] = {x, y, z};
    for (int a = 0; a < 3; ++a) {
        out[a] = found[a];
        if (found[a] != 0.0) continue;
        out[a] = start[a];
        for (std::size_t i = 0; i < points.size; ++i)
            out[a] = take_max ? std::max(out[a], points.coord(i, a))
                              : std::min(out[a], points.coord(i, a));
    }
    return out;
}

}  // namespace

std::array<double, 3> local_origin(PointsView points) {
    if (points.size == 0) return {0.0, 0.0, 0.0};
    const double inf = std::numeric_limits<double>::infinity();
    return corner(points, false, {inf, inf, inf});
}

std::array<double, 3> float32_origin(PointsView points) { return fenced_box(points).first; }

std::pair<std::array<double, 3>, std::array<double, 3>> fenced_box(PointsView points) {
    std::array<double, 3> origin{0.0, 0.0, 0.0}, top{0.0, 0.0, 0.0};
    if (points.size == 0) return {origin, top};
    for (int a = 0; a < 3; ++a) std::tie(origin[a], top[a]) = fenced_range(points, a, 0.0);
    return {origin, top};
}

std::pair<double, double> fenced_range(PointsView points, int axis, double min_reach) {
    const auto first = static_cast<std::ptrdiff_t>((points.size - 1) / 4);
    const auto third = static_cast<std::ptrdiff_t>(3 * (points.size - 1) / 4);
    // A copy, outside any parallel region: a bad_alloc then reaches the caller as
    // MemoryError instead of terminating inside OpenMP.
    std::vector<double> values(points.size);
    for (std::size_t i = 0; i < points.size; ++i) values[i] = points.coord(i, axis);
    std::nth_element(values.begin(), values.begin() + third, values.end());
    const double q3 = values[third];
    std::nth_element(values.begin(), values.begin() + first, values.begin() + third);
    const double q1 = values[first];
    const double reach = std::max(min_reach, kOriginFence * (q3 - q1));
    const double fence = q1 - reach, upper_fence = q3 + reach;
    double lowest = q1, highest = q3;  // within the fences: q1 and q3 are
    for (std::size_t i = 0; i < points.size; ++i) {
        const double value = points.coord(i, axis);
        if (value >= fence && value < lowest) lowest = value;
        if (value <= upper_fence && value > highest) highest = value;
    }
    return {lowest, highest};
}

std::array<double, 3> upper_corner(PointsView points, const std::array<double, 3>& origin) {
    return corner(points, true, origin);
}

double lattice_floor(double low, double size) {
    const double quotient = low / size;
    if (!(std::fabs(quotient) < 0x1p52)) return low;
    double k = std::floor(quotient);
    double corner = k * size;
    while (corner > low) corner = (k -= 1.0) * size;  // at most once for |k| < 2^52
    return corner;
}

std::vector<std::size_t> rows_within_float32_reach(PointsView points,
                                                   const std::array<double, 3>& origin) {
    std::vector<std::size_t> rows;
    for (std::size_t i = 0; i < points.size; ++i) {
        bool within = true;
        for (int a = 0; a < 3; ++a)
            within = within && std::fabs(points.coord(i, a) - origin[a]) <= kFloat32Reach;
        if (within) rows.push_back(i);
    }
    return rows;
}

Float32Frame float32_frame(PointsView points) {
    return float32_frame(points, float32_origin(points));
}

Float32Frame float32_frame(PointsView points, const std::array<double, 3>& origin) {
    Float32Frame frame;
    frame.local.resize(3 * points.size);
    const auto n = static_cast<std::ptrdiff_t>(points.size);
    bool beyond = false;
#pragma omp parallel for schedule(static) reduction(|| : beyond)
    for (std::ptrdiff_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            const double value = points.coord(i, a) - origin[a];
            frame.local[3 * i + a] = static_cast<float>(value);
            beyond = beyond || !(std::fabs(value) <= kFloat32Reach);
        }
    if (!beyond) return frame;
    frame.local = std::vector<float>();
    frame.near = rows_within_float32_reach(points, origin);
    const std::size_t far = points.size - frame.near.size();
    if (far > max_far_points(points.size))
        throw std::invalid_argument(
            "points: " + std::to_string(far) + " of " + std::to_string(points.size) +
            " points lie more than 2^24 x 0.1 = 1677721.6 (metres for LiDAR) from the local "
            "origin on some axis, where float32, which this step computes in, resolves no "
            "better than 0.125; up to 1 % of the points (at least one) are taken for stray "
            "points and left out, more mean a cloud too wide for one float32 frame: split "
            "it into tiles");
    return frame;
}

std::vector<double> gather_points(PointsView points, const std::vector<std::size_t>& rows) {
    std::vector<double> xyz(3 * rows.size());
    for (std::size_t r = 0; r < rows.size(); ++r)
        for (int a = 0; a < 3; ++a) xyz[3 * r + a] = points.coord(rows[r], a);
    return xyz;
}

void throw_beyond_float32_reach() {
    throw std::invalid_argument(
        "points: a coordinate lies more than 2^24 x 0.1 = 1677721.6 (metres for LiDAR) from "
        "the local origin on some axis, where float32, which this step computes in, "
        "resolves no better than 0.125; a stray point far from the rest? drop it, or split "
        "the cloud into tiles");
}

}  // namespace pcl_rg
