// PCL's pcl::ProgressiveMorphologicalFilter and pcl::ApproximateProgressiveMorphologicalFilter,
// unmodified, behind a plain function: the ground-filter baseline of pcl_rg.pcl.
#pragma once

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Parameters of pcl::(Approximate)ProgressiveMorphologicalFilter; defaults are PCL's
/// tutorial values ("Identifying ground returns using ProgressiveMorphologicalFilter
/// segmentation").
struct ProgressiveMorphologicalFilterParams {
    /// Largest morphological window (>= 1, cells); setMaxWindowSize.
    int max_window_size = 20;
    /// Slope used for the height thresholds (>= 0, m per m); setSlope.
    double slope = 1.0;
    /// Height threshold of the first window (>= 0, m); setInitialDistance.
    double initial_distance = 0.5;
    /// Cap of the height threshold (>= 0, m); setMaxDistance.
    double max_distance = 3.0;
    /// Cell size of the morphological grid (> 0, m); setCellSize.
    double cell_size = 1.0;
    /// Base of the window-size progression (> 0); setBase.
    double base = 2.0;
    /// Windows grow exponentially (true) or linearly; setExponential.
    bool exponential = true;
    /// pcl::ApproximateProgressiveMorphologicalFilter (grid-cell minima) instead of the
    /// point-wise pcl::ProgressiveMorphologicalFilter.
    bool approximate = false;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const ProgressiveMorphologicalFilterParams& params);

/// The filter on the points minus their local origin (as float32); fills `ground`
/// (N entries) from the ground indices PCL returns.
void pcl_progressive_morphological_filter(PointsView points,
                                          const ProgressiveMorphologicalFilterParams& params,
                                          bool* ground);

}  // namespace pcl_rg
