"""Far points: the warning that says how many a step left out.

The k-nearest-neighbour steps compute in float32 relative to a float64 local origin
(``_core.float32_origin``). A point more than 2^24 x 0.1 from it on some axis is far: up
to 1 % of a cloud's points are left out, each with the result of a point without
neighbours, and the core counts them. Most are bad records, but a real second site far
away is left out too, so every call that leaves points out says how many."""

from __future__ import annotations

import warnings

from ._caller import outside_stacklevel

__all__ = ["FarPointsWarning", "check_fewer_than_kept", "far_points_message", "warn_far_points"]


class FarPointsWarning(UserWarning):
    """Some points lay beyond float32's reach of the cloud's origin and were left out.

    :func:`pcl_rg.normals`, :func:`pcl_rg.region_growing`,
    :func:`pcl_rg.convex_segmentation`, :func:`pcl_rg.statistical_outlier_removal`,
    :func:`pcl_rg.point_scale` and :func:`pcl_rg.batch.denoise` compute in float32
    relative to a float64 local origin. A point more than 2^24 x 0.1 = 1677721.6 (metres
    for LiDAR) from it on some axis, where float32 resolves no better than 0.125, is a
    far point: a bad GPS fix, a record at (0, 0, 0) in a UTM tile, or a second site far
    away. Up to 1 % of the points may be far; they are left out, and this warning gives
    their count. Each function's Notes say what a far point gets.

    Examples
    --------
    >>> import warnings
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> tile = rng.uniform(0, 100, (1000, 3)) + (500_000.0, 4_000_000.0, 0.0)
    >>> tile[0] = 0.0  # a record at (0, 0, 0)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     inlier = pcl_rg.statistical_outlier_removal(tile)
    >>> bool(inlier[0]), caught[0].category is pcl_rg.FarPointsWarning
    (False, True)
    """


def far_points_message(function: str, far: int, points: int, outcome: str, where: str) -> str:
    """The warning's text: `far` of `points` left out by `function`, with their `outcome`."""
    return (
        f"{function}: {far:,} of {points:,} points lie more than 2^24 x 0.1 = 1677721.6 "
        f"(metres for LiDAR) from {where} local origin on some axis, beyond float32's "
        f"reach (bad records such as (0, 0, 0), or a second site far away), and were left "
        f"out: {outcome}"
    )


def warn_far_points(function: str, far: int, points: int, outcome: str) -> None:
    """Warn, at the caller's line outside pcl_rg, that `far` of `points` were left out
    (the count is the core's: it includes those that the kept points' own frame leaves
    out in turn)."""
    if far:
        message = far_points_message(function, far, points, outcome, "the cloud's")
        warnings.warn(message, FarPointsWarning, stacklevel=outside_stacklevel())


def check_fewer_than_kept(name: str, count: int, kept: int, cloud: int) -> None:
    """A neighbour count that the `kept` of `cloud` points left once the far ones are out
    can supply, or ValueError worded as the core's (check.cpp, fewer_than_points)."""
    if count >= kept:
        raise ValueError(
            f"{name} must be < the number of points ({kept} within float32's reach, of "
            f"{cloud}: {cloud - kept} far, left out), got {count}"
        )
