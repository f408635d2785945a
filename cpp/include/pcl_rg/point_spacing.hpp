// Mean XY point spacing of a cloud: the length the density-aware defaults of the ground
// filters scale with (TinGroundParams, GridGroundParams).
#pragma once

#include <array>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Mean XY spacing of the points (m): sqrt(M * c * c / N), the side of the square each
/// point would have if the occupied area were shared evenly. With N the number of points
/// and w, h the XY extent (max - min), the cells are squares of side
/// c = max(3 * sqrt(w * h / N), max(w, h) / 65536) (9 points per cell if the box were
/// evenly covered; the second term bounds the cell count of slim clouds) anchored at the
/// minimum corner: cell = floor((x - xmin) / c), floor((y - ymin) / c) in float64, and M
/// counts the cells that hold a point. Empty cells (water, gaps wider than about 3
/// spacings, the outside of an irregular outline) do not count, so a half-empty tile has
/// the spacing of its points, not of its box. Every return counts, so vegetation and
/// walls make the spacing smaller than that of the ground alone. A box less than a
/// quarter occupied (N > 36 M) whose bulk, from the 1st to the 99th percentile of x and
/// of y (N >= 100), spans less than a sixteenth of it is set by a few points far from
/// the rest: then c = max(3 * sqrt(bulk area / N), its larger side / 65536, max(w, h) /
/// 2^31) and M is counted again. NaN when undefined:
/// fewer than 2 points, or no XY area (w * h == 0: all on one line along x or y, such
/// as a vertical wall). Throws std::invalid_argument when w, h or w * h is not finite
/// in float64. Deterministic, O(N) (and a sort of the cells when the bulk sets them).
/// NumPy twin: pcl_rg.reference.point_spacing.
double point_spacing(PointsView points);

/// The same on the points' bounding box `lower` (local_origin) and `upper`
/// (upper_corner) when the caller has it: the box is not scanned again.
double point_spacing(PointsView points, const std::array<double, 3>& lower,
                     const std::array<double, 3>& upper);

/// The spacing the unset lengths of the ground filters scale with: point_spacing, or
/// 1 m where that is NaN (a cloud with no XY extent has no spacing to measure).
double spacing_or_one_metre(PointsView points);
double spacing_or_one_metre(PointsView points, const std::array<double, 3>& lower,
                            const std::array<double, 3>& upper);

}  // namespace pcl_rg
