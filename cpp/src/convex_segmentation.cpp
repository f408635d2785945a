// Scale-free patch growth and a convexity merge on the region graph.
//
// Sources: the convexity criterion between adjacent surface patches, and segments as
// the components joined by convex connections, are those of Stein, Schoeler,
// Papon and Woergoetter, "Object partitioning using local convexity", CVPR 2014
// (LCCP), which PCL implements on supervoxels; here the patches are the regions of
// curvature-seeded growth (region_growing.hpp; Rabbani et al., ISPRS Archives
// XXXVI-5, 2006) and the test compares each patch's centroid with the other's mean
// plane, so one large patch (a table) is judged by where the small one (a box face)
// lies relative to its plane. The growth gate is curvedness times the k-th neighbour
// distance: a curvature in units of the neighbourhood, the same at any spacing.
#include "pcl_rg/convex_segmentation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"
#include "pcl_rg/normals.hpp"
#include "pcl_rg/point_scale.hpp"
#include "pcl_rg/region_growing.hpp"
#include "pcl_rg/timer.hpp"
#include "pcl_rg/voxel_grid.hpp"

namespace pcl_rg {

void validate(const ConvexSegmentationParams& params) {
    check::real("noise_leaves", params.noise_leaves, check::non_negative());
    check::integer("k", params.k, check::at_least(6));
    check::real("smoothness_deg", params.smoothness_deg, {std::nullopt, 0.0, std::nullopt, 180.0});
    check::real("curvature_threshold", params.curvature_threshold, check::non_negative());
    check::real("concavity_tolerance_deg", params.concavity_tolerance_deg,
                {0.0, std::nullopt, std::nullopt, 90.0});
    check::integer("min_cluster_size", params.min_cluster_size, check::at_least(1));
    if (params.viewpoint)
        for (const double v : *params.viewpoint) check::real("viewpoint", v, check::any());
}

std::array<double, 3> default_viewpoint(PointsView points) {
    if (points.size == 0) return {0.0, 0.0, 0.0};
    // x and y without stray points: one record at (0, 0, 0) in a projected tile within
    // float32's reach made the origin the viewpoint, and every normal lay sideways. z
    // within the box's width (or 4 interquartile ranges, if more) of its quartiles: an
    // airborne tile's roofs and trees lie beyond the fence of its ground, which makes
    // most of its points, but a no-data height (-9999) or a bad fix 5 km up does not.
    std::array<double, 3> low{}, high{};
    for (int a = 0; a < 2; ++a) std::tie(low[a], high[a]) = fenced_range(points, a, 0.0);
    std::tie(low[2], high[2]) =
        fenced_range(points, 2, std::hypot(high[0] - low[0], high[1] - low[1]));
    double diagonal_squared = 0.0, origin_squared = 0.0;
    for (int d = 0; d < 3; ++d) {
        diagonal_squared += (high[d] - low[d]) * (high[d] - low[d]);
        // Distance from the origin to the box, per axis: how far 0 lies outside [low, high].
        const double outside = std::max({low[d], -high[d], 0.0});
        origin_squared += outside * outside;
    }
    const double diagonal = std::sqrt(diagonal_squared);
    if (std::sqrt(origin_squared) <= kSensorFrameReach * diagonal) return {0.0, 0.0, 0.0};
    return {0.5 * (low[0] + high[0]), 0.5 * (low[1] + high[1]), high[2] + diagonal};
}

namespace {

// Union-find whose root is the smallest member: the components, and so the result, do
// not depend on the order in which the convex pairs are joined.
std::int64_t find_root(std::vector<std::int64_t>& parent, std::int64_t x) {
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

}  // namespace

void merge_convex(PointsView points, std::size_t k, const std::uint32_t* neighbours,
                  const double* normals, const std::int32_t* patches,
                  const ConvexSegmentationParams& params, std::int32_t* labels) {
    validate(params);
    const std::size_t n = points.size;
    if (n == 0) return;
    check::indexable_by_int32(n);
    std::int64_t n_patches = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t a = patches[i];
        if (a < -1 || (a >= 0 && static_cast<std::size_t>(a) >= n))
            throw std::invalid_argument("patches: id " + std::to_string(a) + " out of range for " +
                                        std::to_string(n) + " points");
        n_patches = std::max<std::int64_t>(n_patches, static_cast<std::int64_t>(patches[i]) + 1);
    }
    for (std::size_t i = 0; i < n * k; ++i)
        if (neighbours[i] >= n)
            throw std::invalid_argument("neighbours: index " + std::to_string(neighbours[i]) +
                                        " out of range for " + std::to_string(n) + " points");
    const Interruption interruption;
    const std::array<double, 3> viewpoint =
        params.viewpoint ? *params.viewpoint : default_viewpoint(points);

    // Steps 1 and 2: counts, centroids and mean oriented normals, summed in index order.
    std::vector<std::int64_t> count(n_patches, 0);
    std::vector<double> centroid(3 * n_patches, 0.0), mean_normal(3 * n_patches, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t a = patches[i];
        if (a < 0) continue;
        ++count[a];
        for (int d = 0; d < 3; ++d) centroid[3 * a + d] += points.coord(i, d);
        const double* nv = normals + 3 * i;
        if (!(std::isfinite(nv[0]) && std::isfinite(nv[1]) && std::isfinite(nv[2]))) continue;
        double towards = 0.0;
        for (int d = 0; d < 3; ++d) towards += nv[d] * (viewpoint[d] - points.coord(i, d));
        const double sign = towards < 0.0 ? -1.0 : 1.0;
        for (int d = 0; d < 3; ++d) mean_normal[3 * a + d] += sign * nv[d];
    }
    for (std::int64_t a = 0; a < n_patches; ++a) {
        const double* m = &mean_normal[3 * a];
        const double length = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        for (int d = 0; d < 3; ++d) {
            centroid[3 * a + d] /= static_cast<double>(std::max<std::int64_t>(count[a], 1));
            mean_normal[3 * a + d] /= length;  // 0 / 0: NaN, never convex
        }
    }
    interruption.check_now();

    // Step 3: adjacent pairs (low id, high id) and their weights.
    std::vector<std::uint64_t> keys;
    for (std::size_t p = 0; p < n; ++p) {
        const std::int32_t a = patches[p];
        if (a < 0) continue;
        for (std::size_t j = 0; j < k; ++j) {
            const std::int32_t b = patches[neighbours[p * k + j]];
            if (b < 0 || b == a) continue;
            const auto lo = static_cast<std::uint64_t>(std::min(a, b));
            const auto hi = static_cast<std::uint64_t>(std::max(a, b));
            keys.push_back(lo << 32 | hi);
        }
    }
    std::sort(keys.begin(), keys.end());
    interruption.check_now();
    std::vector<std::int64_t> edge_a, edge_b, weight;
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        while (j < keys.size() && keys[j] == keys[i]) ++j;
        edge_a.push_back(static_cast<std::int64_t>(keys[i] >> 32));
        edge_b.push_back(static_cast<std::int64_t>(keys[i] & 0xffffffffu));
        weight.push_back(static_cast<std::int64_t>(j - i));
        i = j;
    }

    // Step 4: convex pairs of large patches, joined into segments.
    const double sin_tolerance = std::sin(params.concavity_tolerance_deg * (M_PI / 180.0));
    std::vector<char> large(n_patches);
    for (std::int64_t a = 0; a < n_patches; ++a) large[a] = count[a] >= params.min_cluster_size;
    std::vector<std::int64_t> parent(n_patches);
    std::iota(parent.begin(), parent.end(), std::int64_t{0});
    for (std::size_t e = 0; e < edge_a.size(); ++e) {
        const std::int64_t a = edge_a[e], b = edge_b[e];
        if (!large[a] || !large[b]) continue;
        const double* ca = &centroid[3 * a];
        const double* cb = &centroid[3 * b];
        const double* ma = &mean_normal[3 * a];
        const double* mb = &mean_normal[3 * b];
        const double d0 = cb[0] - ca[0], d1 = cb[1] - ca[1], d2 = cb[2] - ca[2];
        const double distance = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        const double b_over_a = d0 * ma[0] + d1 * ma[1] + d2 * ma[2];
        const double a_over_b = -d0 * mb[0] - d1 * mb[1] - d2 * mb[2];
        const double limit = sin_tolerance * distance;
        if (!(b_over_a <= limit && a_over_b <= limit)) continue;  // NaN: not convex
        const std::int64_t ra = find_root(parent, a), rb = find_root(parent, b);
        if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
    std::vector<std::int64_t> segment(n_patches);
    for (std::int64_t a = 0; a < n_patches; ++a) segment[a] = find_root(parent, a);

    // Step 5: small patches join the segment of their heaviest large neighbour.
    std::vector<std::int64_t> best_weight(n_patches, 0), best_segment(n_patches, -1);
    for (std::size_t e = 0; e < edge_a.size(); ++e) {
        const std::int64_t a = edge_a[e], b = edge_b[e];
        if (large[a] == large[b]) continue;
        const std::int64_t small = large[a] ? b : a;
        const std::int64_t target = segment[large[a] ? a : b];
        if (weight[e] > best_weight[small] ||
            (weight[e] == best_weight[small] && target < best_segment[small])) {
            best_weight[small] = weight[e];
            best_segment[small] = target;
        }
    }
    for (std::int64_t a = 0; a < n_patches; ++a)
        if (!large[a]) segment[a] = best_segment[a];

    std::vector<std::int64_t> segment_size(n_patches, 0);
    for (std::int64_t a = 0; a < n_patches; ++a)
        if (segment[a] >= 0) segment_size[segment[a]] += count[a];
    std::vector<std::int32_t> number(n_patches, -1);
    std::int32_t next = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t a = patches[i];
        const std::int64_t s = a < 0 ? -1 : segment[a];
        if (s < 0 || segment_size[s] < params.min_cluster_size) {
            labels[i] = -1;
            continue;
        }
        if (number[s] == -1) number[s] = next++;
        labels[i] = number[s];
    }
}

namespace {

ConvexSegmentationTimings segment_points(PointsView points, const ConvexSegmentationParams& params,
                                         std::int32_t* labels,
                                         std::vector<std::uint8_t>* far_rows = nullptr);

}  // namespace

ConvexSegmentationTimings convex_segmentation(PointsView points,
                                              const ConvexSegmentationParams& given,
                                              std::int32_t* labels) {
    validate(given);
    const std::size_t n = points.size;
    if (n == 0) return ConvexSegmentationTimings{};
    check::indexable_by_int32(n);
    // Far points (float32_frame) are left out of every step, the viewpoint, the scale
    // and the grid included (one at 1e39 overflowed the grid's voxel indices).
    Float32Frame frame = float32_frame(points);
    if (frame.has_far_points()) {
        check::fewer_than_points("k", given.k, n);
        check::fewer_than_points("k", given.k, frame.near.size(), n);
        const std::vector<double> kept = gather_points(points, frame.near);
        std::vector<std::int32_t> kept_labels(frame.near.size());
        ConvexSegmentationTimings timings = convex_segmentation(
            PointsView{kept.data(), frame.near.size()}, given, kept_labels.data());
        std::fill_n(labels, n, -1);
        for (std::size_t s = 0; s < frame.near.size(); ++s) labels[frame.near[s]] = kept_labels[s];
        timings.far_points += static_cast<std::int64_t>(n - frame.near.size());
        return timings;
    }
    const auto start = std::chrono::steady_clock::now();
    // Resolved on the input, so that a grid's centroids are seen from the same place.
    ConvexSegmentationParams params = given;
    params.viewpoint = given.viewpoint ? *given.viewpoint : default_viewpoint(points);
    double leaf = 0.0;
    if (params.noise_leaves > 0.0) {
        const PointScale scale = point_scale(points, frame);
        frame = Float32Frame();  // its float32 copy is not needed past the scale
        if (params.noise_leaves * scale.noise > scale.spacing)  // NaN (tiny cloud): no grid
            leaf = params.noise_leaves * scale.noise;
    }
    VoxelGridResult grid;
    std::vector<std::int64_t> voxel_of_point;
    if (leaf > 0.0) {
        VoxelGridParams grid_params;
        grid_params.leaf_size = {leaf, leaf, leaf};
        voxel_of_point.resize(n);
        grid = voxel_grid(points, grid_params, voxel_of_point.data());
        // A grid that leaves no more than k centroids (a small cloud, or one the grid's
        // world anchoring cuts unluckily) is not used: the caller's k < N must suffice.
        if (grid.counts.size() <= static_cast<std::size_t>(params.k)) leaf = 0.0;
    }
    if (leaf == 0.0) {
        ConvexSegmentationTimings timings = segment_points(points, params, labels);
        timings.viewpoint = *params.viewpoint;
        return timings;
    }
    const double grid_seconds = seconds_since(start);
    const std::size_t m = grid.counts.size();
    std::vector<std::int32_t> voxel_labels(m);
    std::vector<std::uint8_t> far_voxel;
    ConvexSegmentationTimings timings = segment_points(PointsView{grid.centroids.data(), m}, params,
                                                       voxel_labels.data(), &far_voxel);
    // The centroids have a float32 frame of their own, whose origin may lie elsewhere
    // than the points' (whose frame had no far point here): a far centroid leaves out
    // every point of its voxel, and those are the points counted.
    if (timings.far_points > 0) {
        timings.far_points = 0;
        for (std::size_t v = 0; v < m; ++v)
            if (far_voxel[v]) timings.far_points += grid.counts[v];
    }
    // Every point takes its voxel's label, renumbered by the smallest point index.
    std::vector<std::int32_t> number(m, -1);
    std::int32_t next = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t v = voxel_labels[voxel_of_point[i]];
        if (v >= 0 && number[v] == -1) number[v] = next++;
        labels[i] = v < 0 ? -1 : number[v];
    }
    timings.normals_seconds += grid_seconds;  // the scale and the grid: preparation
    timings.leaf = leaf;
    timings.viewpoint = *params.viewpoint;
    return timings;
}

namespace {

ConvexSegmentationTimings segment_points(PointsView points, const ConvexSegmentationParams& params,
                                         std::int32_t* labels,
                                         std::vector<std::uint8_t>* far_rows) {
    ConvexSegmentationTimings timings;
    const std::size_t n = points.size;
    const auto start = std::chrono::steady_clock::now();
    std::vector<double> normal(3 * n), gaussian(n), mean(n);
    NormalsOutput out;
    out.normal = normal.data();
    out.gaussian_curvature = gaussian.data();
    out.mean_curvature = mean.data();
    std::vector<std::uint32_t> neighbours;
    const std::size_t far = normals(points, NormalsParams{params.k}, out, &neighbours);
    const auto k = static_cast<std::size_t>(params.k);
    timings.far_points = static_cast<std::int64_t>(far);
    // Which rows were far: a far point's neighbour row is itself alone, a kept point's
    // holds k >= 6 distinct points.
    if (far_rows) {
        far_rows->assign(n, 0);
        for (std::size_t i = 0; i < n && far > 0; ++i)
            (*far_rows)[i] = neighbours[i * k + 1] == static_cast<std::uint32_t>(i);
    }

    // Curvedness (as region_growing.cpp writes it) times the k-th neighbour distance.
    std::vector<double> measure(n);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
        const std::size_t far = neighbours[static_cast<std::size_t>(i) * k + k - 1];
        double squared = 0.0;
        for (int d = 0; d < 3; ++d) {
            const double delta = points.coord(far, d) - points.coord(i, d);
            squared += delta * delta;
        }
        measure[i] = curvedness(mean[i], gaussian[i]) * std::sqrt(squared);
    }
    timings.normals_seconds = seconds_since(start);
    poll_interrupt();

    const auto grow_start = std::chrono::steady_clock::now();
    RegionGrowingParams growth;
    growth.k = params.k;
    growth.smoothness_deg = params.smoothness_deg;
    growth.curvature_threshold = params.curvature_threshold;
    growth.min_cluster_size = 1;
    std::vector<std::int32_t> patches(n);
    grow_regions(n, k, neighbours.data(), normal.data(), measure.data(), growth, patches.data());
    timings.growth_seconds = seconds_since(grow_start);
    poll_interrupt();

    const auto merge_start = std::chrono::steady_clock::now();
    merge_convex(points, k, neighbours.data(), normal.data(), patches.data(), params, labels);
    timings.merge_seconds = seconds_since(merge_start);
    return timings;
}

}  // namespace

}  // namespace pcl_rg
