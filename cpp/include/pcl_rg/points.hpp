// Shared point handling: a read-only view of the caller's float64 points and the
// float32 local frame every PCL-facing algorithm works in.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace pcl_rg {

/// Read-only view of `size` points stored row-major as x, y, z (float64, caller's units).
struct PointsView {
    const double* xyz = nullptr;  ///< 3 * size values, never modified
    std::size_t size = 0;         ///< number of points

    double coord(std::size_t i, int axis) const { return xyz[3 * i + axis]; }
};

/// Lower corner of the bounding box, the float64 origin subtracted before anything
/// becomes float32, so UTM-sized coordinates lose nothing (zeros for an empty view).
std::array<double, 3> local_origin(PointsView points);

/// The points minus `origin`, as row-major float32 x, y, z: the local frame in which
/// distances are computed exactly as PCL computes them on its float clouds.
std::vector<float> to_local_float(PointsView points, const std::array<double, 3>& origin);

}  // namespace pcl_rg
