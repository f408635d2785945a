// Point spacing and surface noise of a cloud, measured on a sample of its points: the
// noise is the RMS residual of a local PCA plane fit (the smallest covariance
// eigenvalue, as in Pauly et al., "Efficient simplification of point-sampled
// surfaces", IEEE Visualization 2002, section 2), the spacing the nearest-neighbour
// distance; medians make both robust to edges and outliers. The noise is read on
// surface neighbourhoods only (thin against their spread): in a volume of scattered
// points, such as tree canopy, the residual of a plane is the volume's thickness.
#include "pcl_rg/point_scale.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/knn.hpp"

namespace pcl_rg {

namespace {

double lower_median(std::vector<double>& values) {
    if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>((values.size() - 1) / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

}  // namespace

PointScale point_scale(PointsView points) {
    if (points.size <= kPointScaleNeighbours) return point_scale(points, Float32Frame{});
    return point_scale(points, float32_frame(points));
}

PointScale point_scale(PointsView points, const Float32Frame& frame) {
    const std::size_t n = points.size, k = kPointScaleNeighbours;
    PointScale scale;
    if (n <= k) {
        scale.spacing = scale.noise = std::numeric_limits<double>::quiet_NaN();
        return scale;
    }
    if (frame.has_far_points()) {  // measured on the others alone
        const std::vector<double> kept = gather_points(points, frame.near);
        PointScale scale_of_kept = point_scale(PointsView{kept.data(), frame.near.size()});
        scale_of_kept.far_points += static_cast<std::int64_t>(n - frame.near.size());
        return scale_of_kept;
    }
    const KnnIndex index(frame.local.data(), n);
    const std::size_t step = std::max<std::size_t>(1, n / kPointScaleSamples);
    const std::size_t m = (n + step - 1) / step;
    std::vector<double> spacing(m), noise(m);
    poll_interrupt();
#pragma omp parallel
    {
        std::vector<std::uint32_t> near(k);
        std::vector<float> squared(k);
#pragma omp for schedule(static)
        for (std::ptrdiff_t r = 0; r < static_cast<std::ptrdiff_t>(m); ++r) {
            const std::size_t i = static_cast<std::size_t>(r) * step;
            index.nearest(i, k, near.data(), squared.data());
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            std::vector<Eigen::Vector3d> rel(k);
            for (std::size_t j = 0; j < k; ++j) {
                for (int a = 0; a < 3; ++a)
                    rel[j][a] = points.coord(near[j], a) - points.coord(i, a);
                sum += rel[j];
            }
            spacing[r] = rel[1].norm();
            const Eigen::Vector3d mean = sum / static_cast<double>(k);
            Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
            for (std::size_t j = 0; j < k; ++j) {
                const Eigen::Vector3d d = rel[j] - mean;
                covariance += d * d.transpose();
            }
            covariance /= static_cast<double>(k);
            const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance,
                                                                        Eigen::EigenvaluesOnly);
            const double thickness = std::sqrt(std::max(solver.eigenvalues()[0], 0.0));
            const double spread = std::sqrt(std::max(solver.eigenvalues()[1], 0.0));
            // NaN marks a volume; the surfaces are gathered below in sample order.
            noise[r] = thickness <= kPointScaleSurfaceRatio * spread
                           ? thickness
                           : std::numeric_limits<double>::quiet_NaN();
        }
    }
    scale.spacing = lower_median(spacing);
    noise.erase(std::remove_if(noise.begin(), noise.end(), [](double v) { return std::isnan(v); }),
                noise.end());
    scale.noise = lower_median(noise);
    return scale;
}

}  // namespace pcl_rg
