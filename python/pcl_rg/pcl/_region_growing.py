"""``pcl::NormalEstimation`` and ``pcl::RegionGrowing`` on NumPy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from .. import _pcl
from .._diagnostics import record, record_segmentation
from .._docstrings import fill_docstring
from .._params import check_fields, param, resolve_arguments, to_core
from .._region_growing import NO_MAX_CLUSTER_SIZE, check_cluster_sizes
from .._validation import as_points

__all__ = [
    "NormalEstimationParams",
    "NormalEstimationResult",
    "RegionGrowingPclParams",
    "normals",
    "region_growing",
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


class NormalEstimationResult(NamedTuple):
    """Result of :func:`normals`."""

    normals: np.ndarray
    """float32 (N, 3): PCL's unit normals, flipped towards the local origin (see Notes)."""
    curvature: np.ndarray
    """float32 (N,): PCL's surface variation lambda0 / (lambda0 + lambda1 + lambda2)."""


@fill_docstring
def normals(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    params: NormalEstimationParams | None = None,
) -> NormalEstimationResult:
    """Estimate normals and surface variation with ``pcl::NormalEstimation``.

    Parameters
    ----------
    %(points)s
    k : int, optional
        Neighbours of each normal, the point itself included (default 15,
        ``setKSearch``); >= 3 and < N.
    %(params)s

    Returns
    -------
    NormalEstimationResult
        ``normals`` float32 (N, 3) and ``curvature`` float32 (N,), as PCL
        computes them (NaN where PCL cannot fit a plane).

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, ``k < 3``, ``k >= N``, N * k over
        1.2e9, or copies of positions whose counts' squares sum over 1e10
        (PCL's search would take minutes).
    %(type_error)s

    Notes
    -----
    PCA of the k nearest neighbours (``pcl::search::KdTree``) in float32 in
    the local frame (origin: the minimum corner, stray points far below left
    out); normals are flipped towards PCL's viewpoint, set to the minimum
    corner of the points. These are the normals :func:`region_growing` grows
    on.

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
    p = resolve_arguments(NormalEstimationParams, locals())
    xyz = as_points(points)
    normal, curvature = _pcl.normal_estimation(xyz, p.to_core())
    record("pcl.normals", points=len(xyz))
    return NormalEstimationResult(normal, curvature)


@fill_docstring
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
    %(points)s
    k : int, optional
        Neighbours for the normals and the growth, the point itself included
        (default 15); >= 3, < N and at most 1.2e9 / N (PCL's searches would
        take minutes, which cannot be interrupted).
    smoothness_deg : float, optional
        Maximum angle between neighbouring normals, degrees, in (0, 180)
        (default 16); passed to PCL in radians as float.
    curvature_threshold : float, optional
        Joined points whose surface variation is <= this grow further
        (default 0.025, the best on the mOSD learn scenes at k 15 and 16
        degrees; surface variation lies in [0, 1/3]).
    min_cluster_size, max_cluster_size : int, optional
        Regions outside these sizes are dropped (defaults 20 and 2**32 - 1).
    %(params)s

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
        threshold, ``min_cluster_size > max_cluster_size``), N * k over
        1.2e9, or copies of positions whose counts' squares sum over 1e10
        (PCL's searches would take minutes).
    %(type_error)s

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
    p = resolve_arguments(RegionGrowingPclParams, locals())
    xyz = as_points(points)
    labels, normals_seconds, growth_seconds = _pcl.region_growing(xyz, p.to_core())
    # PCL's clouds hold every point: far points were refused (pcl_cloud.cpp).
    record_segmentation("pcl.region_growing", len(xyz), labels, normals_seconds, growth_seconds, 0)
    return labels
