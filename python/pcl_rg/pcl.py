"""PCL's own classes, unmodified, on NumPy arrays: the baselines to compare against.

Each function runs one PCL 1.13 class as PCL ships it (``pcl::VoxelGrid``,
``pcl::StatisticalOutlierRemoval``, ``pcl::NormalEstimation`` with
``pcl::RegionGrowing``, ``pcl::ProgressiveMorphologicalFilter`` and
``pcl::ApproximateProgressiveMorphologicalFilter``) behind the signature and the
result type of the matching :mod:`pcl_rg` function, so the two can be swapped in
a comparison. Only the crossing is ours: input is checked as everywhere in
pcl_rg, a float64 local origin (the minimum corner) is subtracted before the
points become PCL's float32 ``PointXYZ``, coordinate outputs are shifted back,
and results are per input point. Bad parameters raise instead of PCL's warnings.

PCL's classes are single-threaded (the approximate morphological filter aside)
and cannot be interrupted inside a class: Ctrl-C takes effect between stages.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from . import _pcl
from ._diagnostics import record, record_segmentation
from ._params import check_fields, param, resolve, to_core
from ._region_growing import NO_MAX_CLUSTER_SIZE, check_cluster_sizes
from ._statistical_outlier_removal import StatisticalOutlierRemovalParams
from ._validation import MAX_POINTS_UINT32, as_points
from ._voxel_grid import VoxelGridParams, VoxelGridResult

__all__ = [
    "NormalEstimationParams",
    "NormalEstimationResult",
    "ProgressiveMorphologicalFilterParams",
    "RegionGrowingPclParams",
    "StatisticalOutlierRemovalParams",
    "VoxelGridParams",
    "VoxelGridResult",
    "normals",
    "progressive_morphological_filter",
    "region_growing",
    "statistical_outlier_removal",
    "voxel_grid",
]


@dataclass(frozen=True, kw_only=True, slots=True)
class NormalEstimationParams:
    """Parameters of :func:`normals` (mirrors ``pcl_rg::NormalEstimationParams``)."""

    k: int = param(
        15, minimum=3, bits=32, help="neighbours of each normal, itself included (setKSearch)"
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _pcl.NormalEstimationParams:
        return to_core(self, _pcl.NormalEstimationParams())


@dataclass(frozen=True, kw_only=True, slots=True)
class RegionGrowingPclParams:
    """Parameters of :func:`region_growing` (mirrors ``pcl_rg::RegionGrowingPclParams``)."""

    k: int = param(
        15,
        minimum=3,
        bits=32,
        help="neighbours for normals and growth, itself included (setKSearch, "
        "setNumberOfNeighbours)",
    )
    smoothness_deg: float = param(
        16.0, above=0.0, below=180.0, unit="deg", help="max normal angle (setSmoothnessThreshold)"
    )
    curvature_threshold: float = param(
        0.025, minimum=0.0, help="surface variation gate for further seeds (setCurvatureThreshold)"
    )
    min_cluster_size: int = param(
        20, minimum=1, help="drop regions with fewer points (setMinClusterSize)"
    )
    # PCL counts cluster sizes in pcl::uindex_t (uint32).
    max_cluster_size: int = param(
        NO_MAX_CLUSTER_SIZE,
        minimum=1,
        maximum=NO_MAX_CLUSTER_SIZE,
        help="drop regions with more points (setMaxClusterSize)",
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_cluster_sizes(self.min_cluster_size, self.max_cluster_size)

    def to_core(self) -> _pcl.RegionGrowingPclParams:
        return to_core(self, _pcl.RegionGrowingPclParams())


@dataclass(frozen=True, kw_only=True, slots=True)
class ProgressiveMorphologicalFilterParams:
    """Parameters of :func:`progressive_morphological_filter` (PCL's tutorial defaults).

    Mirrors ``pcl_rg::ProgressiveMorphologicalFilterParams``.
    """

    max_window_size: int = param(
        20, minimum=1, bits=32, unit="cells", help="largest window (setMaxWindowSize)"
    )
    slope: float = param(1.0, minimum=0.0, unit="m/m", help="terrain slope (setSlope)")
    initial_distance: float = param(
        0.5, minimum=0.0, unit="m", help="height threshold of the first window (setInitialDistance)"
    )
    max_distance: float = param(
        3.0, minimum=0.0, unit="m", help="cap of the height threshold (setMaxDistance)"
    )
    cell_size: float = param(1.0, above=0.0, unit="m", help="grid cell size (setCellSize)")
    base: float = param(2.0, above=0.0, help="base of the window progression (setBase)")
    exponential: bool = param(
        True, help="windows grow exponentially, else linearly (setExponential)"
    )
    approximate: bool = param(
        False,
        help="pcl::ApproximateProgressiveMorphologicalFilter (cell minima) instead of the "
        "point-wise filter",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _pcl.ProgressiveMorphologicalFilterParams:
        return to_core(self, _pcl.ProgressiveMorphologicalFilterParams())


class NormalEstimationResult(NamedTuple):
    """Result of :func:`normals`."""

    normals: np.ndarray
    """float32 (N, 3): PCL's unit normals, flipped towards the local origin (see Notes)."""
    curvature: np.ndarray
    """float32 (N,): PCL's surface variation lambda0 / (lambda0 + lambda1 + lambda2)."""


def voxel_grid(
    points: npt.ArrayLike,
    leaf_size: float | tuple[float, float, float] | None = None,
    *,
    min_points_per_voxel: int | None = None,
    params: VoxelGridParams | None = None,
) -> VoxelGridResult:
    """Downsample points with ``pcl::VoxelGrid``.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order).
    leaf_size : float or sequence of 3 floats
        Voxel edge length, one value or one per axis (x, y, z), in metres
        (``setLeafSize``). Required unless `params` is given.
    min_points_per_voxel : int, optional
        Voxels holding fewer points are dropped (default 1;
        ``setMinimumPointsNumberPerVoxel``).
    params : VoxelGridParams, optional
        All parameters at once; keywords given explicitly override it.

    Returns
    -------
    VoxelGridResult
        ``centroids`` float64 (M, 3): PCL's float32 centroids plus the local
        origin; ``counts`` int64 (M,); ``voxel_of_point`` intp (N,), -1 where a
        point's voxel was dropped. Voxels in PCL's order: by z index, then y,
        then x.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, a leaf size <= 0, or a bounding box
        of more than 2**31 - 1 voxels (where PCL warns and returns its input).
    TypeError
        Non-numeric points or parameters of the wrong type.

    Notes
    -----
    PCL returns the centroids only. The counts and ``voxel_of_point`` are
    recomputed in C++ with PCL's own expression, ``floor(p * (1 / leaf))`` in
    float32 on the same local-frame cloud PCL filtered, grouped and ordered as
    PCL groups and orders its voxels; the number of voxels is checked against
    PCL's output. PCL anchors its grid at the origin of the frame it sees, so
    the local origin here is the minimum corner snapped down to a multiple of
    the leaf size per axis: the voxels are those of the caller's frame, as in
    :func:`pcl_rg.voxel_grid`, except where float32 rounding moves a point
    across a voxel boundary.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> pts = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.5, 0.0, 0.0]])
    >>> result = pcl_rg.pcl.voxel_grid(pts, leaf_size=1.0)
    >>> result.centroids
    array([[0.25, 0.  , 0.  ],
           [1.5 , 0.  , 0.  ]])
    >>> result.counts.tolist(), result.voxel_of_point.tolist()
    ([2, 1], [0, 0, 1])
    """
    if leaf_size is None and params is None:
        raise TypeError("voxel_grid() needs leaf_size (or params)")
    p = resolve(
        VoxelGridParams, params, leaf_size=leaf_size, min_points_per_voxel=min_points_per_voxel
    )
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)
    centroids, counts, voxel_of_point = _pcl.voxel_grid(xyz, to_core(p, _pcl.VoxelGridParams()))
    record("pcl.voxel_grid", points=len(xyz), voxels=len(counts))
    return VoxelGridResult(centroids, counts, voxel_of_point.astype(np.intp, copy=False))


def statistical_outlier_removal(
    points: npt.ArrayLike,
    *,
    mean_k: int | None = None,
    std_mul: float | None = None,
    params: StatisticalOutlierRemovalParams | None = None,
) -> np.ndarray:
    """Mark statistical outliers with ``pcl::StatisticalOutlierRemoval``.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order).
    mean_k : int, optional
        Neighbours averaged per point, the point itself excluded (``setMeanK``);
        >= 1 and < N. Default as :class:`pcl_rg.StatisticalOutlierRemovalParams`.
    std_mul : float, optional
        A point is an outlier when its mean neighbour distance exceeds
        mean + std_mul * std over all points (``setStddevMulThresh``); >= 0.
    params : StatisticalOutlierRemovalParams, optional
        All parameters at once; keywords given explicitly override it.

    Returns
    -------
    numpy.ndarray
        bool (N,): True for inliers.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range
        (``mean_k < 1``, ``mean_k >= N``, ``std_mul < 0``).
    TypeError
        Non-numeric points or parameters of the wrong type.

    Notes
    -----
    PCL searches its float32 ``KdTreeFLANN`` on the points minus the local
    origin; :func:`pcl_rg.statistical_outlier_removal` is bit-equal to it.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> pts = np.vstack([rng.uniform(0, 1, (200, 3)), [[10.0, 10.0, 10.0]]])
    >>> inlier = pcl_rg.pcl.statistical_outlier_removal(pts, mean_k=8, std_mul=2.0)
    >>> bool(inlier[-1]), int(inlier.sum()) > 190
    (False, True)
    """
    p = resolve(StatisticalOutlierRemovalParams, params, mean_k=mean_k, std_mul=std_mul)
    xyz = as_points(points)
    inlier = _pcl.statistical_outlier_removal(
        xyz, to_core(p, _pcl.StatisticalOutlierRemovalParams())
    )
    record("pcl.statistical_outlier_removal", points=len(xyz), inliers=int(inlier.sum()))
    return inlier


def normals(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    params: NormalEstimationParams | None = None,
) -> NormalEstimationResult:
    """Estimate normals and surface variation with ``pcl::NormalEstimation``.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order).
    k : int, optional
        Neighbours of each normal, the point itself included (default 15,
        ``setKSearch``); >= 3 and < N.
    params : NormalEstimationParams, optional
        All parameters at once; keywords given explicitly override it.

    Returns
    -------
    NormalEstimationResult
        ``normals`` float32 (N, 3) and ``curvature`` float32 (N,), as PCL
        computes them (NaN where PCL cannot fit a plane).

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, ``k < 3`` or ``k >= N``.
    TypeError
        Non-numeric points or parameters of the wrong type.

    Notes
    -----
    PCA of the k nearest neighbours (``pcl::search::KdTree``) in float32 in
    the local frame; normals are flipped towards PCL's default viewpoint
    (0, 0, 0) of that frame, which is the minimum corner of the points. These
    are the normals :func:`region_growing` grows on.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> plane = np.column_stack([rng.uniform(0, 1, (100, 2)), np.zeros(100)])
    >>> result = pcl_rg.pcl.normals(plane, k=8)
    >>> bool(np.allclose(np.abs(result.normals[:, 2]), 1.0)), float(result.curvature.max())
    (True, 0.0)
    """
    p = resolve(NormalEstimationParams, params, k=k)
    xyz = as_points(points)
    normal, curvature = _pcl.normal_estimation(xyz, p.to_core())
    record("pcl.normals", points=len(xyz))
    return NormalEstimationResult(normal, curvature)


def region_growing(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    smoothness_deg: float | None = None,
    curvature_threshold: float | None = None,
    min_cluster_size: int | None = None,
    max_cluster_size: int | None = None,
    params: RegionGrowingPclParams | None = None,
) -> np.ndarray:
    """Segment points with PCL's classic region growing (the baseline of seed 004).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order).
    k : int, optional
        Neighbours for the normals and the growth, the point itself included
        (default 15); >= 3 and < N.
    smoothness_deg : float, optional
        Maximum angle between neighbouring normals, degrees, in (0, 180)
        (default 16); passed to PCL in radians as float.
    curvature_threshold : float, optional
        Joined points whose surface variation is <= this grow further
        (default 0.025, the best on the mOSD learn scenes at k 15 and 16
        degrees; surface variation lies in [0, 1/3]).
    min_cluster_size, max_cluster_size : int, optional
        Regions outside these sizes are dropped (defaults 20 and 2**32 - 1).
    params : RegionGrowingPclParams, optional
        All parameters at once; keywords given explicitly override it.

    Returns
    -------
    numpy.ndarray
        int32 (N,) labels, -1 for points of dropped regions, numbered 0, 1, ...
        by each region's smallest point index (PCL lists them in growth order).
        The stage times are recorded as ``normals_seconds`` and
        ``growth_seconds`` under ``"pcl.region_growing"`` in
        :func:`pcl_rg.collect_diagnostics`.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range
        (``k < 3``, ``k >= N``, an angle outside (0, 180), a negative
        threshold, ``min_cluster_size > max_cluster_size``).
    TypeError
        Non-numeric points or parameters of the wrong type.

    Notes
    -----
    As PCL 1.13 does it (``pcl/segmentation/impl/region_growing.hpp``):

    * ``pcl::NormalEstimation`` with ``setKSearch(k)``, as :func:`normals`.
    * ``pcl::RegionGrowing`` searches the k nearest neighbours of every point
      again, then sorts (curvature, index) pairs with ``std::sort`` on the
      curvature alone. That sort is unstable: points of equal curvature (in
      float32 ties are common, e.g. 0 on exact planes) are visited in an
      order the sort leaves unspecified, so the labels can change with it, and
      with the input order, wherever growth is not transitive.
    * Growth is breadth-first; the seed always grows; a neighbour joins when
      ``|n_p . n_q| >= cos(theta)`` in float (so a NaN normal always joins)
      and grows further unless its curvature exceeds the threshold. Every
      point lands in some region; regions outside the size limits are then
      dropped. Smooth mode is on, the residual test off.

    References
    ----------
    Rabbani et al., "Segmentation of point clouds using smoothness
    constraint", ISPRS Archives XXXVI-5, 2006; PCL's region growing tutorial.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> floor = np.column_stack([rng.uniform(0, 2, (600, 2)), np.zeros(600)])
    >>> wall = np.column_stack([rng.uniform(0, 2, 600), np.full(600, 2.3),
    ...                         rng.uniform(0.3, 2, 600)])
    >>> labels = pcl_rg.pcl.region_growing(np.vstack([floor, wall]), k=12, smoothness_deg=5)
    >>> np.unique(labels[:600]).tolist(), np.unique(labels[600:]).tolist()
    ([0], [1])
    """
    p = resolve(
        RegionGrowingPclParams,
        params,
        k=k,
        smoothness_deg=smoothness_deg,
        curvature_threshold=curvature_threshold,
        min_cluster_size=min_cluster_size,
        max_cluster_size=max_cluster_size,
    )
    xyz = as_points(points)
    labels, normals_seconds, growth_seconds = _pcl.region_growing(xyz, p.to_core())
    record_segmentation("pcl.region_growing", len(xyz), labels, normals_seconds, growth_seconds)
    return labels


def progressive_morphological_filter(
    points: npt.ArrayLike,
    *,
    max_window_size: int | None = None,
    slope: float | None = None,
    initial_distance: float | None = None,
    max_distance: float | None = None,
    cell_size: float | None = None,
    base: float | None = None,
    exponential: bool | None = None,
    approximate: bool | None = None,
    params: ProgressiveMorphologicalFilterParams | None = None,
) -> np.ndarray:
    """Classify ground with PCL's progressive morphological filter.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order).
    max_window_size : int, optional
        Largest morphological window, cells (default 20; ``setMaxWindowSize``).
    slope : float, optional
        Terrain slope for the height thresholds, m per m (default 1;
        ``setSlope``); >= 0.
    initial_distance : float, optional
        Height threshold of the first window, metres (default 0.5;
        ``setInitialDistance``); >= 0.
    max_distance : float, optional
        Cap of the height threshold, metres (default 3; ``setMaxDistance``).
    cell_size : float, optional
        Cell size of the grid, metres (default 1; ``setCellSize``); > 0.
    base : float, optional
        Base of the window-size progression (default 2; ``setBase``); > 0.
    exponential : bool, optional
        Windows grow as base**k (default True) or linearly
        (``setExponential``).
    approximate : bool, optional
        Run ``pcl::ApproximateProgressiveMorphologicalFilter`` (openings of
        the grid of cell minima, much faster) instead of
        ``pcl::ProgressiveMorphologicalFilter`` (default False).
    params : ProgressiveMorphologicalFilterParams, optional
        All parameters at once; keywords given explicitly override it.

    Returns
    -------
    numpy.ndarray
        bool (N,): True for ground.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range.
    TypeError
        Non-numeric points or parameters of the wrong type.

    Notes
    -----
    Defaults are those of PCL's tutorial "Identifying ground returns using
    ProgressiveMorphologicalFilter segmentation". The filter runs on the
    points minus the local origin, as float32.

    References
    ----------
    Zhang et al., "A progressive morphological filter for removing nonground
    measurements from airborne LIDAR data", IEEE TGRS 41(4), 2003.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 40, (4000, 2))
    >>> box = (np.abs(xy - 20) < 4).all(axis=1)
    >>> pts = np.column_stack([xy, np.where(box, 6.0, 0.0)])
    >>> ground = pcl_rg.pcl.progressive_morphological_filter(pts)
    >>> bool(ground[~box].all()), bool(ground[box].any())
    (True, False)
    """
    p = resolve(
        ProgressiveMorphologicalFilterParams,
        params,
        max_window_size=max_window_size,
        slope=slope,
        initial_distance=initial_distance,
        max_distance=max_distance,
        cell_size=cell_size,
        base=base,
        exponential=exponential,
        approximate=approximate,
    )
    xyz = as_points(points)
    ground = _pcl.progressive_morphological_filter(xyz, p.to_core())
    record("pcl.progressive_morphological_filter", points=len(xyz), ground=int(ground.sum()))
    return ground
