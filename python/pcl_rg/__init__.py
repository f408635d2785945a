"""pcl_rg: LiDAR ground filtering and point-cloud segmentation on NumPy arrays.

The algorithms run in a C++ core over PCL 1.13; each has a NumPy/SciPy twin in
:mod:`pcl_rg.reference` that the tests hold it to.
"""

from . import evaluation
from .grid_ground import GridGroundParams, grid_ground
from .normals import NormalsParams, NormalsResult, normals
from .region_growing import RegionGrowingParams, region_growing
from .region_growing_pcl import RegionGrowingPclParams, region_growing_pcl
from .statistical_outlier_removal import (
    StatisticalOutlierRemovalParams,
    statistical_outlier_removal,
)
from .tin_ground import TinGroundParams, tin_ground
from .voxel_grid import VoxelGridParams, VoxelGridResult, voxel_grid

__version__ = "0.1.0"

__all__ = [
    "GridGroundParams",
    "NormalsParams",
    "NormalsResult",
    "RegionGrowingParams",
    "RegionGrowingPclParams",
    "StatisticalOutlierRemovalParams",
    "TinGroundParams",
    "VoxelGridParams",
    "VoxelGridResult",
    "evaluation",
    "grid_ground",
    "normals",
    "region_growing",
    "region_growing_pcl",
    "statistical_outlier_removal",
    "tin_ground",
    "voxel_grid",
]
