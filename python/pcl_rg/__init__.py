"""pcl_rg: LiDAR ground filtering and point-cloud segmentation on NumPy arrays.

The algorithms run in a C++ core over PCL 1.13; each has a NumPy/SciPy twin in
:mod:`pcl_rg.reference` that the tests hold it to. PCL's own classes, on the same
arrays and parameters, are in :mod:`pcl_rg.pcl`.

Everything here loads on first use, as in SciPy: ``import pcl_rg`` is cheap, and
``pcl_rg.io``, ``pcl_rg.datasets``, ``pcl_rg.evaluation``, ``pcl_rg.plot``,
``pcl_rg.reference``, ``pcl_rg.pcl`` and ``pcl_rg.pipeline`` are there without
importing them first.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

# Public name -> the private module that defines it.
_NAMES = {
    "ConvexSegmentationParams": "_convex_segmentation",
    "convex_segmentation": "_convex_segmentation",
    "GridGroundParams": "_grid_ground",
    "grid_ground": "_grid_ground",
    "point_spacing": "_point_spacing",
    "NormalsParams": "_normals",
    "NormalsResult": "_normals",
    "normals": "_normals",
    "PointScale": "_point_scale",
    "point_scale": "_point_scale",
    "RegionGrowingParams": "_region_growing",
    "region_growing": "_region_growing",
    "StatisticalOutlierRemovalParams": "_statistical_outlier_removal",
    "statistical_outlier_removal": "_statistical_outlier_removal",
    "TinGroundParams": "_tin_ground",
    "tin_ground": "_tin_ground",
    "VoxelGridParams": "_voxel_grid",
    "VoxelGridResult": "_voxel_grid",
    "voxel_grid": "_voxel_grid",
    "Diagnostics": "_diagnostics",
    "collect_diagnostics": "_diagnostics",
    "FarPointsWarning": "_far_points",
    "release_memory": "_memory",
    "set_memory_cache_limit": "_memory",
}
_SUBMODULES = (
    "batch",
    "datasets",
    "demo",
    "evaluation",
    "io",
    "pcl",
    "pipeline",
    "plot",
    "reference",
)

__all__ = sorted([*_NAMES, *_SUBMODULES])


def __getattr__(name: str) -> Any:
    if name in _NAMES:
        value = getattr(importlib.import_module(f".{_NAMES[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'pcl_rg' has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])


if TYPE_CHECKING:  # what type checkers and IDEs see; nothing runs here
    from . import datasets, demo, evaluation, io, pcl, pipeline, plot, reference
    from ._convex_segmentation import ConvexSegmentationParams, convex_segmentation
    from ._diagnostics import Diagnostics, collect_diagnostics
    from ._far_points import FarPointsWarning
    from ._grid_ground import GridGroundParams, grid_ground
    from ._memory import release_memory, set_memory_cache_limit
    from ._normals import NormalsParams, NormalsResult, normals
    from ._point_scale import PointScale, point_scale
    from ._point_spacing import point_spacing
    from ._region_growing import RegionGrowingParams, region_growing
    from ._statistical_outlier_removal import (
        StatisticalOutlierRemovalParams,
        statistical_outlier_removal,
    )
    from ._tin_ground import TinGroundParams, tin_ground
    from ._voxel_grid import VoxelGridParams, VoxelGridResult, voxel_grid
