// Statistical outlier removal, Rusu et al., "Towards 3D Point Cloud Based Object Maps
// for Household Environments", Robotics and Autonomous Systems 56(11), 2008; the
// preprocessing step of seed 004. Semantics follow PCL 1.13's
// pcl::StatisticalOutlierRemoval exactly:
//   * neighbours come from an exact k-d tree on the float32 cloud, the query point
//     counted as its own first neighbour and skipped;
//   * d_i is the double sum of the float square roots of the float squared
//     distances, divided by mean_k and stored as float;
//   * mu and sigma use the sample (n - 1) variance, sum and sum of squares taken in
//     index order, the squares formed in float;
//   * a point is an inlier when d_i <= mu + std_mul * sigma (so a NaN sigma, which
//     only arises when all d_i are equal within rounding, keeps every point);
// except for far points (float32_frame), which PCL's float32 cloud cannot hold with
// the rest: outliers with d_i = inf, left out of mu and sigma.
// The differences are speed only: nanoflann instead of FLANN and the neighbour
// queries run in parallel.
#include "pcl_rg/statistical_outlier_removal.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/knn.hpp"
#include "pcl_rg/spatial_order.hpp"

namespace pcl_rg {

void validate(const StatisticalOutlierRemovalParams& params) {
    check::integer("mean_k", params.mean_k, check::at_least(1));
    check::real("std_mul", params.std_mul, check::non_negative());
}

namespace {

// The run without the far points of float32_frame (`near`: the others): a far point is
// an outlier at an infinite distance and stays out of mu and sigma, which it would
// otherwise inflate until no other point is an outlier.
StatisticalOutlierRemovalResult without_far_points(PointsView points,
                                                   const std::vector<std::size_t>& near,
                                                   const StatisticalOutlierRemovalParams& params,
                                                   bool* inlier) {
    const std::vector<double> kept = gather_points(points, near);
    const std::unique_ptr<bool[]> kept_inlier(new bool[near.size()]);
    const StatisticalOutlierRemovalResult part = statistical_outlier_removal(
        PointsView{kept.data(), near.size()}, params, kept_inlier.get());
    const float inf = std::numeric_limits<float>::infinity();
    StatisticalOutlierRemovalResult result;
    result.threshold = part.threshold;
    result.mean_distance.assign(points.size, inf);
    result.farthest_distance.assign(points.size, inf);
    std::fill(inlier, inlier + points.size, false);
    for (std::size_t s = 0; s < near.size(); ++s) {
        result.mean_distance[near[s]] = part.mean_distance[s];
        result.farthest_distance[near[s]] = part.farthest_distance[s];
        inlier[near[s]] = kept_inlier[s];
    }
    return result;
}

}  // namespace

StatisticalOutlierRemovalResult statistical_outlier_removal(
    PointsView points, const StatisticalOutlierRemovalParams& params, bool* inlier,
    const std::array<double, 3>* origin) {
    validate(params);
    StatisticalOutlierRemovalResult result;
    const std::size_t n = points.size;
    if (n == 0) return result;
    if (n > std::numeric_limits<std::uint32_t>::max())  // the Morton order numbers points
        throw std::invalid_argument("points: at most 2^32 - 1 points are supported, got " +
                                    std::to_string(n));
    check::fewer_than_points("mean_k", params.mean_k, n);
    const auto mean_k = static_cast<std::size_t>(params.mean_k);

    const Float32Frame frame = origin ? float32_frame(points, *origin) : float32_frame(points);
    if (frame.has_far_points()) {
        check::fewer_than_points("mean_k", params.mean_k, frame.near.size(), n);
        return without_far_points(points, frame.near, params, inlier);
    }
    // Query in Morton order on a Morton-ordered copy: the same float32 coordinates
    // (so the same distances), but memory is touched in order.
    const std::vector<float>& unordered = frame.local;
    const std::vector<std::uint32_t> order =
        morton_order(unordered.data(), static_cast<std::uint32_t>(n));
    std::vector<float> local(3 * n);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t s = 0; s < static_cast<std::ptrdiff_t>(n); ++s)
        for (int a = 0; a < 3; ++a) local[3 * s + a] = unordered[3 * order[s] + a];
    const KnnIndex index(local.data(), n);
    const Interruption interruption;
    interruption.check_now();
    result.mean_distance.resize(n);
    result.farthest_distance.resize(n);
    const std::size_t k = mean_k + 1;  // the query point comes back as its own neighbour

#pragma omp parallel firstprivate(interruption)
    {
        std::vector<std::uint32_t> nn_index(k);
        std::vector<float> nn_sqdist(k);
#pragma omp for schedule(dynamic, 1024)
        for (std::ptrdiff_t s = 0; s < static_cast<std::ptrdiff_t>(n); ++s) {
            if (interruption.requested()) continue;  // then thrown below, outside the region
            index.nearest(s, k, nn_index.data(), nn_sqdist.data());
            double sum = 0.0;
            for (std::size_t j = 1; j < k; ++j) sum += std::sqrt(nn_sqdist[j]);
            result.mean_distance[order[s]] = static_cast<float>(sum / static_cast<double>(mean_k));
            result.farthest_distance[order[s]] = std::sqrt(nn_sqdist[k - 1]);
        }
    }

    interruption.check();

    // Serial, in index order: the same rounding as PCL and the same on every run.
    double sum = 0.0, sum_sq = 0.0;
    for (const float d : result.mean_distance) {
        sum += d;
        sum_sq += d * d;
    }
    const double count = static_cast<double>(n);
    const double mean = sum / count;
    const double variance = (sum_sq - sum * sum / count) / (count - 1.0);
    result.threshold = mean + params.std_mul * std::sqrt(variance);

    const auto threshold = result.threshold;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
        inlier[i] = !(result.mean_distance[i] > threshold);
    return result;
}

}  // namespace pcl_rg
