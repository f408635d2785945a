"""NumPy reference for :func:`pcl_rg.convex_segmentation` (patches merged across convex edges)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from .._convex_segmentation import ConvexSegmentationParams
from .._far_points import check_fewer_than_kept
from .._params import resolve_arguments
from .._region_growing import RegionGrowingParams
from .._validation import as_points
from ._local import fenced_range, near_rows
from .normals import neighbour_lists, normals
from .point_scale import point_scale
from .region_growing import grow_regions
from .voxel_grid import voxel_grid

__all__ = ["convex_segmentation", "default_viewpoint", "merge_convex", "scaled_curvedness"]

#: The origin is the viewpoint within this many bounding-box diagonals (kSensorFrameReach).
SENSOR_FRAME_REACH = 100.0


def default_viewpoint(points: np.ndarray) -> tuple[float, float, float]:
    """The viewpoint used when none is given: the origin when it lies within
    `SENSOR_FRAME_REACH` diagonals of the points' bounding box without stray points (a
    sensor's own frame), else one diagonal above the top of that box over its centre
    (an airborne sensor). x and y: :func:`~pcl_rg.reference._local.fenced_range`; z:
    within the box's XY diagonal (or 4 interquartile ranges, if more) of the z
    quartiles, which keeps an airborne tile's roofs and trees, beyond the fence of its
    ground, and leaves out a no-data height or a bad fix kilometres up."""
    if len(points) == 0:
        return (0.0, 0.0, 0.0)
    (x0, x1), (y0, y1) = fenced_range(points[:, 0]), fenced_range(points[:, 1])
    z0, z1 = fenced_range(points[:, 2], math.hypot(x1 - x0, y1 - y0))
    low, high = np.array([x0, y0, z0]), np.array([x1, y1, z1])
    # As the core computes them: squares of a far stray point overflow to inf there too
    # (without a word), and the step that follows refuses the cloud.
    with np.errstate(over="ignore"):
        diagonal = math.sqrt(float(np.sum((high - low) ** 2)))
        outside = np.maximum(np.maximum(low, -high), 0.0)
        origin_distance = math.sqrt(float(np.sum(outside**2)))
    if origin_distance <= SENSOR_FRAME_REACH * diagonal:
        return (0.0, 0.0, 0.0)
    return (0.5 * (low[0] + high[0]), 0.5 * (low[1] + high[1]), float(high[2]) + diagonal)


def scaled_curvedness(
    points: np.ndarray, neighbours: np.ndarray, mean: np.ndarray, gaussian: np.ndarray
) -> np.ndarray:
    """Curvedness sqrt(H^2 + max(H^2 - K, 0)) times the distance to the last neighbour."""
    delta = points[neighbours[:, -1]] - points
    radius = np.sqrt(
        delta[:, 0] * delta[:, 0] + delta[:, 1] * delta[:, 1] + delta[:, 2] * delta[:, 2]
    )
    return np.sqrt(mean * mean + np.maximum(mean * mean - gaussian, 0.0)) * radius


def _sum_by(ids: np.ndarray, values: np.ndarray, size: int) -> np.ndarray:
    """Per-id sums of the rows of `values`, each accumulated in index order."""
    return np.column_stack([np.bincount(ids, values[:, d], minlength=size) for d in range(3)])


def merge_convex(
    points: np.ndarray,
    neighbours: np.ndarray,
    normals: np.ndarray,
    patches: np.ndarray,
    params: ConvexSegmentationParams,
) -> np.ndarray:
    """Steps 3 to 5 of :func:`pcl_rg.convex_segmentation` on given patches.

    `points` float64 (N, 3), `neighbours` (N, k) indices, `normals` (N, 3) unit
    (any orientation, NaN allowed), `patches` (N,) ids in [0, N) or -1. Returns
    int32 labels as the core's ``merge_convex``.
    """
    n = len(points)
    patches = np.asarray(patches, dtype=np.int64)
    labels = np.full(n, -1, dtype=np.int32)
    if n == 0 or not (patches >= 0).any():
        return labels
    count_patches = int(patches.max()) + 1
    member = patches >= 0
    ids = patches[member]
    count = np.bincount(ids, minlength=count_patches)

    # Steps 1 and 2: normals towards the viewpoint, centroids, mean oriented normals.
    viewpoint = params.viewpoint if params.viewpoint is not None else default_viewpoint(points)
    to_view = np.asarray(viewpoint, dtype=np.float64) - points
    towards = (
        normals[:, 0] * to_view[:, 0]
        + normals[:, 1] * to_view[:, 1]
        + normals[:, 2] * to_view[:, 2]
    )
    oriented = np.where((towards < 0.0)[:, None], -normals, normals)
    finite = member & np.isfinite(normals).all(axis=1)
    centroid = _sum_by(ids, points[member], count_patches) / np.maximum(count, 1)[:, None]
    mean_normal = _sum_by(patches[finite], oriented[finite], count_patches)
    with np.errstate(invalid="ignore", divide="ignore"):
        length = np.sqrt(mean_normal[:, 0] ** 2 + mean_normal[:, 1] ** 2 + mean_normal[:, 2] ** 2)
        mean_normal = mean_normal / length[:, None]

    # Step 3: adjacent pairs and their weights.
    k = neighbours.shape[1]
    a = np.repeat(patches, k)
    b = patches[np.asarray(neighbours).ravel()]
    pair = (a >= 0) & (b >= 0) & (a != b)
    low, high = np.minimum(a[pair], b[pair]), np.maximum(a[pair], b[pair])
    keys, weight = np.unique(low * count_patches + high, return_counts=True)
    edge_a, edge_b = keys // count_patches, keys % count_patches

    # Step 4: convex pairs of large patches, connected components.
    large = count >= params.min_cluster_size
    d = centroid[edge_b] - centroid[edge_a]
    ma, mb = mean_normal[edge_a], mean_normal[edge_b]
    distance = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    b_over_a = d[:, 0] * ma[:, 0] + d[:, 1] * ma[:, 1] + d[:, 2] * ma[:, 2]
    a_over_b = -d[:, 0] * mb[:, 0] - d[:, 1] * mb[:, 1] - d[:, 2] * mb[:, 2]
    limit = math.sin(params.concavity_tolerance_deg * (math.pi / 180.0)) * distance
    with np.errstate(invalid="ignore"):
        convex = large[edge_a] & large[edge_b] & (b_over_a <= limit) & (a_over_b <= limit)
    segment = np.arange(count_patches)
    # Components by repeated min-label propagation: each patch ends with the smallest
    # patch id of its component, whatever the order of the pairs.
    ca, cb = edge_a[convex], edge_b[convex]
    while ca.size:
        low_id = np.minimum(segment[ca], segment[cb])
        before = segment.copy()
        np.minimum.at(segment, ca, low_id)
        np.minimum.at(segment, cb, low_id)
        segment = segment[segment]
        if np.array_equal(segment, before):
            break

    # Step 5: small patches join the segment of their heaviest large neighbour.
    mixed = large[edge_a] != large[edge_b]
    small = np.where(large[edge_a], edge_b, edge_a)[mixed]
    target = segment[np.where(large[edge_a], edge_a, edge_b)[mixed]]
    w = weight[mixed]
    order = np.lexsort((target, -w, small))
    small, target = small[order], target[order]
    first = np.ones(small.size, dtype=bool)
    first[1:] = small[1:] != small[:-1]
    joined = np.full(count_patches, -1, dtype=np.int64)
    joined[small[first]] = target[first]
    segment = np.where(large, segment, joined)

    kept = segment >= 0
    size = np.bincount(segment[kept], weights=count[kept], minlength=count_patches)
    of_point = np.full(n, -1, dtype=np.int64)
    of_point[member] = segment[ids]
    valid = of_point >= 0
    valid[valid] = size[of_point[valid]] >= params.min_cluster_size
    # Number the kept segments by their smallest point index.
    index = np.flatnonzero(valid)
    found, first_index = np.unique(of_point[index], return_index=True)
    rank = np.empty(found.size, dtype=np.int32)
    rank[np.argsort(index[first_index])] = np.arange(found.size, dtype=np.int32)
    labels[index] = rank[np.searchsorted(found, of_point[index])]
    return labels


def convex_segmentation(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    smoothness_deg: float | None = None,
    curvature_threshold: float | None = None,
    concavity_tolerance_deg: float | None = None,
    min_cluster_size: int | None = None,
    noise_leaves: float | None = None,
    viewpoint: tuple[float, float, float] | None = None,
    params: ConvexSegmentationParams | None = None,
) -> np.ndarray:
    """Reference convex segmentation: same signature and result as the core's.

    The grid from :func:`pcl_rg.reference.point_scale` and
    :func:`pcl_rg.reference.voxel_grid`; normals and curvatures from
    :func:`pcl_rg.reference.normals`, the growth of
    :func:`pcl_rg.reference.region_growing`'s ``grow_regions``, then
    :func:`merge_convex`. Agrees with :func:`pcl_rg.convex_segmentation` except
    where a decision lies within rounding of a threshold or a neighbour list
    has a tie at its k-th place.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> rng = np.random.default_rng(0)
    >>> floor = np.column_stack([rng.uniform(0, 1, (500, 2)), np.zeros(500)])
    >>> np.unique(reference.convex_segmentation(floor, viewpoint=(0.5, 0.5, 1))).tolist()
    [0]
    """
    p = resolve_arguments(ConvexSegmentationParams, locals())
    xyz = as_points(points)
    if len(xyz) == 0:
        return np.empty(0, dtype=np.int32)
    near = near_rows(xyz)
    if near is not None:  # far points: left out of every step, the viewpoint included
        if p.k >= len(xyz):
            raise ValueError(f"k must be < the number of points ({len(xyz)}), got {p.k}")
        check_fewer_than_kept("k", p.k, len(near), len(xyz))
        labels = np.full(len(xyz), -1, dtype=np.int32)
        labels[near] = convex_segmentation(xyz[near], params=p)
        return labels
    if p.viewpoint is None:  # resolved on the input, so a grid is seen from the same place
        p = dataclasses.replace(p, viewpoint=default_viewpoint(xyz))
    if p.noise_leaves > 0:
        scale = point_scale(xyz)
        leaf = p.noise_leaves * scale.noise
        if leaf > scale.spacing:
            grid = voxel_grid(xyz, leaf)
            if len(grid.centroids) > p.k:  # else the points, as if there were no grid
                on_grid = _segment(np.ascontiguousarray(grid.centroids), p)[grid.voxel_of_point]
                return _number_by_first_index(on_grid)
    return _segment(xyz, p)


def _number_by_first_index(labels: np.ndarray) -> np.ndarray:
    out = np.full(labels.shape, -1, dtype=np.int32)
    kept = np.flatnonzero(labels >= 0)
    found, first = np.unique(labels[kept], return_index=True)
    rank = np.empty(found.size, dtype=np.int32)
    rank[np.argsort(kept[first])] = np.arange(found.size, dtype=np.int32)
    out[kept] = rank[np.searchsorted(found, labels[kept])]
    return out


def _segment(xyz: np.ndarray, p: ConvexSegmentationParams) -> np.ndarray:
    """Steps 1 to 5 on the given points."""
    geometry = normals(xyz, k=p.k)
    neighbours = neighbour_lists(xyz, p.k)
    measure = scaled_curvedness(
        xyz, neighbours, geometry.mean_curvature, geometry.gaussian_curvature
    )
    growth = RegionGrowingParams(
        k=p.k,
        smoothness_deg=p.smoothness_deg,
        curvature_threshold=p.curvature_threshold,
        min_cluster_size=1,
    )
    patches = grow_regions(neighbours, geometry.normals, measure, growth)
    return merge_convex(xyz, neighbours, geometry.normals, patches, p)
