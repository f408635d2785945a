"""``pcl::VoxelGrid`` and ``pcl::StatisticalOutlierRemoval`` on NumPy arrays."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .. import _pcl
from .._diagnostics import record
from .._docstrings import fill_docstring
from .._params import resolve_arguments
from .._statistical_outlier_removal import StatisticalOutlierRemovalParams
from .._validation import MAX_POINTS_UINT32, as_points
from .._voxel_grid import VoxelGridParams, VoxelGridResult

__all__ = ["statistical_outlier_removal", "voxel_grid"]


@fill_docstring
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
    %(points)s
    leaf_size : float or sequence of 3 floats
        Voxel edge length, one value or one per axis (x, y, z), in metres
        (``setLeafSize``). Required unless `params` is given.
    min_points_per_voxel : int, optional
        Voxels holding fewer points are dropped (default 1;
        ``setMinimumPointsNumberPerVoxel``).
    %(params)s

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
        Non-finite points, a wrong shape, a leaf size <= 0 or one whose
        float32 inverse is not finite, ``min_points_per_voxel`` beyond 32 bits,
        or a bounding box of more than 2**31 - 1 voxels (where PCL warns and
        returns its input).
    %(type_error)s

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
    across a voxel boundary. That snapped corner can lie up to a leaf from the
    points, and PCL sums their float32 coordinates from it: with leaves of
    kilometres the centroids lose precision (about 0.2 m at 10 km, 70 m at
    1,000 km); :func:`pcl_rg.voxel_grid` sums in float64.

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
    p = resolve_arguments(VoxelGridParams, locals())
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)
    centroids, counts, voxel_of_point = _pcl.voxel_grid(xyz, p.to_core())
    record("pcl.voxel_grid", points=len(xyz), voxels=len(counts))
    return VoxelGridResult(centroids, counts, voxel_of_point.astype(np.intp, copy=False))


@fill_docstring
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
    %(points)s
    mean_k : int, optional
        Neighbours averaged per point, the point itself excluded (``setMeanK``);
        >= 1 and < N. Default as :class:`pcl_rg.StatisticalOutlierRemovalParams`.
    std_mul : float, optional
        A point is an outlier when its mean neighbour distance exceeds
        mean + std_mul * std over all points (``setStddevMulThresh``); >= 0.
    %(params)s

    Returns
    -------
    numpy.ndarray
        bool (N,): True for inliers.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range
        (``mean_k < 1``, ``mean_k >= N``, ``std_mul < 0``), N * mean_k over
        1.2e9, or copies of positions whose counts' squares sum over 1e10
        (PCL's search would take minutes).
    %(type_error)s

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
    p = resolve_arguments(StatisticalOutlierRemovalParams, locals())
    xyz = as_points(points)
    inlier = _pcl.statistical_outlier_removal(xyz, p.to_core())
    record("pcl.statistical_outlier_removal", points=len(xyz), inliers=int(inlier.sum()))
    return inlier
