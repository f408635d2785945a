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
    points: npt.NDArray[np.float64],
    params: StatisticalOutlierRemovalParams,
    origin: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float32], float, npt.NDArray[np.float32]]: ...
def lzf_decompress(data: bytes, expected_size: int) -> bytes: ...
def lzf_compress(data: bytes) -> bytes: ...
def block_cache_release() -> int: ...
def block_cache_set_limit(bytes: int) -> int: ...
def block_cache_stats() -> dict[str, int]: ...

class GridGroundParams:
    block_size: tuple[float, float]
    cell_size: tuple[float, float] | None
    slope: float
    height_tolerance: float
    min_seed_component: int
    outlier_depth: float
    grow_across_blocks: bool
    filter_passes: int
    filter_slope: float
    filter_tolerance: float
    final_cell: float
    final_above: float
    final_below: float
    final_slope: float
    final_low_depth: float
    final_passes: int
    def __init__(self) -> None: ...

def grid_ground(
    points: npt.NDArray[np.float64], params: GridGroundParams
) -> tuple[npt.NDArray[np.bool_], dict[str, float | int | tuple[float, float]]]: ...

class TinGroundParams:
    max_building_size: float
    max_terrain_angle: float
    iteration_angle: float
    iteration_distance: float
    reduce_angle_edge: float
    stop_edge: float | None
    near_vertex_distance: float | None
    seed_cell: float | None
    seed_tolerance: float
    outlier_depth: float
    opening_rank: int
    border_vertices: bool
    final_cell: float | None
    final_above: float
    final_below: float
    final_slope: float
    final_low_depth: float
    densify_cell: float | None
    def __init__(self) -> None: ...

def tin_ground(
    points: npt.NDArray[np.float64], params: TinGroundParams
) -> tuple[npt.NDArray[np.bool_], dict[str, float]]: ...

class DelaunayTin:
    quantum: float
    vertices: npt.NDArray[np.int64]
    triangles: npt.NDArray[np.int32]
    neighbors: npt.NDArray[np.int32]
    dead_vertices: int
    live: npt.NDArray[np.bool_]
    def __init__(self, lower_x: float, lower_y: float, upper_x: float, upper_y: float) -> None: ...
    def insert(self, xy: npt.NDArray[np.float64], batch: bool = ...) -> npt.NDArray[np.int32]: ...
    def insert_on_border(self, grid: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]: ...
    def locate(self, xy: npt.NDArray[np.float64]) -> npt.NDArray[np.int32]: ...
    def to_grid(self, xy: npt.NDArray[np.float64]) -> npt.NDArray[np.int32]: ...

def delaunay_triangulate(xy: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]: ...
def point_spacing(points: npt.NDArray[np.float64]) -> float: ...

ORIGIN_FENCE: float

def float32_origin(points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
def rows_within_float32_reach(
    points: npt.NDArray[np.float64], origin: npt.NDArray[np.float64]
) -> npt.NDArray[np.int64]: ...
def max_far_points(n: int) -> int: ...

# --- normals, region growing (region_growing.hpp) -----------------------------------

QUADRIC_CONDITION_LIMIT: float

class NormalsParams:
    k: int
    def __init__(self) -> None: ...

def normals(
    points: npt.NDArray[np.float64], params: NormalsParams
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    int,
]: ...
def neighbour_lists(
    points: npt.NDArray[np.float64],
    params: NormalsParams,
    leaf_budget: int | None = ...,
    heap_from_k: int | None = ...,
) -> npt.NDArray[np.uint32]: ...

class SeedMeasure:
    curvedness: SeedMeasure
    gaussian: SeedMeasure
    mean: SeedMeasure
    surface_variation: SeedMeasure
    concavity: SeedMeasure
    name: str
    value: int

class RegionGrowingParams:
    k: int
    smoothness_deg: float
    curvature_threshold: float
    min_cluster_size: int
    max_cluster_size: int
    seed_measure: SeedMeasure
    viewpoint: list[float]
    def __init__(self) -> None: ...

def region_growing(
    points: npt.NDArray[np.float64], params: RegionGrowingParams
) -> tuple[npt.NDArray[np.int32], float, float, int]: ...

class ConvexSegmentationParams:
    noise_leaves: float
    k: int
    smoothness_deg: float
    curvature_threshold: float
    concavity_tolerance_deg: float
    min_cluster_size: int
    viewpoint: list[float] | None
    def __init__(self) -> None: ...

def convex_segmentation(
    points: npt.NDArray[np.float64], params: ConvexSegmentationParams
) -> tuple[npt.NDArray[np.int32], float, float, float, float, list[float], int]: ...
def default_viewpoint(points: npt.NDArray[np.float64]) -> list[float]: ...
def point_scale(points: npt.NDArray[np.float64]) -> tuple[float, float, int]: ...
def merge_convex(
    points: npt.NDArray[np.float64],
    neighbours: npt.NDArray[np.uint32],
    normals: npt.NDArray[np.float64],
    patches: npt.NDArray[np.int32],
    params: ConvexSegmentationParams,
) -> npt.NDArray[np.int32]: ...
def grow_regions(
    neighbours: npt.NDArray[np.uint32],
    normals: npt.NDArray[np.float64],
    measure: npt.NDArray[np.float64],
    params: RegionGrowingParams,
) -> npt.NDArray[np.int32]: ...
