"""Type stub of the pcl_rg._pcl extension: PCL's own classes (internal; use pcl_rg.pcl)."""

import numpy as np
import numpy.typing as npt

from pcl_rg._core import StatisticalOutlierRemovalParams, VoxelGridParams

def voxel_grid(
    points: npt.NDArray[np.float64], params: VoxelGridParams
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def statistical_outlier_removal(
    points: npt.NDArray[np.float64], params: StatisticalOutlierRemovalParams
) -> npt.NDArray[np.bool_]: ...

class ProgressiveMorphologicalFilterParams:
    max_window_size: int
    slope: float
    initial_distance: float
    max_distance: float
    cell_size: float
    base: float
    exponential: bool
    approximate: bool
    def __init__(self) -> None: ...

def progressive_morphological_filter(
    points: npt.NDArray[np.float64], params: ProgressiveMorphologicalFilterParams
) -> npt.NDArray[np.bool_]: ...

class LccpParams:
    voxel_resolution: float
    seed_resolution: float
    spatial_importance: float
    normal_importance: float
    refinement_iterations: int
    concavity_tolerance_deg: float
    smoothness_threshold: float
    k_factor: int
    sanity_check: bool
    min_segment_size: int
    viewpoint: list[float]
    def __init__(self) -> None: ...

def lccp(
    points: npt.NDArray[np.float64], params: LccpParams
) -> tuple[npt.NDArray[np.int32], float, float]: ...

class NormalEstimationParams:
    k: int
    def __init__(self) -> None: ...

class RegionGrowingPclParams:
    k: int
    smoothness_deg: float
    curvature_threshold: float
    min_cluster_size: int
    max_cluster_size: int
    def __init__(self) -> None: ...

def normal_estimation(
    points: npt.NDArray[np.float64], params: NormalEstimationParams
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
def region_growing(
    points: npt.NDArray[np.float64], params: RegionGrowingPclParams
) -> tuple[npt.NDArray[np.int32], float, float]: ...
