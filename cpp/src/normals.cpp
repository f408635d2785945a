// Normals and curvatures of seed 004 (Wang et al., "Point cloud segmentation based on
// improved region growing", ISPRS Archives XLII-3/W10, 2020, sections 3.1 and 3.2):
// the least-squares (PCA) normal, the eigenvector of the smallest eigenvalue of the
// neighbourhood covariance, and the Gaussian and mean curvatures of Besl & Jain (1986)
// from a quadric z = f(x, y) fitted in the point's tangent frame (a Monge patch).
// PCL's surface variation (Pauly et al., 2002) comes out beside them.
//
// Precision: neighbours are searched on float32 coordinates relative to a float64
// local origin (shared KnnIndex), but every geometric quantity is computed in float64
// from the caller's coordinates relative to the query point, so UTM-sized coordinates
// lose nothing. Each point is independent: an OpenMP loop, same result on every run.
#include "pcl_rg/normals.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/knn.hpp"

namespace pcl_rg {

void validate(const NormalsParams& params) { check::integer("k", params.k, check::at_least(3)); }

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct PointGeometry {
    Eigen::Vector3d normal{kNaN, kNaN, kNaN};
    double surface_variation = kNaN;
    double gaussian = kNaN, mean = kNaN, k1 = kNaN, k2 = kNaN;
};

// Unoriented normals get one deterministic sign: "up" (n_z > 0), with ties broken on
// y then x, so both the core and the reference pick the same one.
void orient_up(Eigen::Vector3d& n) {
    const bool flip =
        n.z() < 0.0 || (n.z() == 0.0 && (n.y() < 0.0 || (n.y() == 0.0 && n.x() < 0.0)));
    if (flip) n = -n;
}

// Whether `rel` holds at least kMinCurvatureK distinct positions: the quadric's six
// unknowns need them. Fewer make its design exactly rank deficient, which the pivot
// test does not always see: with pivots just above its limit, the last one, zero in
// exact arithmetic, came out as rounding noise of order 0.1 and the curvatures as
// arbitrary finite numbers (points copied three times, k = 15). Stops at the sixth.
bool enough_distinct_positions(const std::vector<Eigen::Vector3d>& rel) {
    std::array<const Eigen::Vector3d*, kMinCurvatureK> seen{};
    int distinct = 0;
    for (const auto& r : rel) {
        bool fresh = true;
        for (int j = 0; j < distinct && fresh; ++j) fresh = !(*seen[j] == r);
        if (fresh) {
            seen[distinct++] = &r;
            if (distinct == kMinCurvatureK) return true;
        }
    }
    return false;
}

// rel: the k neighbours relative to the query point (float64). Loops rather than
// Eigen expressions on dynamic matrices: no allocation per point.
PointGeometry point_geometry(const std::vector<Eigen::Vector3d>& rel) {
    PointGeometry g;
    const std::size_t k = rel.size();
    const double inv_k = 1.0 / static_cast<double>(k);
    // Step 1: covariance about the neighbourhood centroid, two-pass in float64.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& r : rel) centroid += r;
    centroid *= inv_k;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const auto& r : rel) {
        const Eigen::Vector3d c = r - centroid;
        covariance.noalias() += c * c.transpose();
    }
    covariance *= inv_k;
    const double trace = covariance.trace();
    if (!(trace > 0.0)) return g;  // all neighbours coincide: nothing is defined

    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
    // Eigenvalues ascending; lambda0 may come out as -1e-20 on exact planes.
    g.surface_variation = std::max(eigen.eigenvalues()(0), 0.0) / trace;
    Eigen::Vector3d n = eigen.eigenvectors().col(0).normalized();
    orient_up(n);
    g.normal = n;

    // Step 2: quadric in the tangent frame (x: largest-variance axis, y = n x x, z = n),
    // centred at the point itself. Six unknowns need six neighbours.
    if (k < kMinCurvatureK || !enough_distinct_positions(rel)) return g;
    const Eigen::Vector3d x_axis = eigen.eigenvectors().col(2).normalized();
    const Eigen::Vector3d y_axis = n.cross(x_axis);
    // Scale the tangent coordinates to unit RMS radius so the design is well
    // conditioned whatever the units: w/s = A u'^2 + B u'v' + C v'^2 + D u' + E v' + F
    // with u' = u/s, v' = v/s gives a = A/s, b = B/s, c = C/s, d = D, e = E.
    double radius2 = 0.0;
    for (const auto& r : rel) {
        const double u = r.dot(x_axis), v = r.dot(y_axis);
        radius2 += u * u + v * v;
    }
    const double s = std::sqrt(radius2 * inv_k);
    if (!(s > 0.0)) return g;
    const double inv_s = 1.0 / s;
    Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    for (const auto& r : rel) {
        const double u = r.dot(x_axis) * inv_s, v = r.dot(y_axis) * inv_s, w = r.dot(n) * inv_s;
        Eigen::Matrix<double, 6, 1> row;
        row << u * u, u * v, v * v, u, v, 1.0;
        normal_matrix.noalias() += row * row.transpose();
        rhs.noalias() += row * w;
    }
    // Rank test and solve with one Cholesky factorisation of the normal matrix divided
    // by k. Its pivots are unique (any correct Cholesky gives them): pivot j squared is
    // the mean squared distance of design column j from the span of columns 0..j-1.
    // With u, v scaled to unit RMS radius every column has a mean square of order 1
    // when the neighbours spread in both directions, so a tiny pivot means a column
    // the data do not determine (e.g. v = 0 up to rounding for collinear points).
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> cholesky(normal_matrix * inv_k);
    if (cholesky.info() != Eigen::Success) return g;
    const Eigen::Matrix<double, 6, 6> l = cholesky.matrixL();
    for (int j = 0; j < 6; ++j)
        if (!(l(j, j) * l(j, j) > kQuadricConditionLimit)) return g;  // rank deficient
    const Eigen::Matrix<double, 6, 1> q = cholesky.solve(rhs * inv_k);
    const double a = q(0) * inv_s, b = q(1) * inv_s, c = q(2) * inv_s, d = q(3), e = q(4);
    const double m = 1.0 + d * d + e * e;
    g.gaussian = (4.0 * a * c - b * b) / (m * m);
    g.mean = ((1.0 + e * e) * a - d * e * b + (1.0 + d * d) * c) / (m * std::sqrt(m));
    const double root = std::sqrt(std::max(g.mean * g.mean - g.gaussian, 0.0));
    g.k1 = g.mean + root;
    g.k2 = g.mean - root;
    return g;
}

// Turns the lists of the points `near` alone (the first near.size() rows of `lists`,
// numbered among those points) into the lists of the whole view of n points, in place:
// each far point (float32_frame) gets a row of itself alone, no neighbours, so its
// geometry is undefined (NaN) and no region reaches it. The callers reserve n * k
// entries before the kept points' lists are made: a second table, built beside the
// first, nearly doubled a step's peak memory for one stray point (region growing on 1M
// points, k = 30: +365 MB against +184 MB without it; now +213 MB, RESULTS.md's "Far
// points" section) and broke the neighbour table's documented bound.
void spread_over_far_points(std::vector<std::uint32_t>& lists, std::size_t n, std::size_t k,
                            const std::vector<std::size_t>& near) {
    lists.resize(n * k);
    const auto fill_alone = [&](std::size_t first, std::size_t end) {
        for (std::size_t r = first; r < end; ++r)
            std::fill_n(lists.begin() + static_cast<std::ptrdiff_t>(r * k), k,
                        static_cast<std::uint32_t>(r));
    };
    // Kept row s moves to row near[s] >= s. Taken from the last down, every row is read
    // before anything is written over it; the rows in between are far points.
    std::size_t end = n;
    for (std::size_t s = near.size(); s-- > 0;) {
        const std::size_t to = near[s];
        fill_alone(to + 1, end);
        for (std::size_t j = 0; j < k; ++j)
            lists[to * k + j] = static_cast<std::uint32_t>(near[lists[s * k + j]]);
        end = to;
    }
    fill_alone(0, end);
}

// normals() on the points `near` alone, copied, with NaN for the far points. The kept
// points' results are written into the first rows of the caller's arrays, then moved to
// their own rows in place, as their neighbour lists are: no second set of arrays.
// Returns how many far points were left out, n - m and those the kept points' own frame
// leaves out.
std::size_t normals_without_far_points(PointsView points, const std::vector<std::size_t>& near,
                                       const NormalsParams& params, const NormalsOutput& out,
                                       std::vector<std::uint32_t>* neighbours) {
    const std::size_t n = points.size, m = near.size();
    if (neighbours) neighbours->reserve(n * static_cast<std::size_t>(params.k));
    const std::size_t inner =
        normals(PointsView{gather_points(points, near).data(), m}, params, out, neighbours);
    double* const fields[5] = {out.surface_variation, out.gaussian_curvature, out.mean_curvature,
                               out.k1, out.k2};
    const auto move_row = [&](std::size_t from, std::size_t to, bool far) {
        for (int a = 0; a < 3; ++a) out.normal[3 * to + a] = far ? kNaN : out.normal[3 * from + a];
        for (double* field : fields)
            if (field) field[to] = far ? kNaN : field[from];
    };
    std::size_t end = n;  // kept row s moves to row near[s] >= s: from the last down
    for (std::size_t s = m; s-- > 0;) {
        for (std::size_t r = near[s] + 1; r < end; ++r) move_row(r, r, true);
        move_row(s, near[s], false);
        end = near[s];
    }
    for (std::size_t r = 0; r < end; ++r) move_row(r, r, true);
    if (neighbours)
        spread_over_far_points(*neighbours, n, static_cast<std::size_t>(params.k), near);
    return n - m + inner;
}

// neighbour_lists() into `lists`, whose capacity it keeps when that is enough.
void fill_neighbour_lists(PointsView points, const NormalsParams& params,
                          std::optional<std::size_t> leaf_budget,
                          std::optional<std::size_t> heap_from_k,
                          std::vector<std::uint32_t>& lists) {
    const std::size_t n = points.size;
    check::fewer_than_points("k", params.k, n);  // of the kept points too
    const auto k = static_cast<std::size_t>(params.k);
    const Float32Frame frame = float32_frame(points);
    if (frame.has_far_points()) {
        check::fewer_than_points("k", params.k, frame.near.size(), n);
        lists.reserve(n * k);
        fill_neighbour_lists(
            PointsView{gather_points(points, frame.near).data(), frame.near.size()}, params,
            leaf_budget, heap_from_k, lists);
        spread_over_far_points(lists, n, k, frame.near);
        return;
    }
    const KnnIndex index(frame.local.data(), n);
    lists.resize(n * k);
    const Interruption interruption;
    interruption.check_now();
#pragma omp parallel firstprivate(interruption)
    {
        std::vector<float> sqdist(k);
#pragma omp for schedule(dynamic, 1024)
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
            if (!interruption.requested())
                index.nearest(i, k, lists.data() + i * k, sqdist.data(), leaf_budget, heap_from_k);
    }
    interruption.check();
}

}  // namespace

std::vector<std::uint32_t> neighbour_lists(PointsView points, const NormalsParams& params,
                                           std::optional<std::size_t> leaf_budget,
                                           std::optional<std::size_t> heap_from_k) {
    validate(params);
    std::vector<std::uint32_t> lists;
    if (points.size == 0) return lists;
    check::neighbour_table_fits("k", params.k, points.size);
    fill_neighbour_lists(points, params, leaf_budget, heap_from_k, lists);
    return lists;
}

std::size_t normals(PointsView points, const NormalsParams& params, const NormalsOutput& out,
                    std::vector<std::uint32_t>* neighbours) {
    validate(params);
    const std::size_t n = points.size;
    if (neighbours) neighbours->clear();
    if (n == 0) return 0;
    check::fewer_than_points("k", params.k, n);
    if (neighbours) check::neighbour_table_fits("k", params.k, n);
    const auto k = static_cast<std::size_t>(params.k);

    const Float32Frame frame = float32_frame(points);
    if (frame.has_far_points()) {
        check::fewer_than_points("k", params.k, frame.near.size(), n);
        return normals_without_far_points(points, frame.near, params, out, neighbours);
    }
    const KnnIndex index(frame.local.data(), n);
    if (neighbours) neighbours->resize(n * k);
    const Interruption interruption;
    interruption.check_now();

#pragma omp parallel firstprivate(interruption)
    {
        std::vector<std::uint32_t> own_index(k);
        std::vector<float> sqdist(k);
        std::vector<Eigen::Vector3d> rel(k);
#pragma omp for schedule(dynamic, 512)
        for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
            if (interruption.requested()) continue;  // then thrown below, outside the region
            std::uint32_t* nn = neighbours ? neighbours->data() + i * k : own_index.data();
            index.nearest(i, k, nn, sqdist.data());
            for (std::size_t j = 0; j < k; ++j)
                for (int a = 0; a < 3; ++a) rel[j](a) = points.coord(nn[j], a) - points.coord(i, a);
            const PointGeometry g = point_geometry(rel);
            for (int a = 0; a < 3; ++a) out.normal[3 * i + a] = g.normal(a);
            if (out.surface_variation) out.surface_variation[i] = g.surface_variation;
            if (out.gaussian_curvature) out.gaussian_curvature[i] = g.gaussian;
            if (out.mean_curvature) out.mean_curvature[i] = g.mean;
            if (out.k1) out.k1[i] = g.k1;
            if (out.k2) out.k2[i] = g.k2;
        }
    }
    interruption.check();
    return 0;
}

}  // namespace pcl_rg
