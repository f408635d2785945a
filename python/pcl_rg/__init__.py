"""pcl_rg: LiDAR ground filtering and point-cloud segmentation on NumPy arrays.

The algorithms run in a C++ core over PCL 1.13; each has a NumPy/SciPy twin in
:mod:`pcl_rg.reference` that the tests hold it to.
"""

from .statistical_outlier_removal import (
    StatisticalOutlierRemovalParams,
    statistical_outlier_removal,
)
from .voxel_grid import VoxelGridParams, VoxelGridResult, voxel_grid

__version__ = "0.1.0"

__all__ = [
    "StatisticalOutlierRemovalParams",
    "VoxelGridParams",
    "VoxelGridResult",
    "statistical_outlier_removal",
    "voxel_grid",
]
