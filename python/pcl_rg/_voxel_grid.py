"""VoxelGrid downsampling: PCL's ``pcl::VoxelGrid`` for any extent, on NumPy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._params import check_fields, param, resolve_arguments, to_core
from ._validation import MAX_POINTS_UINT32, as_points

__all__ = ["VoxelGridParams", "VoxelGridResult", "voxel_grid"]


@dataclass(frozen=True, kw_only=True, slots=True)
class VoxelGridParams:
    """Parameters of :func:`voxel_grid` (mirrors ``pcl_rg::VoxelGridParams``)."""

    leaf_size: tuple[float, float, float] = param(
        axes=3, above=0.0, unit="m", help="voxel edge length, one value or x,y,z (PCL setLeafSize)"
    )
    min_points_per_voxel: int = param(
        1, minimum=1, help="drop voxels with fewer points (PCL setMinimumPointsNumberPerVoxel)"
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _core.VoxelGridParams:
        return to_core(self, _core.VoxelGridParams())


class VoxelGridResult(NamedTuple):
    """Result of :func:`voxel_grid`."""

    centroids: np.ndarray
    """float64 (M, 3): mean of the points of each kept voxel, caller's coordinates."""
    counts: np.ndarray
    """int64 (M,): number of input points in each kept voxel."""
    voxel_of_point: np.ndarray
    """intp (N,): row of ``centroids`` holding each input point, -1 if its voxel was dropped."""


@fill_docstring
def voxel_grid(
    points: npt.ArrayLike,
    leaf_size: float | tuple[float, float, float] | None = None,
    *,
    min_points_per_voxel: int | None = None,
    params: VoxelGridParams | None = None,
) -> VoxelGridResult:
    """Downsample points to the centroid of each occupied voxel.

    Parameters
    ----------
    %(points)s
    leaf_size : float or sequence of 3 floats
        Voxel edge length, one value for all axes or one per axis (x, y, z),
        in metres. Required unless `params` is given.
    min_points_per_voxel : int, optional
        Voxels holding fewer points are dropped (default 1, keep all).
    %(params)s

    Returns
    -------
    VoxelGridResult
        ``centroids`` float64 (M, 3), ``counts`` int64 (M,) and
        ``voxel_of_point`` intp (N,), -1 where a point's voxel was dropped.
        Voxels come in PCL's order: by z index, then y, then x.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a leaf size <= 0.
    %(type_error)s

    Notes
    -----
    The voxel of a point p is ``floor(p / leaf_size)`` per axis, computed in
    float64 in the caller's coordinates, so the grid is anchored at the world
    origin as in PCL and tiles of one survey share their voxels. The result
    equals ``pcl::VoxelGrid`` (PCL 1.13) wherever PCL works, up to PCL's
    float32 rounding of the centroids (a few micrometres); unlike PCL, any
    extent is handled (64-bit voxel keys): PCL warns and returns its input
    unchanged when the grid has more than 2**31 - 1 voxels. Centroids are
    averaged in float64, with each voxel's points in input order, so the
    result is deterministic.

    References
    ----------
    Seed 004 (Wang et al., ISPRS Archives XLII-3/W10, 2020), section 2.2.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> pts = np.array([[0.1, 0.1, 0.0], [0.3, 0.1, 0.0], [1.2, 0.0, 0.0]])
    >>> result = pcl_rg.voxel_grid(pts, leaf_size=1.0)
    >>> result.centroids
    array([[0.2, 0.1, 0. ],
           [1.2, 0. , 0. ]])
    >>> result.counts.tolist(), result.voxel_of_point.tolist()
    ([2, 1], [0, 0, 1])
    """
    if leaf_size is None and params is None:
        raise TypeError("voxel_grid() needs leaf_size (or params)")
    p = resolve_arguments(VoxelGridParams, locals())
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)
    centroids, counts, voxel_of_point = _core.voxel_grid(xyz, p.to_core())
    record("voxel_grid", points=len(xyz), voxels=len(counts))
    return VoxelGridResult(centroids, counts, voxel_of_point.astype(np.intp, copy=False))
