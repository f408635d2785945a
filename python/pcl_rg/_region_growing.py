"""Curvature-seeded region growing (seed 004) on NumPy arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record_segmentation
from ._docstrings import fill_docstring
from ._far_points import warn_far_points
from ._normals import MIN_CURVATURE_K
from ._params import check_fields, param, resolve_arguments, to_core
from ._validation import as_points

__all__ = ["SEED_MEASURES", "RegionGrowingParams", "region_growing"]

#: Names accepted by ``seed_measure``, in the order of ``pcl_rg::SeedMeasure``.
SEED_MEASURES = ("curvedness", "gaussian", "mean", "surface_variation", "concavity")

#: PCL's default maximum cluster size (``std::numeric_limits<pcl::uindex_t>::max()``).
NO_MAX_CLUSTER_SIZE = 2**32 - 1


@dataclass(frozen=True, kw_only=True, slots=True)
class RegionGrowingParams:
    """Parameters of :func:`region_growing` (mirrors ``pcl_rg::RegionGrowingParams``)."""

    k: int = param(
        15,
        minimum=3,
        bits=32,
        help="neighbours per point, itself included, for normals, curvatures and growth "
        "(PCL setNumberOfNeighbours); >= 6 unless seed_measure is surface_variation",
    )
    smoothness_deg: float = param(
        16.0,
        above=0.0,
        below=180.0,
        unit="deg",
        help="max angle between neighbouring normals, in degrees (PCL's "
        "setSmoothnessThreshold takes radians)",
    )
    curvature_threshold: float = param(
        80.0,
        minimum=0.0,
        help="joined points whose seed measure is <= this grow further, in the measure's "
        "unit, scale dependent (PCL setCurvatureThreshold)",
    )
    min_cluster_size: int = param(
        20, minimum=1, help="drop regions with fewer points (PCL setMinClusterSize)"
    )
    max_cluster_size: int = param(
        NO_MAX_CLUSTER_SIZE, minimum=1, help="drop regions with more points (PCL setMaxClusterSize)"
    )
    seed_measure: str = param(
        "curvedness",
        choices=SEED_MEASURES,
        help="seed order and seed gate: curvedness sqrt((k1^2+k2^2)/2) [1/m], gaussian |K| "
        "[1/m^2], mean |H| [1/m], surface_variation (PCL's) or concavity max(H towards the "
        "viewpoint, 0) [1/m]",
    )
    viewpoint: tuple[float, float, float] = param(
        (0.0, 0.0, 0.0),
        axes=3,
        unit="m",
        help="sensor position x,y,z for seed_measure=concavity, caller's coordinates "
        "(PCL setViewPoint)",
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_cluster_sizes(self.min_cluster_size, self.max_cluster_size)
        # The curvatures are a quadric's: below MIN_CURVATURE_K neighbours they are NaN,
        # no point may seed, and every point came out unassigned without a word.
        if self.k < MIN_CURVATURE_K and self.seed_measure != "surface_variation":
            raise ValueError(
                f"k must be >= {MIN_CURVATURE_K} unless seed_measure is surface_variation (the "
                f"other measures are curvatures, which need {MIN_CURVATURE_K} neighbours), "
                f"got {self.k}"
            )

    def to_core(self) -> _core.RegionGrowingParams:
        return to_core(self, _core.RegionGrowingParams())


def check_cluster_sizes(minimum: int, maximum: int) -> None:
    """max_cluster_size >= min_cluster_size, worded as the C++ check."""
    if maximum < minimum:
        raise ValueError(f"max_cluster_size must be >= min_cluster_size ({minimum}), got {maximum}")


@fill_docstring
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
    """Segment points into smooth regions grown from the flattest points first.

    Parameters
    ----------
    %(points)s
    k : int, optional
        Neighbourhood size, the point itself included (default 15), for the
        normals, the curvatures and the growth. Must be >= 3 and < N (the
        curvatures need k >= 6), and at most 2^31 / N, which keeps the table
        of neighbours (4 bytes per point and neighbour) within 8 GiB.
    smoothness_deg : float, optional
        A neighbour joins a region when the angle between its normal and the
        current region point's normal is at most this, in degrees, in (0, 180)
        (default 16).
    curvature_threshold : float, optional
        A joined point is queued as a further seed when its seed measure is
        <= this, in the measure's unit (default 80 1/m, for curvedness).
        Curvatures scale with 1 / size: tune it to the data's scale and noise.
    min_cluster_size, max_cluster_size : int, optional
        Regions with fewer or more points are dropped (defaults 20 and
        2**32 - 1, PCL's "no limit").
    seed_measure : {"curvedness", "gaussian", "mean", "surface_variation", \
"concavity"}, optional
        Per-point measure that orders the seeds and gates further seeds:
        curvedness sqrt((k1^2 + k2^2) / 2) (default), |K|, |H|, PCL's
        surface variation, or concavity max(H_v, 0) (see Notes).
    viewpoint : sequence of 3 float, optional
        Sensor position for ``seed_measure="concavity"`` (default the origin,
        as PCL: right for Kinect and terrestrial scans in the sensor frame;
        for airborne data give a point high above the area).
    %(params)s

    Returns
    -------
    numpy.ndarray
        int32 (N,): region label per point, -1 for points of dropped regions.
        Labels are 0, 1, ... in the order of each region's smallest point
        index.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range
        (``k < 3``, ``k < 6`` with a seed measure other than
        ``"surface_variation"``, ``k >= N``, an angle outside (0, 180), a negative
        threshold, ``min_cluster_size > max_cluster_size``, an unknown
        ``seed_measure``).
    %(far_points_value_error)s
    %(type_error)s

    Notes
    -----
    1. Normals and curvatures as :func:`pcl_rg.normals` computes them (PCA
       normal, quadric K and H, k1 and k2), on the k nearest neighbours.
    2. Seeds are taken in increasing order of the seed measure, ties by point
       index; points with an undefined (NaN) measure come last.
    3. From a seed, breadth-first: a neighbour q of a region point p joins
       when ``|n_p . n_q| >= cos(smoothness_deg)`` (normals unoriented;
       undefined normals never join), and is queued to grow further when its
       seed measure is ``<= curvature_threshold`` (the same measure that orders
       the seeds; NaN never grows). The seed itself always grows, as in PCL.
       When the queue is empty, the next unassigned point in seed order starts
       a new region; every point ends in some region.
    4. Regions outside [min_cluster_size, max_cluster_size] are dropped (-1).

    The defaults (k 15, 16 degrees, curvedness <= 80 1/m, 20 points) were
    chosen by a grid search on the seven mOSD learn scenes (Kinect, about 1 m
    away), each after voxel grids of 3 to 8 mm, for the highest pooled mean
    IoU (``benchmarks/studies/region_growing_mosd.py --grid``). Curvatures scale
    as 1 / length: for other data, scale the threshold accordingly.

    ``seed_measure="concavity"`` is an option beyond the seed's definition:
    H_v is the mean curvature with the normal turned towards `viewpoint`, so
    it is > 0 where the surface is concave as seen from the sensor (the crease
    where a box stands on a table) and <= 0 on convex edges (the box's own
    edges). Gating on max(H_v, 0) lets regions run over convex edges but stop
    in concave creases, which segments objects rather than faces; on mOSD it
    raises the mean IoU markedly (RESULTS.md). Its seeds with measure 0 (flat
    or convex points) are taken in index order.

    Against ``pcl::RegionGrowing`` (see :func:`pcl_rg.pcl.region_growing`),
    the growth is the same; the differences are the seed measure, a total seed
    order (PCL's unstable sort leaves equal curvatures in unspecified order),
    float64 normals, and one neighbour search shared by the normals and the
    growth. The result is deterministic and does not depend on the number of
    threads. It does depend on the input order wherever two measures tie or
    neighbour distances tie (the index breaks the tie).

    %(far_points)s
    A far point, with undefined normal and measure, is a region of its own
    (-1 unless ``min_cluster_size`` is 1).

    References
    ----------
    Seed 004: Wang et al., "Point cloud segmentation based on improved region
    growing", ISPRS Archives XLII-3/W10, 2020; Rabbani et al., ISPRS Archives
    XXXVI-5, 2006.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> floor = np.column_stack([rng.uniform(0, 2, (600, 2)), np.zeros(600)])
    >>> wall = np.column_stack([rng.uniform(0, 2, 600), np.full(600, 2.3),
    ...                         rng.uniform(0.3, 2, 600)])
    >>> labels = pcl_rg.region_growing(np.vstack([floor, wall]), k=12, smoothness_deg=5)
    >>> np.unique(labels[:600]).tolist(), np.unique(labels[600:]).tolist()
    ([0], [1])
    """
    p = resolve_arguments(RegionGrowingParams, locals())
    xyz = as_points(points)
    labels, normals_seconds, growth_seconds, far = _core.region_growing(xyz, p.to_core())
    record_segmentation("region_growing", len(xyz), labels, normals_seconds, growth_seconds, far)
    outcome = "each is a region of its own (-1 unless min_cluster_size is 1)"
    warn_far_points("region_growing", far, len(xyz), outcome)
    return labels
