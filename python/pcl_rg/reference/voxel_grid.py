"""NumPy reference for :func:`pcl_rg.voxel_grid`."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._params import resolve_arguments
from .._validation import as_points
from .._voxel_grid import VoxelGridParams, VoxelGridResult

__all__ = ["voxel_grid"]


def voxel_grid(
    points: npt.ArrayLike,
    leaf_size: float | tuple[float, float, float] | None = None,
    *,
    min_points_per_voxel: int | None = None,
    params: VoxelGridParams | None = None,
) -> VoxelGridResult:
    """Reference VoxelGrid: same signature and result as :func:`pcl_rg.voxel_grid`.

    Examples
    --------
    >>> from pcl_rg import reference
    >>> reference.voxel_grid([[0.1, 0.1, 0.0], [0.3, 0.1, 0.0]], 1.0).counts.tolist()
    [2]
    """
    if leaf_size is None and params is None:
        raise TypeError("voxel_grid() needs leaf_size (or params)")
    p = resolve_arguments(VoxelGridParams, locals())
    xyz = as_points(points)
    n = len(xyz)
    if n == 0:
        return VoxelGridResult(np.empty((0, 3)), np.empty(0, np.int64), np.empty(0, np.intp))
    # The definition: voxel = floor(p / leaf) per axis, in float64; indices beyond 2^62
    # are refused, as the core refuses them (int64 would wrap them into one voxel).
    scaled = xyz / np.asarray(p.leaf_size)
    for axis in range(3):
        if np.abs(scaled[:, axis]).max() >= 2.0**62:
            raise ValueError(
                "leaf_size is too small for the coordinates: voxel indices exceed 2^62 on "
                f"axis {axis}"
            )
    cell = np.floor(scaled).astype(np.int64)
    # PCL's order: z index first, then y, then x (lexicographic on reversed columns).
    _, first, voxel, counts = np.unique(
        cell[:, ::-1], axis=0, return_index=True, return_inverse=True, return_counts=True
    )
    voxel = voxel.ravel()
    # Offsets from each voxel's first point are summed, as the core sums them: a plain
    # sum of coordinates near the float64 limit overflows (1e308 + 1.5e308 = inf).
    offset = xyz - xyz[first[voxel]]
    sums = np.stack([np.bincount(voxel, weights=offset[:, a]) for a in range(3)], axis=1)
    centroids = xyz[first] + sums / counts[:, None]
    keep = counts >= p.min_points_per_voxel
    row = np.full(len(counts), -1, dtype=np.intp)
    row[keep] = np.arange(int(keep.sum()))
    return VoxelGridResult(centroids[keep], counts[keep].astype(np.int64), row[voxel])
