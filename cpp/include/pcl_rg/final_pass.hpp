// Final pass of a ground filter: classify every point by its height above a TIN of the
// filter's ground (TerraScan's "classify by distance to ground TIN"), shared by the filters.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "pcl_rg/cell_lowest.hpp"
#include "pcl_rg/delaunay.hpp"
#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Settings of the final pass; the filters carry them as fields named final_<name>.
struct FinalPassParams {
    /// Surface cell (m, > 0): the lowest ground point of each cell is a TIN vertex. Cells
    /// are anchored at multiples of their size in world coordinates.
    double cell = 4.0;
    /// Height above the TIN up to which a point is ground on flat terrain (m, >= 0).
    double above = 0.5;
    /// Depth below the TIN down to which a point is ground (m, >= 0).
    double below = 1.0;
    /// Allowance per unit of the TIN's gradient (m, >= 0): a point is ground up to
    /// above + slope * |grad z| above the TIN (Zhao et al. 2016's slope-adaptive threshold).
    double slope = 1.0;
    /// Depth (m, >= 0; 0: off) below the median of the lowest ground heights of the 7 x 7
    /// cells around its cell beyond which a ground point is no vertex candidate
    /// (final_pass_low.hpp): a patch of low points then pulls no TIN down to it.
    double low_depth = 0.0;
};

/// A setting's value; a filter's unset (std::nullopt) final_cell reads as 0, which passes
/// validate: the filter fills it in from the point spacing before the pass runs.
inline double final_setting(double value) { return value; }
inline double final_setting(const std::optional<double>& value) { return value.value_or(0.0); }

/// The final pass's settings of a filter's params (fields final_cell, final_above,
/// final_below, final_slope, final_low_depth).
template <class FilterParams>
FinalPassParams final_pass_params(const FilterParams& params) {
    return {final_setting(params.final_cell), params.final_above, params.final_below,
            params.final_slope, params.final_low_depth};
}

/// Throws std::invalid_argument when a setting is out of range, naming it as the filters
/// do (final_cell, final_above, ...). Every setting is a finite real >= 0.
void validate(const FinalPassParams& params);

/// Replaces `ground` (N entries, read as the filter's ground) by the final pass's
/// classification: the TIN's vertices are the lowest ground point of each cell (with
/// low_depth, of those not too low: final_pass_low.hpp; ties:
/// smallest index; of vertices on one snapped XY, the lowest, then smallest index), with
/// virtual vertices on its box's corners and sides (final_pass_border.hpp);
/// a point p is ground when -below <= z_p - z_TIN(p) <= above + slope * |grad z_TIN(p)|,
/// in the triangle holding p + (eps, eps^2). No ground in: no ground out. The parameters
/// are checked by the caller (validate above). Deterministic for any number of
/// threads; see final_pass.cpp for the exact formulas.
void final_pass(PointsView points, const FinalPassParams& params, bool* ground);

/// Throws std::invalid_argument when the bounding box `origin`, `upper` has an extent
/// that is not finite in float64: the final pass cannot snap such points. For callers
/// that snap the points themselves (snap_frame, snap_points).
void check_final_pass_extent(const std::array<double, 3>& origin,
                             const std::array<double, 3>& upper);
/// The final pass's cells of `cell` metres (> 0) over the snapped points' box: anchored
/// at multiples of `cell` in world coordinates, heights from snapped.origin[2]. Throws
/// std::invalid_argument when more than 2^40 cells lie on an axis.
CellLattice final_cells(const SnappedPoints& snapped, double cell);

/// Whether a caller may fill SnappedPoints::cell for the lattice `cells` of N points:
/// the pass scans by position only where a raster of the cells holds at most an eighth
/// of a cell per point (each thread keeps its own; the presets' 4 m cells hold about 64
/// points each), and every cell number fits 32 bits.
inline bool final_cells_by_position(const CellLattice& cells, std::size_t n) {
    return cells.columns <= static_cast<std::int64_t>(n / 8) / cells.rows;
}

/// A virtual vertex of the final pass's TIN on a side of its box: grid XY and height.
struct BorderVertex {
    std::int32_t x, y;
    double z;
};

/// What a round of the final pass leaves for the next round on the same snapped points
/// and settings (final_pass's `rounds`): its vertices and where their triangles lie.
struct FinalPassRounds {
    bool ran = false;                     ///< whether a round filled the fields below
    std::size_t points = 0;               ///< how many points that round classified
    std::vector<std::uint32_t> vertices;  ///< the TIN's vertices' points, insertion order
    /// Per vertex (as `vertices`): the grid box of its triangles, x0, y0, x1, y1 (closed).
    std::vector<std::array<std::int32_t, 4>> vertex_star;
    std::vector<std::uint64_t> is_vertex;  ///< bit i: point i is a vertex
    std::array<double, 4> corner_z{};      ///< heights of the virtual corners
    /// The virtual vertices on the box's sides, by (x, y), and the grid boxes of their stars.
    std::vector<BorderVertex> border;
    std::vector<std::array<std::int32_t, 4>> border_star;
};

/// The same pass on points already snapped and sorted (by snap_points, as tin_ground
/// has them, or in grid_ground's own order on snap_frame's frame), so that nothing is
/// computed twice; their extent is finite. The points `never_ground` (indices) are not
/// ground whatever their height. With `rounds` (grid_ground's final_passes), a round
/// that follows another on the same points, settings and never_ground, with `ground` as
/// that round left it, locates again only the points near a triangle that the last
/// round's TIN did not have, and none when its vertices are the last round's: a
/// triangle of both TINs holds the same points and gives them the same verdict (its
/// three vertices, and so its plane, are the same points), so the result is the full
/// pass's, exactly. With `tin_memory`, a triangulation the caller no longer needs
/// (tin_ground's), the pass builds its TIN in it (Delaunay::reset), reusing its memory;
/// the result is the same. (grid_ground's rounds build TINs of a vertex per 4 m cell,
/// too small for it to show.)
void final_pass(PointsView points, const FinalPassParams& params, const SnappedPoints& snapped,
                bool* ground, FinalPassRounds* rounds = nullptr,
                const std::vector<std::uint32_t>& never_ground = {},
                Delaunay* tin_memory = nullptr);

}  // namespace pcl_rg
