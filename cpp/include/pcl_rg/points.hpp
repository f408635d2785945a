// Shared point handling: a read-only view of the caller's float64 points and the
// float32 local frame every PCL-facing algorithm works in.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
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

/// The float64 origin of the float32 frames in which the k-nearest-neighbour steps and
/// PCL's k-nearest-neighbour classes see the points: per axis the least coordinate that
/// is not below the fence q1 - kOriginFence * (q3 - q1), q1 and q3 the coordinates at
/// sorted positions (N - 1) / 4 and 3 (N - 1) / 4 (zeros for an empty view). That is the
/// minimum corner unless some points lie far below the rest: float32 resolves a
/// coordinate relative to its size, so one stray point 100 km below a Kinect scene (a
/// bad GPS fix) moved the frame that far from every other point, which lost its
/// millimetres, and its normals and segments silently went wrong. Order-independent.
/// NumPy twin: pcl_rg.reference._local.float32_origin.
std::array<double, 3> float32_origin(PointsView points);

/// The bounding box of the points within the fences q1 - kOriginFence * (q3 - q1) and
/// q3 + kOriginFence * (q3 - q1) per axis (float32_origin's quartiles): the box of a
/// cloud without its stray points, such as a record at (0, 0, 0) in a projected tile.
/// Its lower corner is float32_origin. Zeros for an empty view. NumPy twin:
/// pcl_rg.reference._local.fenced_box.
std::pair<std::array<double, 3>, std::array<double, 3>> fenced_box(PointsView points);

/// The range of coordinate `axis` of the points (N > 0) within max(min_reach,
/// kOriginFence * (q3 - q1)) of its quartiles q1 and q3 (float32_origin's): fenced_box's
/// per axis with min_reach 0, and with a wider reach where a cloud's spread is not
/// stray (the default viewpoint's z). NumPy twin: pcl_rg.reference._local.fenced_range.
std::pair<double, double> fenced_range(PointsView points, int axis, double min_reach);

/// The fence of float32_origin, in interquartile ranges below the first quartile: far
/// enough that no ordinary cloud (a tile, a scan) has a point beyond it, so that their
/// frame stays the minimum corner.
constexpr double kOriginFence = 4.0;

/// Upper corner of the bounding box, `origin` being local_origin(points) (itself for an
/// empty view).
std::array<double, 3> upper_corner(PointsView points, const std::array<double, 3>& origin);

/// The largest k * size (k a whole number, the product in float64) that is <= low: the
/// corner of the world lattice of step `size` at or below `low`, so that grids anchored
/// there line up across tiles. floor(low / size) * size alone can land above low, as the
/// quotient may round up to a whole number; then k goes down by one. Returns low itself
/// when |low / size| >= 2^52, where whole numbers k are no longer all representable (a
/// lattice that fine has no use). NumPy twin: pcl_rg.reference.lattice_floor.
double lattice_floor(double low, double size);

/// floor(q) as an integer, equal to static_cast<std::int64_t>(std::floor(q)) for every
/// |q| < 2^63 (truncation is exact there, and from 2^52 on q is whole), but without a call
/// into libm, which the x86-64 baseline (no SSE4.1 rounding) makes for std::floor.
inline std::int64_t floor_to_int(double q) {
    const auto truncated = static_cast<std::int64_t>(q);
    return truncated - (q < static_cast<double>(truncated) ? 1 : 0);
}

/// How far from the local origin a float32 coordinate may lie: 2^24 x 0.1, about 1.68e6
/// (1,678 km for LiDAR in metres), where float32's step reaches 0.125, so points about
/// 0.1 apart could merge (and a point beyond 3.4e38 becomes infinite). No tile spans
/// that much: what lies beyond is a stray point.
constexpr double kFloat32Reach = 0x1p24 * 0.1;

/// Throws the error of a float32 frame that cannot hold the points (a coordinate beyond
/// kFloat32Reach of the local origin): PCL's clouds (pcl_cloud.cpp), which hold every
/// point; our own steps leave a few far points out instead (float32_frame).
[[noreturn]] void throw_beyond_float32_reach();

/// The float32 frame of one of our k-nearest-neighbour steps (normals, neighbour lists,
/// outlier removal, point_scale). A point beyond kFloat32Reach of float32_origin on some
/// axis is far: a stray point (a bad GPS fix, a record at (0, 0, 0) in a UTM tile) that
/// float32 cannot place among the rest, and whose neighbours lie at least that far away.
/// Up to max_far_points(N) far points are left out: the step runs on the others as if
/// the far ones were absent (in their own frame) and gives each far point the result of
/// a point without neighbours. More are refused: the cloud is too wide for one frame.
struct Float32Frame {
    std::vector<float> local;       ///< the points less the origin, when none is far
    std::vector<std::size_t> near;  ///< else the points that are not far, ascending

    bool has_far_points() const { return !near.empty(); }
};

/// The frame of `points` (a non-empty view); throws std::invalid_argument when more
/// than max_far_points(points.size) points are far. NumPy twin:
/// pcl_rg.reference._local.near_rows.
Float32Frame float32_frame(PointsView points);

/// The same at a given `origin` instead of float32_origin(points): pcl_rg.batch's
/// denoise passes the merged survey's, so that a tile and its buffer get the float32
/// coordinates, and so the neighbour distances, of one run over the merged survey.
Float32Frame float32_frame(PointsView points, const std::array<double, 3>& origin);

/// The rows of `points` within kFloat32Reach of `origin` on every axis, ascending. Any
/// number may be far here. float32_frame passes float32_origin(points); pcl_rg.batch's
/// denoise passes one origin for the whole survey, so that a tile whose own cloud is
/// mostly bad records (whose own origin lies among them) still keeps the points that
/// one run over the merged survey would keep, and it applies max_far_points to the
/// survey's count.
std::vector<std::size_t> rows_within_float32_reach(PointsView points,
                                                   const std::array<double, 3>& origin);

/// How many far points (Float32Frame) a step leaves out of N: 1 % of N, and at least one.
inline std::size_t max_far_points(std::size_t n) { return n / 100 > 1 ? n / 100 : 1; }

/// The points `rows` of `points`, copied row-major: the cloud a step runs on when it
/// leaves the far points out.
std::vector<double> gather_points(PointsView points, const std::vector<std::size_t>& rows);

}  // namespace pcl_rg
