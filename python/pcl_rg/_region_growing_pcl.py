"""PCL's own NormalEstimation + RegionGrowing: the baseline of seed 004."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._params import check_fields, param, resolve, to_core
from ._validation import as_points
from ._region_growing import NO_MAX_CLUSTER_SIZE, check_cluster_sizes

__all__ = ["RegionGrowingPclParams", "PclRegionGrowingResult", "region_growing_pcl"]


@dataclass(frozen=True, kw_only=True, slots=True)
class RegionGrowingPclParams:
    """Parameters of :func:`region_growing_pcl` (mirrors ``pcl_rg::RegionGrowingPclParams``)."""

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

    def to_core(self) -> _core.RegionGrowingPclParams:
        return to_core(self, _core.RegionGrowingPclParams())


class PclRegionGrowingResult(NamedTuple):
    """Everything :func:`region_growing_pcl` can return with ``full_output=True``."""

    labels: np.ndarray
    """int32 (N,): region per point, -1 for dropped regions."""
    normals: np.ndarray
    """float32 (N, 3): PCL's normals (flipped towards the local origin, see Notes)."""
    curvature: np.ndarray
    """float32 (N,): PCL's surface variation lambda0 / (lambda0 + lambda1 + lambda2)."""
    normals_seconds: float
    """Wall time of ``pcl::NormalEstimation`` (its own k-d tree included)."""
    growth_seconds: float
    """Wall time of ``pcl::RegionGrowing::extract`` and the label numbering."""


def region_growing_pcl(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    smoothness_deg: float | None = None,
    curvature_threshold: float | None = None,
    min_cluster_size: int | None = None,
    max_cluster_size: int | None = None,
    params: RegionGrowingPclParams | None = None,
    full_output: bool = False,
) -> np.ndarray | PclRegionGrowingResult:
    """Segment points with PCL's classic region growing (the baseline).

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
    full_output : bool, default False
        Return a :class:`PclRegionGrowingResult` (labels, PCL's normals and
        curvature, timings) instead of the labels alone.

    Returns
    -------
    numpy.ndarray or PclRegionGrowingResult
        int32 (N,) labels, -1 for points of dropped regions, numbered 0, 1, ...
        by each region's smallest point index (PCL lists them in growth order).

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
    The points minus a float64 local origin (the minimum corner) go to PCL as
    float32 ``PointXYZ``. Then, as PCL 1.13 does it
    (``pcl/segmentation/impl/region_growing.hpp``):

    * ``pcl::NormalEstimation`` with ``setKSearch(k)``: PCA normal and surface
      variation in float32, normals flipped towards the viewpoint (0, 0, 0) of
      the local frame (irrelevant to the growth, which compares ``|cos|``).
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

    Single-threaded, as PCL's classes are; the GIL is released.

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
    >>> labels = pcl_rg.region_growing_pcl(np.vstack([floor, wall]), k=12, smoothness_deg=5)
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
    result = PclRegionGrowingResult(*_core.region_growing_pcl(xyz, p.to_core()))
    record(
        "region_growing_pcl",
        points=len(xyz),
        clusters=int(result.labels.max(initial=-1)) + 1,
        normals_seconds=result.normals_seconds,
        growth_seconds=result.growth_seconds,
    )
    return result if full_output else result.labels
