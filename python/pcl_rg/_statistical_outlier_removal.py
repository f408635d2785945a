"""Statistical outlier removal with the exact semantics of PCL 1.13."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._far_points import warn_far_points
from ._params import check_fields, param, resolve_arguments, to_core
from ._validation import MAX_POINTS_UINT32, as_points

__all__ = ["StatisticalOutlierRemovalParams", "statistical_outlier_removal"]


@dataclass(frozen=True, kw_only=True, slots=True)
class StatisticalOutlierRemovalParams:
    """Parameters of :func:`statistical_outlier_removal` (mirrors the C++ struct)."""

    mean_k: int = param(
        50, minimum=1, bits=32, help="neighbours averaged per point, itself excluded (PCL setMeanK)"
    )
    std_mul: float = param(
        1.0,
        minimum=0.0,
        help="inlier when mean distance <= mean + std_mul * std (PCL setStddevMulThresh)",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _core.StatisticalOutlierRemovalParams:
        return to_core(self, _core.StatisticalOutlierRemovalParams())


@fill_docstring
def statistical_outlier_removal(
    points: npt.ArrayLike,
    *,
    mean_k: int | None = None,
    std_mul: float | None = None,
    params: StatisticalOutlierRemovalParams | None = None,
) -> np.ndarray:
    """Flag points whose mean neighbour distance is unusually large.

    Parameters
    ----------
    %(points)s
    mean_k : int, optional
        Number of nearest neighbours averaged per point, the point itself
        excluded (default 50, PCL's tutorial value). Must be < N.
    std_mul : float, optional
        Standard-deviation multiplier of the threshold (default 1.0).
    %(params)s

    Returns
    -------
    numpy.ndarray
        bool (N,): True for inliers (points to keep).

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, ``mean_k < 1``, ``mean_k >= N``,
        or a negative or non-finite ``std_mul``.
    %(far_points_value_error)s
    %(type_error)s

    Notes
    -----
    For each point, d_i is the mean Euclidean distance to its `mean_k`
    nearest neighbours. With mu and sigma the mean and sample standard
    deviation (n - 1) of all d_i, point i is an inlier when
    ``d_i <= mu + std_mul * sigma``. This is ``pcl::StatisticalOutlierRemoval``
    of PCL 1.13 to the bit (far points aside, below): distances are computed
    in float32 after a float64 local origin (the minimum corner, stray points
    far below left out) is subtracted, and the sums are taken in the same
    order and precision. Neighbour queries run in parallel on an
    exact k-d tree (nanoflann) with the GIL released.

    mu and sigma are taken over every point, outliers included, so a few
    points very far from the rest (a bad GPS fix hundreds of km away) raise
    the threshold until only they are outliers: remove them, then run it
    again for the ordinary noise (as PCL's class behaves). Far points (below)
    are the exception: outliers by rule, with d_i = inf, outside mu and sigma.

    %(far_points)s

    References
    ----------
    Seed 004 (Wang et al., ISPRS Archives XLII-3/W10, 2020), section 2.1;
    Rusu et al., Robotics and Autonomous Systems 56(11), 2008.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> pts = np.vstack([rng.uniform(0, 1, (200, 3)), [[10.0, 10.0, 10.0]]])
    >>> inlier = pcl_rg.statistical_outlier_removal(pts, mean_k=8, std_mul=2.0)
    >>> bool(inlier[-1]), int(inlier.sum()) > 190
    (False, True)
    """
    p = resolve_arguments(StatisticalOutlierRemovalParams, locals())
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)
    inlier, mean_distance, threshold, _ = _core.statistical_outlier_removal(xyz, p.to_core())
    counted = mean_distance[np.isfinite(mean_distance)]  # far points' d_i is inf
    far = len(xyz) - len(counted)
    record(
        "statistical_outlier_removal",
        points=len(xyz),
        inliers=int(inlier.sum()),
        threshold=float(threshold),
        mean_distance=float(counted.mean()) if len(counted) else float("nan"),
        far_points=far,
    )
    warn_far_points(
        "statistical_outlier_removal", far, len(xyz), "outliers, outside the mean and deviation"
    )
    return inlier
