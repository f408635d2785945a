// Curvature-seeded region growing, seed 004: Wang et al., "Point cloud segmentation
// based on improved region growing", ISPRS Archives XLII-3/W10, 2020, section 3 (seeds
// in increasing order of curvature from the Gaussian and mean curvatures, growth by
// the normal angle, curvature threshold and cluster-size limits), on the growth scheme
// of Rabbani et al., "Segmentation of point clouds using smoothness constraint",
// ISPRS Archives XXXVI-5, 2006, as PCL's pcl::RegionGrowing implements it.
//
// Differences from pcl::RegionGrowing, all deliberate: the seed measure (curvedness by
// default, PCL: surface variation) and a total seed order (measure, then index; PCL's
// unstable sort leaves equal curvatures in unspecified order); the neighbour lists of
// the normal pass are reused for the growth instead of searched again; normals and
// tests in float64. The growth itself (breadth-first queue, neighbours in distance
// order, the first seed always grows, joined points over the threshold join without
// growing) is PCL's.
//
// Beyond the seed, behind seed_measure = concavity (not the default): the gate uses
// max(H_v, 0), the mean curvature with the normal turned towards a viewpoint, which is
// positive only in concave creases as the sensor sees them; growth then runs over
// convex edges (the faces of a box) and stops where an object meets its support.
#include "pcl_rg/region_growing.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/normals.hpp"
#include "pcl_rg/timer.hpp"

namespace pcl_rg {

void validate(const RegionGrowingParams& params) {
    check::integer("k", params.k, check::at_least(3));
    check::real("smoothness_deg", params.smoothness_deg, {std::nullopt, 0.0, std::nullopt, 180.0});
    check::real("curvature_threshold", params.curvature_threshold, check::non_negative());
    check::integer("min_cluster_size", params.min_cluster_size, check::at_least(1));
    check::integer("max_cluster_size", params.max_cluster_size, check::at_least(1));
    check::relation(params.max_cluster_size >= params.min_cluster_size, "max_cluster_size",
                    ">= min_cluster_size (" + check::format_value(params.min_cluster_size) + ")",
                    static_cast<double>(params.max_cluster_size));
    switch (params.seed_measure) {
        case SeedMeasure::curvedness:
        case SeedMeasure::gaussian:
        case SeedMeasure::mean:
        case SeedMeasure::surface_variation:
        case SeedMeasure::concavity:
            break;
        default:
            throw std::invalid_argument("seed_measure is not a known measure");
    }
    for (const double v : params.viewpoint) check::real("viewpoint", v, check::any());
    // The curvatures are a quadric's, fitted to the neighbours: below kMinCurvatureK they are NaN,
    // no point may seed, and every point came out unassigned without a word.
    const std::string needed = std::to_string(kMinCurvatureK);
    check::relation(
        params.k >= kMinCurvatureK || params.seed_measure == SeedMeasure::surface_variation, "k",
        ">= " + needed + " unless seed_measure is surface_variation (the other measures are " +
            "curvatures, which need " + needed + " neighbours)",
        static_cast<double>(params.k));
}

void grow_regions(std::size_t n, std::size_t k, const std::uint32_t* neighbours,
                  const double* normals, const double* measure, const RegionGrowingParams& params,
                  std::int32_t* labels) {
    validate(params);
    if (n == 0) return;
    check::indexable_by_int32(n);
    for (std::size_t i = 0; i < n * k; ++i)
        if (neighbours[i] >= n)
            throw std::invalid_argument("neighbours: index " + std::to_string(neighbours[i]) +
                                        " out of range for " + std::to_string(n) + " points");

    const Interruption interruption;
    interruption.check_now();

    // Step 3: seeds in increasing (measure, index) order, undefined measures last.
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [measure](std::uint32_t p, std::uint32_t q) {
        const double mp = measure[p], mq = measure[q];
        const bool np = std::isnan(mp), nq = std::isnan(mq);
        if (np != nq) return nq;
        if (!np && mp != mq) return mp < mq;
        return p < q;
    });
    interruption.check_now();

    const double cos_threshold = std::cos(params.smoothness_deg * (M_PI / 180.0));
    const double gate = params.curvature_threshold;
    std::vector<std::int32_t> region(n, -1);
    std::vector<std::int64_t> region_size;
    std::vector<std::uint32_t> queue;
    queue.reserve(n);
    std::size_t visits = 0;  // polled every 256 points: a region may be the whole cloud
    for (const std::uint32_t seed : order) {
        if (region[seed] != -1) continue;
        const auto id = static_cast<std::int32_t>(region_size.size());
        region[seed] = id;
        std::int64_t size = 1;
        queue.clear();
        queue.push_back(seed);
        // Breadth-first, as PCL's std::queue: the vector is the queue, `head` its front.
        for (std::size_t head = 0; head < queue.size(); ++head) {
            if (++visits % 256 == 0) interruption.check();
            const std::uint32_t p = queue[head];
            const double* np = normals + 3 * static_cast<std::size_t>(p);
            const std::uint32_t* row = neighbours + static_cast<std::size_t>(p) * k;
            for (std::size_t j = 0; j < k; ++j) {
                const std::uint32_t q = row[j];
                if (region[q] != -1) continue;
                const double* nq = normals + 3 * static_cast<std::size_t>(q);
                const double cosine = std::abs(np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2]);
                if (!(cosine >= cos_threshold)) continue;  // NaN normals never join
                region[q] = id;
                ++size;
                if (measure[q] <= gate) queue.push_back(q);  // NaN never seeds further
            }
        }
        region_size.push_back(size);
    }

    // Step 4: size filter, then number the kept regions by their smallest member index.
    std::vector<std::int32_t> label_of_region(region_size.size(), -1);
    std::vector<char> kept(region_size.size());
    for (std::size_t r = 0; r < region_size.size(); ++r)
        kept[r] =
            region_size[r] >= params.min_cluster_size && region_size[r] <= params.max_cluster_size;
    std::int32_t next = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t r = region[i];
        if (kept[r] && label_of_region[r] == -1) label_of_region[r] = next++;
        labels[i] = label_of_region[r];
    }
}

RegionGrowingTimings region_growing(PointsView points, const RegionGrowingParams& params,
                                    std::int32_t* labels) {
    validate(params);
    RegionGrowingTimings timings;
    const std::size_t n = points.size;
    if (n == 0) return timings;
    const auto start = std::chrono::steady_clock::now();

    std::vector<double> normal(3 * n), sv, gaussian, mean;
    NormalsOutput out;
    out.normal = normal.data();
    switch (params.seed_measure) {
        case SeedMeasure::surface_variation:
            sv.resize(n);
            out.surface_variation = sv.data();
            break;
        case SeedMeasure::gaussian:
            gaussian.resize(n);
            out.gaussian_curvature = gaussian.data();
            break;
        case SeedMeasure::mean:
            mean.resize(n);
            out.mean_curvature = mean.data();
            break;
        case SeedMeasure::curvedness:
            gaussian.resize(n);
            mean.resize(n);
            out.gaussian_curvature = gaussian.data();
            out.mean_curvature = mean.data();
            break;
        case SeedMeasure::concavity:
            mean.resize(n);
            out.mean_curvature = mean.data();
            break;
    }
    std::vector<std::uint32_t> neighbours;
    timings.far_points =
        static_cast<std::int64_t>(normals(points, NormalsParams{params.k}, out, &neighbours));

    std::vector<double> measure(n);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
        switch (params.seed_measure) {
            case SeedMeasure::curvedness:
                measure[i] = curvedness(mean[i], gaussian[i]);
                break;
            case SeedMeasure::gaussian:
                measure[i] = std::abs(gaussian[i]);
                break;
            case SeedMeasure::mean:
                measure[i] = std::abs(mean[i]);
                break;
            case SeedMeasure::surface_variation:
                measure[i] = sv[i];
                break;
            case SeedMeasure::concavity: {
                // H is signed by the normal (n_z > 0); turn it towards the viewpoint.
                double towards = 0.0;
                for (int a = 0; a < 3; ++a)
                    towards += normal[3 * i + a] * (params.viewpoint[a] - points.coord(i, a));
                const double h = towards < 0.0 ? -mean[i] : mean[i];
                measure[i] = std::isnan(h) ? h : std::max(h, 0.0);
                break;
            }
        }
    }
    timings.normals_seconds = seconds_since(start);
    poll_interrupt();

    const auto grow_start = std::chrono::steady_clock::now();
    grow_regions(n, static_cast<std::size_t>(params.k), neighbours.data(), normal.data(),
                 measure.data(), params, labels);
    timings.growth_seconds = seconds_since(grow_start);
    return timings;
}

}  // namespace pcl_rg
