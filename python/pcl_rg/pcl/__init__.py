"""PCL's own classes, unmodified, on NumPy arrays: the baselines to compare against.

Each function runs one PCL 1.13 class as PCL ships it (``pcl::VoxelGrid``,
``pcl::StatisticalOutlierRemoval``, ``pcl::NormalEstimation`` with
``pcl::RegionGrowing``, ``pcl::SupervoxelClustering`` with
``pcl::LCCPSegmentation``, ``pcl::ProgressiveMorphologicalFilter`` and
``pcl::ApproximateProgressiveMorphologicalFilter``) behind the signature and the
result type of the matching :mod:`pcl_rg` function, so the two can be swapped in
a comparison. Only the crossing is ours: input is checked as everywhere in
pcl_rg, a float64 local origin (the minimum corner for the voxel grid and the
morphological filters, the per-axis median for the k-nearest-neighbour classes,
so that a stray point far away does not coarsen the rest) is subtracted before
the points become PCL's float32 ``PointXYZ``, coordinate outputs are shifted back,
and results are per input point. Bad parameters raise instead of PCL's warnings.

PCL's classes are single-threaded (the approximate morphological filter aside)
and cannot be interrupted inside a class: Ctrl-C takes effect between stages.
"""

from .._statistical_outlier_removal import StatisticalOutlierRemovalParams
from .._voxel_grid import VoxelGridParams, VoxelGridResult
from ._filters import statistical_outlier_removal, voxel_grid
from ._lccp import LccpParams, lccp
from ._pmf import ProgressiveMorphologicalFilterParams, progressive_morphological_filter
from ._region_growing import (
    NormalEstimationParams,
    NormalEstimationResult,
    RegionGrowingPclParams,
    normals,
    region_growing,
)

__all__ = [
    "LccpParams",
    "NormalEstimationParams",
    "NormalEstimationResult",
    "ProgressiveMorphologicalFilterParams",
    "RegionGrowingPclParams",
    "StatisticalOutlierRemovalParams",
    "VoxelGridParams",
    "VoxelGridResult",
    "lccp",
    "normals",
    "progressive_morphological_filter",
    "region_growing",
    "statistical_outlier_removal",
    "voxel_grid",
]
