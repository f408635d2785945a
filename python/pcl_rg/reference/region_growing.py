"""NumPy reference for :func:`pcl_rg.region_growing` (curvature-seeded growth)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .._normals import NormalsResult
from .._params import resolve_arguments
from .._region_growing import RegionGrowingParams
from .._validation import as_points
from .normals import neighbour_lists, normals

__all__ = ["grow_regions", "measure_values", "region_growing", "seed_order"]


def measure_values(
    geometry: NormalsResult,
    name: str,
    points: np.ndarray | None = None,
    viewpoint: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """The per-point seed measure ``name`` from a :class:`~pcl_rg.NormalsResult`.

    ``concavity`` also needs the `points` (float64 (N, 3)) and the `viewpoint`.
    """
    if name == "curvedness":
        # sqrt((k1^2 + k2^2) / 2) written as H^2 + max(H^2 - K, 0), as the core does:
        # equal in exact arithmetic, without the rounding of k1,2 near umbilics.
        h, g = geometry.mean_curvature, geometry.gaussian_curvature
        return np.sqrt(h * h + np.maximum(h * h - g, 0.0))
    if name == "gaussian":
        return np.abs(geometry.gaussian_curvature)
    if name == "mean":
        return np.abs(geometry.mean_curvature)
    if name == "surface_variation":
        return geometry.surface_variation.copy()
    if name == "concavity":
        if points is None:
            raise ValueError("seed_measure 'concavity' needs the points")
        # H is signed by the normal (n_z > 0): turn it towards the viewpoint, the dot
        # product summed x, y, z in order as the core does.
        n, to_view = geometry.normals, np.asarray(viewpoint, dtype=np.float64) - points
        towards = n[:, 0] * to_view[:, 0] + n[:, 1] * to_view[:, 1] + n[:, 2] * to_view[:, 2]
        h = np.where(towards < 0.0, -geometry.mean_curvature, geometry.mean_curvature)
        return np.where(np.isnan(h), h, np.maximum(h, 0.0))
    raise ValueError(f"unknown seed_measure {name!r}")


def seed_order(measure: np.ndarray) -> np.ndarray:
    """Point indices in increasing (measure, index) order, NaN measures last."""
    undefined = np.isnan(measure)
    return np.lexsort((np.arange(len(measure)), np.where(undefined, 0.0, measure), undefined))


def grow_regions(
    neighbours: np.ndarray,
    normals: np.ndarray,
    measure: np.ndarray,
    params: RegionGrowingParams,
    *,
    order: np.ndarray | None = None,
    return_regions: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Steps 3 and 4 of the definition on given neighbour lists, normals and measure.

    Breadth-first from each seed in :func:`seed_order`; a neighbour q of a region
    point p joins when ``|n_p . n_q| >= cos(smoothness)`` and is queued when
    ``measure[q] <= curvature_threshold``; the seed always grows. The dot product
    is formed x + y + z in that order and the cosine with ``math.cos`` (the C
    library's), as the core does, so identical inputs give identical labels.

    ``order`` replaces :func:`seed_order` (e.g. to replay another implementation's
    order). With ``return_regions=True`` also returns the region of every point before
    the size filter, numbered in growth order (int64).
    """
    n = len(neighbours)
    region = np.full(n, -1, dtype=np.int64)
    sizes: list[int] = []
    cos_threshold = math.cos(params.smoothness_deg * (math.pi / 180.0))
    gate = params.curvature_threshold
    with np.errstate(invalid="ignore"):
        grows = measure <= gate  # NaN never grows
    for seed in seed_order(measure) if order is None else order:
        if region[seed] != -1:
            continue
        rid = len(sizes)
        region[seed] = rid
        size = 1
        queue = [int(seed)]
        head = 0
        while head < len(queue):
            p = queue[head]
            head += 1
            row = neighbours[p]
            free = row[region[row] == -1]  # a row never repeats a point: order-free test
            if free.size == 0:
                continue
            nq = normals[free]
            npt_ = normals[p]
            with np.errstate(invalid="ignore"):
                cosine = np.abs(nq[:, 0] * npt_[0] + nq[:, 1] * npt_[1] + nq[:, 2] * npt_[2])
                joined = free[cosine >= cos_threshold]  # NaN never joins
            region[joined] = rid
            size += joined.size
            queue.extend(joined[grows[joined]].tolist())
        sizes.append(size)

    counts = np.asarray(sizes, dtype=np.int64)
    kept = (counts >= params.min_cluster_size) & (counts <= params.max_cluster_size)
    labels = np.full(n, -1, dtype=np.int32)
    if n == 0:
        return (labels, region) if return_regions else labels
    # Number kept regions by their smallest member index.
    first = np.full(len(counts), n, dtype=np.int64)
    np.minimum.at(first, region, np.arange(n))
    kept_ids = np.flatnonzero(kept)
    new_id = np.full(len(counts), -1, dtype=np.int32)
    new_id[kept_ids[np.argsort(first[kept_ids])]] = np.arange(kept_ids.size, dtype=np.int32)
    labels = new_id[region]
    return (labels, region) if return_regions else labels


def region_growing(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    smoothness_deg: float | None = None,
    curvature_threshold: float | None = None,
    min_cluster_size: int | None = None,
    max_cluster_size: int | None = None,
    seed_measure: str | None = None,
    viewpoint: tuple[float, float, float] | None = None,
    params: RegionGrowingParams | None = None,
) -> np.ndarray:
    """Reference region growing: same signature and result as :func:`pcl_rg.region_growing`.

    Normals and measures from :func:`pcl_rg.reference.normals` (float64, LAPACK),
    neighbour lists from :func:`pcl_rg.reference.neighbour_lists`, growth in
    Python. Agrees with the core label for label except where a decision lies
    within rounding of a threshold, two seed measures tie within rounding, or a
    neighbour list has a tie at its k-th place.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> rng = np.random.default_rng(0)
    >>> floor = np.column_stack([rng.uniform(0, 2, (300, 2)), np.zeros(300)])
    >>> labels = reference.region_growing(floor, k=10, min_cluster_size=10)
    >>> np.unique(labels).tolist()
    [0]
    """
    p = resolve_arguments(RegionGrowingParams, locals())
    xyz = as_points(points)
    if len(xyz) == 0:
        return np.empty(0, dtype=np.int32)
    geometry = normals(xyz, k=p.k)
    measure = measure_values(geometry, p.seed_measure, xyz, p.viewpoint)
    return grow_regions(neighbour_lists(xyz, p.k), geometry.normals, measure, p)
