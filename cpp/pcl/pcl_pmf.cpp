// Thin wrappers over pcl::ProgressiveMorphologicalFilter and
// pcl::ApproximateProgressiveMorphologicalFilter (PCL 1.13), after Zhang et al., "A
// progressive morphological filter for removing nonground measurements from airborne
// LIDAR data", IEEE TGRS 41(4), 2003: the ground-filter baseline (see pcl_pmf.hpp).
#include "pcl_pmf.hpp"

#include <pcl/segmentation/approximate_progressive_morphological_filter.h>
#include <pcl/segmentation/progressive_morphological_filter.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "pcl_cloud.hpp"
#include "pcl_rg/check.hpp"
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

void validate(const ProgressiveMorphologicalFilterParams& params) {
    check::integer("max_window_size", params.max_window_size, check::at_least(1));
    check::real("slope", params.slope, check::non_negative());
    check::real("initial_distance", params.initial_distance, check::non_negative());
    check::real("max_distance", params.max_distance, check::non_negative());
    check::real("cell_size", params.cell_size, check::positive());
    check::real("base", params.base, check::positive());
}

namespace {

// PCL builds its series of windows with `while (window < max_window_size)`, which never
// ends when the series does not grow (base 1, or a base that float32 rounds to 1 or 0)
// and runs for ages or overflows int when it grows too slowly or too fast; its grids are
// sized from the extent with no limit, and its octree and Eigen assert (abort) where a
// cell is too small for the extent. So the series is computed here first, in PCL's own
// float32 arithmetic, and the grid and the work it implies are checked against limits
// far above any use (the 10M-point benchmark: 5 windows, 2.5M cells, 7e9 comparisons).
constexpr int kMaxWindows = 64;
constexpr double kMaxCellsPerAxis = 1 << 24;      // octree keys and Eigen's int rows
constexpr double kMaxApproximateCells = 1 << 28;  // 3 float matrices: 3 GiB
constexpr double kMaxApproximateWork = 1e11;      // cells x window area, summed
// The point-wise filter opens each window with two passes (erode, dilate) in which every
// point collects the points of a box one window wide from PCL's octree. Measured: 1e8
// to 2.5e8 points collected per second (20k to 50k points, windows up to 2^16 m), so
// 1e10 is one to two minutes in a call PCL gives no way to interrupt. The largest ISPRS
// sample with PCL's tutorial parameters needs about 1e8.
constexpr double kMaxPointwiseWork = 1e10;

// At most how many points the point-wise filter's octree collects for one pass over
// windows of `window` metres: each point's box, one window wide and centred on it, lies
// within the 5 x 5 cells of side window / 4 around the point's own, so each point counts
// those cells' points: at most 1.56 times what its box holds for evenly spread points
// (25 / 16), and a dense cluster beside a far point is counted as dense, which a count
// from the extent is not.
double collected_at_most(const pcl::PointCloud<pcl::PointXYZ>& cloud, float window, double ex,
                         double ey) {
    const double side = 0.25 * static_cast<double>(window);
    const auto n = static_cast<double>(cloud.size());
    if (0.5 * static_cast<double>(window) >= std::max(ex, ey)) return n * n;  // all in each
    // Cells numbered from 2 (cell 0 has neighbours at -2): below 2^27 per axis, as the
    // cell size is checked against the extent first.
    const auto key = [](std::int64_t cx, std::int64_t cy) { return (cx + 2) << 32 | (cy + 2); };
    std::vector<std::int64_t> keys(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i)
        keys[i] = key(static_cast<std::int64_t>(std::floor(cloud[i].x / side)),
                      static_cast<std::int64_t>(std::floor(cloud[i].y / side)));
    std::sort(keys.begin(), keys.end());
    std::vector<std::int64_t> cells, counts;  // the occupied cells, sorted, and their points
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i + 1;
        while (j < keys.size() && keys[j] == keys[i]) ++j;
        cells.push_back(keys[i]);
        counts.push_back(static_cast<std::int64_t>(j - i));
        i = j;
    }
    double total = 0.0;
    for (std::size_t c = 0; c < cells.size(); ++c) {
        double around = 0.0;
        for (std::int64_t dx = -2; dx <= 2; ++dx)
            for (std::int64_t dy = -2; dy <= 2; ++dy) {
                const std::int64_t other = cells[c] + dx * (std::int64_t{1} << 32) + dy;
                const auto found = std::lower_bound(cells.begin(), cells.end(), other);
                if (found != cells.end() && *found == other)
                    around += static_cast<double>(counts[found - cells.begin()]);
            }
        total += static_cast<double>(counts[c]) * around;
    }
    return total;
}

void check_against_extent(const ProgressiveMorphologicalFilterParams& params,
                          const pcl::PointCloud<pcl::PointXYZ>& cloud, double ex, double ey) {
    const std::size_t n = cloud.size();
    const auto cell = static_cast<float>(params.cell_size);
    const auto base = static_cast<float>(params.base);
    if (!(cell >= std::numeric_limits<float>::min()) || !std::isfinite(cell))
        throw std::invalid_argument("cell_size: PCL computes in float32, which cannot hold " +
                                    check::format_value(params.cell_size));
    const double cells_x = std::floor(ex / cell) + 1.0, cells_y = std::floor(ey / cell) + 1.0;
    if (std::max(cells_x, cells_y) > kMaxCellsPerAxis)
        throw std::invalid_argument("cell_size is too small for the extent of the points (" +
                                    check::format_value(ex) + " x " + check::format_value(ey) +
                                    " m: more than 2^24 cells on an axis), got " +
                                    check::format_value(params.cell_size));
    if (params.approximate && cells_x * cells_y > kMaxApproximateCells)
        throw std::invalid_argument(
            "cell_size is too small for the extent of the points: the approximate filter's "
            "grids would hold " +
            check::format_value(cells_x * cells_y) +
            " cells (at most 2^28; a stray point far from the rest makes the extent this "
            "large), got " +
            check::format_value(params.cell_size));
    // The series, as PCL computes it: metres (point-wise) or cells (approximate).
    float window = 0.0f, previous = -1.0f;
    double work = 0.0;
    std::vector<float> windows;  // the point-wise series
    for (int k = 0; window < params.max_window_size; ++k) {
        if (k == kMaxWindows)
            throw std::invalid_argument(
                "base and max_window_size: the window series takes more than 64 steps to "
                "reach max_window_size (base " +
                check::format_value(params.base) + ", " +
                (params.exponential ? "exponential" : "linear") + ")");
        double half = 0.0;
        if (params.approximate) {
            // PCL: static_cast<int>(pow(base, k)), or (k + 1) * base in float truncated.
            half = params.exponential
                       ? std::trunc(std::pow(static_cast<double>(base), k))
                       : std::trunc(static_cast<double>(static_cast<float>(k + 1) * base));
            if (!(half < 1 << 30))  // PCL's int half size, and int row indices beyond it
                throw std::invalid_argument(
                    "base: the approximate filter's window half size overflows int at step " +
                    std::to_string(k) + ", got base " + check::format_value(params.base));
            window = static_cast<float>(2 * static_cast<std::int64_t>(half) + 1);
            work += cells_x * cells_y * std::min(2 * half + 1, cells_y) *
                    std::min(2 * half + 1, cells_x);
        } else {
            window = params.exponential ? cell * (2.0f * std::pow(base, k) + 1.0f)
                                        : cell * (2.0f * static_cast<float>(k + 1) * base + 1.0f);
            if (!std::isfinite(window))
                throw std::invalid_argument(
                    "cell_size and base: a window of the series is beyond float32 at step " +
                    std::to_string(k));
            // Points spread evenly: a box holds the share of them its window covers of
            // each axis (all of them once the window spans the extent). Counted from
            // the points below, once this cheap count passes.
            const double share_x = ex > 0.0 ? std::min(1.0, window / ex) : 1.0;
            const double share_y = ey > 0.0 ? std::min(1.0, window / ey) : 1.0;
            const auto points = static_cast<double>(n);
            work += 2.0 * points * points * share_x * share_y;
            windows.push_back(window);
        }
        if (!(window > previous))
            throw std::invalid_argument(
                "base: the window series does not grow (base " + check::format_value(params.base) +
                " as float32 holds it" +
                (params.exponential ? ", exponential: it must exceed 1" : "") +
                "), so PCL would never reach max_window_size");
        previous = window;
    }
    if (!params.approximate && work <= kMaxPointwiseWork) {
        work = 0.0;
        for (const float w : windows) {
            work += 2.0 * collected_at_most(cloud, w, ex, ey);
            if (work > kMaxPointwiseWork) break;
        }
    }
    if (!params.approximate && work > kMaxPointwiseWork)
        throw std::invalid_argument(
            "max_window_size and cell_size: the point-wise filter would collect up to about " +
            check::format_value(work) +
            " points from its octree (every point, in a box one window wide, twice per "
            "window, counted by cells a quarter window wide; at most 1e10, a minute or two); "
            "use approximate=True, fewer points, a "
            "smaller max_window_size or a larger cell_size");
    if (params.approximate && work > kMaxApproximateWork)
        throw std::invalid_argument(
            "cell_size and max_window_size: the approximate filter would compare about " +
            check::format_value(work) +
            " cells (each cell against its window, for every window; at most 1e11); use a "
            "larger cell_size or a smaller max_window_size");
}

template <class Filter>
void run(Filter& filter, const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud,
         const ProgressiveMorphologicalFilterParams& params, pcl::Indices& indices) {
    filter.setInputCloud(cloud);
    filter.setMaxWindowSize(params.max_window_size);
    filter.setSlope(static_cast<float>(params.slope));
    filter.setInitialDistance(static_cast<float>(params.initial_distance));
    filter.setMaxDistance(static_cast<float>(params.max_distance));
    filter.setCellSize(static_cast<float>(params.cell_size));
    filter.setBase(static_cast<float>(params.base));
    filter.setExponential(params.exponential);
    filter.extract(indices);
}

}  // namespace

void pcl_progressive_morphological_filter(PointsView points,
                                          const ProgressiveMorphologicalFilterParams& params,
                                          bool* ground) {
    validate(params);
    std::fill(ground, ground + points.size, false);
    if (points.size == 0) return;
    const auto origin = local_origin(points);
    const auto cloud = to_pcl_cloud(points, origin);  // first: it names a stray point
    const auto upper = upper_corner(points, origin);
    check_against_extent(params, *cloud, upper[0] - origin[0], upper[1] - origin[1]);
    poll_interrupt();  // PCL's filters themselves cannot be interrupted

    pcl::Indices indices;
    if (params.approximate) {
        pcl::ApproximateProgressiveMorphologicalFilter<pcl::PointXYZ> filter;
        run(filter, cloud, params, indices);
    } else {
        pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> filter;
        run(filter, cloud, params, indices);
    }
    poll_interrupt();
    for (const auto i : indices) ground[i] = true;
}

}  // namespace pcl_rg
