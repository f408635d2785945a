// Progressive TIN densification ground filter (Axelsson 2000; LiDAR360's parameters).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// The lengths left unset take min(cap, multiple x the point spacing), the seed, final
/// and densify cells a rung below it (tin_lattice_length) (point_spacing.hpp:
/// spacing_or_one_metre). The caps are the lengths of the ISPRS preset, fixed lengths
/// chosen and cross-validated on the seven ISPRS samples (benchmarks/studies/
/// tin_isprs_params.py, ground_isprs_cv.py: no rule that scales them did better there);
/// each multiple is its cap / kTinFullLengthSpacing, so data as sparse as the ISPRS
/// samples (0.99-2.41 m) keeps the preset's lengths and denser data gets them in
/// proportion to its spacing. The stop edge's multiple is that of a 4 m stop edge
/// instead: on ISPRS any stop edge of 2-6 m scores the same (3.23-3.25 %, 10 m
/// 3.33 %), so up to about 6 spacings it costs no accuracy there, while on dense
/// data a stop edge half as long inserts 2-3 times the vertices (0.5 m spacing,
/// 10M points: 7.4M vertices at 1.05 m, 2.7M at 2 m). It stays 2 m down to a
/// spacing of 0.475 m (benchmarks/RESULTS.md, "Ground filters at 2-20 points per
/// m^2"). The seed, final and densify cells lie on the world lattice of their size, and
/// their unset lengths are the rungs of a ladder below their caps (tin_lattice_length).
/// Python mirror: TinGroundParams.SPACING_CAPS and SPACING_MULTIPLES.
inline constexpr double kTinFullLengthSpacing = 0.95;
inline constexpr double kTinStopEdgeCap = 2.0;
inline constexpr double kTinNearVertexCap = 1.0;
inline constexpr double kTinSeedCellCap = 2.0;
inline constexpr double kTinFinalCellCap = 3.0;
inline constexpr double kTinStopEdgePerSpacing = 4.0 / kTinFullLengthSpacing;
inline constexpr double kTinNearVertexPerSpacing = kTinNearVertexCap / kTinFullLengthSpacing;
inline constexpr double kTinSeedCellPerSpacing = kTinSeedCellCap / kTinFullLengthSpacing;
/// The largest opening_rank: the rank erosion keeps that many heights per seed cell
/// (8 bytes each; the seed raster has at most 4 cells per point + 2^22, or a corridor's
/// 2^25 / opening_rank).
inline constexpr std::int64_t kTinMaxOpeningRank = 8;
inline constexpr double kTinFinalCellPerSpacing = kTinFinalCellCap / kTinFullLengthSpacing;
/// densify_cell's: half the final cell's, so that unset both are on one ladder.
inline constexpr double kTinDensifyCellCap = kTinFinalCellCap / 2.0;
inline constexpr double kTinDensifyCellPerSpacing = kTinDensifyCellCap / kTinFullLengthSpacing;
inline constexpr double kTinLatticeRungs = 8.0;  // rungs per halving (tin_lattice_length)

/// An unset seed, final or densify cell: the largest cap x 2^(-j / 8), j >= 0 whole, that is at
/// most multiple x spacing (to rounding: at an exact rung, one either side). A cell in
/// exact proportion to the spacing moved the lattice's cells far from the world origin
/// by metres when one stray point nudged the spacing (UTM coordinates: 508 of 60,000
/// labels changed); on a ladder of 9 % rungs it changes only where the spacing crosses
/// one. (Whole fractions of the cap, as grid_ground's cell, halved the cells just below
/// the caps: 2 pts/m^2 scored 7.58 against 6.97 %.) Python: _point_spacing.lattice_length,
/// the same operations.
inline double tin_lattice_length(double cap, double multiple, double spacing) {
    const double ratio = cap / (multiple * spacing);
    // Below cap / DBL_MAX, as min(cap, length): 0 or a cell the seeds then refuse.
    if (!std::isfinite(ratio)) return std::min(cap, multiple * spacing);
    const double rungs = std::ceil(kTinLatticeRungs * std::log2(ratio));
    return cap * std::pow(2.0, -std::max(0.0, rungs) / kTinLatticeRungs);
}

/// The defaults are Python's TinGroundParams.isprs() preset (chosen on the ISPRS
/// samples); TinGroundParams.lidar360() is LiDAR360's own set: 20, 88, 8, 1.4, 5, 2 and
/// the improvements off. The five lengths that depend on the point spacing are unset
/// (std::nullopt) by default: each call then takes them from the spacing of its points
/// (the constants above).
struct TinGroundParams {
    /// Seed-grid cell (m, > 0): the lowest point of each cell is a seed. LiDAR360 "Max
    /// Building Size"; must exceed the largest building, or its flat roof becomes ground.
    /// The cells (and those of seed_cell) are anchored at multiples of their size in world
    /// coordinates, so that tiles of a survey share one lattice.
    double max_building_size = 40.0;
    /// Steepest triangle a point may form with its triangle's vertices (deg, (0, 90)).
    /// LiDAR360 "Max Terrain Angle".
    double max_terrain_angle = 88.0;
    /// Largest angle between the triangle's plane and the lines from its vertices to a
    /// point (deg, (0, 90]). LiDAR360 "Iteration Angle".
    double iteration_angle = 30.0;
    /// Largest distance from a point to the triangle's plane (m, > 0). LiDAR360
    /// "Iteration Distance".
    double iteration_distance = 1.4;
    /// In triangles whose longest XY edge L is shorter (m, > 0), the angle limit is
    /// iteration_angle * L / reduce_angle_edge. LiDAR360 "Reduce Iteration Angle When
    /// Edge Length <".
    double reduce_angle_edge = 0.01;
    /// Triangles whose longest XY edge is shorter (m, > 0) accept ground points without
    /// inserting them. LiDAR360 "Stop Triangulation When Edge Length <". Unset:
    /// min(kTinStopEdgeCap, kTinStopEdgePerSpacing x the point spacing).
    std::optional<double> stop_edge;
    /// Improvement (0: off): in the angle test the 3-D distance from a point
    /// to a vertex counts as at least this much (m, >= 0), so a point (nearly) above a
    /// vertex is judged by its distance to the plane, d <= sin(limit) * this, instead
    /// of an angle near 90 deg minus the slope. Helps on data with coarse or repeated XY.
    /// Unset: min(kTinNearVertexCap, kTinNearVertexPerSpacing x the point spacing).
    std::optional<double> near_vertex_distance;
    /// Improvement (0: off): seeds from a morphological opening instead of
    /// one per max_building_size cell. The lowest point of every seed_cell cell (m, >= 0)
    /// is a seed when it lies at most seed_tolerance above the grey opening of the
    /// cells' lowest heights by a square window of max_building_size, in the manner of
    /// Zhao et al. 2016's morphological seeds: dense seeds on open terrain, none on roofs.
    /// Unset: tin_lattice_length(kTinSeedCellCap, kTinSeedCellPerSpacing, the point spacing).
    std::optional<double> seed_cell;
    /// Height above the opened surface up to which a seed_cell cell's lowest point is a
    /// seed (m, >= 0); used only when seed_cell > 0.
    double seed_tolerance = 0.5;
    /// Improvement (0: off): a seed_cell cell whose lowest point lies more than
    /// this (m, >= 0) below the 9th lowest of the 25 cells of its 5 x 5 window gives no
    /// seed (low outliers, peeled repeatedly); used only when seed_cell > 0.
    double outlier_depth = 5.0;
    /// Improvement (1: off): the opening's erosion takes the opening_rank-th lowest of the
    /// cells of each window (an integer in [1, kTinMaxOpeningRank]; the lowest where a
    /// window holds fewer finite cells) instead of the lowest, so that a few low cells
    /// that outlier_depth leaves (true ground in a pit, or outliers shallower than it)
    /// cannot lower the opened surface, and take the seeds, across a whole window; used
    /// only when seed_cell > 0.
    std::int64_t opening_rank = 1;
    /// Improvement (false: off): virtual vertices along the box's sides besides its four
    /// corners, each side cut into floor(its extent / s) equal parts, s =
    /// max(max_building_size, the shorter XY extent) (ground_tin.hpp: border_points), each
    /// at the height of its nearest seed, so that along a corridor the TIN's border
    /// triangles do not reach to corners kilometres away.
    bool border_vertices = true;
    /// Final pass (0: off): cell (m, >= 0) of a TIN of the lowest ground point per cell;
    /// every point is then ground when -final_below <= z - z_TIN <= final_above +
    /// final_slope * |grad z_TIN| (final_pass.hpp; TerraScan, Zhao et al. 2016), so ground
    /// is complete below the stop edge. Unset: tin_lattice_length(kTinFinalCellCap,
    /// kTinFinalCellPerSpacing, the point spacing).
    std::optional<double> final_cell;
    /// Height above the final TIN up to which a point is ground on flat terrain (m, >= 0).
    double final_above = 0.5;
    /// Depth below the final TIN down to which a point is ground (m, >= 0).
    double final_below = 5.0;
    /// Allowance per unit of the final TIN's gradient (m, >= 0).
    double final_slope = 1.0;
    /// Depth (m, >= 0; 0: off) below the median of the lowest ground heights of the 7 x 7
    /// final cells around its own beyond which a ground point gives no vertex of the
    /// final TIN (final_pass.hpp), so that a patch of low points (multipath) pulls no
    /// surface down to it. 2 m: the ISPRS preset's (cross-validated).
    double final_low_depth = 2.0;
    /// Improvement (0: off; used only with a final pass): the densification tests only the
    /// lowest point (then smallest index; placed at its TIN grid position) of each cell of
    /// side min(densify_cell, final_cell / 2) (m, >= 0) on the world lattice of that size,
    /// and the final pass then classifies every point. The final TIN takes the lowest
    /// ground point of each final cell, which is nearly always one of those: on dense data
    /// the densification tests and inserts a fraction of the points (tin_densified.hpp),
    /// for the same held-out ISPRS error (benchmarks/RESULTS.md). Unset:
    /// tin_lattice_length(kTinDensifyCellCap, kTinDensifyCellPerSpacing, the point
    /// spacing), half the unset final cell: a cell that follows the spacing, because
    /// the lowest of ~100 points (a 1.5 m cell at 50 pts/m^2) misses ground the final
    /// pass cannot recover.
    std::optional<double> densify_cell;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const TinGroundParams& params);

/// What a run did, for benchmarks and tests.
struct TinGroundStats {
    std::int64_t seeds = 0;         ///< lowest points of the seed cells
    std::int64_t iterations = 0;    ///< the definition's, the last adding nothing or
                                    ///< leaving no point unclassified
    std::int64_t tin_vertices = 0;  ///< final TIN vertices, the virtual ones included
    std::int64_t tests = 0;         ///< point-in-triangle tests evaluated (after skipping)
    double prepare_seconds = 0.0;   ///< extent, spacing, snapping, spatial sort, seeds, and the
                                    ///< densification's arrays and first work list
    double triangulation_seconds = 0.0;   ///< Delaunay insertions
    double classification_seconds = 0.0;  ///< point location and acceptance tests
    double point_spacing = 0.0;         ///< spacing the unset lengths took (m; NaN: all were given)
    double stop_edge = 0.0;             ///< the lengths used (m): given, or from the spacing
    double near_vertex_distance = 0.0;  ///< (see stop_edge)
    double seed_cell = 0.0;             ///< (see stop_edge)
    double final_cell = 0.0;            ///< (see stop_edge)
    double densify_cell = 0.0;          ///< (see stop_edge; 0: every point tested)
};

/// The side (m) of the cells whose lowest points the densification tests, of `params`
/// with every length set: min(densify_cell, final_cell / 2), or 0 (every point tested)
/// when either is 0 (without a final pass nothing else would classify the others). A
/// subnormal final cell halves to 0 too; tin_densified refuses it.
inline double densify_cell(const TinGroundParams& params) {
    const double densify = params.densify_cell.value_or(0.0);
    const double final_cell = params.final_cell.value_or(0.0);
    if (!(densify > 0.0) || !(final_cell > 0.0)) return 0.0;
    return std::min(densify, final_cell / 2.0);
}

/// `params` with every unset length set from `spacing` (m, > 0) as stated there.
TinGroundParams with_spacing(const TinGroundParams& params, double spacing);

/// Fills `ground[i]` for every point (true: ground). Empty input is fine; 1 or 2
/// points, or points all collinear in XY, throw std::invalid_argument.
TinGroundStats tin_ground(PointsView points, const TinGroundParams& params, bool* ground);

}  // namespace pcl_rg
