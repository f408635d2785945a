"""SciPy reference for :func:`pcl_rg.statistical_outlier_removal`."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from .._far_points import check_fewer_than_kept
from .._params import check_number, resolve_arguments
from .._statistical_outlier_removal import StatisticalOutlierRemovalParams
from .._validation import as_points
from ._local import local_frame, near_rows

__all__ = ["statistical_outlier_removal", "mean_neighbour_distance"]


def mean_neighbour_distance(points: npt.ArrayLike, mean_k: int) -> np.ndarray:
    """d_i: mean float64 distance of each point to its `mean_k` nearest others; inf for
    the far points (``_local.near_rows``), which have none."""
    xyz = as_points(points)
    mean_k = check_number("mean_k", mean_k, int, minimum=1)
    if mean_k >= len(xyz):
        raise ValueError(f"mean_k must be < the number of points ({len(xyz)}), got {mean_k}")
    near = near_rows(xyz)
    if near is not None:
        check_fewer_than_kept("mean_k", mean_k, len(near), len(xyz))
        distance = np.full(len(xyz), np.inf)
        distance[near] = mean_neighbour_distance(xyz[near], mean_k)
        return distance
    local = local_frame(xyz)
    # k + 1 neighbours: the nearest is the point itself (or a duplicate), at distance 0.
    distance, _ = cKDTree(local).query(local, k=mean_k + 1)
    return distance[:, 1:].mean(axis=1)


def statistical_outlier_removal(
    points: npt.ArrayLike,
    *,
    mean_k: int | None = None,
    std_mul: float | None = None,
    params: StatisticalOutlierRemovalParams | None = None,
) -> np.ndarray:
    """Reference SOR in float64: same signature as the core function.

    It differs from the float32 core (and PCL) only for points whose d_i lies
    within float32 rounding of the threshold.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> pts = np.vstack([np.random.default_rng(0).uniform(0, 1, (100, 3)), [[9, 9, 9]]])
    >>> bool(reference.statistical_outlier_removal(pts, mean_k=8, std_mul=2.0)[-1])
    False
    """
    p = resolve_arguments(StatisticalOutlierRemovalParams, locals())
    xyz = as_points(points)
    if len(xyz) == 0:
        return np.empty(0, dtype=bool)
    d = mean_neighbour_distance(xyz, p.mean_k)
    finite = d[np.isfinite(d)]  # far points: outliers, outside mu and sigma
    # The mean of equal values can round below them (six 0.1s: 0.09999999999999999),
    # which with std_mul = 0 made every point an outlier; a mean lies within the values.
    mu = min(max(finite.mean(), finite.min()), finite.max()) if finite.size else np.nan
    threshold = mu + p.std_mul * finite.std(ddof=1)
    return d <= threshold
