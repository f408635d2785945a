// Grid region-growing ground filter (seed 000; algorithms.md section 3).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Defaults are GridGroundParams.isprs(): the pick of benchmarks/studies/ground_isprs.py
/// --search --rule resolution over the seven ISPRS samples (mean total error; chosen
/// among the rules by leave-one-sample-out error, ground_isprs_cv.py). The definition of
/// algorithms.md section 3 is min_seed_component = 1, grow_across_blocks = false,
/// outlier_depth = 0, filter_passes = 0, final_cell = 0 (final_passes then does nothing),
/// and its pure slope rule height_tolerance = 0.
/// The multiple of the point spacing an unset cell_size is at most (see cell_size);
/// chosen with the other defaults on the seven ISPRS samples (benchmarks/studies/
/// ground_isprs.py --search, cross-validated by ground_isprs_cv.py). Python mirror:
/// GridGroundParams.SPACING_MULTIPLES.
inline constexpr double kGridCellPerSpacing = 2.0;
/// The most passes filter_passes and final_passes may ask for. Both stop sooner when a
/// pass changes nothing (each pass reads only the last one's ground, so nothing would
/// change again), but a cycle could go on; the presets use 2. Python mirror: the
/// fields' maximum in GridGroundParams.
inline constexpr std::int64_t kGridMaxPasses = 64;

struct GridGroundParams {
    /// Block edge lengths along x, y (> 0, m): one seed per block; should exceed the
    /// largest building. Blocks are anchored at multiples of block_size in world
    /// coordinates, so that tiles of a survey share one lattice.
    std::array<double, 2> block_size{30.0, 30.0};
    /// Cell edge lengths along x, y (> 0, m, at most the block size): links reach the
    /// 3 x 3 cells around a point. Cells start at the block corner below the input's
    /// minimum corner, so they line up across tiles when block_size is a whole
    /// multiple of cell_size. Unset (the default): per axis block_size / k with k the
    /// smallest whole number making the cell at most kGridCellPerSpacing x the point
    /// spacing (point_spacing.hpp: spacing_or_one_metre), so cells always line up.
    std::optional<std::array<double, 2>> cell_size;
    /// S, tangent of the steepest terrain (>= 0, finite): p, q are linked when
    /// |z_p - z_q| <= slope * d_xy(p, q) + height_tolerance.
    double slope = 0.3;
    /// t, height difference always allowed between linked points (>= 0, finite, m).
    double height_tolerance = 0.0;
    /// Robust seed (>= 1): the seed is the lowest point of the block whose connected
    /// component holds at least this many points (1: the lowest point, the seed's rule).
    /// When no component is that large the lowest point's component is ground.
    std::int64_t min_seed_component = 10;
    /// Low outliers (m, >= 0; 0: off): a point with a point at another position in its
    /// 3 x 3 cells (any block) and every such point more than this above it (copies of it
    /// do not count) is never ground: not a seed,
    /// not linked, not tested against by the pre-filter, not a final-pass TIN vertex.
    double outlier_depth = 2.0;
    /// Links also join points of different blocks (cells still 3 x 3); the seeds stay
    /// one per block and ground is the union of their components.
    bool grow_across_blocks = true;
    /// Slope pre-filter passes (0 to kGridMaxPasses; 0 = off). Pass 1 drops every point p
    /// that lies higher than some point q of its 3 x 3 cells (any block) by more than
    /// filter_slope * d_xy + filter_tolerance; pass k > 1 tests only against the ground
    /// of pass k - 1. Dropped points are object and never link; the growth runs per pass.
    /// A pass whose ground is the last one's ends them: the rest would repeat it.
    std::int64_t filter_passes = 2;
    /// Slope of the pre-filter (>= 0, finite).
    double filter_slope = 0.7;
    /// Height tolerance of the pre-filter (>= 0, finite, m).
    double filter_tolerance = 0.5;
    /// Final pass (0: off): cell (m, >= 0) of a TIN of the lowest ground point per cell;
    /// every point is then ground when -final_below <= z - z_TIN <= final_above +
    /// final_slope * |grad z_TIN| (final_pass.hpp; TerraScan, Zhao et al. 2016).
    double final_cell = 4.0;
    /// Height above the final TIN up to which a point is ground on flat terrain (m, >= 0).
    double final_above = 0.5;
    /// Depth below the final TIN down to which a point is ground (m, >= 0).
    double final_below = 5.0;
    /// Allowance per unit of the final TIN's gradient (m, >= 0).
    double final_slope = 2.0;
    /// Depth (m, >= 0; 0: off) below the median of the lowest ground heights of the 7 x 7
    /// final cells around its own beyond which a ground point gives no vertex of the
    /// final TIN (final_pass.hpp), so that a patch of low points (multipath) pulls no
    /// surface down to it. 2 m: the ISPRS preset's (cross-validated).
    double final_low_depth = 2.0;
    /// Rounds of the final pass (1 to kGridMaxPasses; used when final_cell > 0): each
    /// round after the first builds its TIN from the previous round's ground, whose
    /// lowest point per cell may be a ground point the growth missed where the growth's
    /// was an object point. A round that changes nothing ends them.
    std::int64_t final_passes = 2;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const GridGroundParams& params);

/// `params` with cell_size, when unset, set from `spacing` (m, > 0) as stated there.
GridGroundParams with_spacing(const GridGroundParams& params, double spacing);

/// What a run used, for diagnostics.
struct GridGroundStats {
    /// The spacing an unset cell_size took (m; NaN: it was given, or no points).
    double point_spacing = std::numeric_limits<double>::quiet_NaN();
    std::array<double, 2> cell_size{};   ///< the cell size used (m)
    std::int64_t filter_passes_run = 0;  ///< pre-filter passes run (fewer: one changed nothing)
    std::int64_t final_passes_run = 0;   ///< final-pass rounds run (likewise)
    double prepare_seconds = 0.0;        ///< bounding box, spacing and the cell grid
    double growth_seconds = 0.0;         ///< low outliers, pre-filter passes and components
    double final_pass_seconds = 0.0;     ///< every final-pass round
};

/// Fills `ground[i]` (N entries) with the ground mask of algorithms.md section 3 and the
/// options above. In float64 local coordinates l = p - o, with o_x, o_y the block corner
/// lattice_floor(min, block_size) at or below the minimum corner and o_z the minimum z,
/// block = floor(l / block_size) and cell = floor(l / cell_size) per axis (x, y): the
/// world lattice's indices less a constant of the call. p, q are neighbours when
/// their cells differ by at most 1 on x and on y, and linked when they are neighbours in
/// the same block (any block with grow_across_blocks), both pass the pre-filter, and
/// |lz_p - lz_q| <= slope * sqrt(dx * dx + dy * dy) + height_tolerance (that operation
/// order; dx, dy differences of local coordinates). Ground is the union of the connected
/// components of the blocks' seeds. Parallel (OpenMP) and deterministic: the result
/// depends on the point order only through the tie rule of the seed (lowest index).
/// `stats`, when given, receives the spacing and cell size used.
void grid_ground(PointsView points, const GridGroundParams& params, bool* ground,
                 GridGroundStats* stats = nullptr);

}  // namespace pcl_rg
