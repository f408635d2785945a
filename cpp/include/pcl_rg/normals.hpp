// Normals and curvatures from k-nearest neighbourhoods: PCA normal and PCL's surface
// variation, plus Gaussian, mean and principal curvatures of a local quadric
// (algorithms.md section 5, steps 1 and 2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// The fewest neighbours (the point itself included) whose quadric fit gives curvatures:
/// with fewer, K, H, k1, k2 and the curvedness are NaN. Python mirror:
/// pcl_rg._normals.MIN_CURVATURE_K.
inline constexpr int kMinCurvatureK = 6;

struct NormalsParams {
    /// Neighbours per point, the point itself included (>= 3, < N); PCL setKSearch.
    int k = 30;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const NormalsParams& params);

/// Caller-owned outputs, N entries each (normal: 3 * N, row-major). Every pointer
/// except `normal` may be null when that quantity is not wanted.
struct NormalsOutput {
    double* normal = nullptr;              ///< unit normal, n_z >= 0 (see normals())
    double* surface_variation = nullptr;   ///< lambda0 / (lambda0 + lambda1 + lambda2)
    double* gaussian_curvature = nullptr;  ///< K of the local quadric (1/m^2)
    double* mean_curvature = nullptr;      ///< H of the local quadric, signed by the normal (1/m)
    double* k1 = nullptr;                  ///< larger principal curvature, H + sqrt(H^2 - K) (1/m)
    double* k2 = nullptr;                  ///< smaller principal curvature, H - sqrt(H^2 - K) (1/m)
};

/// Rank tolerance of the quadric fit: the fit is refused (curvatures NaN) when a
/// squared Cholesky pivot of the 6x6 normal matrix divided by k is not above this, with
/// the tangent coordinates scaled to unit RMS radius and the design columns in the
/// order x^2, xy, y^2, x, y, 1 (pivot j squared: the mean squared distance of column j
/// from the span of the previous columns).
inline constexpr double kQuadricConditionLimit = 1e-10;

/// Per point, over its `k` nearest neighbours (itself included; k-d tree on the
/// float32 local frame; see knn.hpp for ties at the k-th distance):
///  * normal: eigenvector of the smallest eigenvalue lambda0 of the float64 covariance
///    of the neighbours, oriented so n_z > 0 (n_z == 0: n_y > 0, then n_x > 0);
///  * surface variation lambda0 / trace(covariance) (PCL's Normal::curvature);
///  * a least-squares quadric z = a x^2 + b xy + c y^2 + d x + e y + f in the frame
///    (largest-eigenvalue axis, normal x it, normal) centred at the point, from which
///    K = (4ac - b^2) / (1 + d^2 + e^2)^2,
///    H = ((1 + e^2) a - d e b + (1 + d^2) c) / (1 + d^2 + e^2)^(3/2),
///    k1,2 = H +- sqrt(max(H^2 - K, 0)).
/// Degenerate neighbourhoods: all k points coincident -> every output NaN; fewer than
/// 6 neighbours or a rank-deficient quadric design (e.g. collinear points) -> K, H,
/// k1, k2 NaN while the normal and surface variation are kept (for collinear points
/// the normal is an arbitrary unit vector perpendicular to the line). Far points
/// (float32_frame, points.hpp) are left out: every output NaN, and a row of themselves.
/// When `neighbours` is not null it receives the N x k neighbour lists (row-major).
/// Throws std::invalid_argument when k >= N (non-empty input). Returns how many far
/// points were left out (those of the kept points' own frame included).
std::size_t normals(PointsView points, const NormalsParams& params, const NormalsOutput& out,
                    std::vector<std::uint32_t>* neighbours = nullptr);

/// The N x k neighbour lists normals() uses (row-major; row i: the k nearest points
/// to point i, itself included, by ascending float32 squared distance in the local
/// frame, equal distances by lower index; which of several points tied at the k-th
/// distance is kept follows the k-d tree traversal, see knn.hpp). Throws
/// std::invalid_argument when k >= N (non-empty input). `leaf_budget`, `heap_from_k`:
/// see KnnIndex::nearest (the lists depend on neither). Far points (float32_frame) are
/// left out: in no other row, and each a row of itself alone.
std::vector<std::uint32_t> neighbour_lists(PointsView points, const NormalsParams& params,
                                           std::optional<std::size_t> leaf_budget = std::nullopt,
                                           std::optional<std::size_t> heap_from_k = std::nullopt);

}  // namespace pcl_rg
