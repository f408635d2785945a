"""Type stub of the pcl_rg._core extension (internal; use the pcl_rg package)."""

import numpy as np
import numpy.typing as npt

class VoxelGridParams:
    leaf_size: list[float]
    min_points_per_voxel: int
    def __init__(self) -> None: ...

class StatisticalOutlierRemovalParams:
    mean_k: int
    std_mul: float
    def __init__(self) -> None: ...

def voxel_grid(
    points: npt.NDArray[np.float64], params: VoxelGridParams
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def statistical_outlier_removal(
    points: npt.NDArray[np.float64], params: StatisticalOutlierRemovalParams
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float32], float]: ...
def pcl_voxel_grid(
    points: npt.NDArray[np.float64], origin: npt.NDArray[np.float64], params: VoxelGridParams
) -> npt.NDArray[np.float64]: ...
def pcl_statistical_outlier_removal(
    points: npt.NDArray[np.float64],
    origin: npt.NDArray[np.float64],
    params: StatisticalOutlierRemovalParams,
) -> npt.NDArray[np.bool_]: ...
def lzf_decompress(data: bytes, expected_size: int) -> bytes: ...
def lzf_compress(data: bytes) -> bytes: ...
