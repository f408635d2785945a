// PCL's pcl::ProgressiveMorphologicalFilter behind a plain function: a ground-filter
// baseline for benchmarks only, not part of the public algorithms.
#pragma once

#include <array>

#include "pcl_rg/points.hpp"

namespace pcl_rg {

/// Parameters of pcl::ProgressiveMorphologicalFilter; defaults are PCL's tutorial values
/// ("Identifying ground returns using ProgressiveMorphologicalFilter segmentation").
struct PclProgressiveMorphologicalFilterParams {
    /// Largest morphological window (>= 1, cells); setMaxWindowSize.
    int max_window_size = 20;
    /// Slope used for the height thresholds (>= 0, finite, m per m); setSlope.
    double slope = 1.0;
    /// Height threshold of the first window (>= 0, finite, m); setInitialDistance.
    double initial_distance = 0.5;
    /// Cap of the height threshold (>= 0, finite, m); setMaxDistance.
    double max_distance = 3.0;
    /// Cell size of the morphological grid (> 0, finite, m); setCellSize.
    double cell_size = 1.0;
    /// Base of the window-size progression (> 0, finite); setBase.
    double base = 2.0;
    /// Windows grow exponentially (true) or linearly; setExponential.
    bool exponential = true;
};

/// Throws std::invalid_argument naming the parameter when a value is out of range.
void validate(const PclProgressiveMorphologicalFilterParams& params);

/// pcl::ProgressiveMorphologicalFilter on the points minus `origin` (as float32); fills
/// `ground` (N entries) from the ground indices PCL returns.
void pcl_progressive_morphological_filter(PointsView points, const std::array<double, 3>& origin,
                                          const PclProgressiveMorphologicalFilterParams& params,
                                          bool* ground);

}  // namespace pcl_rg
