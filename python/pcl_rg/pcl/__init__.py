"""PCL's own classes, unmodified, on NumPy arrays: the baselines to compare against.

Each function runs one PCL 1.13 class as PCL ships it (``pcl::VoxelGrid``,
``pcl::StatisticalOutlierRemoval``, ``pcl::NormalEstimation`` with
``pcl::RegionGrowing``, ``pcl::SupervoxelClustering`` with
``pcl::LCCPSegmentation``, ``pcl::ProgressiveMorphologicalFilter`` and
``pcl::ApproximateProgressiveMorphologicalFilter``) on the points of the
matching :mod:`pcl_rg` function. The voxel grid and the outlier removal take its
signature and give its result type, so the two swap in a comparison; normals,
region growing, LCCP and the morphological filters take parameter classes of
their own, as PCL's parameters mean other things (PCL's curvature is the surface
variation, at most 1/3: a ``curvature_threshold`` of pcl_rg's default, 80 1/m,
lets every point grow), and :func:`normals` gives PCL's normals and curvature.
Labels are int32, -1 for none, as everywhere in pcl_rg. Only the crossing is
ours: input is checked as everywhere in pcl_rg, a float64 local origin (the
minimum corner; for the k-nearest-neighbour classes that of the points not more
than 4 interquartile ranges below the first quartile, so that a stray point far
away does not coarsen the rest) is subtracted before the points become PCL's
float32 ``PointXYZ``, coordinate outputs are shifted back, and results are per
input point. Bad parameters raise instead of PCL's warnings.

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
